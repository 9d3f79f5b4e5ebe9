//! The contact definition of one pair of working regions in intersection: the first half of the
//! per-frame pipeline (thesis chapter 4, method B; the algorithm box of §4.5, "Part 1 – Contact").
//!
//! [`contact_pair`] runs the stages in order — [`intersect`](super::intersect) (§4.1),
//! [`direction`](super::direction) (§4.2.2, Eq. 4.1), [`mapping`](super::mapping) (§4.2.2),
//! [`surface`](super::surface) (§4.3), [`zone`](super::zone) (§4.4.2) — and returns a
//! [`PairContact`] holding every intermediate region (for inspection and the debug export), the two
//! [`ContactZone`]s the deformation stage consumes, and per-stage timings and fallback counters.
//!
//! Conventions: the pair is (a, b) = (first, second object); d̂ is oriented along b's normals
//! (Eq. 4.1); a is displaced along d̄ = −d̂ and b along +d̂. Two meshes that do not intersect give
//! an empty result (`Ok`), never an error.
//!
//! Only the working regions are processed: the caller passes the working-region meshes, their
//! topologies, unit vertex normals and triangle trees (built once and refitted across frames).
//!
//! Method A's alternatives (chosen in [`PairParams`]): [`MappingMethod::SharedParametrization`]
//! replaces the mapping stage by [`super::uv_mapping`] (§4.2.1; the sides then need UVs), and
//! [`ContactMethod::Ball`] replaces the zone stage by [`super::ball`] (§4.4.1; exactly one rigid
//! side, whose zone is then empty).

use std::time::{Duration, Instant};

use glam::DVec3;

use super::direction::{DirectionSource, NormalStats, direction_from_points, direction_from_stats, normal_stats};
use super::intersect::{Interior, IntersectionPoint, IntersectionStats, intersect};
use super::mapping::{MappingStats, SideMapping, map_regions};
use super::stiffness::{Stiffness, relative_stiffness};
use super::surface::{SideSurface, side_surface};
use super::zone::{CriterionStats, ZoneSetup, criterion, extract_zone};
use super::{ContactError, ContactZone, EdgeRegion};
use crate::mesh::{Topology, TriMesh};
use crate::params::{MappingMethod, PairParams, Params};
use crate::params::{Uvs, VertexFlags};
use crate::spatial::TriangleBvh;
use crate::stage::{Stage, StageTimes, StageWork, Work};

/// One side of a pair: a working region and what the contact definition needs about it.
#[derive(Clone, Copy, Debug)]
pub struct ContactSide<'a> {
    /// Name used in error messages (e.g. the object's name in the scene). Empty: "a" / "b".
    pub name: &'a str,
    /// The working-region mesh.
    pub mesh: &'a TriMesh,
    /// Its topology.
    pub topology: &'a Topology,
    /// Unit vertex normals (e.g. [`crate::mesh::vertex_normals`]), one per vertex.
    pub normals: &'a [DVec3],
    /// Triangle tree over all faces of `mesh` (face ids = mesh face ids).
    pub bvh: &'a TriangleBvh,
    /// Pseudo-stiffness (§4.3).
    pub stiffness: Stiffness,
    /// Per vertex: true where the working region was cut out of a bigger mesh. `None`: the
    /// region is the whole object (its boundary, if any, is genuine).
    pub border: Option<&'a [bool]>,
    /// Texture coordinates (per vertex or per triangle corner), needed by
    /// [`MappingMethod::SharedParametrization`] only.
    pub uvs: Option<&'a Uvs>,
    /// Per vertex: true if it lies inside the other side, decided by the caller. `None`: decided
    /// by the intersection stage (tags and flood fill, §4.1). Self-contact (ch. 6) gives it: its
    /// two sides are parts of one closed mesh whose intersection curves end at the crease cut,
    /// where a flood fill would leak (see [`super::intersect`]).
    pub interior: Option<Interior<'a>>,
    /// Tree over the faces that the other side's lines along ±d̂ are matched on (§4.2.2), face
    /// ids = mesh face ids. `None`: all faces ([`Self::bvh`]). Self-contact (ch. 6) gives the
    /// faces that face the fold: its sides are open parts of one limb, and the farthest crossing
    /// of a line with the whole part would be the limb's outer skin, beyond the fold.
    pub match_bvh: Option<&'a TriangleBvh>,
}

impl<'a> ContactSide<'a> {
    /// A side with the default stiffness (elastic, 1), no name and no cut border.
    pub fn new(mesh: &'a TriMesh, topology: &'a Topology, normals: &'a [DVec3], bvh: &'a TriangleBvh) -> Self {
        Self {
            name: "",
            mesh,
            topology,
            normals,
            bvh,
            stiffness: Stiffness::default(),
            border: None,
            uvs: None,
            interior: None,
            match_bvh: None,
        }
    }

    /// Sets the name used in error messages.
    pub fn with_name(mut self, name: &'a str) -> Self {
        self.name = name;
        self
    }

    /// Sets the stiffness.
    pub fn with_stiffness(mut self, stiffness: Stiffness) -> Self {
        self.stiffness = stiffness;
        self
    }

    /// Sets the cut-border flags (one per vertex).
    pub fn with_border(mut self, border: Option<&'a [bool]>) -> Self {
        self.border = border;
        self
    }

    /// Sets the UVs (one per vertex or three per triangle; for the shared-parametrization
    /// mapping).
    pub fn with_uvs(mut self, uvs: Option<&'a Uvs>) -> Self {
        self.uvs = uvs;
        self
    }

    /// Sets the interior flags decided by the caller (one per vertex).
    pub fn with_interior(mut self, interior: Option<&'a [bool]>) -> Self {
        self.interior = interior.map(Interior::Flags);
        self
    }

    /// Sets the interior decided by the caller as flags of the object's vertices, asked only for
    /// the vertices the intersection stage needs: vertex `v` of this side is `parent[v]` of the
    /// object `flags` answers for (see [`Interior::Asked`]).
    pub fn with_interior_asked(mut self, interior: Option<(&'a VertexFlags, &'a [u32])>) -> Self {
        self.interior = interior.map(|(flags, parent)| Interior::Asked { flags, parent });
        self
    }

    /// Sets the tree of the faces the other side's lines are matched on (see [`Self::match_bvh`]).
    pub fn with_match_bvh(mut self, tree: Option<&'a TriangleBvh>) -> Self {
        self.match_bvh = tree;
        self
    }

    /// The tree the other side's lines are matched on.
    pub fn match_tree(&self) -> &'a TriangleBvh {
        self.match_bvh.unwrap_or(self.bvh)
    }

    /// The name for messages.
    pub fn display_name(&self) -> String {
        if self.name.is_empty() { "unnamed".to_string() } else { self.name.to_string() }
    }

    /// Checks that all parts describe the same mesh.
    pub fn validate(&self) -> Result<(), ContactError> {
        let nv = self.mesh.num_vertices();
        let nf = self.mesh.num_triangles();
        let checks = [
            ("the topology's vertex count", nv, self.topology.num_vertices()),
            ("the topology's face count", nf, self.topology.num_faces()),
            ("the normals", nv, self.normals.len()),
            ("the triangle tree", nf, self.bvh.len()),
            ("the border flags", nv, self.border.map_or(nv, <[bool]>::len)),
            ("the UVs", self.uvs.map_or(nv, |u| u.expected(nv, nf)), self.uvs.map_or(nv, |u| u.count().1)),
            ("the interior flags", nv, self.interior.map_or(nv, |i| i.len())),
        ];
        for (what, expected, got) in checks {
            if expected != got {
                return Err(ContactError::InputMismatch { object: self.display_name(), what, expected, got });
            }
        }
        Ok(())
    }
}

/// Everything computed on one side of the pair.
#[derive(Clone, Debug)]
pub struct SideContact {
    /// ℐ_l (§4.1).
    pub intersection: EdgeRegion,
    /// Mean normal and total variation over ℐ_l (Eq. 4.1).
    pub normal_stats: NormalStats,
    /// ℬ_l, 𝒫_l(ℬ_other), ℳ_l and the matches (§4.2.2).
    pub mapping: SideMapping,
    /// 𝒮 at the samples of ℳ_l (§4.3).
    pub surface: SideSurface,
    /// 𝒞_l with its targets and normals on 𝒮 (§4.4.2): what the deformation stage consumes.
    pub zone: ContactZone,
    /// Area of 𝒞_l measured at its points on 𝒮.
    pub zone_area_on_surface: f64,
    /// Area of 𝒞_l on the mesh.
    pub zone_area_on_mesh: f64,
    /// k̄_l.
    pub relative_stiffness: f64,
}

impl SideContact {
    fn empty(side: &ContactSide, direction: DVec3, toward: DVec3, k: f64) -> Self {
        let empty = EdgeRegion::empty(side.topology);
        let nv = side.mesh.num_vertices();
        Self {
            intersection: empty.clone(),
            normal_stats: NormalStats::default(),
            mapping: SideMapping {
                front: empty.clone(),
                projected: empty.clone(),
                region: empty.clone(),
                vertex_slot: vec![super::mapping::NO_SLOT; nv],
                ..Default::default()
            },
            surface: SideSurface::default(),
            zone: ContactZone {
                region: empty,
                targets: side.mesh.positions.clone(),
                normals: vec![DVec3::ZERO; nv],
                boundary_positions: Vec::new(),
                boundary_targets: Vec::new(),
                boundary_normals: Vec::new(),
                direction: -toward,
                mapping_direction: direction,
            },
            zone_area_on_surface: 0.0,
            zone_area_on_mesh: 0.0,
            relative_stiffness: k,
        }
    }
}

/// Sizes of the regions, per side [a, b].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct ContactCounts {
    pub intersection_points: usize,
    pub intersection_vertices: [usize; 2],
    pub mapping_vertices: [usize; 2],
    pub mapping_boundary_points: [usize; 2],
    pub zone_vertices: [usize; 2],
    pub zone_boundary_points: [usize; 2],
}

/// Numerical corners and decisions, counted (0 in a clean configuration).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactFallbacks {
    pub intersection: IntersectionStats,
    pub mapping: MappingStats,
    /// Zone boundary points whose recomputed match fell back to the closest point.
    pub zone_closest_point_matches: usize,
}

impl ContactFallbacks {
    /// Total number of numerical fallbacks (tag conflicts decided by a rule are not counted).
    pub fn numerical(&self) -> usize {
        self.intersection.edges_without_crossing
            + self.mapping.midpoint_alphas
            + self.mapping.closest_point_matches
            + self.zone_closest_point_matches
    }
}

/// Figures of one run.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ContactStats {
    /// Wall-clock time of each stage: [`Stage::Intersection`], [`Stage::Mapping`] (direction and
    /// mapping regions) and [`Stage::ContactZone`] (potential contact surface and zones).
    pub timings: StageTimes,
    /// The work of the same stages ([`crate::stage::Work`]).
    #[serde(default)]
    pub work: StageWork,
    /// Wall-clock time of the whole call.
    pub time: Duration,
    pub counts: ContactCounts,
    pub fallbacks: ContactFallbacks,
}

/// The contact definition of a pair (a, b).
#[derive(Clone, Debug)]
pub struct PairContact {
    /// The mapping direction d̂ (unit, along b's normals); zero when there is no intersection and
    /// no user direction.
    pub direction: DVec3,
    /// Where d̂ came from ([`DirectionSource::is_automatic`]).
    pub direction_source: DirectionSource,
    /// m_𝒮, σ_𝒮 and ε_c (Eq. 4.3).
    pub criterion: CriterionStats,
    /// All edge/face intersection points (§4.1), located on both meshes.
    pub intersection_points: Vec<IntersectionPoint>,
    /// Side a, side b.
    pub sides: [SideContact; 2],
    /// Area of the contact on 𝒮: the area of 𝒞_a at its points on 𝒮 (that of 𝒞_b agrees up to
    /// discretization).
    pub contact_area: f64,
    /// Method A: the ball radius used when the given r_s left the zone empty (halved until the
    /// balls fit inside the elastic object); `None` when r_s was used as given.
    pub ball_radius: Option<f64>,
    /// The gap left between the two sides' targets across the zone ([`PairParams::contact_gap`]
    /// bounded by the typical penetration depth; 0 without contact).
    pub gap: f64,
    pub stats: ContactStats,
}

impl PairContact {
    /// True when neither side has a contact zone.
    pub fn is_empty(&self) -> bool {
        self.sides.iter().all(|s| s.zone.is_empty())
    }

    /// The two contact zones [𝒞_a, 𝒞_b].
    pub fn zones(&self) -> [&ContactZone; 2] {
        [&self.sides[0].zone, &self.sides[1].zone]
    }

    /// ε_c.
    pub fn threshold(&self) -> f64 {
        self.criterion.threshold
    }
}

/// Contact definition between two working regions in intersection (thesis ch. 4, method B).
///
/// `a` and `b` are the first and second objects (d̂ is oriented along b's normals). Returns an
/// empty result when they do not intersect. Errors: inconsistent inputs, invalid parameters,
/// both objects rigid, an intersection reaching a cut working-region border, or an undefined
/// automatic direction.
pub fn contact_pair(a: &ContactSide, b: &ContactSide, params: &PairParams) -> Result<PairContact, ContactError> {
    // One span for the call, lapped at each stage (see `Work`).
    Work::measure(|| contact_pair_measured(a, b, params)).0
}

fn contact_pair_measured(a: &ContactSide, b: &ContactSide, params: &PairParams) -> Result<PairContact, ContactError> {
    let start = Instant::now();
    let a = if a.name.is_empty() { a.with_name("a") } else { *a };
    let b = if b.name.is_empty() { b.with_name("b") } else { *b };
    a.validate()?;
    b.validate()?;
    params.validate()?;
    let user_direction = params.direction.map(|d| d.normalize());
    let [ka, kb] = relative_stiffness(a.stiffness, b.stiffness, [a.name, b.name])?;
    // Method A's choices are checked before any work (§4.4.1: one rigid side; §4.2.1: UVs).
    let ball = match params.ball() {
        Some(radius) => Some((super::ball::elastic_side(&a, &b)?, radius)),
        None => None,
    };
    if params.mapping == MappingMethod::SharedParametrization {
        super::uv_mapping::check_uvs([&a, &b])?;
    }
    let sides = [&a, &b];
    let mut stats = ContactStats::default();

    let t = Instant::now();
    Work::lap();
    let inter = intersect(&a, &b)?;
    stats.timings[Stage::Intersection] = t.elapsed();
    stats.work[Stage::Intersection] = Work::lap();
    stats.fallbacks.intersection = inter.stats;
    stats.counts.intersection_points = inter.points.len();
    if inter.points.is_empty() {
        let direction = user_direction.unwrap_or(DVec3::ZERO);
        let source = if user_direction.is_some() { DirectionSource::User } else { DirectionSource::None };
        stats.time = start.elapsed();
        return Ok(PairContact {
            direction,
            direction_source: source,
            criterion: CriterionStats::default(),
            intersection_points: Vec::new(),
            sides: [
                SideContact::empty(&a, direction, direction, ka),
                SideContact::empty(&b, direction, -direction, kb),
            ],
            contact_area: 0.0,
            ball_radius: None,
            gap: 0.0,
            stats,
        });
    }
    let [ia, ib] = inter.regions;

    let t = Instant::now();
    let normal_stats =
        [normal_stats(&ia, a.mesh, a.topology, a.normals), normal_stats(&ib, b.mesh, b.topology, b.normals)];
    let (direction, direction_source) = match user_direction {
        Some(d) => (d, DirectionSource::User),
        None => match direction_from_stats(&normal_stats[0], &normal_stats[1]) {
            Some(result) => result?,
            None => direction_from_points(
                &inter.points,
                [a.topology, b.topology],
                [a.mesh, b.mesh],
                [a.normals, b.normals],
            )?,
        },
    };
    stats.timings[Stage::Mapping] = t.elapsed();
    stats.work[Stage::Mapping] = Work::lap();

    let t = Instant::now();
    let (mappings, mapping_stats, shared) = match params.mapping {
        MappingMethod::UniqueDirection => {
            let (mappings, stats) = map_regions(sides, [&ia, &ib], direction)?;
            (mappings, stats, None)
        }
        MappingMethod::SharedParametrization => {
            let (mappings, stats, shared) = super::uv_mapping::map_regions_uv(sides, [&ia, &ib], &inter.points)?;
            (mappings, stats, Some(shared))
        }
    };
    stats.timings[Stage::Mapping] += t.elapsed();
    stats.work[Stage::Mapping] += Work::lap();
    stats.fallbacks.mapping = mapping_stats;

    let t = Instant::now();
    let toward = [direction, -direction];
    let k = [ka, kb];
    let surfaces = [0, 1].map(|l| side_surface(sides[l], &mappings[l], toward[l], k[l], k[1 - l]));
    let mut crit = criterion(sides, [&mappings[0], &mappings[1]], [&surfaces[0], &surfaces[1]], params.contact_tau);
    if params.contact_threshold_floor.is_some() || params.contact_tau > 0.0 || params.contact_gap != Some(0.0) {
        crit.penetration =
            super::zone::typical_penetration(sides, [&mappings[0], &mappings[1]], [&surfaces[0], &surfaces[1]]);
    }
    if let Some(floor) = params.contact_threshold_floor {
        crit.threshold = crit.threshold.max(-floor * crit.penetration);
    }
    // τ is clamped so that the zone is never empty while the meshes penetrate (docs/decisions.md,
    // "Contact spread τ"): ε_c ≤ P, the typical penetration depth, which points of ℳ always
    // reach. For τ ≤ 0 the clamp cannot bind (m_𝒮 ≤ P), so it is not computed.
    if params.contact_tau > 0.0 && crit.penetration > 0.0 && crit.threshold > crit.penetration {
        crit.unclamped_threshold = Some(crit.threshold);
        crit.threshold = crit.penetration;
    }
    if let Some(max) = params.max_contact_threshold {
        crit.threshold = crit.threshold.min(max);
    }
    stats.timings[Stage::ContactZone] = t.elapsed();
    stats.work[Stage::ContactZone] = Work::lap();

    let t = Instant::now();
    let cos_guard = params.safeguard_cosine();
    let geometric = |l: usize| {
        let setup = ZoneSetup {
            toward: toward[l],
            mapping_direction: direction,
            k_own: k[l],
            k_other: k[1 - l],
            threshold: crit.threshold,
            cos_guard,
        };
        extract_zone(sides[l], sides[1 - l], &mappings[l], &surfaces[l], &setup)
    };
    let mut ball_radius = None;
    let zones = match ball {
        Some((elastic, radius)) => {
            let run = |r: f64| {
                super::ball::ball_zones(sides, &mappings, &surfaces, [&ia, &ib], elastic, r, direction, shared.as_ref())
            };
            // A ball wider than the elastic object at the contact touches its far side from
            // every vertex, and the zone is empty (§4.4.1 discussion: r_s is bounded by the
            // local feature size). The radius is then halved until balls fit, and the radius
            // used is reported (docs/decisions.md, "Ball radius").
            let mut zones = run(radius)?;
            let mut used = radius;
            for _ in 0..MAX_BALL_HALVINGS {
                if !(zones[elastic].zone.is_empty() && ia.num_inside() + ib.num_inside() > 0) {
                    break;
                }
                used *= 0.5;
                zones = run(used)?;
            }
            if used != radius {
                ball_radius = Some(used);
            }
            zones
        }
        None => {
            let mut zones = [0, 1].map(geometric);
            if let Some(shared) = &shared {
                // Boundary points recomputed in UV space rather than along d̂.
                for (l, zone) in zones.iter_mut().enumerate() {
                    super::uv_mapping::rematch_zone(
                        zone,
                        sides[l],
                        sides[1 - l],
                        &mappings[l],
                        &shared.sides[l],
                        toward[l],
                        k[l],
                        k[1 - l],
                    );
                }
            }
            zones
        }
    };
    // The targets backed off 𝒮 so that the outputs do not interleave (super::gap).
    let mut zones = zones;
    let gap = match params.contact_gap {
        Some(0.0) => 0.0,
        requested => {
            let edges = [0, 1].map(|l| super::gap::zone_edge_length(sides[l].mesh, sides[l].topology, &zones[l].zone));
            super::gap::effective_gap(requested, edges, crit.penetration)
        }
    };
    for (l, z) in zones.iter_mut().enumerate() {
        super::gap::apply_gap(&mut z.zone, k[1 - l] * gap);
    }
    stats.timings[Stage::ContactZone] += t.elapsed();
    stats.work[Stage::ContactZone] += Work::lap();

    let [ma, mb] = mappings;
    let [sa, sb] = surfaces;
    let [za, zb] = zones;
    stats.counts.intersection_vertices = [ia.num_inside(), ib.num_inside()];
    stats.fallbacks.zone_closest_point_matches = za.closest_point_matches + zb.closest_point_matches;
    // With ball testing the rigid side has no zone: the area is the elastic side's.
    let contact_area = if ball.is_some() { za.area_on_surface.max(zb.area_on_surface) } else { za.area_on_surface };
    let [na, nb] = normal_stats;
    let sides = [
        SideContact {
            intersection: ia,
            normal_stats: na,
            mapping: ma,
            surface: sa,
            zone: za.zone,
            zone_area_on_surface: za.area_on_surface,
            zone_area_on_mesh: za.area_on_mesh,
            relative_stiffness: ka,
        },
        SideContact {
            intersection: ib,
            normal_stats: nb,
            mapping: mb,
            surface: sb,
            zone: zb.zone,
            zone_area_on_surface: zb.area_on_surface,
            zone_area_on_mesh: zb.area_on_mesh,
            relative_stiffness: kb,
        },
    ];
    for (l, s) in sides.iter().enumerate() {
        stats.counts.mapping_vertices[l] = s.mapping.vertices.len();
        stats.counts.mapping_boundary_points[l] = s.mapping.region.points().len();
        stats.counts.zone_vertices[l] = s.zone.region.num_inside();
        stats.counts.zone_boundary_points[l] = s.zone.region.points().len();
    }
    stats.time = start.elapsed();
    Ok(PairContact {
        direction,
        direction_source,
        criterion: crit,
        intersection_points: inter.points,
        sides,
        contact_area,
        ball_radius,
        gap,
        stats,
    })
}

/// How many times a ball radius that gives an empty zone is halved (1/256 of it at most).
const MAX_BALL_HALVINGS: usize = 8;
