//! Test fixtures for the contact stages: working regions that own their mesh, topology, normals
//! and tree; the sphere-in-a-plane scene; exact mirror images and rigid motions.

use glam::{DMat3, DVec3};

use super::{ContactSide, Stiffness};
use crate::mesh::{Topology, TriMesh, shapes, vertex_normals};
use crate::spatial::TriangleBvh;

/// A working region with everything a [`ContactSide`] borrows.
pub struct Owned {
    pub mesh: TriMesh,
    pub topology: Topology,
    pub normals: Vec<DVec3>,
    pub bvh: TriangleBvh,
    pub stiffness: Stiffness,
}

impl Owned {
    /// The mesh translated by `offset`.
    pub fn new(mut mesh: TriMesh, offset: DVec3) -> Self {
        mesh.map_positions(|p| p + offset);
        let topology = Topology::new(&mesh);
        let normals = vertex_normals(&mesh);
        let bvh = TriangleBvh::new(&mesh).unwrap();
        Self { mesh, topology, normals, bvh, stiffness: Stiffness::default() }
    }

    pub fn with_stiffness(mut self, stiffness: Stiffness) -> Self {
        self.stiffness = stiffness;
        self
    }

    /// A copy with another stiffness.
    pub fn clone_with(&self, stiffness: Stiffness) -> Self {
        Self {
            mesh: self.mesh.clone(),
            topology: self.topology.clone(),
            normals: self.normals.clone(),
            bvh: self.bvh.clone(),
            stiffness,
        }
    }

    pub fn side(&self) -> ContactSide<'_> {
        ContactSide::new(&self.mesh, &self.topology, &self.normals, &self.bvh).with_stiffness(self.stiffness)
    }

    /// Moves the mesh and refits (normals of a translated mesh do not change).
    pub fn translate(&mut self, offset: DVec3) {
        self.mesh.map_positions(|p| p + offset);
        self.bvh.refit(&self.mesh.positions).unwrap();
    }

    /// A rigid motion x ↦ R x + t, with normals recomputed and the tree rebuilt.
    pub fn transformed(&self, rotation: DMat3, translation: DVec3) -> Self {
        let mut mesh = self.mesh.clone();
        mesh.map_positions(|p| rotation * p + translation);
        Self::new(mesh, DVec3::ZERO).with_stiffness(self.stiffness)
    }

    /// The image under a linear map `m` (e.g. a mirror), with vertex i ↦ vertex i. An improper
    /// map (det < 0) turns triangles inside out: their orientation is then fixed by swapping two
    /// corners, so that the image is again outward-oriented.
    pub fn image(&self, m: DMat3) -> Self {
        let mut mesh = self.mesh.clone();
        mesh.map_positions(|p| m * p);
        if m.determinant() < 0.0 {
            for t in &mut mesh.triangles {
                t.swap(1, 2);
            }
        }
        Self::new(mesh, DVec3::ZERO).with_stiffness(self.stiffness)
    }
}

/// A unit icosphere (subdivision `level`) whose bottom is `h` below a 3 × 3 grid of `n` × `n`
/// cells at z = 0, sphere centre at (0.013, −0.021, 1 − h) (off the grid's symmetry axes).
/// Returns (sphere, grid).
pub fn sphere_in_grid(h: f64, level: u32, n: u32) -> (Owned, Owned) {
    let sphere = Owned::new(shapes::icosphere(1.0, level), sphere_center(h));
    let grid = Owned::new(shapes::grid(3.0, 3.0, n, n), DVec3::ZERO);
    (sphere, grid)
}

/// Centre of the sphere of [`sphere_in_grid`].
pub fn sphere_center(h: f64) -> DVec3 {
    DVec3::new(0.013, -0.021, 1.0 - h)
}

/// Distance from `p` to the mesh of `o`.
pub fn distance_to(o: &Owned, p: DVec3) -> f64 {
    o.bvh.closest_point(p).map_or(f64::INFINITY, |c| c.distance)
}
