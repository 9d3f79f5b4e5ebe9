//! Sub-meshes: a working region 𝒲 (thesis §4, §4.5) as a subset of a parent mesh's faces, with
//! the maps between local and parent vertex ids, so that every stage can run on a region and
//! write its result back into the whole object.

use glam::DVec3;

use super::TriMesh;

/// Marks a parent vertex that is not part of the sub-mesh.
pub const NOT_IN_SUBMESH: u32 = u32::MAX;

/// A subset of a parent mesh's faces, re-indexed as a mesh of its own.
#[derive(Clone, Debug)]
pub struct SubMesh {
    /// The region as a mesh; local vertex `i` is parent vertex `parent_vertex[i]`.
    pub mesh: TriMesh,
    /// Local vertex id → parent vertex id.
    pub parent_vertex: Vec<u32>,
    /// Local face id → parent face id.
    pub parent_face: Vec<u32>,
    /// Parent vertex id → local vertex id, or [`NOT_IN_SUBMESH`].
    pub local_vertex: Vec<u32>,
}

impl SubMesh {
    /// The whole mesh as a region (identity maps).
    pub fn whole(parent: &TriMesh) -> Self {
        let n = parent.num_vertices() as u32;
        Self {
            mesh: parent.clone(),
            parent_vertex: (0..n).collect(),
            parent_face: (0..parent.num_triangles() as u32).collect(),
            local_vertex: (0..n).collect(),
        }
    }

    /// The region made of the given parent faces (duplicates are ignored). Local vertices are
    /// numbered in increasing parent id and local faces keep the order of the parent's ids, so
    /// the same face set always gives the same sub-mesh.
    pub fn from_faces(parent: &TriMesh, faces: impl IntoIterator<Item = u32>) -> Self {
        let mut face_ids: Vec<u32> = faces.into_iter().collect();
        face_ids.sort_unstable();
        face_ids.dedup();
        let mut local_vertex = vec![NOT_IN_SUBMESH; parent.num_vertices()];
        for &f in &face_ids {
            for &v in &parent.triangles[f as usize] {
                local_vertex[v as usize] = 0;
            }
        }
        let mut parent_vertex = Vec::new();
        for (v, slot) in local_vertex.iter_mut().enumerate() {
            if *slot != NOT_IN_SUBMESH {
                *slot = parent_vertex.len() as u32;
                parent_vertex.push(v as u32);
            }
        }
        let positions = parent_vertex.iter().map(|&v| parent.positions[v as usize]).collect();
        let triangles =
            face_ids.iter().map(|&f| parent.triangles[f as usize].map(|v| local_vertex[v as usize])).collect();
        Self { mesh: TriMesh { positions, triangles }, parent_vertex, parent_face: face_ids, local_vertex }
    }

    /// The region made of the parent faces whose three vertices are all selected by `mask`.
    pub fn from_vertex_mask(parent: &TriMesh, mask: &[bool]) -> Self {
        let faces = parent
            .triangles
            .iter()
            .enumerate()
            .filter(|(_, t)| t.iter().all(|&v| mask.get(v as usize).copied().unwrap_or(false)))
            .map(|(f, _)| f as u32);
        Self::from_faces(parent, faces)
    }

    /// Number of local vertices.
    pub fn num_vertices(&self) -> usize {
        self.parent_vertex.len()
    }

    /// Copies the parent's current positions into the region (same connectivity, new frame).
    pub fn update_positions(&mut self, parent_positions: &[DVec3]) {
        for (local, &p) in self.mesh.positions.iter_mut().zip(&self.parent_vertex) {
            *local = parent_positions[p as usize];
        }
    }

    /// Writes local values back into a parent-sized array.
    pub fn scatter<T: Copy>(&self, local: &[T], parent: &mut [T]) {
        for (&value, &p) in local.iter().zip(&self.parent_vertex) {
            parent[p as usize] = value;
        }
    }

    /// Reads a parent-sized array at the region's vertices.
    pub fn gather<T: Copy>(&self, parent: &[T]) -> Vec<T> {
        self.parent_vertex.iter().map(|&p| parent[p as usize]).collect()
    }

    /// True if the parent vertex is part of the region.
    pub fn is_in_region(&self, parent_vertex: u32) -> bool {
        self.local_vertex.get(parent_vertex as usize).is_some_and(|&l| l != NOT_IN_SUBMESH)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{Topology, shapes};

    #[test]
    fn maps_round_trip() {
        let parent = shapes::icosphere(1.0, 2);
        // Faces of the upper half.
        let faces = (0..parent.num_triangles() as u32)
            .filter(|&f| parent.triangles[f as usize].iter().all(|&v| parent.positions[v as usize].z > 0.0));
        let sub = SubMesh::from_faces(&parent, faces);
        assert!(sub.num_vertices() > 0 && sub.num_vertices() < parent.num_vertices());
        for (local, &p) in sub.parent_vertex.iter().enumerate() {
            assert_eq!(sub.local_vertex[p as usize], local as u32);
            assert_eq!(sub.mesh.positions[local], parent.positions[p as usize]);
        }
        for (lf, &pf) in sub.parent_face.iter().enumerate() {
            let expected = parent.triangles[pf as usize];
            let got = sub.mesh.triangles[lf].map(|v| sub.parent_vertex[v as usize]);
            assert_eq!(got, expected);
        }
        // The cut makes a disk with one boundary loop.
        let topo = Topology::new(&sub.mesh);
        assert_eq!(topo.boundary_loops(&sub.mesh).len(), 1);
        assert!(topo.is_manifold(&sub.mesh));

        let mut values = vec![0.0; parent.num_vertices()];
        sub.scatter(&vec![1.0; sub.num_vertices()], &mut values);
        assert_eq!(values.iter().filter(|&&x| x == 1.0).count(), sub.num_vertices());
        assert_eq!(sub.gather(&values), vec![1.0; sub.num_vertices()]);
    }

    #[test]
    fn vertex_mask_selects_faces_inside_it() {
        let parent = shapes::grid(2.0, 2.0, 4, 4);
        let mask: Vec<bool> = parent.positions.iter().map(|p| p.x <= 0.0).collect();
        let sub = SubMesh::from_vertex_mask(&parent, &mask);
        assert!(sub.mesh.positions.iter().all(|p| p.x <= 0.0));
        assert_eq!(sub.num_vertices(), 3 * 5);
        assert_eq!(sub.mesh.num_triangles(), 2 * 2 * 4);
    }
}
