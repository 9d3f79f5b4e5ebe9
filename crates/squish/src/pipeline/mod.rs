//! The library's entry point: one frame of a scene in, deformed meshes and [`FrameStats`] out
//! (thesis ch. 3's pipeline, figure 3.1, method B).
//!
//! A [`Frame`] lists objects (meshes with [`ObjectParams`]) and the pairs of objects that may
//! touch (with [`PairParams`]). Every object is divided into **working regions** 𝒲
//! ([`ObjectParams::region`], [`WorkingRegion`]; default: the whole object — see
//! [`regions`] for the choices, the automatic rule and the cost trade-off of §7.5).
//! [`Deformer::deform`] then
//! 1. expands every [`FramePair`] into the pairs of its objects' regions whose boxes overlap
//!    (a hand of five finger regions against a ball is one `FramePair`; a pair of one object with
//!    itself pairs its distinct regions: fingers on their own palm);
//! 2. runs the contact definition of chapter 4 on every region pair (in parallel): intersection
//!    regions, mapping direction, mapping regions, potential contact surface, contact zones — each
//!    region pair with its own d̂ and ε_c;
//! 3. gathers, for every region of a non-rigid object, the zones of all its region pairs and runs
//!    the deformation of chapter 5 on it (regions in parallel; several zones are diffused into one
//!    direction field, §5.2.2, and the anisotropic bulge map sums over them, Eq. 5.6);
//! 4. writes the regions' results back into each object's positions (vertices outside every
//!    region are returned bit for bit) and reports per-stage timings and quality figures, per
//!    object, per region and per region pair.
//!
//! Every frame is computed from scratch: the result never depends on the frames processed before.
//! What the [`Deformer`] keeps between frames is only what does not depend on positions — each
//! object's topology, each region's sub-mesh, topology, triangle tree (refitted) and sparse-matrix
//! pattern with its symbolic factorization — so a frame costs numeric work only (plus a rebuild
//! for a region whose face set changed). The same input gives bit-identical output with a fresh or
//! a reused deformer, whatever the thread count.

pub mod bench_scenes;
mod params;
pub mod regions;
pub mod scenes;
mod self_contact;
mod warnings;

use std::time::{Duration, Instant};

use glam::{DVec2, DVec3};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

pub use params::ObjectParams;
pub use regions::WorkingRegion;
pub use self_contact::SelfContactResult;
pub use warnings::{FrameWarning, RESIDUAL_PENETRATION_TOLERANCE, WarningKind, pair_warnings};

use crate::contact::{ContactError, ContactSide, ContactZone, PairContact, PairParams, contact_pair};
use crate::deform::{DeformError, DeformStats, RegionDeformation, RegionOverrides, RegionSolver, deform_region_with};
use crate::linalg::FillOrder;
use crate::mesh::{Aabb3, MeshError, Topology, TriMesh, signed_volume, signed_volume_of, vertex_areas, vertex_normals};
use crate::spatial::{SpatialError, TriangleBvh};
use regions::{ComponentFigures, Components, Partner, RegionCache, Selection};

/// One object of a frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameObject<'a> {
    /// Name used in messages and reports.
    pub name: &'a str,
    /// The mesh at this frame. Its triangles must stay the same from frame to frame for the
    /// deformer's caches to be reused (they are rebuilt otherwise).
    pub mesh: &'a TriMesh,
    /// Its parameters at this frame (including its working regions).
    pub params: &'a ObjectParams,
}

/// A pair of objects that may be in contact. It stands for every pair of their working regions
/// whose boxes overlap (see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FramePair {
    /// Indices of the two objects in [`Frame::objects`]. The mapping direction is oriented along
    /// the second object's normals. Both indices may be the same object when it has several
    /// explicit regions ([`WorkingRegion::allows_self_contact`]): its distinct regions are paired.
    pub objects: [usize; 2],
    /// Contact parameters (τ, direction, safeguard angle), shared by its region pairs.
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
    #[error(
        "pair {pair} pairs object \"{object}\" with itself; self-contact needs several explicit working regions \
         (region = components, a mask or masks)"
    )]
    SelfPair { pair: usize, object: String },
    #[error("object \"{object}\": {what} must be finite and positive (got {value})")]
    InvalidParameter { object: String, what: &'static str, value: f64 },
    #[error("object \"{object}\": working region: {reason}")]
    InvalidRegion { object: String, reason: String },
    #[error(
        "object \"{object}\": {what} has {actual} values but the mesh has {expected} vertices; give one value per vertex"
    )]
    PerVertexLength { object: String, what: &'static str, expected: usize, actual: usize },
    #[error("object \"{object}\", articulation \"{articulation}\": {source}")]
    SelfContact { object: String, articulation: String, source: Box<crate::skinning::SelfContactError> },
    #[error(
        "object \"{object}\", working region {region}: {reason}; use a larger working region (a wider mask or \
         distance) or a smaller extent"
    )]
    RegionTooSmall { object: String, region: usize, reason: String },
}

/// Wall-clock time spent in each stage, summed over pairs (ch. 4 stages) and regions (ch. 5
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
    /// Of the factorizations: symbolic analyses of coupled-row submatrices.
    #[serde(default)]
    pub analysis: Duration,
    /// Choosing the working regions and updating their caches (wall clock).
    #[serde(default)]
    pub regions: Duration,
}

/// Figures of one object for one frame. For an object of several regions, the per-region
/// figures are in [`FrameStats::regions`]; here counts are summed over its regions and
/// `extent`, `bulge_height` and `applied_bulge_height` are those of its first deformed region.
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
    /// Number of working regions this frame.
    #[serde(default)]
    pub regions: usize,
    /// Number of non-empty contact zones over its regions.
    #[serde(default)]
    pub zones: usize,
    /// True if the extent of one of its regions was clamped to fit the region.
    #[serde(default)]
    pub extent_clamped: bool,
    /// True if the parametrization domain of one of its regions reached the region's cut (see
    /// [`RegionStats::domain_reaches_cut`]): the result may then differ slightly from the whole
    /// object's.
    #[serde(default)]
    pub domain_reaches_cut: bool,
}

/// Figures of one region pair for one frame (one entry per pair of overlapping regions of a
/// [`FramePair`], or one entry with `regions: None` when none overlap).
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
    /// Index of the [`FramePair`] this region pair comes from.
    #[serde(default)]
    pub pair: usize,
    /// The two regions (indices among each object's regions, see [`FrameStats::regions`]);
    /// `None` when no region of one object overlaps a region of the other.
    #[serde(default)]
    pub regions: Option<[usize; 2]>,
}

/// Figures of one working region for one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionStats {
    /// Index and name of its object.
    pub object: usize,
    pub name: String,
    /// Index among the object's regions.
    pub region: usize,
    /// True if the region is the whole object.
    pub whole: bool,
    pub vertices: usize,
    pub faces: usize,
    /// Vertices on the border where it was cut out of its object.
    pub cut_border_vertices: usize,
    /// True if its caches were built at this frame (new or changed face set).
    pub rebuilt: bool,
    /// The regions it is in contact with, as `[object, region]`.
    pub touching: Vec<[usize; 2]>,
    /// Non-empty contact zones (one per region pair in contact, when the object is not rigid).
    pub zones: usize,
    pub deformed: bool,
    /// φ_max used (after clamping).
    pub extent: f64,
    /// True if φ_max was clamped so that 𝒟 stays inside the region.
    pub extent_clamped: bool,
    /// True if the parametrization domain 𝒫 (within `domain_factor·φ_max` of ∂𝒞 along edges)
    /// reached the region's cut, so the cut limited it: the result then differs slightly from
    /// the whole object's. False otherwise, and the result is the whole object's up to round-off.
    pub domain_reaches_cut: bool,
    /// Vertices within the parametrization domain's radius.
    pub domain_vertices: usize,
    pub bulge_height: f64,
    pub applied_bulge_height: f64,
    pub contact_vertices: usize,
    pub deformable_vertices: usize,
    /// True if its factorizations eliminate in the nested-dissection order, kept because it
    /// needs fewer flops than AMD's for this region (see [`crate::linalg::FillOrder`]); false for
    /// AMD's order, always the one of automatic regions. Changes the time, not the result beyond
    /// round-off.
    #[serde(default)]
    pub nested_dissection: bool,
    /// Wall-clock time of its deformation (ch. 5).
    pub time: Duration,
}

/// Timings and quality figures of one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct FrameStats {
    /// Wall-clock time of the whole frame.
    pub total: Duration,
    /// Per-stage times (summed over pairs and regions).
    pub stages: StageTimes,
    pub objects: Vec<ObjectStats>,
    /// One entry per region pair (see [`PairStats`]); for objects of one region each, one entry
    /// per [`FramePair`] in order.
    pub pairs: Vec<PairStats>,
    /// Every working region, object by object.
    #[serde(default)]
    pub regions: Vec<RegionStats>,
    /// Every articulation with self-contact (ch. 6), object by object.
    #[serde(default)]
    pub articulations: Vec<crate::skinning::ArticulationStats>,
    /// What the frame did not do that it was asked to (see [`FrameWarning`]).
    #[serde(default)]
    pub warnings: Vec<FrameWarning>,
}

/// Which part of its object a working region is (same order as [`FrameStats::regions`]).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RegionSummary {
    pub object: usize,
    pub region: usize,
    /// True when the region is the whole object (the lists below are then empty).
    pub whole: bool,
    /// Its faces (object face ids, increasing).
    pub faces: Vec<u32>,
    /// Its vertices (object vertex ids, increasing): region vertex `i` is object vertex
    /// `vertices[i]` — the numbering of the region pairs' [`PairContact`]s.
    pub vertices: Vec<u32>,
    /// Its vertices on the cut border (object vertex ids).
    pub cut_border: Vec<u32>,
}

/// The result of one frame.
#[derive(Clone, Debug)]
pub struct FrameResult {
    /// Deformed positions per object (same order and count as the input; vertices outside the
    /// deformed regions are bit-identical to the input).
    pub positions: Vec<Vec<DVec3>>,
    /// The contact definition of each region pair, in the order of [`FrameStats::pairs`] (`None`
    /// for region pairs whose boxes are apart). Vertex and face ids are those of the regions
    /// (see [`RegionSummary::vertices`]); for objects of one region each, one entry per
    /// [`FramePair`] in object ids.
    pub contacts: Vec<Option<PairContact>>,
    /// The deformation of each object (`None` when it was not deformed), per object vertex: for
    /// an object of several regions, the regions' results written into object-sized arrays
    /// (outside the regions: u = +∞, zero direction and height, η = 1; stats summed).
    pub deformations: Vec<Option<RegionDeformation>>,
    /// The working regions, in the order of [`FrameStats::regions`].
    pub regions: Vec<RegionSummary>,
    /// Per object: the result of its articulations' self-contact (ch. 6), `None` without any.
    pub self_contact: Vec<Option<SelfContactResult>>,
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
    /// Tree over the whole object; refitted at the frames where it is used (`Whole` regions,
    /// partners of automatic regions).
    bvh: TriangleBvh,
    components: Components,
    regions: Vec<RegionCache>,
    /// The last frame's component figures and the positions they were computed from: an object
    /// that has not moved since, bit for bit (a static ground, a prop at rest), reuses them, which
    /// gives the same bits as computing them again.
    figures: Option<(Vec<DVec3>, ComponentFigures)>,
}

impl ObjectCache {
    fn new(name: &str, mesh: &TriMesh) -> Result<Self, PipelineError> {
        let topology =
            mesh.check_for_deformation().map_err(|source| PipelineError::Mesh { object: name.to_string(), source })?;
        let bvh =
            TriangleBvh::new(mesh).map_err(|source| PipelineError::Spatial { object: name.to_string(), source })?;
        let components = Components::new(mesh, &topology);
        Ok(Self {
            triangles: mesh.triangles.clone(),
            closed: topology.is_closed(),
            topology,
            bvh,
            components,
            regions: Vec::new(),
            figures: None,
        })
    }

    /// The figures of the object's components at `mesh`'s positions.
    fn figures(&mut self, mesh: &TriMesh) -> ComponentFigures {
        let bits = |p: &DVec3| p.to_array().map(f64::to_bits);
        if let Some((positions, figures)) = &self.figures
            && positions.len() == mesh.positions.len()
            && positions.iter().zip(&mesh.positions).all(|(a, b)| bits(a) == bits(b))
        {
            return figures.clone();
        }
        let figures = ComponentFigures::new(mesh, &self.topology, &self.components);
        let mut positions = self.figures.take().map(|(positions, _)| positions).unwrap_or_default();
        positions.clear();
        positions.extend_from_slice(&mesh.positions);
        self.figures = Some((positions, figures.clone()));
        figures
    }

    fn matches(&self, mesh: &TriMesh) -> bool {
        self.triangles == mesh.triangles && self.topology.num_vertices() == mesh.num_vertices()
    }

    /// The contact side of region `r`.
    fn side<'a>(
        &'a self,
        r: usize,
        object: &'a FrameObject,
        normals: Option<&'a [DVec3]>,
        name: &'a str,
        uvs: Option<&'a [DVec2]>,
    ) -> Option<ContactSide<'a>> {
        let region = self.regions.get(r)?;
        let side = match region.sub.as_deref() {
            None => ContactSide::new(object.mesh, &self.topology, normals?, &self.bvh),
            Some(sub) => ContactSide::new(&sub.sub.mesh, &sub.topology, &sub.normals, &sub.bvh)
                .with_border((sub.border_count > 0).then_some(sub.border.as_slice())),
        };
        Some(side.with_name(name).with_stiffness(object.params.contact_stiffness()).with_uvs(uvs))
    }

    /// For a cut region `r` and a partner region that is a whole closed object: the first vertex
    /// of `r` (object id) if it lies inside the partner.
    fn inside_whole_closed(&self, r: usize, other: &ObjectCache, other_r: usize) -> Option<u32> {
        let sub = self.regions.get(r)?.sub.as_deref()?;
        if !other.closed || other.regions.get(other_r)?.sub.is_some() {
            return None;
        }
        let p = *sub.sub.mesh.positions.first()?;
        other.bvh.contains(p).then(|| sub.sub.parent_vertex[0])
    }

    /// For whole regions that no edge crosses: true if `mesh` (this object, region `r`) has a
    /// vertex inside `other` (closed, region `other_r`), i.e. lies inside it.
    fn lies_inside(&self, r: usize, mesh: &TriMesh, other: &ObjectCache, other_r: usize) -> bool {
        let whole = |c: &ObjectCache, r: usize| c.regions.get(r).is_some_and(|region| region.sub.is_none());
        if !other.closed || !whole(self, r) || !whole(other, other_r) {
            return false;
        }
        mesh.triangles.first().is_some_and(|t| other.bvh.contains(mesh.positions[t[0] as usize]))
    }

    fn region_bounds(&self, r: usize) -> Aabb3 {
        match self.regions[r].sub.as_deref() {
            None => self.bvh.bounds(),
            Some(sub) => sub.bvh.bounds(),
        }
    }
}

/// Per-object data computed at the start of a frame.
struct Prepared {
    figures: ComponentFigures,
}

/// A region pair of this frame.
#[derive(Clone, Copy, Debug)]
struct RegionPair {
    pair: usize,
    regions: Option<[usize; 2]>,
}

/// The deformation of one region.
struct RegionOutcome {
    deformation: RegionDeformation,
    extent: f64,
    clamped: bool,
    /// Whether 𝒫 reached the region's cut.
    domain_reaches_cut: bool,
    time: Duration,
    /// Whether this frame built the region's solver (one symbolic analysis).
    new_solver: bool,
}

/// Runs the pipeline frame after frame, keeping connectivity-only caches (see the module doc).
#[derive(Default)]
pub struct Deformer {
    caches: Vec<Option<ObjectCache>>,
    /// Symbolic factorizations run since creation (one per deformed region unless its face set
    /// or connectivity changes): lets benchmarks check that frames reuse them.
    symbolic_analyses: usize,
    /// Per object: the caches of its articulations (ch. 6).
    self_contact: Vec<self_contact::SelfContactCache>,
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
///
/// With working regions, each region gets its own extent: r is the size of the connected
/// components of its object that it touches (the object's size for a one-piece object; a finger's
/// size when the fingers are separate components), r_partner the smallest such size among the
/// regions it is paired with, A the largest contact area of its region pairs.
pub fn automatic_extent(size: f64, partner_size: f64, contact_area: f64) -> f64 {
    (1.2 * size).min(3.0 * partner_size).max(1.5 * (contact_area.max(0.0) / std::f64::consts::PI).sqrt())
}

/// Area-weighted RMS distance of a mesh to its area-weighted centroid.
pub fn object_size(mesh: &TriMesh) -> f64 {
    size_from_areas(mesh, &vertex_areas(mesh))
}

/// [`object_size`] with the lumped vertex areas given.
fn size_from_areas(mesh: &TriMesh, areas: &[f64]) -> f64 {
    let total: f64 = areas.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return 0.0;
    }
    let centroid = mesh.positions.iter().zip(areas).map(|(p, a)| *p * *a).sum::<DVec3>() / total;
    let spread: f64 = mesh.positions.iter().zip(areas).map(|(p, a)| a * (*p - centroid).length_squared()).sum();
    (spread / total).sqrt()
}

/// Display name of a region for messages: the object's name, qualified when it has several
/// regions or is cut.
fn region_name(object: &str, cache: &RegionCache, index: usize, count: usize) -> String {
    if cache.sub.is_none() && count == 1 { object.to_string() } else { format!("{object} (region {index})") }
}

impl Deformer {
    /// A deformer with empty caches.
    pub fn new() -> Self {
        Self::default()
    }

    /// Number of symbolic Cholesky analyses run by this deformer since it was created: one per
    /// deformed region on its first frame (and again only if its face set or connectivity
    /// changes).
    pub fn symbolic_analyses(&self) -> usize {
        self.symbolic_analyses
    }

    /// Deforms one frame. See the module doc.
    pub fn deform(&mut self, frame: &Frame) -> Result<FrameResult, PipelineError> {
        let start = Instant::now();
        if frame.objects.iter().all(|o| o.params.self_contact.is_empty()) {
            self.self_contact.clear();
            return self.deform_pairs(frame, start);
        }
        let (resolved, articulations) = self_contact::resolve_self_contacts(&mut self.self_contact, frame)?;
        let meshes: Vec<Option<TriMesh>> = resolved
            .iter()
            .zip(&frame.objects)
            .map(|(r, o)| {
                r.as_ref().map(|r| TriMesh { positions: r.positions.clone(), triangles: o.mesh.triangles.clone() })
            })
            .collect();
        let objects = frame
            .objects
            .iter()
            .zip(&meshes)
            .map(|(o, m)| FrameObject { mesh: m.as_ref().unwrap_or(o.mesh), ..*o })
            .collect();
        let mut result = self.deform_pairs(&Frame { objects, pairs: frame.pairs.clone() }, start)?;
        // Figures relative to the frame's input, not to the self-contact stage's output.
        for ((stats, object), (positions, r)) in
            result.stats.objects.iter_mut().zip(&frame.objects).zip(result.positions.iter().zip(&resolved))
        {
            if r.is_none() {
                continue;
            }
            stats.volume_before = signed_volume(object.mesh);
            if stats.volume_before != 0.0 {
                stats.relative_volume_change = (stats.volume_after - stats.volume_before) / stats.volume_before.abs();
            }
            stats.max_displacement =
                object.mesh.positions.iter().zip(positions).map(|(a, b)| (*a - *b).length()).fold(0.0, f64::max);
            stats.deformed |= r.as_ref().is_some_and(|r| r.moved.iter().any(|&m| m));
        }
        result.stats.articulations = articulations;
        result.self_contact = resolved;
        result.stats.total = start.elapsed();
        Ok(result)
    }

    /// The contacts between objects (ch. 4–5) of a frame; `start` is when the frame began.
    fn deform_pairs(&mut self, frame: &Frame, start: Instant) -> Result<FrameResult, PipelineError> {
        let count = frame.objects.len();
        let mut partners: Vec<Vec<usize>> = vec![Vec::new(); count];
        for (p, pair) in frame.pairs.iter().enumerate() {
            for &index in &pair.objects {
                if index >= count {
                    return Err(PipelineError::PairIndex { pair: p, index, count });
                }
            }
            let [a, b] = pair.objects;
            if a == b {
                if !frame.objects[a].params.region.allows_self_contact() {
                    return Err(PipelineError::SelfPair { pair: p, object: frame.objects[a].name.to_string() });
                }
            } else {
                partners[a].push(b);
                partners[b].push(a);
            }
        }
        for list in &mut partners {
            list.sort_unstable();
            list.dedup();
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
            params
                .region
                .validate(object.mesh.num_vertices())
                .map_err(|reason| regions::invalid(object.name, reason))?;
            if let Some(uvs) = &params.uvs
                && uvs.len() != object.mesh.num_vertices()
            {
                return Err(PipelineError::PerVertexLength {
                    object: object.name.to_string(),
                    what: "the UVs",
                    expected: object.mesh.num_vertices(),
                    actual: uvs.len(),
                });
            }
        }
        // The whole-object tree is needed by `Whole` regions and by the partners of automatic ones.
        let needs_tree: Vec<bool> = (0..count)
            .map(|i| {
                matches!(frame.objects[i].params.region, WorkingRegion::Whole)
                    || partners[i].iter().any(|&j| frame.objects[j].params.region.is_automatic())
            })
            .collect();

        // Setup: caches (rebuilt when the connectivity changes), refitted trees, normals, sizes.
        let setup_start = Instant::now();
        self.caches.resize_with(count, || None);
        self.caches.truncate(count);
        let prepared: Vec<Prepared> = self
            .caches
            .par_iter_mut()
            .zip(&frame.objects)
            .zip(&needs_tree)
            .map(|((cache, object), &needs_tree)| -> Result<Prepared, PipelineError> {
                object
                    .mesh
                    .check_structure()
                    .map_err(|source| PipelineError::Mesh { object: object.name.to_string(), source })?;
                let cache = match cache {
                    Some(c) if c.matches(object.mesh) => {
                        if needs_tree {
                            c.bvh
                                .refit(&object.mesh.positions)
                                .map_err(|source| PipelineError::Spatial { object: object.name.to_string(), source })?;
                        }
                        c
                    }
                    _ => cache.insert(ObjectCache::new(object.name, object.mesh)?),
                };
                Ok(Prepared { figures: cache.figures(object.mesh) })
            })
            .collect::<Result<_, _>>()?;
        let setup = setup_start.elapsed();

        // Working regions: choose them, then update their caches.
        let regions_start = Instant::now();
        let selections: Vec<Selection> = {
            let caches: Vec<&ObjectCache> = self.caches.iter().flatten().collect();
            (0..count)
                .into_par_iter()
                .map(|i| {
                    let object = &frame.objects[i];
                    let others: Vec<Partner> = partners[i]
                        .iter()
                        .map(|&j| Partner {
                            mesh: frame.objects[j].mesh,
                            bvh: &caches[j].bvh,
                            closed: caches[j].closed,
                            figures: &prepared[j].figures,
                        })
                        .collect();
                    let cache = caches[i];
                    regions::select(
                        object.mesh,
                        &cache.topology,
                        &cache.components,
                        &prepared[i].figures,
                        object.params,
                        &others,
                    )
                    .map_err(|reason| regions::invalid(object.name, reason))
                })
                .collect::<Result<_, _>>()?
        };
        self.caches.par_iter_mut().zip(selections).zip(&frame.objects).zip(&needs_tree).try_for_each(
            |(((cache, selection), object), &refitted)| -> Result<(), PipelineError> {
                let Some(cache) = cache.as_mut() else { return Ok(()) };
                // A selection may be the whole object without `WorkingRegion::Whole`.
                if matches!(selection, Selection::Whole) && !refitted {
                    cache
                        .bvh
                        .refit(&object.mesh.positions)
                        .map_err(|source| PipelineError::Spatial { object: object.name.to_string(), source })?;
                }
                let ObjectCache { regions, topology, components, .. } = cache;
                regions::update_regions(regions, selection, object.mesh, topology, components)
                    .map_err(|reason| regions::invalid(object.name, reason))
            },
        )?;
        let regions_time = regions_start.elapsed();
        let caches: Vec<&ObjectCache> = self.caches.iter().flatten().collect();
        // Vertex normals of the objects processed whole (cut regions have their own).
        let normals: Vec<Option<Vec<DVec3>>> = caches
            .par_iter()
            .zip(&frame.objects)
            .map(|(c, o)| c.regions.iter().any(|r| r.sub.is_none()).then(|| vertex_normals(o.mesh)))
            .collect();
        let closed: Vec<bool> = caches.iter().map(|c| c.closed).collect();
        let names: Vec<Vec<String>> = caches
            .iter()
            .zip(&frame.objects)
            .map(|(c, o)| {
                c.regions
                    .iter()
                    .enumerate()
                    .map(|(r, region)| region_name(o.name, region, r, c.regions.len()))
                    .collect()
            })
            .collect();
        // UVs of each region (gathered for cut regions), for the shared-parametrization mapping.
        let uvs: Vec<Vec<Option<Vec<DVec2>>>> = caches
            .iter()
            .zip(&frame.objects)
            .map(|(c, o)| {
                c.regions
                    .iter()
                    .map(|region| {
                        let uvs = o.params.uvs.as_ref()?;
                        Some(region.sub.as_deref().map_or_else(|| uvs.clone(), |sub| sub.sub.gather(uvs)))
                    })
                    .collect()
            })
            .collect();
        let sizes: Vec<Vec<f64>> = caches
            .iter()
            .zip(&prepared)
            .map(|(c, p)| c.regions.iter().map(|r| p.figures.size_of(&r.components)).collect())
            .collect();

        // Region pairs: every pair of regions of a frame pair whose boxes overlap.
        let mut region_pairs = Vec::new();
        for (p, pair) in frame.pairs.iter().enumerate() {
            let [a, b] = pair.objects;
            let before = region_pairs.len();
            for ra in 0..caches[a].regions.len() {
                let first = if a == b { ra + 1 } else { 0 };
                for rb in first..caches[b].regions.len() {
                    if caches[a].region_bounds(ra).intersects(&caches[b].region_bounds(rb)) {
                        region_pairs.push(RegionPair { pair: p, regions: Some([ra, rb]) });
                    }
                }
            }
            if region_pairs.len() == before {
                region_pairs.push(RegionPair { pair: p, regions: None });
            }
        }

        // Chapter 4, every region pair in parallel.
        let mut contacts: Vec<Option<PairContact>> = region_pairs
            .par_iter()
            .map(|rp| -> Result<Option<PairContact>, PipelineError> {
                let Some([ra, rb]) = rp.regions else { return Ok(None) };
                let pair = &frame.pairs[rp.pair];
                let [ia, ib] = pair.objects;
                let (oa, ob) = (&frame.objects[ia], &frame.objects[ib]);
                let side_a = caches[ia].side(ra, oa, normals[ia].as_deref(), &names[ia][ra], uvs[ia][ra].as_deref());
                let side_b = caches[ib].side(rb, ob, normals[ib].as_deref(), &names[ib][rb], uvs[ib][rb].as_deref());
                let sides = side_a.zip(side_b);
                let Some((side_a, side_b)) = sides else { return Ok(None) };
                let contact = contact_pair(&side_a, &side_b, &pair.params).map_err(|source| {
                    PipelineError::Contact { a: names[ia][ra].clone(), b: names[ib][rb].clone(), source }
                })?;
                if contact.intersection_points.is_empty() {
                    // No crossing: a cut region lying wholly inside a closed object would go unseen.
                    for (o, r, other, other_r) in [(ia, ra, ib, rb), (ib, rb, ia, ra)] {
                        if let Some(v) = caches[o].inside_whole_closed(r, caches[other], other_r) {
                            return Err(PipelineError::RegionTooSmall {
                                object: frame.objects[o].name.to_string(),
                                region: r,
                                reason: format!(
                                    "it lies wholly inside \"{}\" (its vertex {v} is inside, and no edge crosses)",
                                    frame.objects[other].name
                                ),
                            });
                        }
                    }
                }
                Ok(Some(contact))
            })
            .collect::<Result<_, _>>()?;

        // One side wholly inside the other, for the warnings: [inner, outer] as sides of the pair.
        let contained: Vec<Option<[usize; 2]>> = region_pairs
            .iter()
            .zip(&contacts)
            .map(|(rp, contact)| {
                let (Some([ra, rb]), Some(contact)) = (rp.regions, contact) else { return None };
                if !contact.intersection_points.is_empty() {
                    return None;
                }
                let [ia, ib] = frame.pairs[rp.pair].objects;
                let (ma, mb) = (frame.objects[ia].mesh, frame.objects[ib].mesh);
                if caches[ia].lies_inside(ra, ma, caches[ib], rb) {
                    Some([0, 1])
                } else if caches[ib].lies_inside(rb, mb, caches[ia], ra) {
                    Some([1, 0])
                } else {
                    None
                }
            })
            .collect();

        // Zones, partners, contact areas and touching regions per region.
        let per_region = |fill: f64| -> Vec<Vec<f64>> { caches.iter().map(|c| vec![fill; c.regions.len()]).collect() };
        let mut zones: Vec<Vec<Vec<ContactZone>>> =
            caches.iter().map(|c| (0..c.regions.len()).map(|_| Vec::new()).collect()).collect();
        let mut touching: Vec<Vec<Vec<[usize; 2]>>> =
            caches.iter().map(|c| vec![Vec::new(); c.regions.len()]).collect();
        let mut partner_size = per_region(f64::INFINITY);
        let mut contact_area = per_region(0.0);
        // The zones move into their regions' lists for chapter 5 and back into `contacts` after
        // it, instead of being copied (each holds two vectors of the region's size). `lent`
        // remembers where each came from (pair contact, side), in the same lists.
        let mut lent: Vec<Vec<Vec<(usize, usize)>>> =
            caches.iter().map(|c| vec![Vec::new(); c.regions.len()]).collect();
        for (k, (rp, contact)) in region_pairs.iter().zip(&mut contacts).enumerate() {
            let Some(regions) = rp.regions else { continue };
            let objects = frame.pairs[rp.pair].objects;
            for side in 0..2 {
                let (o, r) = (objects[side], regions[side]);
                let (other_o, other_r) = (objects[1 - side], regions[1 - side]);
                partner_size[o][r] = partner_size[o][r].min(sizes[other_o][other_r]);
            }
            let Some(contact) = contact else { continue };
            if contact.is_empty() {
                continue;
            }
            for side in 0..2 {
                let (o, r) = (objects[side], regions[side]);
                touching[o][r].push([objects[1 - side], regions[1 - side]]);
                contact_area[o][r] = contact_area[o][r].max(contact.contact_area);
                let zone = &mut contact.sides[side].zone;
                if !zone.is_empty() && !frame.objects[o].params.rigid {
                    zones[o][r].push(std::mem::take(zone));
                    lent[o][r].push((k, side));
                }
            }
        }
        drop(caches);

        // Chapter 5, every region with zones in parallel.
        let outcomes: Vec<Vec<Option<RegionOutcome>>> = self
            .caches
            .par_iter_mut()
            .zip(&frame.objects)
            .zip(&zones)
            .enumerate()
            .map(|(i, ((cache, object), zones))| -> Result<Vec<Option<RegionOutcome>>, PipelineError> {
                let Some(cache) = cache.as_mut() else { return Ok(Vec::new()) };
                let ObjectCache { regions, topology, closed, .. } = cache;
                let (topology, closed) = (&*topology, *closed);
                regions
                    .par_iter_mut()
                    .zip(zones)
                    .enumerate()
                    .map(|(r, (region, zones))| {
                        if zones.is_empty() {
                            return Ok(None);
                        }
                        let extent = object
                            .params
                            .extent
                            .unwrap_or_else(|| automatic_extent(sizes[i][r], partner_size[i][r], contact_area[i][r]));
                        let scale =
                            Scale { extent, edge_length: prepared[i].figures.mean_edge_length(&region.components) };
                        deform_one(object, topology, closed, region, r, zones, normals[i].as_deref(), scale).map(Some)
                    })
                    .collect()
            })
            .collect::<Result<_, _>>()?;
        self.symbolic_analyses += outcomes.iter().flatten().flatten().filter(|o| o.new_solver).count();
        // The zones back where they came from.
        for (zone, &(k, side)) in zones.iter_mut().flatten().flatten().zip(lent.iter().flatten().flatten()) {
            if let Some(Some(contact)) = contacts.get_mut(k) {
                contact.sides[side].zone = std::mem::take(zone);
            }
        }

        // Results and statistics.
        let mut stages = StageTimes { setup, regions: regions_time, ..StageTimes::default() };
        let mut pair_stats = Vec::with_capacity(region_pairs.len());
        for (rp, contact) in region_pairs.iter().zip(&contacts) {
            let names = frame.pairs[rp.pair].objects.map(|i| frame.objects[i].name.to_string());
            let base = PairStats { objects: names, pair: rp.pair, regions: rp.regions, ..PairStats::default() };
            let Some(contact) = contact else {
                pair_stats.push(base);
                continue;
            };
            let t = &contact.stats.timings;
            stages.intersection += t.intersection;
            stages.mapping += t.direction + t.mapping;
            stages.contact_zone += t.surface + t.zone;
            let counts = &contact.stats.counts;
            pair_stats.push(PairStats {
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
                ..base
            });
        }

        let mut positions = Vec::with_capacity(count);
        let mut object_stats = Vec::with_capacity(count);
        let mut kept = Vec::with_capacity(count);
        let mut region_stats = Vec::new();
        let mut summaries = Vec::new();
        for (i, (object, outcomes)) in frame.objects.iter().zip(outcomes).enumerate() {
            let Some(cache) = self.caches[i].as_ref() else { continue };
            let input = &object.mesh.positions;
            let volume_before = signed_volume(object.mesh);
            let mut stats = ObjectStats {
                name: object.name.to_string(),
                vertices: input.len(),
                rigid: object.params.rigid,
                volume_before,
                volume_after: volume_before,
                preserve_volume: object.params.preserve_volume.unwrap_or(closed[i]),
                regions: cache.regions.len(),
                zones: zones[i].iter().map(Vec::len).sum(),
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
                    zones: zones[i][r].len(),
                    ..RegionStats::default()
                };
                if let Some(outcome) = outcome {
                    let s = &outcome.deformation.stats;
                    stages.parametrization += s.timings.parametrization;
                    stages.directions += s.timings.directions;
                    stages.guide += s.timings.guide;
                    stages.deformation += s.timings.deformation;
                    stages.factorization += s.timings.factorization;
                    stages.analysis += s.timings.analysis;
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
                        .map(|s| {
                            s.sub.parent_vertex.iter().zip(&s.border).filter(|(_, b)| **b).map(|(v, _)| *v).collect()
                        })
                        .unwrap_or_default(),
                });
            }
            let combined = combine(input, &cache.regions, outcomes);
            match combined {
                Some(deformation) => {
                    stats.volume_after = signed_volume_of(&deformation.positions, &object.mesh.triangles);
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
        let params: Vec<&PairParams> = region_pairs.iter().map(|rp| &frame.pairs[rp.pair].params).collect();
        let warnings = warnings::frame_warnings(&pair_stats, &contacts, &params, &contained, &object_stats, &closed);
        Ok(FrameResult {
            positions,
            contacts,
            deformations: kept,
            regions: summaries,
            self_contact: vec![None; count],
            stats: FrameStats {
                total: start.elapsed(),
                stages,
                objects: object_stats,
                pairs: pair_stats,
                regions: region_stats,
                articulations: Vec::new(),
                warnings,
            },
        })
    }
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

/// Runs chapter 5 on one region, clamping its extent when 𝒟 would reach the cut (see
/// [`regions`]). `object_normals`: the object's vertex normals when the contact stage computed
/// them (it does for objects with a region processed whole).
#[allow(clippy::too_many_arguments)]
fn deform_one(
    object: &FrameObject,
    topology: &Topology,
    closed: bool,
    region: &mut RegionCache,
    index: usize,
    zones: &[ContactZone],
    object_normals: Option<&[DVec3]>,
    scale: Scale,
) -> Result<RegionOutcome, PipelineError> {
    let Scale { extent, edge_length: object_edge_length } = scale;
    let start = Instant::now();
    let err = |source| PipelineError::Deform { object: object.name.to_string(), source };
    let too_small =
        |reason: String| PipelineError::RegionTooSmall { object: object.name.to_string(), region: index, reason };
    let (mesh, topology, border) = match region.sub.as_deref() {
        None => (object.mesh, topology, None),
        Some(sub) => (&sub.sub.mesh, &sub.topology, (sub.border_count > 0).then_some(sub.border.as_slice())),
    };
    // A region processed whole reuses the object's normals of the contact stage (the same
    // `vertex_normals` of the same mesh); a cut region's own are its sub-mesh's.
    let overrides =
        RegionOverrides { normals: object_normals.filter(|_| region.sub.is_none()), ..RegionOverrides::default() };
    let new_solver = region.solver.is_none();
    if new_solver {
        // An automatic region is cut again whenever its faces change: its analysis, then paid
        // every few frames, stays AMD's alone; the others are analyzed once per shot.
        let fill_order = if object.params.region.is_automatic() { FillOrder::Amd } else { FillOrder::FewerFlops };
        region.solver = Some(RegionSolver::with_fill_order(mesh, topology, fill_order).map_err(err)?);
    }
    let Some(solver) = region.solver.as_mut() else {
        return Err(err(DeformError::StaleFactorization { stage: "region solver" }));
    };
    let mut params = object.params.deform_params(extent, closed);
    if let Some(sub) = region.sub.as_deref()
        && let Some(map) = params.bulge_map.as_ref()
    {
        if map.len() != object.mesh.num_vertices() {
            return Err(err(DeformError::BulgeMapLength { expected: object.mesh.num_vertices(), actual: map.len() }));
        }
        let gathered = sub.sub.gather(map);
        params.bulge_map = Some(gathered);
    }
    if object_edge_length > 0.0 {
        // The length scale h (heat time, slope confidence) is the object's (of the components
        // the region touches, from the frame's figures), whole or cut: the result must not
        // depend on where a cut falls, which automatic regions move from frame to frame.
        params.edge_length = Some(object_edge_length);
    }
    let mut deformation = deform_region_with(mesh, topology, solver, zones, &params, &overrides).map_err(err)?;
    let mut clamped = false;
    if let Some(border) = border {
        if let Some(v) = (0..border.len()).find(|&v| border[v] && deformation.contact[v]) {
            return Err(too_small(format!("its contact zone reaches vertex {v} on the cut border")));
        }
        if (0..border.len()).any(|v| border[v] && deformation.deformable[v]) {
            // φ does not depend on φ_max: the smallest φ on the cut bounds the extent that fits.
            let reach = (0..border.len())
                .filter(|&v| border[v])
                .map(|v| deformation.u[v] * params.extent)
                .fold(f64::INFINITY, f64::min);
            let fitted = CLAMP_FRACTION * reach;
            if !(fitted.is_finite() && fitted > 0.0) {
                return Err(too_small(format!("its deformable region reaches the cut border at φ = {reach:.3e}")));
            }
            // The same domain as the first solve, so the same φ.
            params.domain_radius = Some(params.domain_radius());
            params.extent = fitted;
            deformation = deform_region_with(mesh, topology, solver, zones, &params, &overrides).map_err(err)?;
            clamped = true;
            if let Some(v) =
                (0..border.len()).find(|&v| border[v] && (deformation.deformable[v] || deformation.contact[v]))
            {
                return Err(too_small(format!("vertex {v} on the cut border still moves after clamping the extent")));
            }
        }
    }
    let domain_reaches_cut = border.is_some_and(|border| {
        // Every vertex within the radius in the whole object is in the region, at the same
        // distance, unless a shortest path crosses the cut: then a cut vertex is within it.
        border.iter().zip(&deformation.domain).any(|(&on_cut, &within)| on_cut && within)
    });
    Ok(RegionOutcome {
        deformation,
        extent: params.extent,
        clamped,
        domain_reaches_cut,
        time: start.elapsed(),
        new_solver,
    })
}

/// Writes the regions' deformations into one object-sized deformation (`None` if none).
fn combine(
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
        t.numeric_factorizations += s.numeric_factorizations;
        t.factorized_rows += s.factorized_rows;
        t.recomputed_rows += s.recomputed_rows;
        t.reduced_analyses += s.reduced_analyses;
        t.timings.parametrization += s.timings.parametrization;
        t.timings.directions += s.timings.directions;
        t.timings.guide += s.timings.guide;
        t.timings.deformation += s.timings.deformation;
        t.timings.factorization += s.timings.factorization;
        t.timings.analysis += s.timings.analysis;
        t.timings.total += s.timings.total;
        t.fallbacks.direction_blend += s.fallbacks.direction_blend;
        t.fallbacks.bulge_map += s.fallbacks.bulge_map;
        t.fallbacks.volume_without_root += s.fallbacks.volume_without_root;
        t.fallbacks.clamped_slopes += s.fallbacks.clamped_slopes;
    }
    Some(out)
}

#[cfg(test)]
mod region_tests;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod warning_tests;
