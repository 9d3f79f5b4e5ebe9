//! The deformation stage of a frame (thesis ch. 5, §5.2.2, §7.1.2): every working region with
//! contact zones is deformed with all its zones at once (regions in parallel, objects in
//! parallel), then each object's regions are written back into one object-sized result
//! ([`object_results`], with the figures of the object and its regions).
//!
//! Inputs: the object caches (each region's sub-mesh and [`RegionSolver`]), the frame, the
//! [`RegionZones`] of the contact stage, the component figures and region sizes of the setup.
//! Output: per object and region, a [`RegionOutcome`] (`None` for a region without zones).
//!
//! Conventions:
//! - each region's extent φ_max is the object's or [`automatic_extent`] of the region's size, its
//!   largest contact area and its mean edge length; its length scale h is the mean edge length of
//!   the components it touches, so the result does not depend on where a cut falls;
//! - a cut region's border must not move (faces outside would deform without being part of the
//!   volume balance): a zone reaching the cut is [`PipelineError::RegionTooSmall`], and when 𝒟
//!   reaches it the extent is clamped to 0.95 × the smallest φ on the cut and the region solved
//!   again (φ does not depend on φ_max, so 𝒟 then stops short of the cut);
//! - an automatic region's factorizations eliminate in AMD's order (its face set, hence its
//!   analysis, changes every few frames); the others keep the order of fewer flops.

use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;

use super::cache::{ObjectCache, RegionCache, SubRegion};
use super::contacts::{RegionZones, ZoneSummary};
use super::plan::Trace;
use super::store::FrameStore;
use super::{Frame, FrameObject, ObjectStats, PipelineError, RegionStats, RegionSummary};
use crate::contact::ContactZone;
use crate::deform::{
    DeformError, DeformParams, DeformStats, RegionDeformation, RegionFields, RegionOverrides, RegionSolver, SweptTerms,
    automatic_extent, deform_with_fields_and_terms, region_fields, swept_volume_change,
};
use crate::linalg::{FillOrder, SolveError, SparsePattern, SymbolicFactor};
use crate::mesh::{Topology, signed_volume, signed_volume_of};
use crate::stage::{Stage, Work};

/// The deformation of one region.
pub(super) struct RegionOutcome {
    pub deformation: RegionDeformation,
    /// φ_max used (after clamping).
    pub extent: f64,
    /// Whether φ_max was clamped to keep 𝒟 inside the region.
    pub clamped: bool,
    /// Whether 𝒫 reached the region's cut.
    pub domain_reaches_cut: bool,
    /// Wall-clock time of the region's deformation.
    pub time: Duration,
    /// Whether this frame built the region's solver (one symbolic analysis).
    pub new_solver: bool,
    /// Wall-clock time of that analysis (zero without one): part of updating the working
    /// region ([`Stage::Regions`]), though done when chapter 5 first needs it.
    pub analysis_time: Duration,
    /// The region's fields of §5.1–5.3 and resolved scales, when the deformer keeps them for
    /// edits ([`KeptRegion`]).
    pub kept: Option<KeptRegion>,
    /// The terms of the region's volume cubic, for the separation pass's first height solve
    /// (taken by it).
    pub volume_terms: SweptTerms,
}

/// What an edit of §5.4–5.5's parameters reuses of a region's deformation (see `edits`): its
/// fields of §5.1–5.3 and the scales the pipeline resolved for it.
#[derive(Clone, Debug)]
pub(super) struct KeptRegion {
    pub fields: RegionFields,
    pub scales: ResolvedScales,
    pub clamped: bool,
    pub domain_reaches_cut: bool,
}

/// The values the pipeline resolves for a region's [`DeformParams`] besides the object's own
/// parameters: φ_max (after clamping), the length scale h and the domain radius.
#[derive(Clone, Copy, Debug)]
pub(super) struct ResolvedScales {
    pub extent: f64,
    pub edge_length: Option<f64>,
    pub domain_radius: Option<f64>,
}

/// Chapter 5 on every region with zones (in parallel), with the store's region sizes (of the
/// components they touch) and object normals (when the contact stage computed them); `keep`:
/// keep each region's fields for edits ([`RegionOutcome::kept`]).
pub(super) fn deform_regions(
    caches: &mut [Option<ObjectCache>],
    frame: &Frame,
    contacts: &RegionZones,
    store: &FrameStore,
    keep: bool,
) -> Result<Vec<Vec<Option<RegionOutcome>>>, PipelineError> {
    let RegionZones { zones, contact_area, .. } = contacts;
    let FrameStore { figures, sizes, normals, .. } = store;
    caches
        .par_iter_mut()
        .zip(&frame.objects)
        .zip(zones)
        .enumerate()
        .map(|(i, ((cache, object), zones))| -> Result<Vec<Option<RegionOutcome>>, PipelineError> {
            let Some(cache) = cache.as_mut() else { return Ok(Vec::new()) };
            let ObjectCache { regions, topology, fill_ranks, .. } = cache;
            let topology = &*topology;
            let fill_ranks = &*fill_ranks;
            regions
                .par_iter_mut()
                .zip(zones)
                .enumerate()
                .map(|(r, (region, zones))| {
                    if zones.is_empty() {
                        return Ok(None);
                    }
                    let edge_length = figures[i].mean_edge_length(&region.components);
                    let extent = object
                        .params
                        .extent
                        .unwrap_or_else(|| automatic_extent(sizes[i][r], contact_area[i][r], edge_length));
                    let scale = Scale { extent, edge_length };
                    let object_parts = ObjectParts { object, topology, fill_ranks };
                    deform_one(object_parts, region, r, zones, normals[i].as_deref(), scale, keep).map(Some)
                })
                .collect()
        })
        .collect()
}

/// Adds every region's stage times and work of chapter 5 to the frame's.
pub(super) fn record(outcomes: &[Vec<Option<RegionOutcome>>], trace: &mut Trace) {
    for outcome in outcomes.iter().flatten().flatten() {
        trace.add(&outcome.deformation.stats.timings, &outcome.deformation.stats.work);
        trace.time(Stage::Regions, outcome.analysis_time);
    }
}

/// What a region's deformation reads of its object: the frame's object, its connectivity and
/// its fill order for automatic regions ([`ObjectCache::fill_ranks`]).
#[derive(Clone, Copy)]
struct ObjectParts<'a> {
    object: &'a FrameObject<'a>,
    topology: &'a Topology,
    fill_ranks: &'a std::sync::OnceLock<Result<Vec<usize>, SolveError>>,
}

/// Fraction of the smallest φ on a region's cut border that a clamped extent keeps.
const CLAMP_FRACTION: f64 = 0.95;

/// The scales of a region's deformation: φ_max and the mean edge length h of the components it
/// touches.
#[derive(Clone, Copy, Debug)]
struct Scale {
    extent: f64,
    edge_length: f64,
}

/// Runs chapter 5 on one region, clamping its extent when 𝒟 would reach the cut (see the
/// module doc). `object_normals`: the object's vertex normals when the contact stage computed
/// them (it does for objects with a region processed whole); `keep`: return the region's fields.
fn deform_one(
    ObjectParts { object, topology: object_topology, fill_ranks }: ObjectParts<'_>,
    region: &mut RegionCache,
    index: usize,
    zones: &[&ContactZone],
    object_normals: Option<&[DVec3]>,
    scale: Scale,
    keep: bool,
) -> Result<RegionOutcome, PipelineError> {
    let Scale { extent, edge_length: object_edge_length } = scale;
    let start = Instant::now();
    let err = |source| PipelineError::Deform { object: object.name.to_string(), source };
    let too_small =
        |reason: String| PipelineError::RegionTooSmall { object: object.name.to_string(), region: index, reason };
    let (mesh, topology, border) = match region.sub.as_deref() {
        None => (object.mesh, object_topology, None),
        // The contact stage's border: an open seam (ObjectParams::contact_open_border) may move
        // like the region's inside; the part contacts restore the object's volume over it.
        Some(sub) => (&sub.sub.mesh, &sub.topology, sub.contact_border()),
    };
    // A region processed whole reuses the object's normals of the contact stage (the same
    // `vertex_normals` of the same mesh); a cut region's own are its sub-mesh's.
    let overrides =
        RegionOverrides { normals: object_normals.filter(|_| region.sub.is_none()), ..RegionOverrides::default() };
    let new_solver = region.solver.is_none();
    let mut analysis_time = Duration::ZERO;
    if new_solver {
        // An automatic region is cut again whenever its faces change: its analysis, then paid
        // every few frames, takes the order of AMD on the whole object (computed once)
        // restricted to its rows; the others are analyzed once per shot, in their own order.
        let analysis = Instant::now();
        let solver = match region.sub.as_deref().filter(|_| object.params.region.is_automatic()) {
            Some(sub) => {
                let ranks = fill_ranks.get_or_init(|| {
                    SparsePattern::new(object.mesh, object_topology)
                        .and_then(|pattern| SymbolicFactor::amd_ranks(&pattern))
                });
                let ranks = ranks.as_ref().map_err(|e| err(DeformError::solve("symbolic analysis")(e.clone())))?;
                let rank: Vec<usize> = sub.sub.parent_vertex.iter().map(|&v| ranks[v as usize]).collect();
                RegionSolver::with_rank_order(mesh, topology, &rank)
            }
            None => RegionSolver::with_fill_order(mesh, topology, FillOrder::FewerFlops),
        };
        region.solver = Some(solver.map_err(err)?);
        analysis_time = analysis.elapsed();
    }
    let Some(solver) = region.solver.as_mut() else {
        return Err(err(DeformError::StaleFactorization { stage: "region solver" }));
    };
    // The length scale h (heat time, slope confidence) is the object's (of the components the
    // region touches, from the frame's figures), whole or cut: the result must not depend on
    // where a cut falls, which automatic regions move from frame to frame.
    let mut scales = ResolvedScales {
        extent,
        edge_length: (object_edge_length > 0.0).then_some(object_edge_length),
        domain_radius: None,
    };
    let mut params = region_params(object, region.sub.as_deref(), scales).map_err(err)?;
    let mut fields = region_fields(mesh, topology, solver, zones, &params, &overrides).map_err(err)?;
    let mut clamped = false;
    if let Some(border) = border {
        if let Some(v) =
            (0..border.len()).find(|&v| border[v] && fields.contact.vertex_zone[v] != crate::deform::NO_ZONE)
        {
            return Err(too_small(format!("its contact zone reaches vertex {v} on the cut border")));
        }
        if (0..border.len()).any(|v| border[v] && fields.deformable[v]) {
            // φ does not depend on φ_max: the smallest φ on the cut bounds the extent that fits.
            let reach = (0..border.len())
                .filter(|&v| border[v])
                .map(|v| fields.u[v] * params.extent)
                .fold(f64::INFINITY, f64::min);
            let fitted = CLAMP_FRACTION * reach;
            if !(fitted.is_finite() && fitted > 0.0) {
                return Err(too_small(format!("its deformable region reaches the cut border at φ = {reach:.3e}")));
            }
            // The same domain as the first solve, so the same φ.
            scales.domain_radius = Some(params.domain_radius());
            scales.extent = fitted;
            params.domain_radius = scales.domain_radius;
            params.extent = fitted;
            let first = fields.stats;
            fields = region_fields(mesh, topology, solver, zones, &params, &overrides).map_err(err)?;
            // The first solves were work of this frame too.
            fields.stats.add_solve_counts(&first);
            clamped = true;
            let moves = |v: usize| fields.deformable[v] || fields.contact.vertex_zone[v] != crate::deform::NO_ZONE;
            if let Some(v) = (0..border.len()).find(|&v| border[v] && moves(v)) {
                return Err(too_small(format!("vertex {v} on the cut border still moves after clamping the extent")));
            }
        }
    }
    let domain_reaches_cut = border.is_some_and(|border| {
        // Every vertex within the radius in the whole object is in the region, at the same
        // distance, unless a shortest path crosses the cut: then a cut vertex is within it.
        border.iter().zip(&fields.domain).any(|(&on_cut, &within)| on_cut && within)
    });
    let kept = keep.then(|| KeptRegion { fields: fields.clone(), scales, clamped, domain_reaches_cut });
    let (deformation, volume_terms) =
        deform_with_fields_and_terms(mesh, topology, zones, fields, &params).map_err(err)?;
    Ok(RegionOutcome {
        deformation,
        volume_terms,
        extent: params.extent,
        clamped,
        domain_reaches_cut,
        time: start.elapsed(),
        new_solver,
        analysis_time,
        kept,
    })
}

/// The [`DeformParams`] of a region: the object's parameters at this frame with the resolved
/// scales, volume preserved unless the parameters say otherwise (closed or open: an open mesh
/// keeps its swept volume, see `deform::volume`), and the painted bulge map gathered onto the
/// region's vertices.
fn region_params<'a>(
    object: &FrameObject<'a>,
    sub: Option<&SubRegion>,
    scales: ResolvedScales,
) -> Result<DeformParams<'a>, DeformError> {
    let mut params = DeformParams::of(object.params, scales.extent, object.params.preserve_volume.unwrap_or(true));
    if let Some(map) = object.params.bulge_map.as_ref() {
        params.bulge_map = Some(match sub {
            None => map.clone(),
            Some(sub) => {
                if map.len() != object.mesh.num_vertices() {
                    return Err(DeformError::BulgeMapLength {
                        expected: object.mesh.num_vertices(),
                        actual: map.len(),
                    });
                }
                sub.sub.gather(map)
            }
        });
    }
    params.edge_length = scales.edge_length;
    params.domain_radius = scales.domain_radius;
    Ok(params)
}

/// §5.4–5.5 again on every region kept by the last full frame (`kept[object][region]`), with
/// this frame's parameters: the deformation of an edit (see `edits`). The regions with zones are
/// exactly those kept; the work counters of the result are zero (nothing was factorized) and its
/// times are the edit's.
pub(super) fn finish_kept_regions(
    caches: &[Option<ObjectCache>],
    frame: &Frame,
    contacts: &RegionZones,
    kept: &[Vec<Option<KeptRegion>>],
) -> Result<Vec<Vec<Option<RegionOutcome>>>, PipelineError> {
    caches
        .par_iter()
        .zip(&frame.objects)
        .zip(&contacts.zones)
        .zip(kept)
        .map(|(((cache, object), zones), kept)| -> Result<Vec<Option<RegionOutcome>>, PipelineError> {
            let Some(cache) = cache.as_ref() else { return Ok(Vec::new()) };
            let err = |source| PipelineError::Deform { object: object.name.to_string(), source };
            cache
                .regions
                .par_iter()
                .zip(zones)
                .zip(kept)
                .map(|((region, zones), kept)| {
                    let Some(kept) = kept else { return Ok(None) };
                    let start = Instant::now();
                    let (mesh, topology) = region
                        .sub
                        .as_deref()
                        .map_or((object.mesh, &*cache.topology), |sub| (&sub.sub.mesh, &sub.topology));
                    let params = region_params(object, region.sub.as_deref(), kept.scales).map_err(err)?;
                    let (mut deformation, volume_terms) =
                        deform_with_fields_and_terms(mesh, topology, zones, kept.fields.clone(), &params)
                            .map_err(err)?;
                    let stats = &mut deformation.stats;
                    (stats.numeric_factorizations, stats.factorized_rows, stats.recomputed_rows) = (0, 0, 0);
                    stats.reduced_analyses = 0;
                    for stage in
                        [Stage::Parametrization, Stage::Directions, Stage::Guide, Stage::Factorization, Stage::Analysis]
                    {
                        stats.timings[stage] = Duration::ZERO;
                        stats.work[stage] = Work::ZERO;
                    }
                    stats.time = start.elapsed();
                    Ok(Some(RegionOutcome {
                        deformation,
                        extent: kept.scales.extent,
                        clamped: kept.clamped,
                        domain_reaches_cut: kept.domain_reaches_cut,
                        time: start.elapsed(),
                        new_solver: false,
                        analysis_time: Duration::ZERO,
                        kept: None,
                        volume_terms,
                    }))
                })
                .collect()
        })
        .collect()
}

/// Writes the regions' deformations into one object-sized deformation (`None` if none).
pub(super) fn combine(
    input: &[DVec3],
    regions: &[RegionCache],
    outcomes: Vec<Option<RegionOutcome>>,
) -> Option<RegionDeformation> {
    let deformed = outcomes.iter().filter(|o| o.is_some()).count();
    if deformed == 0 {
        return None;
    }
    let mut parts = regions.iter().zip(outcomes).filter_map(|(r, o)| o.map(|o| (r, o.deformation)));
    if regions.len() == 1 && regions[0].sub.is_none() {
        return parts.next().map(|(_, d)| d);
    }
    let n = input.len();
    let mut out = RegionDeformation {
        positions: input.to_vec(),
        u: vec![f64::INFINITY; n],
        domain: vec![false; n],
        deformable: vec![false; n],
        contact: vec![false; n],
        directions: vec![DVec3::ZERO; n],
        heights: vec![0.0; n],
        amplitude: vec![0.0; n],
        slope: vec![0.0; n],
        bulge_map: vec![1.0; n],
        displacement: crate::deform::AffineDisplacement::none(n),
        stats: DeformStats::default(),
    };
    let mut first = true;
    for (region, d) in parts {
        let Some(sub) = region.sub.as_deref() else { continue };
        let map = &sub.sub;
        map.scatter(&d.positions, &mut out.positions);
        map.scatter(&d.u, &mut out.u);
        map.scatter(&d.domain, &mut out.domain);
        map.scatter(&d.deformable, &mut out.deformable);
        map.scatter(&d.contact, &mut out.contact);
        map.scatter(&d.directions, &mut out.directions);
        map.scatter(&d.heights, &mut out.heights);
        map.scatter(&d.amplitude, &mut out.amplitude);
        map.scatter(&d.slope, &mut out.slope);
        map.scatter(&d.bulge_map, &mut out.bulge_map);
        map.scatter(&d.displacement.linear, &mut out.displacement.linear);
        map.scatter(&d.displacement.constant, &mut out.displacement.constant);
        map.scatter(&d.displacement.moved, &mut out.displacement.moved);
        let (s, t) = (&d.stats, &mut out.stats);
        if first {
            t.bulge_height = s.bulge_height;
            t.applied_bulge_height = s.applied_bulge_height;
            t.volume_exact = s.volume_exact;
            first = false;
        }
        t.volume_exact &= s.volume_exact;
        t.volume_residual += s.volume_residual;
        t.volume_before += s.volume_before;
        t.volume_after += s.volume_after;
        t.num_deformable += s.num_deformable;
        t.num_contact += s.num_contact;
        t.num_boundary_points += s.num_boundary_points;
        t.outer_boundary_moved += s.outer_boundary_moved;
        t.add_solve_counts(s);
        t.time += s.time;
        t.fallbacks.direction_blend += s.fallbacks.direction_blend;
        t.fallbacks.bulge_map += s.fallbacks.bulge_map;
        t.fallbacks.volume_without_root += s.fallbacks.volume_without_root;
        t.fallbacks.clamped_slopes += s.fallbacks.clamped_slopes;
    }
    Some(out)
}

/// Per object, in frame order: its positions, its deformation and its figures; and every working
/// region's figures and summary.
pub(super) struct ObjectResults {
    pub positions: Vec<Vec<DVec3>>,
    pub deformations: Vec<Option<RegionDeformation>>,
    pub stats: Vec<ObjectStats>,
    pub regions: Vec<RegionStats>,
    pub summaries: Vec<RegionSummary>,
}

/// Writes every object's regions back and gathers the figures of objects and regions.
pub(super) fn object_results(
    frame: &Frame,
    caches: &[Option<ObjectCache>],
    zones: &ZoneSummary,
    outcomes: Vec<Vec<Option<RegionOutcome>>>,
) -> ObjectResults {
    let count = frame.objects.len();
    let ZoneSummary { zones, touching } = zones;
    let mut positions = Vec::with_capacity(count);
    let mut object_stats = Vec::with_capacity(count);
    let mut kept = Vec::with_capacity(count);
    let mut region_stats = Vec::new();
    let mut summaries = Vec::new();
    for (i, (object, outcomes)) in frame.objects.iter().zip(outcomes).enumerate() {
        let Some(cache) = caches[i].as_ref() else { continue };
        let input = &object.mesh.positions;
        let volume_before = signed_volume(object.mesh);
        let mut stats = ObjectStats {
            name: object.name.to_string(),
            vertices: input.len(),
            rigid: object.params.rigid,
            volume_before,
            volume_after: volume_before,
            preserve_volume: object.params.preserve_volume.unwrap_or(true),
            regions: cache.regions.len(),
            zones: zones[i].iter().sum(),
            ..ObjectStats::default()
        };
        for (r, (region, outcome)) in cache.regions.iter().zip(&outcomes).enumerate() {
            let sub = region.sub.as_deref();
            let mut rs = RegionStats {
                object: i,
                name: object.name.to_string(),
                region: r,
                whole: sub.is_none(),
                vertices: sub.map_or(input.len(), |s| s.sub.num_vertices()),
                faces: region.num_faces(object.mesh),
                cut_border_vertices: sub.map_or(0, |s| s.border_count),
                rebuilt: region.rebuilt,
                touching: touching[i][r].clone(),
                zones: zones[i][r],
                ..RegionStats::default()
            };
            if let Some(outcome) = outcome {
                let s = &outcome.deformation.stats;
                rs.deformed = true;
                rs.extent = outcome.extent;
                rs.extent_clamped = outcome.clamped;
                rs.domain_reaches_cut = outcome.domain_reaches_cut;
                rs.domain_vertices = outcome.deformation.domain.iter().filter(|&&d| d).count();
                rs.bulge_height = s.bulge_height;
                rs.applied_bulge_height = s.applied_bulge_height;
                rs.contact_vertices = s.num_contact;
                rs.deformable_vertices = s.num_deformable;
                rs.time = outcome.time;
                rs.nested_dissection = region.solver.as_ref().is_some_and(RegionSolver::uses_nested_dissection);
                if !stats.deformed {
                    stats.extent = outcome.extent;
                    stats.bulge_height = s.bulge_height;
                    stats.applied_bulge_height = s.applied_bulge_height;
                }
                stats.deformed = true;
                stats.extent_clamped |= outcome.clamped;
                stats.domain_reaches_cut |= outcome.domain_reaches_cut;
                stats.contact_vertices += s.num_contact;
                stats.deformable_vertices += s.num_deformable;
                stats.fallbacks += s.fallbacks.direction_blend
                    + s.fallbacks.bulge_map
                    + s.fallbacks.volume_without_root
                    + s.fallbacks.clamped_slopes;
            }
            region_stats.push(rs);
            summaries.push(RegionSummary {
                object: i,
                region: r,
                whole: sub.is_none(),
                faces: region.faces.clone().unwrap_or_default(),
                vertices: sub.map(|s| s.sub.parent_vertex.clone()).unwrap_or_default(),
                cut_border: sub
                    .map(|s| s.sub.parent_vertex.iter().zip(&s.border).filter(|(_, b)| **b).map(|(v, _)| *v).collect())
                    .unwrap_or_default(),
            });
        }
        let combined = combine(input, &cache.regions, outcomes);
        match combined {
            Some(deformation) => {
                stats.volume_after = if cache.closed {
                    signed_volume_of(&deformation.positions, &object.mesh.triangles)
                } else {
                    // An open mesh keeps the volume its displacement sweeps (`deform::volume`).
                    volume_before
                        + swept_volume_change(object.mesh, &cache.topology, &deformation.positions).unwrap_or(f64::NAN)
                };
                stats.max_displacement =
                    input.iter().zip(&deformation.positions).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
                positions.push(deformation.positions.clone());
                kept.push(Some(deformation));
            }
            None => {
                positions.push(input.clone());
                kept.push(None);
            }
        }
        if volume_before != 0.0 {
            stats.relative_volume_change = (stats.volume_after - volume_before) / volume_before.abs();
        }
        object_stats.push(stats);
    }
    ObjectResults { positions, deformations: kept, stats: object_stats, regions: region_stats, summaries }
}
