//! Faces of a mesh that intersect other faces of the same mesh (self-intersections), and face
//! pairs of two meshes that intersect.
//!
//! The collision detection of thesis §4.1 is correct only for "manifolds with boundaries without
//! self-intersections" (§4.1, Discussion), so `squish info` reports the self-intersecting face
//! count of its inputs. Two faces that share a vertex or an edge always touch there; they are
//! reported only when they intersect elsewhere ([`triangles_intersect_away_from_shared`]: a
//! fold-over across a shared edge, a face piercing a neighbour of its fan). Faces of two different
//! meshes are reported whenever they share a point.
//!
//! Candidates come from the BVH (faces whose boxes overlap); each face queries the tree with its
//! own box in parallel and keeps partners of larger index, so each pair is tested once. Results
//! are sorted.

use rayon::prelude::*;

use super::SpatialError;
use super::bvh::{TriangleBvh, triangle_aabb};
use super::tri_tri::{triangles_intersect, triangles_intersect_away_from_shared};
use crate::mesh::TriMesh;

/// Self-intersections of a mesh.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct SelfIntersections {
    /// Intersecting face pairs `[f, g]`, `f < g`, sorted.
    pub pairs: Vec<[u32; 2]>,
    /// Faces in at least one pair, sorted, without repetition.
    pub faces: Vec<u32>,
}

/// Self-intersections of `mesh` (see the module docs for the rule on adjacent faces).
pub fn self_intersections(mesh: &TriMesh) -> Result<SelfIntersections, SpatialError> {
    Ok(TriangleBvh::new(mesh)?.self_intersections())
}

/// Intersecting face pairs `[face of a, face of b]` of two meshes (touching counts), sorted.
pub fn mesh_intersections(a: &TriMesh, b: &TriMesh) -> Result<Vec<[u32; 2]>, SpatialError> {
    Ok(TriangleBvh::new(a)?.intersections_with(&TriangleBvh::new(b)?))
}

impl TriangleBvh {
    /// Self-intersections of the triangles in this tree (see [`self_intersections`]).
    pub fn self_intersections(&self) -> SelfIntersections {
        let mut pairs: Vec<[u32; 2]> = (0..self.len())
            .into_par_iter()
            .with_min_len(64)
            .fold(Vec::new, |mut found, i| {
                let ti = &self.corners[i];
                let (min, max) = triangle_aabb(ti);
                self.bvh.for_each_in_box(min, max, |j| {
                    let j = j as usize;
                    if j > i && triangles_intersect_away_from_shared(ti, &self.corners[j]) {
                        let (fi, fj) = (self.faces[i], self.faces[j]);
                        found.push([fi.min(fj), fi.max(fj)]);
                    }
                });
                found
            })
            .flatten_iter()
            .collect();
        pairs.par_sort_unstable();
        pairs.dedup();
        let mut faces: Vec<u32> = pairs.iter().flatten().copied().collect();
        faces.par_sort_unstable();
        faces.dedup();
        SelfIntersections { pairs, faces }
    }

    /// Intersecting pairs `[face of self, face of other]` (closed triangles: touching counts),
    /// sorted.
    pub fn intersections_with(&self, other: &TriangleBvh) -> Vec<[u32; 2]> {
        let mut pairs: Vec<[u32; 2]> = (0..self.len())
            .into_par_iter()
            .with_min_len(64)
            .fold(Vec::new, |mut found, i| {
                let ti = &self.corners[i];
                let (min, max) = triangle_aabb(ti);
                other.bvh.for_each_in_box(min, max, |j| {
                    if triangles_intersect(ti, &other.corners[j as usize]) {
                        found.push([self.faces[i], other.faces[j as usize]]);
                    }
                });
                found
            })
            .flatten_iter()
            .collect();
        pairs.par_sort_unstable();
        pairs.dedup();
        pairs
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::mesh::shapes;
    use crate::spatial::test_meshes::bunny;
    use glam::DVec3;

    /// Loads the `v`/`f` lines of an OBJ file (polygons fanned), or `None` if it is absent.
    fn brute_force(mesh: &TriMesh) -> Vec<[u32; 2]> {
        let n = mesh.num_triangles();
        let mut pairs = Vec::new();
        for i in 0..n {
            for j in i + 1..n {
                if triangles_intersect_away_from_shared(&mesh.corners(i), &mesh.corners(j)) {
                    pairs.push([i as u32, j as u32]);
                }
            }
        }
        pairs
    }

    #[test]
    fn clean_closed_meshes_have_no_self_intersection() {
        for mesh in [
            shapes::icosphere(1.0, 4),
            shapes::cube(2.0, 5),
            shapes::capsule(0.5, 2.0, 24, 6, 5),
            shapes::grid(1.0, 1.0, 7, 5),
        ] {
            let found = self_intersections(&mesh).unwrap();
            assert!(found.pairs.is_empty(), "{:?}", &found.pairs[..found.pairs.len().min(5)]);
        }
    }

    #[test]
    fn bunny_has_no_self_intersection() {
        let Some(mesh) = bunny() else {
            return;
        };
        assert!(mesh.num_triangles() > 6000);
        let found = self_intersections(&mesh).unwrap();
        assert_eq!(found.faces.len(), 0, "{:?}", &found.pairs[..found.pairs.len().min(5)]);
    }

    #[test]
    fn two_overlapping_spheres_in_one_mesh_report_exactly_the_crossing_faces() {
        let mut mesh = shapes::icosphere(1.0, 2);
        let mut other = shapes::icosphere(0.8, 2);
        other.map_positions(|p| p + DVec3::new(1.1, 0.2, 0.1));
        mesh.append(&other);
        let found = self_intersections(&mesh).unwrap();
        let expected = brute_force(&mesh);
        assert!(!expected.is_empty());
        assert_eq!(found.pairs, expected);
        // Every pair joins the two spheres, and the faces are those of the pairs.
        let n0 = 320;
        assert!(found.pairs.iter().all(|&[f, g]| f < n0 && g >= n0));
        assert!(found.faces.iter().any(|&f| f < n0) && found.faces.iter().any(|&f| f >= n0));
        // The two-mesh version finds the same pairs.
        let a = shapes::icosphere(1.0, 2);
        let between = mesh_intersections(&a, &other).unwrap();
        let shifted: Vec<[u32; 2]> = between.iter().map(|&[f, g]| [f, g + n0]).collect();
        assert_eq!(shifted, expected);
    }

    #[test]
    fn fold_over_and_duplicate_faces_are_reported() {
        // A grid with one vertex pushed across its neighbours in the plane: the faces around it
        // fold over the adjacent ones.
        let mut mesh = shapes::grid(4.0, 4.0, 4, 4);
        let center = 12; // (2, 2) in a 5 × 5 vertex grid
        assert_eq!(mesh.positions[center], DVec3::ZERO);
        mesh.positions[center] = DVec3::new(1.5, 0.3, 0.0);
        let found = self_intersections(&mesh).unwrap();
        assert_eq!(found.pairs, brute_force(&mesh));
        assert!(!found.pairs.is_empty());
        // The same mesh lifted out of the plane at that vertex is clean (no overlap).
        let mut lifted = shapes::grid(4.0, 4.0, 4, 4);
        lifted.positions[center].z = 0.7;
        assert!(self_intersections(&lifted).unwrap().pairs.is_empty());
        // A duplicated face intersects its twin.
        let mut twin = shapes::icosphere(1.0, 1);
        let t = twin.triangles[3];
        twin.triangles.push(t);
        let found = self_intersections(&twin).unwrap();
        assert!(found.pairs.contains(&[3, twin.num_triangles() as u32 - 1]));
    }
}
