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
//! One module per stage, in pipeline order (each cites its section and states its decisions):
//! - [`intersect`]: edge/face intersection points, tags, flood fill → ℐ_a, ℐ_b (§4.1);
//! - [`direction`]: mapping direction d̂ from normal integrals over ℐ (§4.2.2, Eq. 4.1, App. A);
//! - [`mapping`]: front-facing regions ℬ, projected regions 𝒫, mapping regions ℳ and the
//!   farthest-hit matches along ±d̂ (§4.2.2);
//! - [`surface`]: the potential contact surface 𝒮, p′ and n′ (§4.3);
//! - [`zone`]: the threshold ε_c and the contact zones 𝒞 with exact boundary points (§4.4.2);
//! - method A's alternatives, chosen in [`PairParams`]: [`uv_mapping`], the shared-parametrization
//!   mapping (§4.2.1), and [`ball`], ball testing and sliding (§4.4.1, rigid–elastic pairs);
//! - [`pair`]: [`contact_pair`], which runs them all for a pair and returns a [`PairContact`];
//! - [`export`]: per-vertex labels and boundary points for debugging.
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

mod region;

pub mod ball;
pub mod direction;
pub mod export;
pub mod intersect;
pub mod mapping;
pub mod pair;
pub mod surface;
pub mod uv_mapping;
pub mod zone;

mod error;
mod stiffness;

#[cfg(test)]
mod acceptance;
#[cfg(test)]
mod test_support;

pub use direction::{DirectionSource, NormalStats};
pub use error::ContactError;
pub use export::{BoundaryKind, DebugPoint, DebugSide, debug_export};
pub use intersect::{IntersectionPoint, IntersectionStats};
pub use mapping::{MappingStats, Match, MatchKind, SideMapping};
pub use pair::{
    ContactCounts, ContactFallbacks, ContactSide, ContactStats, PairContact, SideContact, StageTimings, contact_pair,
};
pub use region::{EdgeRegion, Sample};
pub use stiffness::{Stiffness, relative_stiffness};
pub use surface::{SideSurface, SurfaceSample};
pub use zone::CriterionStats;

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
