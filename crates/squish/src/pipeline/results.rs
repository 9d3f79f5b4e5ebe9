//! The results of a frame: each object's positions and deformation, its regions written back
//! ([`combine`]), and the frame's figures — per region pair, per object, per working region and
//! per stage, the stage times summed over region pairs and regions.
//!
//! Vertices outside every deformed region keep their input positions bit for bit. An object's
//! `extent`, `bulge_height` and `applied_bulge_height` are those of its first deformed region;
//! its counts are summed over its regions.

use glam::DVec3;

use std::time::Instant;

use super::cache::ObjectCache;
use super::contacts::{RegionPair, ZoneSummary};
use super::deformations::{RegionOutcome, combine};
use super::plan::Trace;
use super::quality::{QualityCache, measure};
use super::self_contact::{SelfContactResult, relative_to_input};
use super::warnings::frame_warnings;
use super::{
    Frame, FrameResult, FrameStats, ObjectStats, ObjectsLevel, PairStats, PipelineError, RegionStats, RegionSummary,
};
use crate::contact::{DirectionSource, PairContact};
use crate::deform::{RegionDeformation, RegionSolver, swept_volume_change};
use crate::mesh::{signed_volume, signed_volume_of};
use crate::params::PairParams;
use crate::stage::Stage;

/// The result of a frame, assembled in one place for full frames and edits: the contacts between
/// objects written back into each object's positions (`between` is the frame they started from:
/// `frame` after its self-contacts, `resolved`), the figures of every region pair, object, region
/// and stage, then the quality and warnings pass (`quality`: its trees, `None` to leave it out).
/// `start` is when the frame began.
#[allow(clippy::too_many_arguments)]
pub(super) fn assemble(
    frame: &Frame,
    between: &Frame,
    caches: &[Option<ObjectCache>],
    level: ObjectsLevel,
    resolved: Vec<Option<SelfContactResult>>,
    quality: Option<&mut QualityCache>,
    mut trace: Trace,
    start: Instant,
) -> Result<FrameResult, PipelineError> {
    let ObjectsLevel { region_pairs, contacts, outcomes, zones, contained, closed, unseparated, edit } = level;
    let pairs = pair_stats(between, &region_pairs, &contacts);
    let mut objects = object_results(between, caches, &zones, outcomes);

    // The quality and warnings pass.
    let (warnings, quality) = trace.run(Stage::Quality, || {
        let params: Vec<&PairParams> = region_pairs.iter().map(|rp| &between.pairs[rp.pair].params).collect();
        let mut warnings = frame_warnings(&pairs, &contacts, &params, &contained, &objects.stats, &closed);
        warnings.extend(unseparated);
        relative_to_input(&mut objects.stats, frame, &objects.positions, &resolved);
        let quality = match quality {
            Some(cache) => {
                let (figures, residual) = measure(frame, &objects.positions, &pairs, cache);
                warnings.extend(residual);
                figures
            }
            None => Vec::new(),
        };
        (warnings, quality)
    });

    let Trace { stages, work, jobs, articulations, part_pairs } = trace;
    Ok(FrameResult {
        positions: objects.positions,
        contacts,
        deformations: objects.deformations,
        regions: objects.summaries,
        self_contact: resolved,
        stats: FrameStats {
            total: start.elapsed(),
            stages,
            work,
            objects: objects.stats,
            pairs,
            regions: objects.regions,
            articulations,
            part_pairs,
            edit,
            warnings,
            quality,
            jobs,
        },
    })
}

/// The figures of every region pair (same order as `region_pairs`).
pub(super) fn pair_stats(
    frame: &Frame,
    region_pairs: &[RegionPair],
    contacts: &[Option<PairContact>],
) -> Vec<PairStats> {
    let mut pair_stats = Vec::with_capacity(region_pairs.len());
    for (rp, contact) in region_pairs.iter().zip(contacts) {
        let names = frame.pairs[rp.pair].objects.map(|i| frame.objects[i].name.to_string());
        let base = PairStats { objects: names, pair: rp.pair, regions: rp.regions, ..PairStats::default() };
        let Some(contact) = contact else {
            pair_stats.push(base);
            continue;
        };
        let counts = &contact.stats.counts;
        pair_stats.push(PairStats {
            in_contact: !contact.is_empty(),
            direction: contact.direction.to_array(),
            direction_automatic: matches!(contact.direction_source, DirectionSource::Automatic),
            threshold: contact.criterion.threshold,
            mean_depth: contact.criterion.mean,
            depth_std_dev: contact.criterion.std_dev,
            contact_area: contact.contact_area,
            intersection_points: counts.intersection_points,
            zone_vertices: counts.zone_vertices,
            fallbacks: contact.stats.fallbacks.numerical(),
            ..base
        });
    }
    pair_stats
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
