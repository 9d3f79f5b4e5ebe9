//! Closest point on a triangle, with its barycentric coordinates.
//!
//! Used by [`super::TriangleBvh::closest_point`] (penetration depth for the "clean contact"
//! quality measure, and any projection onto the opposite surface). The point is located by the
//! Voronoi region of the triangle it falls in (three vertices, three edges, the face), decided
//! from dot products with the edge vectors, so the barycentric coordinates are exactly 0 on the
//! coordinates that do not matter (e.g. `[1, 0, 0]` at a vertex).

use glam::DVec3;

use crate::stage::Work;

/// Closest point of the triangle `t` to `p`, as barycentric coordinates on `t` (non-negative,
/// summing to 1). Degenerate (zero-area) triangles are handled as their longest edge.
pub fn closest_point_on_triangle(p: DVec3, t: &[DVec3; 3]) -> [f64; 3] {
    Work::count_triangle_tests(1);
    let [a, b, c] = *t;
    let ab = b - a;
    let ac = c - a;
    let ap = p - a;
    let d1 = ab.dot(ap);
    let d2 = ac.dot(ap);
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let d3 = ab.dot(bp);
    let d4 = ac.dot(bp);
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    // vc, vb, va are the (scaled) barycentric coordinates of the projection of p on the plane.
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let denom = d1 - d3;
        if denom > 0.0 {
            let v = d1 / denom;
            return [1.0 - v, v, 0.0];
        }
        return degenerate(p, t);
    }
    let cp = p - c;
    let d5 = ab.dot(cp);
    let d6 = ac.dot(cp);
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let denom = d2 - d6;
        if denom > 0.0 {
            let w = d2 / denom;
            return [1.0 - w, 0.0, w];
        }
        return degenerate(p, t);
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let denom = (d4 - d3) + (d5 - d6);
        if denom > 0.0 {
            let w = (d4 - d3) / denom;
            return [0.0, 1.0 - w, w];
        }
        return degenerate(p, t);
    }
    let sum = va + vb + vc;
    if sum.is_nan() || sum <= 0.0 {
        return degenerate(p, t);
    }
    let v = vb / sum;
    let w = vc / sum;
    [1.0 - v - w, v, w]
}

/// Closest point on the three edges (for zero-area triangles, where the face region is empty).
fn degenerate(p: DVec3, t: &[DVec3; 3]) -> [f64; 3] {
    let mut best = [1.0, 0.0, 0.0];
    let mut best_d = (p - t[0]).length_squared();
    for k in 0..3 {
        let (i, j) = (k, (k + 1) % 3);
        let e = t[j] - t[i];
        let len2 = e.length_squared();
        let s = if len2 > 0.0 { ((p - t[i]).dot(e) / len2).clamp(0.0, 1.0) } else { 0.0 };
        let d = (p - (t[i] + s * e)).length_squared();
        if d < best_d {
            best_d = d;
            best = [0.0; 3];
            best[i] = 1.0 - s;
            best[j] = s;
        }
    }
    best
}

/// The point with barycentric coordinates `bary` on the triangle `t`.
#[inline]
pub(crate) fn barycentric_point(t: &[DVec3; 3], bary: [f64; 3]) -> DVec3 {
    t[0] * bary[0] + t[1] * bary[1] + t[2] * bary[2]
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;

    /// Brute force: the best of a fine barycentric grid.
    fn sampled_distance(p: DVec3, t: &[DVec3; 3]) -> f64 {
        let n = 200;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=n - i {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                best = best.min((barycentric_point(t, [1.0 - u - v, u, v]) - p).length());
            }
        }
        best
    }

    #[test]
    fn closest_point_is_no_farther_than_any_sample_and_close_to_the_best() {
        let t = [DVec3::new(0.0, 0.0, 0.0), DVec3::new(2.0, 0.1, 0.0), DVec3::new(0.5, 1.5, 0.3)];
        let mut lcg = Lcg::from_state(7);
        let mut rnd = || lcg.next_unit() * 6.0 - 3.0;
        for _ in 0..300 {
            let p = DVec3::new(rnd(), rnd(), rnd());
            let bary = closest_point_on_triangle(p, &t);
            assert!(bary.iter().all(|&b| (0.0..=1.0).contains(&b)));
            assert!((bary.iter().sum::<f64>() - 1.0).abs() < 1e-14);
            let d = (barycentric_point(&t, bary) - p).length();
            let sampled = sampled_distance(p, &t);
            assert!(d <= sampled + 1e-12 && d > sampled - 0.02, "{d} vs {sampled}");
        }
    }

    #[test]
    fn vertex_and_edge_regions_are_exact() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        assert_eq!(closest_point_on_triangle(DVec3::new(-1.0, -1.0, 2.0), &t), [1.0, 0.0, 0.0]);
        assert_eq!(closest_point_on_triangle(DVec3::new(0.5, -1.0, 0.0), &t), [0.5, 0.5, 0.0]);
        let inside = closest_point_on_triangle(DVec3::new(0.25, 0.25, 5.0), &t);
        assert!((inside[1] - 0.25).abs() < 1e-15 && (inside[2] - 0.25).abs() < 1e-15);
        // Degenerate: collinear corners.
        let flat = [DVec3::ZERO, DVec3::X, DVec3::new(2.0, 0.0, 0.0)];
        let bary = closest_point_on_triangle(DVec3::new(1.5, 1.0, 0.0), &flat);
        assert!((barycentric_point(&flat, bary) - DVec3::new(1.5, 0.0, 0.0)).length() < 1e-15);
    }
}
