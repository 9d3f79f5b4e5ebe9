//! Indexed triangle meshes in `f64`, their topology, geometry and sub-meshes (working regions).
//!
//! Every stage of the pipeline (thesis ch. 4–6) works on a [`TriMesh`] or on a [`SubMesh`], the
//! working region 𝒲 of §4 ("we work on a set of open subsets 𝒲_l"), which keeps the maps to and
//! from the parent mesh's vertex ids so results can be written back into the full object.
//!
//! Conventions:
//! - positions are `glam::DVec3`, triangles are `[u32; 3]`, counter-clockwise seen from outside
//!   (outward normals by the right-hand rule, positive signed volume for a closed mesh);
//! - edge `k` of a triangle `[a, b, c]` joins corners `k` and `k + 1 (mod 3)`.

mod geometry;
mod region;
mod submesh;
mod topology;

pub mod shapes;

pub use geometry::{
    Aabb3, bounding_box, face_areas, face_normal_unnormalized, face_normals, mean_edge_length, signed_volume,
    signed_volume_of, triangle_area, vertex_areas, vertex_centroid, vertex_normals,
};
pub use region::{
    close_pinches, cut_border, edge_path_distance_bound, edge_path_distance_field, edge_path_distances,
    face_set_pieces, region_vertex_normals,
};
pub use submesh::{NOT_IN_SUBMESH, SubMesh};
pub(crate) use topology::faces_around_vertices;
pub use topology::{NO_FACE, Topology};

use glam::DVec3;

/// A triangle mesh: vertex positions and counter-clockwise triangles indexing them.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TriMesh {
    /// Vertex positions.
    pub positions: Vec<DVec3>,
    /// Triangles as three vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

/// What is wrong with a mesh. Every variant names the element at fault so that a user can find it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshError {
    #[error("the mesh is empty ({vertices} vertices, {triangles} triangles); give a mesh with at least one triangle")]
    Empty { vertices: usize, triangles: usize },
    #[error(
        "triangle {triangle} refers to vertex {index}, but the mesh has only {vertices} vertices (valid indices are 0..{vertices})"
    )]
    IndexOutOfRange { triangle: usize, index: u64, vertices: usize },
    #[error("vertex {vertex} has a non-finite coordinate ({value}); every coordinate must be a finite number")]
    NonFiniteCoordinate { vertex: usize, value: f64 },
    #[error(
        "triangle {triangle} is degenerate ({reason}); remove it or clean the mesh (e.g. merge by distance) before deforming"
    )]
    DegenerateTriangle { triangle: usize, reason: String },
    #[error(
        "edge ({v0}, {v1}) is shared by {faces} triangles; a manifold mesh has at most 2 per edge (split or clean the mesh)"
    )]
    NonManifoldEdge { v0: u32, v1: u32, faces: usize },
    #[error("vertex {vertex} is non-manifold: its triangles form {fans} separate fans; split it into {fans} vertices")]
    NonManifoldVertex { vertex: u32, fans: usize },
    #[error("triangles {t0} and {t1} have opposite orientations across edge ({v0}, {v1}); make the winding consistent")]
    InconsistentOrientation { t0: usize, t1: usize, v0: u32, v1: u32 },
}

impl TriMesh {
    /// Builds a mesh after checking the structural invariants that no later code could survive:
    /// at least one triangle, indices in range, finite coordinates.
    pub fn new(positions: Vec<DVec3>, triangles: Vec<[u32; 3]>) -> Result<Self, MeshError> {
        let mesh = Self { positions, triangles };
        mesh.check_structure()?;
        Ok(mesh)
    }

    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn num_triangles(&self) -> usize {
        self.triangles.len()
    }

    /// The three corner positions of triangle `t`.
    #[inline]
    pub fn corners(&self, t: usize) -> [DVec3; 3] {
        let [a, b, c] = self.triangles[t];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Checks non-emptiness, index ranges and finite coordinates.
    pub fn check_structure(&self) -> Result<(), MeshError> {
        if self.triangles.is_empty() || self.positions.is_empty() {
            return Err(MeshError::Empty { vertices: self.positions.len(), triangles: self.triangles.len() });
        }
        let n = self.positions.len();
        for (t, tri) in self.triangles.iter().enumerate() {
            for &i in tri {
                if i as usize >= n {
                    return Err(MeshError::IndexOutOfRange { triangle: t, index: i as u64, vertices: n });
                }
            }
        }
        for (v, p) in self.positions.iter().enumerate() {
            for value in p.to_array() {
                if !value.is_finite() {
                    return Err(MeshError::NonFiniteCoordinate { vertex: v, value });
                }
            }
        }
        Ok(())
    }

    /// Checks everything the deformation pipeline relies on: [`Self::check_structure`], no
    /// degenerate triangle, edge- and vertex-manifoldness and a consistent orientation.
    ///
    /// A triangle is degenerate when two of its indices are equal or when its area is below
    /// `1e-12` times the square of its longest edge (its smallest angle is then below ~1e-12 rad,
    /// and cotangent weights would overflow).
    pub fn check_for_deformation(&self) -> Result<Topology, MeshError> {
        self.check_structure()?;
        for t in 0..self.triangles.len() {
            if let Some(reason) = self.degeneracy(t) {
                return Err(MeshError::DegenerateTriangle { triangle: t, reason });
            }
        }
        let topology = Topology::new(self);
        topology.check_manifold(self)?;
        Ok(topology)
    }

    /// Why triangle `t` is degenerate, or `None` if it is not.
    pub fn degeneracy(&self, t: usize) -> Option<String> {
        let [a, b, c] = self.triangles[t];
        if a == b || b == c || a == c {
            return Some(format!("it repeats a vertex: [{a}, {b}, {c}]"));
        }
        let [p0, p1, p2] = self.corners(t);
        let longest = (p1 - p0).length_squared().max((p2 - p1).length_squared()).max((p0 - p2).length_squared());
        let twice_area = (p1 - p0).cross(p2 - p0).length();
        if longest == 0.0 || twice_area <= 1e-12 * longest {
            return Some(format!(
                "its area {:.3e} is zero for its longest edge {:.3e}",
                0.5 * twice_area,
                longest.sqrt()
            ));
        }
        None
    }

    /// Applies `f` to every position.
    pub fn map_positions(&mut self, f: impl Fn(DVec3) -> DVec3) {
        for p in &mut self.positions {
            *p = f(*p);
        }
    }

    /// Appends another mesh (its vertices after ours), e.g. to assemble a scene for rendering.
    pub fn append(&mut self, other: &TriMesh) {
        let offset = self.positions.len() as u32;
        self.positions.extend_from_slice(&other.positions);
        self.triangles.extend(other.triangles.iter().map(|t| [t[0] + offset, t[1] + offset, t[2] + offset]));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tetrahedron() -> TriMesh {
        TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y, DVec3::Z], vec![[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
            .expect("valid tetrahedron")
    }

    #[test]
    fn empty_mesh_is_an_error() {
        assert!(matches!(TriMesh::new(vec![], vec![]), Err(MeshError::Empty { .. })));
        assert!(matches!(TriMesh::new(vec![DVec3::ZERO], vec![]), Err(MeshError::Empty { .. })));
    }

    #[test]
    fn out_of_range_index_names_the_triangle() {
        let err = TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::Y], vec![[0, 1, 2], [0, 1, 7]]).unwrap_err();
        assert_eq!(err, MeshError::IndexOutOfRange { triangle: 1, index: 7, vertices: 3 });
        assert!(err.to_string().contains("triangle 1"));
    }

    #[test]
    fn non_finite_coordinate_names_the_vertex() {
        let err =
            TriMesh::new(vec![DVec3::ZERO, DVec3::new(f64::NAN, 0.0, 0.0), DVec3::Y], vec![[0, 1, 2]]).unwrap_err();
        assert!(matches!(err, MeshError::NonFiniteCoordinate { vertex: 1, .. }));
        let err = TriMesh::new(vec![DVec3::ZERO, DVec3::X, DVec3::new(0.0, f64::INFINITY, 0.0)], vec![[0, 1, 2]])
            .unwrap_err();
        assert!(matches!(err, MeshError::NonFiniteCoordinate { vertex: 2, .. }));
    }

    #[test]
    fn degenerate_triangles_are_reported() {
        let mut mesh = tetrahedron();
        mesh.positions[3] = DVec3::new(0.5, 0.5, 0.0); // 1, 2, 3 collinear
        let err = mesh.check_for_deformation().unwrap_err();
        assert!(matches!(err, MeshError::DegenerateTriangle { triangle: 2, .. }), "{err}");
        let mut mesh = tetrahedron();
        mesh.triangles[1] = [0, 1, 1];
        assert!(matches!(mesh.check_for_deformation(), Err(MeshError::DegenerateTriangle { triangle: 1, .. })));
    }

    #[test]
    fn valid_tetrahedron_passes_all_checks() {
        let topology = tetrahedron().check_for_deformation().expect("tetrahedron is fine");
        assert!(topology.is_closed());
    }
}
