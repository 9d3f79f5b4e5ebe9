//! Contact definition between two working regions in intersection (thesis chapter 4, method B).
//!
//! Regions that must evolve continuously over an animation are [`EdgeRegion`]s: inside vertices
//! plus exact boundary points on edges (§4.1, §4.2.2, §4.4).
//!
//! The stage's output for each side of a pair is a [`ContactZone`], which the deformation stage
//! (chapter 5) consumes: the zone 𝒞 on that mesh, where each of its vertices and boundary points
//! goes on the potential contact surface 𝒮 with the normal of 𝒮 there, and the direction along
//! which that side is displaced.
//!
//! One private module per step, in pipeline order (each cites its section and states its
//! decisions), reached through the functions below:
//! - [`intersect()`]: edge/face intersection points, tags, flood fill → ℐ_a, ℐ_b (§4.1);
//! - [`direction_from_points`], [`direction_from_stats`]: mapping direction d̂ from normal
//!   integrals over ℐ (§4.2.2, Eq. 4.1, App. A);
//! - [`map_regions`]: front-facing regions ℬ, projected regions 𝒫, mapping regions ℳ and the
//!   farthest-hit matches along ±d̂ (§4.2.2);
//! - [`side_surface`]: the potential contact surface 𝒮, p′ and n′ (§4.3);
//! - [`extract_zone`]: the threshold ε_c ([`criterion`]) and the contact zones 𝒞 with exact
//!   boundary points (§4.4.2);
//! - method A's alternatives, chosen in [`PairParams`](crate::params::PairParams): [`map_regions_uv`], the
//!   shared-parametrization mapping (§4.2.1), and [`ball_zone`], ball testing and sliding (§4.4.1,
//!   rigid–elastic pairs);
//! - [`apply_gap`]: the zones' targets backed off 𝒮 by the pair's contact gap, so that the
//!   outputs do not interleave (not in the thesis; issue 29);
//! - [`contact_pair`], which runs them all for a pair and returns a [`PairContact`] with the
//!   stage times ([`ContactStats`]);
//! - [`debug_export`]: per-vertex labels and boundary points for debugging.
//!
//! ```
//! use squish::contact::{contact_pair, ContactSide, Stiffness};
//! use squish::PairParams;
//! use squish::mesh::{shapes, vertex_normals, Topology};
//! use squish::spatial::TriangleBvh;
//! use squish::DVec3;
//!
//! // A rigid unit sphere pressed 0.2 deep into an elastic plane.
//! let mut sphere = shapes::icosphere(1.0, 3);
//! sphere.map_positions(|p| p + DVec3::new(0.0, 0.0, 0.8));
//! let plane = shapes::grid(3.0, 3.0, 40, 40);
//! let (ts, tp) = (Topology::new(&sphere), Topology::new(&plane));
//! let (ns, np) = (vertex_normals(&sphere), vertex_normals(&plane));
//! let (bs, bp) = (TriangleBvh::new(&sphere).unwrap(), TriangleBvh::new(&plane).unwrap());
//! let a = ContactSide::new(&sphere, &ts, &ns, &bs).with_stiffness(Stiffness::Rigid);
//! let b = ContactSide::new(&plane, &tp, &np, &bp);
//! let contact = contact_pair(&a, &b, &PairParams::default()).unwrap();
//! assert!((contact.direction - DVec3::Z).length() < 1e-9); // the plane's normal
//! assert!(!contact.sides[1].zone.is_empty());
//! ```

mod ball;
mod direction;
mod error;
mod export;
mod gap;
mod intersect;
mod mapping;
mod pair;
mod region;
mod stiffness;
mod surface;
mod uv_mapping;
mod zone;

#[cfg(test)]
mod acceptance;
#[cfg(test)]
mod test_support;

pub use ball::{BallSetup, BallStats, BallZone, ball_zone};
pub use direction::{DirectionSource, NormalStats, direction_from_points, direction_from_stats, normal_stats};
pub use error::ContactError;
pub use export::{
    BoundaryKind, DebugPoint, DebugSide, LABEL_CONTACT, LABEL_INTERSECTION, LABEL_MAPPING, LABEL_OUTSIDE, debug_export,
};
pub use gap::{PAIR_GAP_FRACTION, apply_gap, effective_gap, zone_edge_length};
pub use intersect::{Interior, Intersection, IntersectionPoint, IntersectionStats, intersect};
pub use mapping::{MappingStats, Match, MatchKind, NO_SLOT, SideMapping, map_regions};
pub use pair::{ContactCounts, ContactFallbacks, ContactSide, ContactStats, PairContact, SideContact, contact_pair};
pub use region::{EdgeRegion, Sample};
pub use stiffness::{Stiffness, relative_stiffness};
pub use surface::{SideSurface, SurfaceSample, side_surface};
pub use uv_mapping::{SharedParametrization, SideParametrization, map_regions_uv};
pub use zone::{CriterionStats, ZoneResult, ZoneSetup, criterion, extract_zone};

use glam::DVec3;

/// A contact zone 𝒞 on one working region, with everything the deformation stage needs.
#[derive(Clone, Debug, Default)]
pub struct ContactZone {
    /// The zone on this region's mesh: inside vertices and exact boundary points (α from the
    /// inside vertex, §4.4.2 Eq. 4.4 / §4.4.1 ball sliding).
    pub region: EdgeRegion,
    /// Per vertex of the region mesh: its position on 𝒮 (p′_i). Meaningful for inside vertices;
    /// other entries hold the vertex's own position.
    pub targets: Vec<DVec3>,
    /// Per vertex: the unit normal of 𝒮 at p′_i, oriented outward from this mesh (n′_i).
    /// Meaningful for inside vertices; other entries are zero.
    pub normals: Vec<DVec3>,
    /// Per boundary point of `region` (same order as `region.points()`): its position on the
    /// mesh p_ij.
    pub boundary_positions: Vec<DVec3>,
    /// Per boundary point: its position on 𝒮, p′_ij (recomputed exactly by projecting the
    /// boundary point along the mapping direction, §4.4.2).
    pub boundary_targets: Vec<DVec3>,
    /// Per boundary point: the unit normal of 𝒮 at p′_ij, oriented outward from this mesh.
    pub boundary_normals: Vec<DVec3>,
    /// The outward displacement direction of this side, d̄ in §5.2.2: −d̂ for the first object of
    /// the pair, +d̂ for the second (d̂ is oriented along the second object's normals, Eq. 4.1), so
    /// that a penetrating vertex moves by −a·d̄ with a > 0.
    pub direction: DVec3,
    /// The pair's mapping direction d̂ (oriented along the second object's normals), used by the
    /// anisotropic bulge map (Eq. 5.6).
    pub mapping_direction: DVec3,
}

impl ContactZone {
    /// True if the zone holds no vertex.
    pub fn is_empty(&self) -> bool {
        self.region.is_empty()
    }
}
