//! Per-face gradient and per-vertex integrated divergence, the two discrete operators of the heat
//! method (Crane, Weischedel, Wardetzky 2013) used by the parametrization of thesis §5.1.
//!
//! Conventions, chosen so that `div(grad u) = −K u` exactly (up to round-off) with the positive
//! semi-definite stiffness `K` of [`super::cotangent_stiffness`] and the same face weights:
//! - `grad u` on face `f` is the gradient of the piecewise-linear interpolant,
//!   `Σ_k u_k (N × e_k) / (2A)` with `e_k` the edge opposite corner `k` (counter-clockwise);
//! - the integrated divergence at vertex `i` is Crane et al.'s
//!   `½ Σ_f w_f [cot θ_1 (e_1 · X_f) + cot θ_2 (e_2 · X_f)]`, with `e_1`, `e_2` the edges of `f`
//!   leaving `i` and `θ_1`, `θ_2` the angles opposite them. For `X = grad u`, `e·X` is the
//!   difference of `u` along the edge, so this is `½ Σ cot (u_j − u_i) = −(K u)_i`.
//!
//! Hence the heat method's Poisson step `Δφ = ∇·X` reads `K φ = −div X` here. Faces cut by the
//! domain boundary use the same weights `w_f` as the stiffness (§5.1: "we reuse the same adjusted
//! cotangent weights to compute the integrated divergences").

use glam::DVec3;

use super::SolveError;
use super::laplacian::{check_face_weights, face_cotangents, face_weight};
use crate::mesh::TriMesh;

/// Gradient of the piecewise-linear function with vertex values `values`, one vector per face
/// (tangent to the face). A degenerate face (zero area) gets a zero gradient.
pub fn face_gradients(mesh: &TriMesh, values: &[f64]) -> Result<Vec<DVec3>, SolveError> {
    if values.len() != mesh.num_vertices() {
        return Err(SolveError::DimensionMismatch {
            what: "vertex values",
            expected: mesh.num_vertices(),
            actual: values.len(),
        });
    }
    Ok(mesh
        .triangles
        .iter()
        .enumerate()
        .map(|(f, tri)| {
            let p = mesh.corners(f);
            let normal = (p[1] - p[0]).cross(p[2] - p[0]);
            let norm_squared = normal.length_squared();
            if norm_squared.is_nan() || norm_squared <= 0.0 {
                return DVec3::ZERO;
            }
            // With the unnormalized normal (length 2A): ∇φ_k = normal × e_k / (2A)².
            let mut g = DVec3::ZERO;
            for k in 0..3 {
                let opposite_edge = p[(k + 2) % 3] - p[(k + 1) % 3];
                g += values[tri[k] as usize] * normal.cross(opposite_edge);
            }
            g / norm_squared
        })
        .collect())
}

/// Integrated divergence of the per-face vector field `field` at every vertex, with optional face
/// weights (`None` = all 1), in the convention `div(grad u) = −K u` (see the module doc).
pub fn integrated_divergence(
    mesh: &TriMesh,
    field: &[DVec3],
    face_weights: Option<&[f64]>,
) -> Result<Vec<f64>, SolveError> {
    if field.len() != mesh.num_triangles() {
        return Err(SolveError::DimensionMismatch {
            what: "face vectors",
            expected: mesh.num_triangles(),
            actual: field.len(),
        });
    }
    check_face_weights(face_weights, mesh.num_triangles())?;
    let mut div = vec![0.0; mesh.num_vertices()];
    for (f, tri) in mesh.triangles.iter().enumerate() {
        let w = face_weight(face_weights, f);
        if w == 0.0 {
            continue;
        }
        let p = mesh.corners(f);
        let (cot, _) = face_cotangents(p, f)?;
        let x = field[f];
        for k in 0..3 {
            let (k1, k2) = ((k + 1) % 3, (k + 2) % 3);
            // Edge to corner k1 is opposite corner k2, and vice versa.
            let along_1 = (p[k1] - p[k]).dot(x);
            let along_2 = (p[k2] - p[k]).dot(x);
            div[tri[k] as usize] += 0.5 * w * (cot[k2] * along_1 + cot[k1] * along_2);
        }
    }
    Ok(div)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::{Lcg, cut_icosphere};
    use crate::linalg::{SparsePattern, cotangent_stiffness};
    use crate::mesh::{Topology, shapes};

    #[test]
    fn gradient_of_a_linear_function_is_exact() {
        let mut mesh = shapes::icosphere(1.0, 2);
        mesh.map_positions(|p| DVec3::new(p.x, p.y, 0.0) + 0.1 * p); // squash, still non-degenerate
        let grid = shapes::grid(2.0, 1.5, 5, 4);
        let g = DVec3::new(2.0, -3.0, 0.0);
        let values: Vec<f64> = grid.positions.iter().map(|p| g.dot(*p) + 1.0).collect();
        for grad in face_gradients(&grid, &values).unwrap() {
            assert!((grad - g).length() < 1e-12);
        }
        // On a curved mesh the gradient is the tangential part of a linear field's gradient.
        let g3 = DVec3::new(0.3, -1.0, 2.0);
        let values: Vec<f64> = mesh.positions.iter().map(|p| g3.dot(*p)).collect();
        let grads = face_gradients(&mesh, &values).unwrap();
        for (f, grad) in grads.iter().enumerate() {
            let [a, b, c] = mesh.corners(f);
            let n = (b - a).cross(c - a).normalize();
            let tangential = g3 - n * n.dot(g3);
            assert!((*grad - tangential).length() < 1e-10, "{grad} vs {tangential}");
        }
    }

    #[test]
    fn divergence_of_gradient_is_minus_stiffness() {
        let check = |mesh: &TriMesh, weights: Option<&[f64]>, seed: u64| {
            let topology = Topology::new(mesh);
            let pattern = SparsePattern::shared(mesh, &topology).unwrap();
            let k = cotangent_stiffness(mesh, &pattern, weights).unwrap();
            let mut rng = Lcg::new(seed);
            let u: Vec<f64> = (0..mesh.num_vertices()).map(|_| rng.next_signed()).collect();
            let div = integrated_divergence(mesh, &face_gradients(mesh, &u).unwrap(), weights).unwrap();
            let ku = k.apply(&u).unwrap();
            let scale = ku.iter().fold(0.0f64, |m, x| m.max(x.abs()));
            for (v, (d, kv)) in div.iter().zip(&ku).enumerate() {
                assert!((d + kv).abs() < 1e-12 * scale, "vertex {v}: div grad u = {d}, −Ku = {}", -kv);
            }
        };
        check(&shapes::icosphere(1.0, 3), None, 1);
        check(&shapes::capsule(0.4, 1.2, 16, 5, 4), None, 2);
        let (mesh, weights) = cut_icosphere();
        check(&mesh, Some(&weights), 3);
    }

    #[test]
    fn divergence_of_a_constant_field_vanishes_inside_a_flat_region() {
        let mesh = shapes::grid(1.0, 1.0, 6, 6);
        let topology = Topology::new(&mesh);
        let field = vec![DVec3::new(0.7, -0.2, 0.0); mesh.num_triangles()];
        let div = integrated_divergence(&mesh, &field, None).unwrap();
        let boundary = topology.boundary_vertices();
        for (v, d) in div.iter().enumerate() {
            if !boundary[v] {
                assert!(d.abs() < 1e-14);
            }
        }
        // The total is the flux through the boundary, which is zero for a constant field.
        assert!(div.iter().sum::<f64>().abs() < 1e-13);
    }
}
