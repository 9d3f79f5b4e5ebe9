//! The library's entry point: one frame of a scene in, deformed meshes and [`FrameStats`] out
//! (thesis ch. 3's pipeline, figure 3.1, method B).
//!
//! A [`Frame`] lists objects (meshes with [`ObjectParams`]) and the pairs of objects that may
//! touch (with [`PairParams`]). [`Deformer::deform`] then
//! 1. runs the contact definition of chapter 4 on every pair (in parallel): intersection regions,
//!    mapping direction, mapping regions, potential contact surface, contact zones;
//! 2. gathers, for every non-rigid object, the zones of all its pairs and runs the deformation of
//!    chapter 5 on it (objects in parallel): parametrization, direction field, guide fields,
//!    profile curves and the volume cubic;
//! 3. reports per-stage timings and quality figures.
//!
//! Every frame is computed from scratch: the result never depends on the frames processed before.
//! What the [`Deformer`] keeps between frames is only what does not depend on positions — each
//! object's topology, triangle tree (refitted) and sparse-matrix pattern with its symbolic
//! factorization — so a frame costs numeric work only. The same input gives bit-identical output
//! with a fresh or a reused deformer, whatever the thread count.
//!
//! The working region of every object is the whole object (method A's automatic regions and
//! masks come with the many-contact pipeline).

mod params;
pub mod bench_scenes;
pub mod scenes;

use std::time::{Duration, Instant};

use glam::DVec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use params::ObjectParams;

use crate::contact::{ContactError, ContactSide, ContactZone, PairContact, PairParams, contact_pair};
use crate::deform::{DeformError, RegionDeformation, RegionSolver, deform_region};
use crate::mesh::{MeshError, Topology, TriMesh, signed_volume, vertex_areas, vertex_normals};
use crate::spatial::{SpatialError, TriangleBvh};

/// One object of a frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameObject<'a> {
    /// Name used in messages and reports.
    pub name: &'a str,
    /// The mesh at this frame. Its triangles must stay the same from frame to frame for the
    /// deformer's caches to be reused (they are rebuilt otherwise).
    pub mesh: &'a TriMesh,
    /// Its parameters at this frame.
    pub params: &'a ObjectParams,
}

/// A pair of objects that may be in contact.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePair {
    /// Indices of the two objects in [`Frame::objects`]. The mapping direction is oriented along
    /// the second object's normals.
    pub objects: [usize; 2],
    /// Contact parameters (τ, direction, safeguard angle).
    pub params: PairParams,
}

/// Everything the deformer needs for one frame.
#[derive(Clone, Debug, Default)]
pub struct Frame<'a> {
    pub objects: Vec<FrameObject<'a>>,
    pub pairs: Vec<FramePair>,
}

/// Why a frame failed. Every variant names the object or pair at fault.
#[derive(Debug, thiserror::Error)]
pub enum PipelineError {
    #[error("object \"{object}\": {source}")]
    Mesh { object: String, source: MeshError },
    #[error("object \"{object}\": {source}")]
    Spatial { object: String, source: SpatialError },
    #[error("pair (\"{a}\", \"{b}\"): {source}")]
    Contact { a: String, b: String, source: ContactError },
    #[error("object \"{object}\": {source}")]
    Deform { object: String, source: DeformError },
    #[error("pair {pair} refers to object {index}, but the frame has {count} objects")]
    PairIndex { pair: usize, index: usize, count: usize },
    #[error("pair {pair} pairs object \"{object}\" with itself; self-contact needs two working regions")]
    SelfPair { pair: usize, object: String },
    #[error("object \"{object}\": {what} must be finite and positive (got {value})")]
    InvalidParameter { object: String, what: &'static str, value: f64 },
}

/// Wall-clock time spent in each stage, summed over pairs (ch. 4 stages) and objects (ch. 5
/// stages); the breakdown of the thesis' tables 7.1–7.2.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StageTimes {
    /// Setup: topology checks, normals, triangle trees.
    pub setup: Duration,
    /// Intersection regions (§4.1).
    pub intersection: Duration,
    /// Mapping direction and mapping regions (§4.2.2).
    pub mapping: Duration,
    /// Potential contact surface and contact zones (§4.3, §4.4.2).
    pub contact_zone: Duration,
    /// Radial parametrization (§5.1).
    pub parametrization: Duration,
    /// Direction field (§5.2).
    pub directions: Duration,
    /// Amplitude and slope fields (§5.3).
    pub guide: Duration,
    /// Profiles, volume and final positions (§5.4–5.5).
    pub deformation: Duration,
    /// Of the ch. 5 stages: time in numeric factorizations.
    pub factorization: Duration,
}

/// Figures of one object for one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ObjectStats {
    pub name: String,
    pub vertices: usize,
    pub rigid: bool,
    /// True if the object was deformed (it had a non-empty contact zone).
    pub deformed: bool,
    /// Signed volume before and after (meaningful for closed meshes).
    pub volume_before: f64,
    pub volume_after: f64,
    /// (after − before) / |before|.
    pub relative_volume_change: f64,
    /// Whether the volume was preserved (solved) for this object.
    pub preserve_volume: bool,
    /// φ_max used this frame.
    pub extent: f64,
    /// h_v and γ·h_v.
    pub bulge_height: f64,
    pub applied_bulge_height: f64,
    /// |𝒞| and |𝒟|.
    pub contact_vertices: usize,
    pub deformable_vertices: usize,
    /// Largest vertex displacement from the input.
    pub max_displacement: f64,
    /// Numeric fallbacks taken by the deformation stage (see `deform::FallbackCounters`).
    pub fallbacks: usize,
}

/// Figures of one pair for one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PairStats {
    pub objects: [String; 2],
    /// True if the meshes intersect (non-empty contact zones).
    pub in_contact: bool,
    /// Mapping direction d̂ and whether it was automatic (Eq. 4.1) or given.
    pub direction: [f64; 3],
    pub direction_automatic: bool,
    /// ε_c, m_𝒮, σ_𝒮 (Eq. 4.3).
    pub threshold: f64,
    pub mean_depth: f64,
    pub depth_std_dev: f64,
    /// Area of the contact zone on the potential contact surface 𝒮.
    pub contact_area: f64,
    pub intersection_points: usize,
    pub zone_vertices: [usize; 2],
    /// Numeric fallbacks taken by the contact stage.
    pub fallbacks: usize,
}

/// Timings and quality figures of one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameStats {
    /// Wall-clock time of the whole frame.
    pub total: Duration,
    /// Per-stage times (summed over pairs and objects).
    pub stages: StageTimes,
    pub objects: Vec<ObjectStats>,
    pub pairs: Vec<PairStats>,
}

/// The result of one frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// Deformed positions per object (same order and count as the input; vertices outside the
    /// deformed regions are bit-identical to the input).
    pub positions: Vec<Vec<DVec3>>,
    /// The contact definition of each pair (`None` for a pair whose objects' boxes are apart).
    pub contacts: Vec<Option<PairContact>>,
    /// The deformation of each object (`None` when it was not deformed).
    pub deformations: Vec<Option<RegionDeformation>>,
    /// Timings and quality figures.
    pub stats: FrameStats,
}

impl FrameResult {
    /// The deformed mesh of object `i` (its input triangles with the new positions).
    pub fn mesh(&self, frame: &Frame, i: usize) -> TriMesh {
        TriMesh { positions: self.positions[i].clone(), triangles: frame.objects[i].mesh.triangles.clone() }
    }
}

/// What the deformer keeps about an object between frames: everything that depends on the
/// connectivity only.
struct ObjectCache {
    triangles: Vec<[u32; 3]>,
    topology: Topology,
    closed: bool,
    bvh: TriangleBvh,
    solver: Option<RegionSolver>,
}

impl ObjectCache {
    fn new(name: &str, mesh: &TriMesh) -> Result<Self, PipelineError> {
        let topology =
            mesh.check_for_deformation().map_err(|source| PipelineError::Mesh { object: name.to_string(), source })?;
        let bvh =
            TriangleBvh::new(mesh).map_err(|source| PipelineError::Spatial { object: name.to_string(), source })?;
        Ok(Self { triangles: mesh.triangles.clone(), closed: topology.is_closed(), topology, bvh, solver: None })
    }

    fn matches(&self, mesh: &TriMesh) -> bool {
        self.triangles == mesh.triangles && self.topology.num_vertices() == mesh.num_vertices()
    }
}

/// Per-object data computed at the start of a frame.
struct Prepared {
    normals: Vec<DVec3>,
    size: f64,
}

/// Runs the pipeline frame after frame, keeping connectivity-only caches (see the module doc).
#[derive(Default)]
pub struct Deformer {
    caches: Vec<Option<ObjectCache>>,
    /// Symbolic factorizations run since creation (one per deformed object unless its
    /// connectivity changes): lets benchmarks check that frames reuse them.
    symbolic_analyses: usize,
}

/// The automatic extent φ_max of an object (used when [`ObjectParams::extent`] is `None`):
/// `max(min(1.2·r, 3·r_partner), 1.5·ρ)`, where r is the object's size, r_partner the smallest size
/// among the objects it is paired with, and ρ = √(A/π) the radius of the largest contact area A
/// of its pairs at this frame.
///
/// The size of an object is its area-weighted RMS distance to its centroid (the radius for a
/// sphere), invariant under rigid motions and continuous with the geometry. The terms follow the
/// thesis' choices (§7.1, Fig. 5.5, 7.23): φ_max = 60 for a sphere of diameter 100 (1.2·r) and 150
/// for the plane it presses (3·r of the sphere: a large object's deformation is limited by the
/// size of what presses it). The contact term keeps the bulge from being squeezed into a band
/// narrower than the contact, which folds the surface for deep contacts. Every term is continuous
/// over an animation, so the automatic extent is too.
pub fn automatic_extent(size: f64, partner_size: f64, contact_area: f64) -> f64 {
    (1.2 * size).min(3.0 * partner_size).max(1.5 * (contact_area.max(0.0) / std::f64::consts::PI).sqrt())
}

/// Area-weighted RMS distance of a mesh to its area-weighted centroid.
pub fn object_size(mesh: &TriMesh) -> f64 {
    let areas = vertex_areas(mesh);
    let total: f64 = areas.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return 0.0;
    }
    let centroid = mesh.positions.iter().zip(&areas).map(|(p, a)| *p * *a).sum::<DVec3>() / total;
    let spread: f64 = mesh.positions.iter().zip(&areas).map(|(p, a)| a * (*p - centroid).length_squared()).sum();
    (spread / total).sqrt()
}

impl Deformer {
    /// A deformer with empty caches.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of symbolic Cholesky analyses run by this deformer since it was created: one per
    /// deformed object on its first frame (and again only if its connectivity changes).
    pub fn symbolic_analyses(&self) -> usize {
        self.symbolic_analyses
    }

    /// Deforms one frame. See the module doc.
    pub fn deform(&mut self, frame: &Frame) -> Result<FrameResult, PipelineError> {
        let start = Instant::now();
        let count = frame.objects.len();
        for (p, pair) in frame.pairs.iter().enumerate() {
            for &index in &pair.objects {
                if index >= count {
                    return Err(PipelineError::PairIndex { pair: p, index, count });
                }
            }
            if pair.objects[0] == pair.objects[1] {
                return Err(PipelineError::SelfPair {
                    pair: p,
                    object: frame.objects[pair.objects[0]].name.to_string(),
                });
            }
        }
        for object in &frame.objects {
            let params = object.params;
            let checks = [("stiffness", Some(params.stiffness)), ("extent", params.extent)];
            for (what, value) in checks {
                if let Some(value) = value
                    && !(value.is_finite() && value > 0.0)
                {
                    return Err(PipelineError::InvalidParameter { object: object.name.to_string(), what, value });
                }
            }
        }

        // Setup: caches (rebuilt when the connectivity changes), refitted trees, normals.
        let setup_start = Instant::now();
        self.caches.resize_with(count, || None);
        self.caches.truncate(count);
        let prepared: Vec<Prepared> = self
            .caches
            .par_iter_mut()
            .zip(&frame.objects)
            .map(|(cache, object)| -> Result<Prepared, PipelineError> {
                object
                    .mesh
                    .check_structure()
                    .map_err(|source| PipelineError::Mesh { object: object.name.to_string(), source })?;
                if !cache.as_ref().is_some_and(|c| c.matches(object.mesh)) {
                    *cache = Some(ObjectCache::new(object.name, object.mesh)?);
                } else if let Some(c) = cache.as_mut() {
                    c.bvh
                        .refit(&object.mesh.positions)
                        .map_err(|source| PipelineError::Spatial { object: object.name.to_string(), source })?;
                }
                Ok(Prepared { normals: vertex_normals(object.mesh), size: object_size(object.mesh) })
            })
            .collect::<Result<_, _>>()?;
        let setup = setup_start.elapsed();
        let caches: Vec<&ObjectCache> = self.caches.iter().flatten().collect();
        let closed: Vec<bool> = caches.iter().map(|c| c.closed).collect();

        // Chapter 4, every pair in parallel.
        let contacts: Vec<Option<PairContact>> = frame
            .pairs
            .par_iter()
            .map(|pair| -> Result<Option<PairContact>, PipelineError> {
                let [ia, ib] = pair.objects;
                let (oa, ob) = (&frame.objects[ia], &frame.objects[ib]);
                if !caches[ia].bvh.bounds().intersects(&caches[ib].bvh.bounds()) {
                    return Ok(None);
                }
                let side_a = ContactSide::new(oa.mesh, &caches[ia].topology, &prepared[ia].normals, &caches[ia].bvh)
                    .with_name(oa.name)
                    .with_stiffness(oa.params.contact_stiffness());
                let side_b = ContactSide::new(ob.mesh, &caches[ib].topology, &prepared[ib].normals, &caches[ib].bvh)
                    .with_name(ob.name)
                    .with_stiffness(ob.params.contact_stiffness());
                contact_pair(&side_a, &side_b, &pair.params).map(Some).map_err(|source| PipelineError::Contact {
                    a: oa.name.to_string(),
                    b: ob.name.to_string(),
                    source,
                })
            })
            .collect::<Result<_, _>>()?;

        // Zones, partners and contact areas per object.
        let mut zones: Vec<Vec<ContactZone>> = vec![Vec::new(); count];
        let mut partner_size = vec![f64::INFINITY; count];
        let mut contact_area = vec![0.0f64; count];
        for (pair, contact) in frame.pairs.iter().zip(&contacts) {
            let [ia, ib] = pair.objects;
            partner_size[ia] = partner_size[ia].min(prepared[ib].size);
            partner_size[ib] = partner_size[ib].min(prepared[ia].size);
            let Some(contact) = contact else { continue };
            for (side, &object) in pair.objects.iter().enumerate() {
                contact_area[object] = contact_area[object].max(contact.contact_area);
                let zone = &contact.sides[side].zone;
                if !zone.is_empty() && !frame.objects[object].params.rigid {
                    zones[object].push(zone.clone());
                }
            }
        }

        // Chapter 5, every object with zones in parallel.
        let solvers_before = self.caches.iter().flatten().filter(|c| c.solver.is_some()).count();
        let deformations: Vec<Option<(RegionDeformation, f64)>> = self
            .caches
            .par_iter_mut()
            .zip(&frame.objects)
            .zip(&zones)
            .enumerate()
            .map(|(i, ((cache, object), zones))| -> Result<Option<(RegionDeformation, f64)>, PipelineError> {
                let Some(cache) = cache.as_mut() else { return Ok(None) };
                if zones.is_empty() {
                    return Ok(None);
                }
                let err = |source| PipelineError::Deform { object: object.name.to_string(), source };
                let extent = object
                    .params
                    .extent
                    .unwrap_or_else(|| automatic_extent(prepared[i].size, partner_size[i], contact_area[i]));
                if cache.solver.is_none() {
                    cache.solver = Some(RegionSolver::new(object.mesh, &cache.topology).map_err(err)?);
                }
                let Some(solver) = cache.solver.as_mut() else { return Ok(None) };
                let params = object.params.deform_params(extent, cache.closed);
                let deformation = deform_region(object.mesh, &cache.topology, solver, zones, &params).map_err(err)?;
                Ok(Some((deformation, extent)))
            })
            .collect::<Result<_, _>>()?;
        // A solver is only ever created (one symbolic analysis each), never replaced in place.
        let solvers_after = self.caches.iter().flatten().filter(|c| c.solver.is_some()).count();
        self.symbolic_analyses += solvers_after.saturating_sub(solvers_before);

        // Results and statistics.
        let mut stages = StageTimes { setup, ..StageTimes::default() };
        let mut pair_stats = Vec::with_capacity(frame.pairs.len());
        for (pair, contact) in frame.pairs.iter().zip(&contacts) {
            let names = pair.objects.map(|i| frame.objects[i].name.to_string());
            let Some(contact) = contact else {
                pair_stats.push(PairStats { objects: names, ..PairStats::default() });
                continue;
            };
            let t = &contact.stats.timings;
            stages.intersection += t.intersection;
            stages.mapping += t.direction + t.mapping;
            stages.contact_zone += t.surface + t.zone;
            let counts = &contact.stats.counts;
            pair_stats.push(PairStats {
                objects: names,
                in_contact: !contact.is_empty(),
                direction: contact.direction.to_array(),
                direction_automatic: matches!(contact.direction_source, crate::contact::DirectionSource::Automatic),
                threshold: contact.criterion.threshold,
                mean_depth: contact.criterion.mean,
                depth_std_dev: contact.criterion.std_dev,
                contact_area: contact.contact_area,
                intersection_points: counts.intersection_points,
                zone_vertices: counts.zone_vertices,
                fallbacks: contact.stats.fallbacks.numerical(),
            });
        }
        let mut positions = Vec::with_capacity(count);
        let mut object_stats = Vec::with_capacity(count);
        let mut kept = Vec::with_capacity(count);
        for (i, (object, result)) in frame.objects.iter().zip(deformations).enumerate() {
            let input = &object.mesh.positions;
            let volume_before = signed_volume(object.mesh);
            let mut stats = ObjectStats {
                name: object.name.to_string(),
                vertices: input.len(),
                rigid: object.params.rigid,
                volume_before,
                volume_after: volume_before,
                preserve_volume: object.params.preserve_volume.unwrap_or(closed[i]),
                ..ObjectStats::default()
            };
            match result {
                Some((deformation, extent)) => {
                    let s = &deformation.stats;
                    stages.parametrization += s.timings.parametrization;
                    stages.directions += s.timings.directions;
                    stages.guide += s.timings.guide;
                    stages.deformation += s.timings.deformation;
                    stages.factorization += s.timings.factorization;
                    let after =
                        TriMesh { positions: deformation.positions.clone(), triangles: object.mesh.triangles.clone() };
                    stats.deformed = true;
                    stats.volume_after = signed_volume(&after);
                    stats.extent = extent;
                    stats.bulge_height = s.bulge_height;
                    stats.applied_bulge_height = s.applied_bulge_height;
                    stats.contact_vertices = s.num_contact;
                    stats.deformable_vertices = s.num_deformable;
                    stats.fallbacks = s.fallbacks.direction_blend
                        + s.fallbacks.bulge_map
                        + s.fallbacks.volume_without_root
                        + s.fallbacks.clamped_slopes;
                    stats.max_displacement =
                        input.iter().zip(&deformation.positions).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
                    positions.push(after.positions);
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
        Ok(FrameResult {
            positions,
            contacts,
            deformations: kept,
            stats: FrameStats { total: start.elapsed(), stages, objects: object_stats, pairs: pair_stats },
        })
    }
}

#[cfg(test)]
mod tests;
