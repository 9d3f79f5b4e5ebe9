//! Self-contact of a skinned articulation, frame by frame (thesis ch. 6).
//!
//! An [`Articulation`] names two overlapping working regions 𝒲₁ (parent side) and 𝒲₂ (child
//! side) of one mesh. [`ArticulationSetup`] holds what depends on the connectivity and the rest
//! pose only: ℛ = 𝒲₁ ∩ 𝒲₂ with its partition of unity β ([`SharedRegion`], §6.1.1), and each
//! region as a sub-mesh with its solver cache (built at the first frame the sides touch). At
//! each frame [`plan_articulation`]
//! 1. takes d̂ from the joints or the user (§6.1.2, [`super::articulation_direction`]);
//! 2. cuts ℛ along the crease by max-flow ([`SharedRegion::crease_cut`], §6.1.3), giving the
//!    non-overlapping truncated regions 𝒲̄₁ = (𝒲₁ \ ℛ) ∪ ℛ₁ and 𝒲̄₂ = (𝒲₂ \ ℛ) ∪ ℛ₂;
//! 3. runs the contact definition of chapter 4 on (𝒲̄₂, 𝒲̄₁) with d̂ given — 𝒲̄₁ is the pair's
//!    second object, d̂ points along its normals inside the fold;
//! 4. reports each contact zone onto both whole regions (§6.2.1): 𝒲₁ gets 𝒞₁ and the part of 𝒞₂
//!    in ℛ, 𝒲₂ gets 𝒞₂ and the part of 𝒞₁ in ℛ, with the same targets and normals, so that the
//!    shared vertices are bound by the same constraints in both;
//! 5. runs chapter 5 on 𝒲₁ and on 𝒲₂ up to the profiles ([`plan_region`]) with the mapping field
//!    `d̄ = (2β − 1)·d̂` left unnormalized (§6.2.2): d̂ on 𝒲₁'s side, −d̂ on 𝒲₂'s, vanishing at
//!    β = ½ so that the direction falls back to the normal at the crease;
//! 6. blends the two results over ℛ, `p′ = βp′₁ + (1 − β)p′₂`.
//!
//! **Volume (better than the thesis).** Each region's result is affine in the bulge height h
//! (see [`crate::deform::volume`]), and so is their blend. Instead of letting each region solve
//! its own h and blending two volume-preserving results into one that is not (the thesis' blend
//! over ℛ), [`apply_articulations`] solves *one* h per articulation for the blended displacement,
//! from the cubic of the whole mesh: the volume after blending is exactly the input's (γ = 1).
//! With several articulations on one mesh whose moving faces overlap (hip and knee of one leg),
//! the heights are solved in turn against the others' current displacement until the volume is
//! met (block Gauss–Seidel; one round when they do not overlap).
//!
//! **Decisions.**
//! - Edges that leave a reported zone without a boundary point — an edge of the crease strip,
//!   whose faces belong to neither truncated region — get the point α = 0 (the zone stops at its
//!   last vertex, with that vertex's target and normal): no extrapolation.
//! - The regions' borders on the shared side are not borders for the contact stage: the
//!   intersection regions of a fold reach the crease cut by nature. Their *far* borders (where a
//!   region is cut from the rest of the mesh) are: an intersection reaching one is an error, and
//!   the extent is clamped so that the deformation stays inside (as for working regions). Both
//!   regions use the same extent.
//! - Automatic extent: `5/3 · max(1.2·r, 1.5·√(A/π)) = max(2·r, 2.5·√(A/π))`, r the RMS radius
//!   of ℛ on the rest pose (about the limb's radius), A the contact area ([`fold_extent`]): the
//!   rule objects had before the pipeline's was calibrated against FEM (issue 29; see
//!   [`crate::deform::automatic_extent`]), with the limb as both objects, scaled by
//!   [`FOLD_EXTENT_SCALE`]. A fold keeps it: it was tuned on folds (below), which the FEM
//!   references of two pressed bodies do not describe. **Why larger than between objects:** a fold's contact pushes its
//!   border vertices deep (into the other side of the fold) right next to side-wall faces that
//!   linear blend skinning has already turned far from their rest orientation, and a short
//!   extent makes the profile's transition steep enough to tilt them past perpendicular. On the
//!   bent capsule (test `bent_capsule_from_0_to_150_degrees`) the pipeline's rule turned two such
//!   faces from 72° (input) to 90.8° from their skinned rest normal at 150°; scaled by 4/3 one or
//!   two remain, by 1.5 none at any frame, by 5/3 none with a margin, and the largest own motion
//!   per frame is the same (0.054 for an input step of 0.15; a scale of 2 raises it to 0.060).
//!   CesiumMan's knees (149 → 0 and 129 → 0 self-intersecting faces, none newly inverted, extent
//!   never clamped) and the skinned cylinders give the same figures as with the pipeline's rule.

use std::sync::Arc;
use std::time::{Duration, Instant};

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::partition::SharedRegion;
use super::{ArticulationError, articulation_direction};
use crate::contact::{ContactError, ContactSide, ContactZone, EdgeRegion, Stiffness, contact_pair};
use crate::deform::{
    AffineDisplacement, DeformError, DeformParams, HeightSolution, RegionOverrides, RegionPlan, RegionSolver,
    VolumeCubic, plan_region, solve_bulge_height, solve_dent_height,
};
use crate::mesh::{NOT_IN_SUBMESH, SubMesh, Topology, TriMesh, region_vertex_normals, signed_volume, vertex_centroid};
use crate::params::{Articulation, PairParams, Params, VertexFlags};
use crate::spatial::{SpatialError, TriangleBvh};

/// The automatic extent of an articulation is `max(1.2·r, 1.5·√(A/π))` scaled by this factor;
/// see the module doc.
pub const FOLD_EXTENT_SCALE: f64 = 5.0 / 3.0;

/// The automatic extent of a fold (see the module doc): `FOLD_EXTENT_SCALE · max(1.2·r,
/// 1.5·√(A/π))`, r the RMS radius of ℛ on the rest pose, A the contact area.
pub fn fold_extent(size: f64, contact_area: f64) -> f64 {
    let contact_radius = (contact_area.max(0.0) / std::f64::consts::PI).sqrt();
    FOLD_EXTENT_SCALE * (1.2 * size).max(crate::deform::EXTENT_CONTACT_FLOOR * contact_radius)
}

/// Why an articulation failed at a frame.
#[derive(Debug, thiserror::Error)]
pub enum SelfContactError {
    #[error(transparent)]
    Articulation(#[from] ArticulationError),
    #[error("contact between its two sides: {0}")]
    Contact(#[from] ContactError),
    #[error("deformation: {0}")]
    Deform(#[from] DeformError),
    #[error("triangle tree: {0}")]
    Spatial(#[from] SpatialError),
    #[error("{reason}; make region {region} larger (lower min_weight or widen its mask) or give a smaller extent")]
    RegionTooSmall { region: usize, reason: String },
}

/// Figures of one articulation at one frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ArticulationStats {
    /// Index of the object and name of the articulation.
    pub object: usize,
    pub name: String,
    /// d̂ at this frame.
    pub direction: [f64; 3],
    /// |𝒲₁|, |𝒲₂|, |ℛ| (vertices).
    pub region_vertices: [usize; 2],
    pub shared_vertices: usize,
    /// Vertices of ℛ labeled 𝒲̄₁ by the crease cut, and edges of ℛ joining the two labels.
    pub shared_first: usize,
    pub cut_edges: usize,
    /// True if the two sides are in contact at this frame.
    pub in_contact: bool,
    pub intersection_points: usize,
    /// ε_c of the contact criterion and the contact area on 𝒮.
    pub threshold: f64,
    pub contact_area: f64,
    /// |𝒞| and |𝒟| of each whole region (after reporting the zones).
    pub contact_vertices: [usize; 2],
    pub deformable_vertices: [usize; 2],
    /// φ_max used, and whether it was clamped to keep 𝒟 inside the regions.
    pub extent: f64,
    pub extent_clamped: bool,
    /// h_v solved for the blend (γ = 1) and γ·h_v applied.
    pub bulge_height: f64,
    pub applied_bulge_height: f64,
    /// Whether h_v is a root of the volume cubic.
    pub volume_exact: bool,
    /// Self-intersecting faces among the faces of 𝒲₁ ∪ 𝒲₂, before and after (set by the
    /// caller that measures them, see [`self_intersection_counts`]).
    pub self_intersecting_faces_before: usize,
    pub self_intersecting_faces_after: usize,
    /// Of those, the faces of intersecting pairs that join the articulation's two sides (see
    /// [`self_intersection_counts`]): what the articulation is there to resolve; the
    /// rest lie within one side (another fold of the body, e.g. a crotch inside a hip's first
    /// region).
    pub self_intersecting_faces_across_before: usize,
    pub self_intersecting_faces_across_after: usize,
    /// Wall-clock times: crease cut, contact definition, the two deformations, and the total of
    /// the articulation's own steps (not the other jobs run between them).
    pub cut_time: Duration,
    pub contact_time: Duration,
    /// The symbolic analyses of the regions' solvers, run at the first frame the sides touch
    /// (zero at the others).
    #[serde(default)]
    pub analysis_time: Duration,
    pub deformation_time: Duration,
    pub total_time: Duration,
    /// Why an automatic articulation was left inactive at this frame (see
    /// [`Articulation::automatic`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// One region 𝒲_l with its connectivity-only caches.
#[derive(Debug)]
struct RegionSide {
    sub: SubMesh,
    topology: Topology,
    /// The region's solver, built (its symbolic analysis run) at the first frame the
    /// articulation's sides touch: many articulations of a character never do in a shot.
    solver: Option<RegionSolver>,
    /// Per local vertex: on the far border (cut from the rest of the mesh, not from the other
    /// region).
    far_border: Vec<bool>,
}

/// What an articulation keeps between frames: everything that depends on the connectivity and
/// the rest pose only.
#[derive(Debug)]
pub struct ArticulationSetup {
    regions: [Vec<u32>; 2],
    rest: Vec<DVec3>,
    triangles: Vec<[u32; 3]>,
    shared: SharedRegion,
    sides: [RegionSide; 2],
    /// Faces of 𝒲₁ ∪ 𝒲₂ (object ids, increasing).
    faces: Vec<u32>,
    /// Per object vertex: in 𝒲₁ ∪ 𝒲₂ (the vertices the interior test runs on).
    in_regions: Vec<bool>,
    /// RMS radius of ℛ on the rest pose.
    size: f64,
    /// Offset of the interior test (10⁻⁴ of the mean edge length).
    epsilon: f64,
    /// Mean edge length of the rest pose.
    edge_length: f64,
    /// Per truncated region 𝒲̄_l: what its last frame built that depends on its faces only.
    kept: [Option<KeptTruncated>; 2],
}

impl ArticulationSetup {
    /// Builds the caches of `articulation` on an object with the given connectivity (`mesh` at
    /// any pose, `topology` its topology) and rest pose `rest` (same connectivity), where β is
    /// computed.
    pub fn new(
        mesh: &TriMesh,
        topology: &Topology,
        articulation: &Articulation,
        rest: &TriMesh,
    ) -> Result<Self, SelfContactError> {
        let shared = SharedRegion::new(rest, topology, &articulation.regions)?;
        let in_faces = |l: usize| -> Vec<bool> {
            mesh.triangles.iter().map(|t| t.iter().all(|&v| shared.membership[v as usize][l])).collect()
        };
        let face_sets = [in_faces(0), in_faces(1)];
        let mut sides = Vec::with_capacity(2);
        for (l, faces) in face_sets.iter().enumerate() {
            let sub = SubMesh::from_faces(mesh, (0..faces.len() as u32).filter(|&f| faces[f as usize]));
            if sub.mesh.triangles.is_empty() {
                return Err(ArticulationError::EmptyRegion {
                    what: if l == 0 {
                        "region 1 (no face has all its vertices in it)"
                    } else {
                        "region 2 (no face has all its vertices in it)"
                    },
                    fix: "give regions of whole faces",
                }
                .into());
            }
            let sub_topology = Topology::new(&sub.mesh);
            let far_border = sub
                .parent_vertex
                .iter()
                .map(|&v| {
                    topology.vertex_faces(v).iter().any(|&f| !face_sets[0][f as usize] && !face_sets[1][f as usize])
                })
                .collect();
            sides.push(RegionSide { sub, topology: sub_topology, solver: None, far_border });
        }
        let Ok(sides) = <[RegionSide; 2]>::try_from(sides) else {
            return Err(ArticulationError::EmptyRegion { what: "a region", fix: "give two regions" }.into());
        };
        let faces = (0..mesh.num_triangles() as u32)
            .filter(|&f| face_sets[0][f as usize] || face_sets[1][f as usize])
            .collect();
        let edge_length = crate::mesh::mean_edge_length(rest, topology);
        let size = shared_size(rest, &shared);
        let in_regions = shared.membership.iter().map(|m| m[0] || m[1]).collect();
        Ok(Self {
            in_regions,
            epsilon: 1e-4 * edge_length,
            edge_length,
            regions: articulation.regions.clone(),
            rest: rest.positions.clone(),
            triangles: mesh.triangles.clone(),
            shared,
            sides,
            faces,
            size,
            kept: [None, None],
        })
    }

    /// True if these caches were built for this articulation's regions and this connectivity
    /// (the rest pose may differ: see [`Self::set_rest`]).
    pub fn matches(&self, mesh: &TriMesh, articulation: &Articulation) -> bool {
        self.regions == articulation.regions && self.triangles == mesh.triangles
    }

    /// Recomputes β (and the scales) when the rest pose differs from the one they were computed
    /// on; the regions' caches are kept.
    pub fn set_rest(&mut self, rest: &TriMesh, topology: &Topology) -> Result<(), SelfContactError> {
        if self.rest != rest.positions {
            self.shared = SharedRegion::new(rest, topology, &self.regions)?;
            self.rest = rest.positions.clone();
            self.edge_length = crate::mesh::mean_edge_length(rest, topology);
            self.epsilon = 1e-4 * self.edge_length;
            self.size = shared_size(rest, &self.shared);
            // Their trees were built on the former rest pose.
            self.kept = [None, None];
        }
        Ok(())
    }

    /// ℛ with β.
    pub fn shared(&self) -> &SharedRegion {
        &self.shared
    }

    /// Faces of 𝒲₁ ∪ 𝒲₂ (object ids).
    pub fn faces(&self) -> &[u32] {
        &self.faces
    }
}

/// RMS radius of ℛ about its centroid on the rest pose (about the limb's radius).
fn shared_size(rest: &TriMesh, shared: &SharedRegion) -> f64 {
    let points: Vec<DVec3> = shared.vertices.iter().map(|&v| rest.positions[v as usize]).collect();
    let count = points.len().max(1) as f64;
    let centroid = vertex_centroid(&points);
    (points.iter().map(|p| (*p - centroid).length_squared()).sum::<f64>() / count).sqrt()
}

/// An articulation's deformation at one frame, before the bulge height is chosen: the blended
/// displacement is affine in h for every vertex of the object (zero outside 𝒲₁ ∪ 𝒲₂).
#[derive(Clone, Debug)]
pub struct ArticulationPlan {
    pub displacement: AffineDisplacement,
    /// φ_max used (the scale of the height search).
    pub extent: f64,
    /// Per vertex of ℛ (order of [`SharedRegion::vertices`]): labeled 𝒲̄₁ by the crease cut.
    pub labels: Vec<bool>,
    /// Per object vertex: in a contact zone of either region.
    pub contact: Vec<bool>,
    pub stats: ArticulationStats,
}

/// What a truncated region keeps between frames: what depends on its faces only. Its tree is
/// built on the rest pose and refitted to each frame, so that it depends on the rest pose, the
/// faces and the positions only, never on the frames before (a kept and a fresh deformer give
/// the same bits).
#[derive(Debug)]
struct KeptTruncated {
    sub: SubMesh,
    topology: Topology,
    bvh: TriangleBvh,
    border: Vec<bool>,
}

/// A truncated region 𝒲̄_l of this frame, ready for the contact stage.
struct Truncated {
    sub: SubMesh,
    topology: Topology,
    bvh: TriangleBvh,
    /// Tree over the faces that face the fold (`n·toward > 0`), where the other side's lines
    /// are matched; `None` when no face does.
    facing: Option<TriangleBvh>,
    normals: Vec<DVec3>,
    border: Vec<bool>,
    /// Per object vertex: inside another part of the object (see [`interior_flags`]), asked for
    /// this region's vertices where chapter 4 needs them.
    interior: VertexFlags,
}

impl Truncated {
    /// The region of `faces` (object ids, increasing); `None` when there is none. `kept`: what
    /// an earlier frame built, used when it is of the same faces; `rest`: the object's rest
    /// pose, where a new tree is built.
    #[allow(clippy::too_many_arguments)]
    fn new(
        mesh: &TriMesh,
        topology: &Topology,
        faces: Vec<u32>,
        side: &RegionSide,
        interior: &VertexFlags,
        toward: DVec3,
        kept: Option<KeptTruncated>,
        rest: &[DVec3],
    ) -> Result<Option<Self>, SpatialError> {
        if faces.is_empty() {
            return Ok(None);
        }
        let KeptTruncated { sub, topology: sub_topology, mut bvh, border } =
            match kept.filter(|k| k.sub.parent_face == faces) {
                Some(mut kept) => {
                    kept.sub.update_positions(&mesh.positions);
                    kept
                }
                None => {
                    let sub = SubMesh::from_faces(mesh, faces);
                    let at_rest = TriMesh {
                        positions: sub.parent_vertex.iter().map(|&v| rest[v as usize]).collect(),
                        triangles: sub.mesh.triangles.clone(),
                    };
                    let border = sub
                        .parent_vertex
                        .iter()
                        .map(|&v| {
                            let local = side.sub.local_vertex[v as usize];
                            local != NOT_IN_SUBMESH && side.far_border[local as usize]
                        })
                        .collect();
                    KeptTruncated { topology: Topology::new(&sub.mesh), bvh: TriangleBvh::new(&at_rest)?, sub, border }
                }
            };
        bvh.refit(&sub.mesh.positions)?;
        let facing_faces: Vec<u32> = crate::mesh::face_normals(&sub.mesh)
            .iter()
            .enumerate()
            .filter(|(_, n)| n.dot(toward) > 0.0)
            .map(|(f, _)| f as u32)
            .collect();
        let facing =
            if facing_faces.is_empty() { None } else { Some(TriangleBvh::with_faces(&sub.mesh, facing_faces)?) };
        let normals = region_vertex_normals(mesh, topology, &sub.parent_vertex);
        Ok(Some(Self { sub, topology: sub_topology, bvh, facing, normals, border, interior: interior.clone() }))
    }

    /// What the next frame may reuse.
    fn into_kept(self) -> KeptTruncated {
        KeptTruncated { sub: self.sub, topology: self.topology, bvh: self.bvh, border: self.border }
    }
}

impl Truncated {
    /// The contact side of this region (only its far border is a border for the contact stage).
    fn side<'a>(&'a self, name: &'a str, stiffness: f64) -> ContactSide<'a> {
        ContactSide::new(&self.sub.mesh, &self.topology, &self.normals, &self.bvh)
            .with_name(name)
            .with_stiffness(Stiffness::Elastic(stiffness))
            .with_border(self.border.iter().any(|&b| b).then_some(self.border.as_slice()))
            .with_interior_asked(Some((&self.interior, &self.sub.parent_vertex)))
            .with_match_bvh(self.facing.as_ref())
    }
}

/// Per object vertex of `vertices`: true if it lies inside another part of the object. The
/// object is closed, so its winding number (exact signed ray crossings) just off its surface,
/// at `p ± ε·n`, is 1 on the side of its own body and 0 on the other where the skin encloses
/// nothing else; a vertex inside another part — the other side of the fold — is inside on
/// *both* sides of its own surface: `min(w(p − εn), w(p + εn)) ≥ 1`. The test does not depend on
/// the orientation of n: linear blend skinning crumples the skin in a crease, where the vertex
/// normals point into the body and the counts are (1, 1) instead of (2, 1), and the former test
/// `w(p − εn) ≥ 2` missed exactly the vertices that had gone through the other side
/// (CesiumMan's knees, the frames they unbend). ε = 10⁻⁴·h keeps the points on the right side of
/// their own faces without reaching other layers.
/// `asked` are the vertices to answer for, `vertices` those the test runs on (false elsewhere).
fn interior_flags(
    positions: &[DVec3],
    normals: &[DVec3],
    tree: &TriangleBvh,
    vertices: &[bool],
    epsilon: f64,
    asked: &[u32],
) -> Vec<bool> {
    use rayon::prelude::*;
    // The queries are counted on whatever thread runs them, for the caller's span.
    let work = crate::stage::SharedWork::default();
    let flags = asked
        .par_iter()
        .with_min_len(256)
        .map(|&v| {
            let v = v as usize;
            if !vertices.get(v).copied().unwrap_or(false) {
                return false;
            }
            work.measure(|| {
                // The outer point first: it is outside everything (0) for most vertices, which
                // settles the minimum without the inner point's query.
                let (p, offset) = (positions[v], epsilon * normals[v]);
                tree.winding_number(p + offset) >= 1 && tree.winding_number(p - offset) >= 1
            })
        })
        .collect();
    work.record();
    flags
}

/// The zone `zone` of the region `from` (a sub-mesh of the object) on the region `to`, for the
/// vertices `to` shares with `from` (see the module doc for edges without a boundary point).
fn report_zone(
    zone: &ContactZone,
    from: &SubMesh,
    from_topology: &Topology,
    to: &SubMesh,
    to_topology: &Topology,
) -> ContactZone {
    let n = to.num_vertices();
    let source = |local_to: u32| -> Option<u32> {
        let v = to.parent_vertex[local_to as usize];
        let f = from.local_vertex[v as usize];
        (f != NOT_IN_SUBMESH).then_some(f)
    };
    let inside: Vec<bool> = (0..n as u32).map(|v| source(v).is_some_and(|f| zone.region.contains(f))).collect();
    let mut targets = to.mesh.positions.clone();
    let mut normals = vec![DVec3::ZERO; n];
    for v in 0..n {
        if inside[v]
            && let Some(f) = source(v as u32)
        {
            targets[v] = zone.targets[f as usize];
            normals[v] = zone.normals[f as usize];
        }
    }
    // The source's boundary point on the same edge, if any.
    let source_point = |i: u32, j: u32| -> Option<usize> {
        let (fi, fj) = (source(i)?, source(j)?);
        let e = from_topology.edge_between(fi, fj)?;
        zone.region.point_on_edge(e).map(|k| k as usize)
    };
    let region = EdgeRegion::from_inside(to_topology, inside, |_, i, j| {
        source_point(i, j).map_or(0.0, |k| zone.region.points()[k].alpha)
    });
    let mut boundary_positions = Vec::with_capacity(region.points().len());
    let mut boundary_targets = Vec::with_capacity(region.points().len());
    let mut boundary_normals = Vec::with_capacity(region.points().len());
    for p in region.points() {
        match source_point(p.inside, p.outside) {
            Some(k) => {
                boundary_positions.push(zone.boundary_positions[k]);
                boundary_targets.push(zone.boundary_targets[k]);
                boundary_normals.push(zone.boundary_normals[k]);
            }
            None => {
                let i = p.inside as usize;
                boundary_positions.push(to.mesh.positions[i]);
                boundary_targets.push(targets[i]);
                boundary_normals.push(normals[i]);
            }
        }
    }
    ContactZone {
        region,
        targets,
        normals,
        boundary_positions,
        boundary_targets,
        boundary_normals,
        direction: zone.direction,
        mapping_direction: zone.mapping_direction,
    }
}

/// ε_c ≥ −P (P the typical penetration depth, see [`PairParams::contact_threshold_floor`]).
pub const CONTACT_THRESHOLD_FLOOR: f64 = 1.0;

/// The automatic contact gap as a fraction of the mean edge length (see `separate`). Both
/// sides sample 𝒮 at their own vertices; at the bottom of a fold, where 𝒮 bends sharply and the
/// two zones meet at the crease, their chords cross unless the gap is a sizeable part of an
/// edge: on a capsule bent to 150°, 13 faces still intersect with 0.05 edge, 4–5 with 0.25 and
/// none with 0.5 (half an edge, hidden inside the fold).
pub const GAP_FRACTION: f64 = 0.5;

/// The zone with its targets moved back by `offset` against 𝒮's normal (outward from this side):
/// the two sides of a fold stop `2·offset` apart instead of both sampling 𝒮 at their own
/// vertices, whose chords would cross each other by the sampling error.
fn separate(zone: &ContactZone, offset: f64) -> ContactZone {
    let mut zone = zone.clone();
    crate::contact::apply_gap(&mut zone, offset);
    zone
}

/// Fraction of the smallest φ on a far border that a clamped extent keeps.
const CLAMP_FRACTION: f64 = 0.95;

/// One articulation at one frame up to the choice of its bulge height: [`contact_articulation`]
/// then [`deform_articulation`], with the interior flags from a triangle tree of its own (the
/// pipeline shares one tree and one set of flags among an object's articulations).
pub fn plan_articulation(
    mesh: &TriMesh,
    topology: &Topology,
    normals: &[DVec3],
    setup: &mut ArticulationSetup,
    articulation: &Articulation,
    params: &DeformParams,
) -> Result<ArticulationPlan, SelfContactError> {
    let tree = Arc::new(TriangleBvh::new(mesh)?);
    let interior = articulation_interiors(mesh, normals, tree, [&*setup]);
    let found = contact_articulation(mesh, topology, normals, &interior, setup, articulation, true)?;
    deform_articulation(found, mesh, setup, articulation, params)
}

/// The contact definition of one articulation at one frame (steps 1–3 of the module doc): the
/// crease cut, the truncated regions and chapter 4 between them. What
/// [`deform_articulation`] then deforms.
pub struct ArticulationContact {
    /// Per vertex of ℛ (order of [`SharedRegion::vertices`]): labeled 𝒲̄₁ by the crease cut.
    pub labels: Vec<bool>,
    /// The contact between the truncated regions (`None` when one is empty), on the pair's
    /// sides `[𝒲̄₂, 𝒲̄₁]`.
    pub contact: Option<crate::contact::PairContact>,
    truncated: Option<[Truncated; 2]>,
    direction: DVec3,
    pub stats: ArticulationStats,
    /// The time of this contact step (the articulation's own, not the other jobs' between its
    /// steps).
    contact_step: Duration,
}

impl ArticulationContact {
    /// The time of this contact step beyond chapter 4's own stages (those in the contact's
    /// [`crate::contact::ContactStats::timings`]): the crease cut, the truncated regions and their
    /// positions.
    pub fn time_beyond_contact(&self) -> Duration {
        let contact: Duration =
            self.contact.as_ref().map_or(Duration::ZERO, |c| c.stats.timings.iter().map(|(_, t)| *t).sum());
        self.contact_step.saturating_sub(contact)
    }

    /// True if the two sides are in contact (non-empty zones).
    pub fn in_contact(&self) -> bool {
        self.contact.as_ref().is_some_and(|c| !c.is_empty())
    }
}

/// Per object vertex: inside another part of the object (the winding number of a point just
/// inside its own faces), for the vertices of every articulation of `setups` (false for the
/// others); `tree` is the whole object's triangle tree at `mesh`'s positions, shared by the
/// object's articulations. The flags are evaluated for the vertices asked only (chapter 4 asks
/// those near the intersection): a vertex's flag is a function of its position and normal, so
/// the answers are those of evaluating every vertex.
pub fn articulation_interiors<'a>(
    mesh: &TriMesh,
    normals: &[DVec3],
    tree: Arc<TriangleBvh>,
    setups: impl IntoIterator<Item = &'a ArticulationSetup>,
) -> VertexFlags {
    let mut vertices = vec![false; mesh.num_vertices()];
    let mut epsilon = None;
    for setup in setups {
        for (v, &inside) in vertices.iter_mut().zip(&setup.in_regions) {
            *v |= inside;
        }
        epsilon.get_or_insert(setup.epsilon);
    }
    let Some(epsilon) = epsilon else { return VertexFlags::new(|asked| vec![false; asked.len()]) };
    let (positions, normals) = (mesh.positions.clone(), normals.to_vec());
    VertexFlags::new(move |asked| interior_flags(&positions, &normals, &tree, &vertices, epsilon, asked))
}

/// Steps 1–3 of the module doc for one articulation at one frame: d̂, the crease cut and the
/// contact of chapter 4 between the truncated regions. `mesh` is the object at this frame (the
/// skinned input), `topology` its connectivity, `normals` its unit vertex normals and
/// `interior` its [`articulation_interiors`]. `crossing`: false when the caller knows that no
/// two faces of 𝒲₁ ∪ 𝒲₂ ([`ArticulationSetup::faces`]) intersect away from what they share; the
/// truncated regions and chapter 4 are then skipped, with the same result: no edge of one side
/// crosses the other (the sides share no vertex), so chapter 4 finds no intersection and no
/// contact (docs/decisions.md, "Articulations whose faces do not cross").
pub fn contact_articulation(
    mesh: &TriMesh,
    topology: &Topology,
    normals: &[DVec3],
    interior: &VertexFlags,
    setup: &mut ArticulationSetup,
    articulation: &Articulation,
    crossing: bool,
) -> Result<ArticulationContact, SelfContactError> {
    let start = Instant::now();
    articulation.params.validate().map_err(ArticulationError::from)?;
    let n = mesh.num_vertices();
    let d = articulation_direction(articulation)?;
    let shared = &setup.shared;
    let mut stats = ArticulationStats {
        name: articulation.name.clone(),
        direction: d.to_array(),
        region_vertices: [setup.sides[0].sub.num_vertices(), setup.sides[1].sub.num_vertices()],
        shared_vertices: shared.vertices.len(),
        ..ArticulationStats::default()
    };

    // §6.1.3: the crease cut.
    let t = Instant::now();
    let labels = shared.crease_cut(normals, d, articulation.params.cut_regional_weight);
    stats.shared_first = labels.iter().filter(|&&l| l).count();
    stats.cut_edges = shared.edges.iter().filter(|&&[i, j]| labels[i as usize] != labels[j as usize]).count();
    let mut masks = [vec![false; n], vec![false; n]];
    for (v, m) in shared.membership.iter().enumerate() {
        match m {
            [true, false] => masks[0][v] = true,
            [false, true] => masks[1][v] = true,
            _ => {}
        }
    }
    for (&v, &first) in shared.vertices.iter().zip(&labels) {
        masks[if first { 0 } else { 1 }][v as usize] = true;
    }
    stats.cut_time = t.elapsed();

    // Ch. 4 on the truncated regions: a = 𝒲̄₂, b = 𝒲̄₁ (d̂ along 𝒲₁'s normals in the fold).
    let t = Instant::now();
    for side in &mut setup.sides {
        side.sub.update_positions(&mesh.positions);
    }
    let truncated = if crossing {
        // A face wholly in a mask is a face of 𝒲₁ ∪ 𝒲₂ (each mask lies in its region's
        // vertices): the regions' faces are the only candidates.
        let faces_in = |mask: &[bool]| -> Vec<u32> {
            let in_mask = |f: u32| mesh.triangles[f as usize].iter().all(|&v| mask[v as usize]);
            setup.faces.iter().copied().filter(|&f| in_mask(f)).collect()
        };
        let [faces_first, faces_second] = [faces_in(&masks[0]), faces_in(&masks[1])];
        let [first, second] = std::mem::take(&mut setup.kept);
        let rest = &setup.rest;
        match (
            Truncated::new(mesh, topology, faces_first, &setup.sides[0], interior, d, first, rest)?,
            Truncated::new(mesh, topology, faces_second, &setup.sides[1], interior, -d, second, rest)?,
        ) {
            (Some(first), Some(second)) => Some([first, second]),
            _ => None,
        }
    } else {
        None
    };
    let pair_params = PairParams {
        contact_tau: articulation.params.contact_tau,
        direction: Some(d),
        safeguard_angle: articulation.params.safeguard_angle,
        max_contact_threshold: Some(0.0),
        contact_threshold_floor: Some(CONTACT_THRESHOLD_FLOOR),
        // The articulation leaves its own gap (`contact_gap` of the articulation, `separate`
        // below); the pair's would add to it.
        contact_gap: Some(0.0),
        ..PairParams::default()
    };
    let contact = match &truncated {
        Some(t) => {
            let k = articulation.params.stiffness;
            let sides = [t[0].side("region 1", k[0]), t[1].side("region 2", k[1])];
            Some(contact_pair(&sides[1], &sides[0], &pair_params)?)
        }
        None => None,
    };
    stats.contact_time = t.elapsed();
    if let Some(contact) = contact.as_ref().filter(|c| !c.is_empty()) {
        stats.in_contact = true;
        stats.intersection_points = contact.intersection_points.len();
        stats.threshold = contact.criterion.threshold;
        stats.contact_area = contact.contact_area;
    }
    Ok(ArticulationContact { labels, contact, truncated, direction: d, stats, contact_step: start.elapsed() })
}

/// Steps 4–6 of the module doc for one articulation at one frame, after
/// [`contact_articulation`]: the zones reported onto both regions, chapter 5 on each up to the
/// profiles and the blend over ℛ, up to the choice of its bulge height. `params` are the object's
/// deformation parameters (its extent is ignored: the articulation's own, or the automatic one,
/// is used).
pub fn deform_articulation(
    found: ArticulationContact,
    mesh: &TriMesh,
    setup: &mut ArticulationSetup,
    articulation: &Articulation,
    params: &DeformParams,
) -> Result<ArticulationPlan, SelfContactError> {
    let start = Instant::now();
    let n = mesh.num_vertices();
    let ArticulationContact { labels, contact, mut truncated, direction: d, stats, contact_step } = found;
    let contact = contact.filter(|c| !c.is_empty());
    if contact.is_none()
        && let Some(truncated) = truncated.take()
    {
        setup.kept = truncated.map(|t| Some(t.into_kept()));
    }
    let shared = &setup.shared;
    let mut plan = ArticulationPlan {
        displacement: AffineDisplacement::none(n),
        extent: f64::NAN,
        labels,
        contact: vec![false; n],
        stats,
    };
    let (Some(contact), Some(truncated)) = (contact, truncated) else {
        plan.stats.total_time = contact_step + start.elapsed();
        return Ok(plan);
    };

    // §6.2.1: each zone reported onto both whole regions; zones on the pair's sides: [𝒲̄₂, 𝒲̄₁].
    let t = Instant::now();
    let gap = articulation.params.contact_gap.unwrap_or(GAP_FRACTION * setup.edge_length);
    let separated = [&contact.sides[1].zone, &contact.sides[0].zone].map(|z| separate(z, 0.5 * gap));
    let found = [(&separated[0], &truncated[0]), (&separated[1], &truncated[1])];
    let zones: [Vec<ContactZone>; 2] = [0, 1].map(|l| {
        let to = &setup.sides[l];
        found
            .iter()
            .map(|(zone, from)| report_zone(zone, &from.sub, &from.topology, &to.sub, &to.topology))
            .filter(|z| !z.is_empty())
            .collect()
    });
    setup.kept = truncated.map(|t| Some(t.into_kept()));
    let zone_refs: [Vec<&ContactZone>; 2] = [0, 1].map(|l| zones[l].iter().collect());
    // §6.2.2: d̄ = (2β − 1)·d̂, unnormalized.
    let fields: [Vec<DVec3>; 2] = [0, 1]
        .map(|l| setup.sides[l].sub.parent_vertex.iter().map(|&v| (2.0 * shared.beta[v as usize] - 1.0) * d).collect());
    let automatic = fold_extent(setup.size, contact.contact_area);
    let mut extent = articulation.params.extent.unwrap_or(automatic);
    // Fixed by the first extent, so that a clamped second attempt sees the same φ.
    let domain_radius = params.domain_radius_for(extent);
    let mut plans: Vec<RegionPlan> = Vec::with_capacity(2);
    for attempt in 0..2 {
        plans.clear();
        let mut reach = f64::INFINITY;
        for l in 0..2 {
            let side = &mut setup.sides[l];
            let mut region_params = params.clone().with_extent(extent);
            region_params.domain_radius = Some(domain_radius);
            if let Some(map) = params.bulge_map.as_ref() {
                if map.len() != n {
                    return Err(DeformError::BulgeMapLength { expected: n, actual: map.len() }.into());
                }
                region_params.bulge_map = Some(side.sub.gather(map));
            }
            let overrides = RegionOverrides { mapping_field: Some(&fields[l]), normals: None };
            let solver = match side.solver.as_mut() {
                Some(solver) => solver,
                None => {
                    let analysis = Instant::now();
                    let solver = RegionSolver::new(&side.sub.mesh, &side.topology)?;
                    plan.stats.analysis_time += analysis.elapsed();
                    side.solver.insert(solver)
                }
            };
            let region_plan =
                plan_region(&side.sub.mesh, &side.topology, solver, &zone_refs[l], &region_params, &overrides)?;
            for (v, &far) in side.far_border.iter().enumerate() {
                if !far {
                    continue;
                }
                if region_plan.contact[v] {
                    return Err(SelfContactError::RegionTooSmall {
                        region: l + 1,
                        reason: format!(
                            "articulation \"{}\": the contact reaches vertex {} on the border of region {}",
                            articulation.name,
                            side.sub.parent_vertex[v],
                            l + 1
                        ),
                    });
                }
                if region_plan.deformable[v] {
                    reach = reach.min(region_plan.u[v] * extent);
                }
            }
            plans.push(region_plan);
        }
        if reach.is_finite() {
            let fitted = CLAMP_FRACTION * reach;
            if attempt == 1 || fitted.is_nan() || fitted <= 0.0 {
                return Err(SelfContactError::RegionTooSmall {
                    region: 1,
                    reason: format!(
                        "articulation \"{}\": the deformation reaches a region's far border (φ = {reach:.3e})",
                        articulation.name
                    ),
                });
            }
            extent = fitted;
            plan.stats.extent_clamped = true;
            continue;
        }
        break;
    }
    plan.extent = extent;
    plan.stats.extent = extent;
    for (l, region_plan) in plans.iter().enumerate() {
        plan.stats.contact_vertices[l] = region_plan.stats.num_contact;
        plan.stats.deformable_vertices[l] = region_plan.stats.num_deformable;
    }

    // §6: p′ = βp′₁ + (1 − β)p′₂, as affine displacements.
    let out = &mut plan.displacement;
    let mut weight_sum = vec![0.0; n];
    for (l, region_plan) in plans.iter().enumerate() {
        let sub = &setup.sides[l].sub;
        for (local, &v) in sub.parent_vertex.iter().enumerate() {
            let v = v as usize;
            let in_other = setup.sides[1 - l].sub.local_vertex[v] != NOT_IN_SUBMESH;
            let beta = shared.beta[v];
            let w = match (in_other, l) {
                (false, _) => 1.0,
                (true, 0) => beta,
                (true, _) => 1.0 - beta,
            };
            weight_sum[v] += w;
            plan.contact[v] |= region_plan.contact[local];
            let d = &region_plan.displacement;
            if w > 0.0 && d.moved[local] {
                out.moved[v] = true;
                out.constant[v] += w * d.constant[local];
                out.linear[v] += w * d.linear[local];
            }
        }
    }
    debug_assert!(weight_sum.iter().all(|&w| w == 0.0 || (w - 1.0).abs() < 1e-12));
    plan.stats.deformation_time = t.elapsed().saturating_sub(plan.stats.analysis_time);
    plan.stats.total_time = contact_step + start.elapsed();
    Ok(plan)
}

/// The bulge heights of an object's articulation plans and the resulting positions.
#[derive(Clone, Debug)]
pub struct AppliedArticulations {
    /// The object's positions after every articulation.
    pub positions: Vec<DVec3>,
    /// Per plan: h_v (γ = 1) and whether it is exact.
    pub heights: Vec<(f64, bool)>,
    /// Block Gauss–Seidel rounds run (1 when the plans' moving faces do not overlap).
    pub rounds: usize,
}

/// Largest number of rounds of the height solve.
const MAX_ROUNDS: usize = 16;

/// Chooses the bulge height of every plan and applies them (see the module doc): with
/// `preserve_volume`, each h solves the whole mesh's volume cubic given the others; otherwise
/// every h is `bulge_height`. Each plan then moves by `constant + bulge·h·linear`.
pub fn apply_articulations(
    mesh: &TriMesh,
    plans: &[ArticulationPlan],
    preserve_volume: bool,
    bulge_height: f64,
    bulge: f64,
) -> Result<AppliedArticulations, DeformError> {
    let k = plans.len();
    let active: Vec<bool> = plans.iter().map(|p| p.displacement.moved.iter().any(|&m| m)).collect();
    let mut heights: Vec<(f64, bool)> = vec![(if preserve_volume { 0.0 } else { bulge_height }, !preserve_volume); k];
    for (h, &a) in heights.iter_mut().zip(&active) {
        if !a {
            *h = (0.0, true);
        }
    }
    let positions_with = |heights: &[(f64, bool)], skip: Option<usize>, scale: f64| -> Vec<DVec3> {
        let mut positions = mesh.positions.clone();
        for (j, plan) in plans.iter().enumerate() {
            if Some(j) == skip || !active[j] {
                continue;
            }
            let d = &plan.displacement;
            for (v, p) in positions.iter_mut().enumerate() {
                if d.moved[v] {
                    *p += d.constant[v] + scale * heights[j].0 * d.linear[v];
                }
            }
        }
        positions
    };
    let mut rounds = 0;
    if preserve_volume && active.iter().any(|&a| a) {
        let target = signed_volume(mesh);
        let reference = vertex_centroid(&mesh.positions);
        // Moving faces of each plan, to know whether one round is exact.
        let moving: Vec<Vec<bool>> = plans
            .iter()
            .map(|p| mesh.triangles.iter().map(|t| t.iter().any(|&v| p.displacement.moved[v as usize])).collect())
            .collect();
        let overlapping = (0..k).any(|i| {
            (i + 1..k).any(|j| moving[i].iter().zip(&moving[j]).any(|(&a, &b)| a && b) && active[i] && active[j])
        });
        for round in 0..MAX_ROUNDS {
            rounds = round + 1;
            let mut change: f64 = 0.0;
            for j in (0..k).filter(|&j| active[j]) {
                let base =
                    TriMesh { positions: positions_with(&heights, Some(j), 1.0), triangles: mesh.triangles.clone() };
                let mut cubic = VolumeCubic::new(&base, &plans[j].displacement, reference)?;
                cubic.coefficients[0] += signed_volume(&base) - target;
                let solution = bulge_or_dent_height(&cubic, plans[j].extent);
                change = change.max((solution.height - heights[j].0).abs() / plans[j].extent);
                heights[j] = (solution.height, solution.exact);
            }
            if !overlapping || change < 1e-12 {
                break;
            }
        }
    }
    Ok(AppliedArticulations { positions: positions_with(&heights, None, bulge), heights, rounds })
}

/// The bulge height of an articulation: the smallest root h ≥ 0 of the volume cubic, else the
/// root h < 0 nearest 0 (a dent: the articulation's displacement adds volume that no outward
/// bulge takes back; docs/decisions.md, "An articulation that adds volume"), else the inexact
/// fallback of [`solve_bulge_height`].
fn bulge_or_dent_height(cubic: &VolumeCubic, extent: f64) -> HeightSolution {
    let bulge = solve_bulge_height(cubic, extent);
    if bulge.exact {
        return bulge;
    }
    let dent = solve_dent_height(cubic, extent);
    if dent.exact { dent } else { bulge }
}

/// Self-intersecting faces among the faces of an articulation's regions (exact triangle–triangle
/// tests, one query): all of them, and those of pairs joining its two sides.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SelfIntersectionCounts {
    pub all: usize,
    pub across: usize,
}

/// The faces behind [`SelfIntersectionCounts`], with the positions they were found at: what
/// [`articulation_crossings`] counts again from.
#[derive(Clone, Debug, Default)]
pub struct ArticulationCrossings {
    pub all: Vec<u32>,
    pub across: Vec<u32>,
    positions: Vec<DVec3>,
}

impl ArticulationCrossings {
    pub fn counts(&self) -> SelfIntersectionCounts {
        SelfIntersectionCounts { all: self.all.len(), across: self.across.len() }
    }
}

/// [`SelfIntersectionCounts`] of `mesh` (the object at this frame, input or result) for the
/// articulation of `setup`. A vertex is on side 1 in 𝒲₁ \ ℛ, on side 2 in 𝒲₂ \ ℛ, and on the
/// side of its crease-cut label in ℛ (`labels`, in the order of [`SharedRegion::vertices`],
/// true = 1); a pair joins the sides when its six vertices include both sides.
pub fn self_intersection_counts(
    mesh: &TriMesh,
    setup: &ArticulationSetup,
    labels: &[bool],
) -> Result<SelfIntersectionCounts, SpatialError> {
    Ok(articulation_crossings(mesh, setup, labels, None)?.counts())
}

/// The faces of [`self_intersection_counts`]; counted again from `before` (the same
/// articulation and labels on the same connectivity, other positions) where given: searched only
/// where vertices moved ([`crate::spatial::self_intersecting_faces_after`]), the same faces.
pub fn articulation_crossings(
    mesh: &TriMesh,
    setup: &ArticulationSetup,
    labels: &[bool],
    before: Option<&ArticulationCrossings>,
) -> Result<ArticulationCrossings, SpatialError> {
    if setup.faces.is_empty() {
        return Ok(ArticulationCrossings::default());
    }
    let side = vertex_sides(setup, labels);
    let across = |f: u32, g: u32| joins_sides(mesh, &side, f, g);
    let (all, across) = match before {
        Some(b) => (
            crate::spatial::self_intersecting_faces_after(mesh, &setup.faces, |_, _| true, &b.positions, &b.all)?,
            crate::spatial::self_intersecting_faces_after(mesh, &setup.faces, across, &b.positions, &b.across)?,
        ),
        None => (
            crate::spatial::self_intersecting_faces(mesh, setup.faces.iter().copied(), |_, _| true)?,
            crate::spatial::self_intersecting_faces(mesh, setup.faces.iter().copied(), across)?,
        ),
    };
    Ok(ArticulationCrossings { all, across, positions: mesh.positions.clone() })
}

/// Per vertex of the object, its side of the articulation for [`self_intersection_counts`]: 1,
/// 2, or 0 (neither).
fn vertex_sides(setup: &ArticulationSetup, labels: &[bool]) -> Vec<u8> {
    let shared = &setup.shared;
    let mut side: Vec<u8> = shared
        .membership
        .iter()
        .map(|m| match m {
            [true, false] => 1,
            [false, true] => 2,
            _ => 0,
        })
        .collect();
    for (&v, &first) in shared.vertices.iter().zip(labels) {
        side[v as usize] = if first { 1 } else { 2 };
    }
    side
}

/// True if faces `f` and `g` of `mesh` have vertices on both sides (`side` of [`vertex_sides`]).
fn joins_sides(mesh: &TriMesh, side: &[u8], f: u32, g: u32) -> bool {
    let sides_of = |f: u32| -> u8 {
        mesh.triangles[f as usize].iter().fold(0u8, |mask, &v| mask | side.get(v as usize).copied().unwrap_or(0))
    };
    sides_of(f) | sides_of(g) == 3
}

/// [`self_intersection_counts`] from `pairs`, every intersecting pair of faces of `mesh` among
/// faces that include the articulation's ([`crate::spatial::self_intersecting_pairs`]): the
/// faces of the pairs within the articulation's faces, the same counts as its own search.
pub fn self_intersection_counts_from_pairs(
    mesh: &TriMesh,
    setup: &ArticulationSetup,
    labels: &[bool],
    pairs: &[[u32; 2]],
) -> SelfIntersectionCounts {
    let mut member = vec![false; mesh.triangles.len()];
    for &f in &setup.faces {
        if let Some(m) = member.get_mut(f as usize) {
            *m = true;
        }
    }
    let side = vertex_sides(setup, labels);
    // Per face: 1 = in a pair, 2 = in a pair joining the sides.
    let mut found = vec![0u8; mesh.triangles.len()];
    for &[f, g] in pairs {
        if !(member.get(f as usize) == Some(&true) && member.get(g as usize) == Some(&true)) {
            continue;
        }
        let mark = if joins_sides(mesh, &side, f, g) { 3 } else { 1 };
        found[f as usize] |= mark;
        found[g as usize] |= mark;
    }
    SelfIntersectionCounts {
        all: found.iter().filter(|&&m| m & 1 != 0).count(),
        across: found.iter().filter(|&&m| m & 2 != 0).count(),
    }
}

#[cfg(test)]
#[path = "self_contact_tests.rs"]
mod tests;
