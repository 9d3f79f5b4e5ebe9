//! Geometric quantities of a triangle mesh: face normals and areas, area-weighted vertex
//! normals, lumped vertex areas, signed volume, bounding box and mean edge length.

use glam::DVec3;

use super::{Topology, TriMesh};

/// Twice the area times the unit normal of the triangle `(a, b, c)` (right-hand rule).
#[inline]
pub fn face_normal_unnormalized(a: DVec3, b: DVec3, c: DVec3) -> DVec3 {
    (b - a).cross(c - a)
}

/// Area of the triangle `(a, b, c)`.
#[inline]
pub fn triangle_area(a: DVec3, b: DVec3, c: DVec3) -> f64 {
    0.5 * face_normal_unnormalized(a, b, c).length()
}

/// Unit face normals (zero for a degenerate face).
pub fn face_normals(mesh: &TriMesh) -> Vec<DVec3> {
    (0..mesh.num_triangles())
        .map(|t| {
            let [a, b, c] = mesh.corners(t);
            face_normal_unnormalized(a, b, c).normalize_or_zero()
        })
        .collect()
}

/// Face areas.
pub fn face_areas(mesh: &TriMesh) -> Vec<f64> {
    (0..mesh.num_triangles())
        .map(|t| {
            let [a, b, c] = mesh.corners(t);
            triangle_area(a, b, c)
        })
        .collect()
}

/// Area-weighted unit vertex normals: the normalized sum of the incident faces' area vectors.
/// A vertex with no face (or whose faces cancel) gets a zero normal.
pub fn vertex_normals(mesh: &TriMesh) -> Vec<DVec3> {
    let mut normals = vec![DVec3::ZERO; mesh.num_vertices()];
    for t in &mesh.triangles {
        let n = face_normal_unnormalized(
            mesh.positions[t[0] as usize],
            mesh.positions[t[1] as usize],
            mesh.positions[t[2] as usize],
        );
        for &v in t {
            normals[v as usize] += n;
        }
    }
    for n in &mut normals {
        *n = n.normalize_or_zero();
    }
    normals
}

/// Lumped (barycentric) vertex areas: one third of the area of the incident faces, the
/// diagonal of the lumped mass matrix.
pub fn vertex_areas(mesh: &TriMesh) -> Vec<f64> {
    let mut areas = vec![0.0; mesh.num_vertices()];
    for t in 0..mesh.num_triangles() {
        let [a, b, c] = mesh.corners(t);
        let third = triangle_area(a, b, c) / 3.0;
        for &v in &mesh.triangles[t] {
            areas[v as usize] += third;
        }
    }
    areas
}

/// Signed volume enclosed by the mesh: Σ_f det(p0, p1, p2) / 6 (positive for a closed mesh with
/// outward normals). On an open mesh this is the volume of the cone from the origin.
///
/// The sum is taken relative to the first vertex rather than the origin, which gives the same
/// value on a closed mesh but with far less cancellation for meshes away from the origin.
pub fn signed_volume(mesh: &TriMesh) -> f64 {
    signed_volume_of(&mesh.positions, &mesh.triangles)
}

/// [`signed_volume`] of the mesh made of `positions` and `triangles`, for positions held apart
/// from their mesh (no copy). Triangles must index `positions`.
pub fn signed_volume_of(positions: &[DVec3], triangles: &[[u32; 3]]) -> f64 {
    let Some(&o) = positions.first() else { return 0.0 };
    let mut sum = 0.0;
    for triangle in triangles {
        let [a, b, c] = triangle.map(|v| positions[v as usize]);
        sum += (a - o).dot((b - o).cross(c - o));
    }
    sum / 6.0
}

/// An axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Aabb3 {
    pub min: DVec3,
    pub max: DVec3,
}

impl Aabb3 {
    /// The empty box (min = +∞, max = −∞), neutral for [`Self::grow`].
    pub const EMPTY: Self = Self { min: DVec3::INFINITY, max: DVec3::NEG_INFINITY };

    /// Smallest box holding `points`.
    pub fn from_points(points: impl IntoIterator<Item = DVec3>) -> Self {
        let mut b = Self::EMPTY;
        for p in points {
            b.grow(p);
        }
        b
    }

    /// Extends the box to hold `p`.
    #[inline]
    pub fn grow(&mut self, p: DVec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// Box size along each axis.
    pub fn extent(&self) -> DVec3 {
        self.max - self.min
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f64 {
        self.extent().length()
    }

    /// Centre of the box.
    pub fn center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }

    /// Squared Euclidean distance from `p` to the box: 0 inside it, +∞ to the empty box.
    #[inline]
    pub fn distance_squared_to(&self, p: DVec3) -> f64 {
        (self.min - p).max(p - self.max).max(DVec3::ZERO).length_squared()
    }

    /// Euclidean distance from `p` to the box: 0 inside it, +∞ to the empty box.
    pub fn distance_to(&self, p: DVec3) -> f64 {
        self.distance_squared_to(p).sqrt()
    }

    /// True if the boxes overlap (touching counts).
    pub fn intersects(&self, other: &Self) -> bool {
        self.min.cmple(other.max).all() && other.min.cmple(self.max).all()
    }
}

/// The mean of the points (0 for none): the reference point of volume figures, the centre of a
/// vertex set.
pub fn vertex_centroid(positions: &[DVec3]) -> DVec3 {
    positions.iter().fold(DVec3::ZERO, |s, p| s + *p) / positions.len().max(1) as f64
}

/// Bounding box of the mesh's vertices.
pub fn bounding_box(mesh: &TriMesh) -> Aabb3 {
    Aabb3::from_points(mesh.positions.iter().copied())
}

/// Mean length of the unique edges (the `h` of the heat method's time step t = 10h², §5.1).
pub fn mean_edge_length(mesh: &TriMesh, topology: &Topology) -> f64 {
    let edges = topology.edges();
    if edges.is_empty() {
        return 0.0;
    }
    let total: f64 =
        edges.iter().map(|&[a, b]| (mesh.positions[a as usize] - mesh.positions[b as usize]).length()).sum();
    total / edges.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes;
    use std::f64::consts::PI;

    #[test]
    fn icosphere_volume_converges_to_four_thirds_pi() {
        let exact = 4.0 * PI / 3.0;
        let mut previous_error = f64::INFINITY;
        for level in 1..=6 {
            let mesh = shapes::icosphere(1.0, level);
            let error = (signed_volume(&mesh) - exact).abs();
            // Inscribed polyhedron: the volume is below the sphere's, and the error shrinks by
            // about 4× per subdivision (it is O(h²)).
            assert!(signed_volume(&mesh) < exact);
            assert!(error < previous_error / 3.5, "level {level}: {error} vs {previous_error}");
            previous_error = error;
        }
        assert!(previous_error < 2e-3 * exact, "{previous_error}");
    }

    #[test]
    fn volume_is_translation_invariant_and_flips_with_orientation() {
        let mut mesh = shapes::icosphere(2.0, 3);
        let v = signed_volume(&mesh);
        mesh.map_positions(|p| p + DVec3::new(1e4, -3e3, 7e3));
        assert!((signed_volume(&mesh) - v).abs() < 1e-9 * v);
        for t in &mut mesh.triangles {
            t.swap(1, 2);
        }
        assert!((signed_volume(&mesh) + v).abs() < 1e-9 * v);
    }

    #[test]
    fn sphere_vertex_normals_point_radially() {
        let mesh = shapes::icosphere(1.0, 3);
        for (p, n) in mesh.positions.iter().zip(vertex_normals(&mesh)) {
            assert!(n.dot(p.normalize()) > 0.999, "{p} {n}");
        }
    }

    #[test]
    fn vertex_areas_sum_to_total_area() {
        let mesh = shapes::cube(2.0, 4);
        let total: f64 = face_areas(&mesh).iter().sum();
        assert!((total - 24.0).abs() < 1e-12);
        assert!((vertex_areas(&mesh).iter().sum::<f64>() - total).abs() < 1e-12);
    }
}
