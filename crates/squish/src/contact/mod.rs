//! Contact definition between two working regions in intersection (thesis chapter 4).
//!
//! Regions that must evolve continuously over an animation are [`EdgeRegion`]s: inside vertices
//! plus exact boundary points on edges (§4.1, §4.2.2, §4.4).
//!
//! The stage's output for each side of a pair is a [`ContactZone`], which the deformation stage
//! (chapter 5) consumes: the zone 𝒞 on that mesh, where each of its vertices and boundary points
//! goes on the potential contact surface 𝒮 with the normal of 𝒮 there, and the direction along
//! which that side is displaced.

mod region;

pub use region::{EdgeRegion, Sample};

use glam::DVec3;

/// A contact zone 𝒞 on one working region, with everything the deformation stage needs.
#[derive(Clone, Debug)]
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
