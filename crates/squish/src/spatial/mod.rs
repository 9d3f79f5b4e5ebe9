//! Spatial queries on triangle meshes: bounding volume hierarchies, segment and ray crossings,
//! closest points, exact triangle–triangle tests, self-intersections and inside/outside tests.
//!
//! Where the pipeline uses them:
//! - **collision detection** (thesis §4.1): every edge of one working region is intersected with
//!   the faces of the other ([`TriangleBvh::segment_hits`], [`TriangleBvh::segment_hits_batch`]);
//!   each crossing keeps its position along the edge and its barycentric coordinates on the face,
//!   hits come sorted along the edge so the closest face at each edge end is the first / last one,
//!   and [`Hit::entering`] gives the side for the *interior*/*exterior* tags;
//! - **mapping** (§4.2.2): vertices are matched to the farthest point of the opposite mesh along
//!   ±d̂ ([`TriangleBvh::ray_farthest`], [`TriangleBvh::ray_farthest_batch`]), and projected
//!   contour segments are intersected with projected mesh edges in 2D ([`SegmentSlabs`], with
//!   the answers of the general [`SegmentTree2`]);
//! - **ball testing** (method A, §4.4.1): points within a radius ([`PointTree`]);
//! - **quality measures and `squish info`**: self-intersecting faces ([`self_intersections`]),
//!   inside/outside and penetration depth ([`TriangleBvh::winding_number`],
//!   [`penetration_depths`]).
//!
//! Robustness: crossing decisions are exact (Shewchuk's predicates) and degenerate cases (a
//! segment through a mesh edge or vertex, an endpoint exactly on a face) are resolved by a
//! symbolic perturbation of the query, so crossings are never missed nor double counted (the
//! rule is stated on [`TriangleBvh::segment_hits`] and derived in `exact.rs`). Results are
//! deterministic: the tree build is deterministic, hit lists are sorted, ties are broken by face
//! id, and batch queries return their results in input order whatever the number of threads.

mod aabb_tree;
mod batch;
mod bvh;
mod closest;
mod exact;
mod flat_bvh;
mod joint;
mod obb_tree;
mod queries;
mod segment_slabs;
mod self_intersection;
#[cfg(test)]
pub(crate) mod test_meshes;
mod tri_tri;
mod winding;

pub use aabb_tree::{AabbTree, PointTree, ProjectionPlane, Segment2Hit, SegmentTree2};
pub use batch::{Batch, BatchHits};
pub use bvh::TriangleBvh;
pub use closest::closest_point_on_triangle;
pub(crate) use flat_bvh::{FlatBvh, Visit};
pub use joint::{EdgeCrossings, EdgeSource, mutual_edge_crossings};
pub use queries::{ClosestPoint, CrossingHint, Hit, Ray};
pub use segment_slabs::SegmentSlabs;
pub use self_intersection::{
    IntersectingPairs, PAIRS_PER_FACE, SelfIntersections, all_self_intersecting_pairs, faces_of_pairs,
    mesh_intersections, self_intersecting_faces, self_intersecting_faces_after, self_intersecting_pairs,
    self_intersections,
};
pub use tri_tri::{intersection_length, triangles_intersect, triangles_intersect_away_from_shared};
pub use winding::{
    FastWinding, OwnedFastWinding, WindingClusters, generalized_winding_number, penetration_depths, solid_angle,
};

use crate::mesh::MeshError;

/// What is wrong with the input of a spatial structure.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SpatialError {
    #[error(transparent)]
    Mesh(#[from] MeshError),
    #[error("face {face} is out of range: the mesh has {faces} faces")]
    FaceOutOfRange { face: u32, faces: usize },
    #[error("got {got} positions to refit a tree built over {expected}; refit with the same mesh's vertices")]
    PositionCount { expected: usize, got: usize },
    #[error("box {index} is not finite or has min > max ({min:?} .. {max:?})")]
    InvalidBox { index: usize, min: [f64; 3], max: [f64; 3] },
    #[error("got {got} items to refit a tree built over {expected}")]
    ItemCount { expected: usize, got: usize },
    #[error(
        "the mesh is not closed ({boundary_edges} boundary edges): inside/outside is undefined; close its holes first"
    )]
    NotClosed { boundary_edges: usize },
}
