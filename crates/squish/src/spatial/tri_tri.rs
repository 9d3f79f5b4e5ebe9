//! Exact triangle–triangle intersection of closed triangles, and its variant for mesh faces that
//! share vertices.
//!
//! Used to find self-intersecting faces (`squish info`, input validation: the thesis' collision
//! detection assumes "manifolds with boundaries without self-intersections", §4.1, Discussion) and
//! faces of two meshes in contact.
//!
//! Construction (all decisions are signs of exact `orient3d`/`orient2d`):
//! 1. Each triangle's vertices are classified against the other's plane; if all three lie strictly
//!    on one side, the triangles are disjoint (this rejects almost every candidate pair).
//! 2. If both triangles lie in one plane, they are projected on the coordinate plane where that
//!    plane's normal has its largest component (dropping a coordinate is exact, and along that
//!    axis the projection is one-to-one), and the 2D closed triangles are tested: an edge pair
//!    touches, or one triangle contains a vertex of the other.
//! 3. Otherwise the intersection, if any, is a segment of the line where the planes meet; its ends
//!    lie on edges of the triangles, so the triangles intersect iff an edge of one touches the
//!    other (closed segment–triangle tests; an edge lying in the other plane is tested in 2D).
//!
//! Zero-area triangles are handled as the segment (or point) they cover.

use glam::DVec3;

use crate::stage::Work;

use super::exact::{
    cross_exact, lex_less, orient2d, orient3d, project, projection_axis, segment_touches_triangle, segments_touch_3d,
    sign, triangles_touch_2d,
};

/// True if the closed triangles `t1` and `t2` share at least one point (touching counts).
pub fn triangles_intersect(t1: &[DVec3; 3], t2: &[DVec3; 3]) -> bool {
    Work::count_triangle_tests(1);
    intersect(t1, t2)
}

/// [`triangles_intersect`] without counting it (for searches whose number of tests depends on the
/// schedule of their threads, see [`crate::stage::Work`]).
pub(super) fn intersect(t1: &[DVec3; 3], t2: &[DVec3; 3]) -> bool {
    let n1 = cross_exact(t1[0], t1[1], t1[2]);
    let n2 = cross_exact(t2[0], t2[1], t2[2]);
    let degenerate1 = n1 == [0.0; 3];
    let degenerate2 = n2 == [0.0; 3];
    if degenerate1 || degenerate2 {
        return degenerate_case(t1, degenerate1, t2, n2, degenerate2);
    }
    let s1 = t1.map(|p| orient3d(t2[0], t2[1], t2[2], p));
    if same_strict_side(s1) {
        return false;
    }
    let s2 = t2.map(|p| orient3d(t1[0], t1[1], t1[2], p));
    if same_strict_side(s2) {
        return false;
    }
    if s1 == [0.0; 3] {
        return coplanar(t1, t2, n1);
    }
    for k in 0..3 {
        let (i, j) = (k, (k + 1) % 3);
        if segment_touches_triangle(t1[i], t1[j], s1[i], s1[j], t2, n2)
            || segment_touches_triangle(t2[i], t2[j], s2[i], s2[j], t1, n1)
        {
            return true;
        }
    }
    false
}

/// True if mesh faces `t1` and `t2` intersect anywhere other than the vertices or edge they share.
/// Sharing is by position: corners at the same coordinates count as the same vertex (so that
/// unwelded seams are not reported).
///
/// - No shared vertex: [`triangles_intersect`].
/// - One shared vertex `v`: they intersect elsewhere iff the edge of one opposite `v` touches the
///   other triangle (the intersection is convex and contains `v`, so if it holds another point `x`
///   it holds the segment `vx`, and the ray from `v` through `x` leaves the two triangles through
///   their opposite edges; the one it leaves first lies in the other triangle).
/// - A shared edge: non-coplanar faces meet exactly on that edge; coplanar ones overlap iff their
///   third vertices are on the same side of the edge (a fold-over).
/// - Three shared vertices: the faces coincide.
///
/// Zero-area faces are never reported (they are reported as degenerate by mesh validation).
pub fn triangles_intersect_away_from_shared(t1: &[DVec3; 3], t2: &[DVec3; 3]) -> bool {
    Work::count_triangle_tests(1);
    intersect_away_from_shared(t1, t2)
}

/// [`triangles_intersect_away_from_shared`] without counting it (see [`intersect`]).
pub(super) fn intersect_away_from_shared(t1: &[DVec3; 3], t2: &[DVec3; 3]) -> bool {
    !certainly_apart(t1, t2) && intersect_away_from_shared_exactly(t1, t2)
}

/// Two triangles sharing exactly one corner whose wedges there are certainly apart
/// ([`wedges_apart`]): they meet at that corner only.
fn certainly_apart(t1: &[DVec3; 3], t2: &[DVec3; 3]) -> bool {
    let mut shared = None;
    for (i, p) in t1.iter().enumerate() {
        for (j, q) in t2.iter().enumerate() {
            if p == q {
                if shared.is_some() {
                    return false;
                }
                shared = Some((i, j));
            }
        }
    }
    shared.is_some_and(|(i, j)| {
        wedges_apart(t1[i], [t1[(i + 1) % 3], t1[(i + 2) % 3]], [t2[(j + 1) % 3], t2[(j + 2) % 3]])
    })
}

/// [`intersect_away_from_shared`] in exact arithmetic only, without the filter.
fn intersect_away_from_shared_exactly(t1: &[DVec3; 3], t2: &[DVec3; 3]) -> bool {
    let n1 = cross_exact(t1[0], t1[1], t1[2]);
    let n2 = cross_exact(t2[0], t2[1], t2[2]);
    if n1 == [0.0; 3] || n2 == [0.0; 3] {
        return false;
    }
    // shared[i] = index in t2 of the corner equal to t1[i].
    let mut shared = [None; 3];
    let mut count = 0;
    for i in 0..3 {
        shared[i] = (0..3).find(|&j| t1[i] == t2[j]);
        count += shared[i].is_some() as usize;
    }
    match count {
        0 => triangles_intersect(t1, t2),
        1 => {
            let i = (0..3).find(|&i| shared[i].is_some()).unwrap_or(0);
            let j = shared[i].unwrap_or(0);
            let (a1, b1) = (t1[(i + 1) % 3], t1[(i + 2) % 3]);
            let (a2, b2) = (t2[(j + 1) % 3], t2[(j + 2) % 3]);
            let plane2 = |p: DVec3| orient3d(t2[0], t2[1], t2[2], p);
            let plane1 = |p: DVec3| orient3d(t1[0], t1[1], t1[2], p);
            segment_touches_triangle(a1, b1, plane2(a1), plane2(b1), t2, n2)
                || segment_touches_triangle(a2, b2, plane1(a2), plane1(b2), t1, n1)
        }
        2 => {
            let i = (0..3).find(|&i| shared[i].is_none()).unwrap_or(0);
            let j = (0..3).find(|&j| !shared.contains(&Some(j))).unwrap_or(0);
            let (u, v, w1, w2) = (t1[(i + 1) % 3], t1[(i + 2) % 3], t1[i], t2[j]);
            if orient3d(u, v, w1, w2) != 0.0 {
                return false;
            }
            let Some(axis) = projection_axis(n1) else {
                return false;
            };
            let (pu, pv) = (project(u, axis), project(v, axis));
            // Both non-zero: each triangle is non-degenerate and the projection is one-to-one.
            let side1 = sign(orient2d(pu, pv, project(w1, axis)));
            let side2 = sign(orient2d(pu, pv, project(w2, axis)));
            side1 == side2
        }
        _ => true,
    }
}

/// A floating-point filter for two triangles that share exactly the corner `v`, their other
/// corners `first` and `second`: true when they certainly meet at `v` only, false when it cannot
/// tell (the exact test decides then).
///
/// Any common point x ≠ v gives a direction r = x − v in both wedges {s·p + t·q : s, t ≥ 0}
/// spanned at v by the triangles' edges. With the triple product det(a, b) = (a × b)·m for any
/// fixed vector m, det(e, ·) is linear, so a boundary ray e of one wedge leaves that wedge on one
/// closed side (det(q₁, s·p₁ + t·q₁) = −s·det(p₁, q₁)) and, when det(e, ·) has the other sign
/// strictly at both rays of the other wedge, the other wedge strictly on the other side: their
/// only common direction is 0. Each sign is taken only when it exceeds 10⁻¹⁰ of the product of
/// the lengths, far beyond the rounding of the differences and products (≈ 10⁻¹⁵ of it). m is the
/// bisector of the two unit normals (or of one and the other's opposite, for faces folded onto
/// each other), against which both wedges are far from edge-on. Adjacent faces of a smooth
/// surface, nearly coplanar, are where the exact test's orientations are slowest: its adaptive
/// arithmetic runs to full precision there, and this filter answers most of them.
fn wedges_apart(v: DVec3, first: [DVec3; 2], second: [DVec3; 2]) -> bool {
    const MARGIN: f64 = 1e-10;
    let (mut p1, mut q1) = (first[0] - v, first[1] - v);
    let (mut p2, mut q2) = (second[0] - v, second[1] - v);
    let (n1, n2) = (p1.cross(q1), p2.cross(q2));
    let (l1, l2) = (n1.length(), n2.length());
    // Also false for a non-finite corner (every comparison with NaN is false).
    if !(l1 > 0.0 && l2 > 0.0 && l1.is_finite() && l2.is_finite()) {
        return false;
    }
    let (u1, u2) = (n1 / l1, n2 / l2);
    let m = if u1.dot(u2) >= 0.0 { u1 + u2 } else { u1 - u2 };
    let det = |a: DVec3, b: DVec3| a.cross(b).dot(m);
    let scale = m.length();
    let positive = |a: DVec3, b: DVec3| det(a, b) > MARGIN * a.length() * b.length() * scale;
    let negative = |a: DVec3, b: DVec3| det(a, b) < -MARGIN * a.length() * b.length() * scale;
    // Each wedge counter-clockwise about m: det(p, q) > 0.
    if negative(p1, q1) {
        std::mem::swap(&mut p1, &mut q1);
    } else if !positive(p1, q1) {
        return false;
    }
    if negative(p2, q2) {
        std::mem::swap(&mut p2, &mut q2);
    } else if !positive(p2, q2) {
        return false;
    }
    // The lines of the four boundary rays: the wedge of q (p) lies on its det(q, ·) ≤ 0
    // (det(p, ·) ≥ 0) side.
    (positive(q1, p2) && positive(q1, q2))
        || (negative(p1, p2) && negative(p1, q2))
        || (positive(q2, p1) && positive(q2, q1))
        || (negative(p2, p1) && negative(p2, q1))
}

#[inline]
/// Length of the segment where two triangles meet, in floating point: the overlap, along the
/// line where their planes meet, of the chords each triangle cuts from the other's plane; 0 for
/// disjoint, coplanar or zero-area triangles. Not a predicate (see [`triangles_intersect`] for
/// that) but a measure of a crossing's depth that starts from zero where two triangles start to
/// cross and grows continuously as they move through each other.
pub fn intersection_length(t1: &[DVec3; 3], t2: &[DVec3; 3]) -> f64 {
    let n1 = (t1[1] - t1[0]).cross(t1[2] - t1[0]);
    let n2 = (t2[1] - t2[0]).cross(t2[2] - t2[0]);
    let line = n1.cross(n2);
    let length = line.length();
    // Parallel planes (or a zero-area triangle, or a NaN corner): no line to measure along.
    if length.is_nan() || length <= 1e-12 * n1.length() * n2.length() {
        return 0.0;
    }
    // The interval along `line` of the points of `t` on the plane through `origin` normal to `n`.
    let chord = |t: &[DVec3; 3], n: DVec3, origin: DVec3| -> Option<(f64, f64)> {
        let d = t.map(|p| n.dot(p - origin));
        let mut interval: Option<(f64, f64)> = None;
        let mut add = |p: DVec3| {
            let x = line.dot(p);
            interval = Some(interval.map_or((x, x), |(a, b)| (a.min(x), b.max(x))));
        };
        for k in 0..3 {
            let (i, j) = (k, (k + 1) % 3);
            if d[i] == 0.0 {
                add(t[i]);
            }
            if (d[i] < 0.0 && d[j] > 0.0) || (d[i] > 0.0 && d[j] < 0.0) {
                add(t[i] + d[i] / (d[i] - d[j]) * (t[j] - t[i]));
            }
        }
        interval
    };
    match (chord(t1, n2, t2[0]), chord(t2, n1, t1[0])) {
        (Some((a0, a1)), Some((b0, b1))) => (a1.min(b1) - a0.max(b0)).max(0.0) / length,
        _ => 0.0,
    }
}

fn same_strict_side(s: [f64; 3]) -> bool {
    (s[0] > 0.0 && s[1] > 0.0 && s[2] > 0.0) || (s[0] < 0.0 && s[1] < 0.0 && s[2] < 0.0)
}

fn coplanar(t1: &[DVec3; 3], t2: &[DVec3; 3], n1: [f64; 3]) -> bool {
    let Some(axis) = projection_axis(n1) else {
        return false;
    };
    let p1 = t1.map(|p| project(p, axis));
    let p2 = t2.map(|p| project(p, axis));
    triangles_touch_2d(&p1, &p2)
}

/// The segment covered by collinear points: their lexicographic extremes.
fn as_segment(t: &[DVec3; 3]) -> (DVec3, DVec3) {
    let mut lo = t[0];
    let mut hi = t[0];
    for &p in &t[1..] {
        if lex_less(p, lo) {
            lo = p;
        }
        if lex_less(hi, p) {
            hi = p;
        }
    }
    (lo, hi)
}

fn degenerate_case(t1: &[DVec3; 3], degenerate1: bool, t2: &[DVec3; 3], n2: [f64; 3], degenerate2: bool) -> bool {
    match (degenerate1, degenerate2) {
        (true, true) => {
            let (a, b) = as_segment(t1);
            let (c, d) = as_segment(t2);
            segments_touch_3d(a, b, c, d)
        }
        (true, false) => {
            let (a, b) = as_segment(t1);
            let plane = |p: DVec3| orient3d(t2[0], t2[1], t2[2], p);
            segment_touches_triangle(a, b, plane(a), plane(b), t2, n2)
        }
        (false, true) => {
            let n1 = cross_exact(t1[0], t1[1], t1[2]);
            degenerate_case(t2, true, t1, n1, false)
        }
        (false, false) => triangles_intersect(t1, t2),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    #[test]
    fn the_intersection_length_is_the_chord_both_triangles_share() {
        let flat = [DVec3::new(-1.0, -1.0, 0.0), DVec3::new(3.0, -1.0, 0.0), DVec3::new(-1.0, 3.0, 0.0)];
        // A vertical triangle through the plane z = 0 along x = 0, from y = -0.5 to y = 0.5.
        let upright =
            |z: f64| [DVec3::new(0.0, -0.5, z - 1.0), DVec3::new(0.0, 0.5, z - 1.0), DVec3::new(0.0, 0.0, z + 1.0)];
        // At z = 0 it cuts the flat one along y in [-0.25, 0.25]; lowered by 1 its apex only
        // touches it, and lowered further it is apart.
        assert!((intersection_length(&flat, &upright(0.0)) - 0.5).abs() < 1e-12);
        assert!((intersection_length(&upright(0.0), &flat) - 0.5).abs() < 1e-12);
        assert!(intersection_length(&flat, &upright(-1.0)).abs() < 1e-12);
        assert_eq!(intersection_length(&flat, &upright(-1.5)), 0.0);
        // Continuous: it shrinks to zero as the triangle is lowered out of the plane.
        let lengths: Vec<f64> = (0..=10).map(|k| intersection_length(&flat, &upright(-k as f64 / 10.0))).collect();
        assert!(lengths.windows(2).all(|w| w[1] <= w[0] && w[0] - w[1] <= 0.0501), "{lengths:?}");
        assert_eq!(intersection_length(&flat, &flat), 0.0, "coplanar");
    }

    use super::*;
    use crate::linalg::test_support::Lcg;

    fn t(a: [f64; 3], b: [f64; 3], c: [f64; 3]) -> [DVec3; 3] {
        [DVec3::from_array(a), DVec3::from_array(b), DVec3::from_array(c)]
    }

    fn both_orders(t1: &[DVec3; 3], t2: &[DVec3; 3]) -> bool {
        let r = triangles_intersect(t1, t2);
        assert_eq!(r, triangles_intersect(t2, t1), "asymmetric");
        // Invariant under cyclic permutations and orientation flips.
        assert_eq!(r, triangles_intersect(&[t1[1], t1[2], t1[0]], &[t2[2], t2[1], t2[0]]));
        r
    }

    #[test]
    fn crossing_triangles_intersect() {
        let a = t([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let b = t([0.5, 0.5, -1.0], [0.5, 0.5, 1.0], [3.0, 3.0, 0.5]);
        assert!(both_orders(&a, &b));
        // Piercing through the middle without any edge of a crossing b's interior.
        let c = t([-1.0, 0.5, -1.0], [3.0, 0.5, -1.0], [0.5, 0.5, 3.0]);
        assert!(both_orders(&a, &c));
    }

    #[test]
    fn touching_at_a_vertex_or_an_edge_counts() {
        let a = t([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        // b's vertex lies in a's interior.
        let b = t([0.2, 0.2, 0.0], [0.2, 0.2, 1.0], [1.0, 1.0, 1.0]);
        assert!(both_orders(&a, &b));
        // Vertex on vertex.
        let c = t([1.0, 0.0, 0.0], [2.0, 0.0, 1.0], [2.0, 1.0, 1.0]);
        assert!(both_orders(&a, &c));
        // Moved off by one ulp-ish: apart.
        let d = t([1.0 + 1e-15, 0.0, 0.0], [2.0, 0.0, 1.0], [2.0, 1.0, 1.0]);
        assert!(!both_orders(&a, &d));
        // Edge on edge, crossing.
        let e = t([0.5, -0.5, 0.0], [0.5, 0.5, 0.0], [0.5, 0.0, 1.0]);
        assert!(both_orders(&a, &e));
    }

    #[test]
    fn coplanar_triangles() {
        let a = t([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let overlapping = t([0.2, 0.2, 0.0], [2.0, 0.2, 0.0], [0.2, 2.0, 0.0]);
        assert!(both_orders(&a, &overlapping));
        let inside = t([0.1, 0.1, 0.0], [0.3, 0.1, 0.0], [0.1, 0.3, 0.0]);
        assert!(both_orders(&a, &inside));
        let disjoint = t([0.6, 0.6, 0.0], [2.0, 0.6, 0.0], [0.6, 2.0, 0.0]);
        assert!(!both_orders(&a, &disjoint));
        let touching = t([0.5, 0.5, 0.0], [2.0, 0.5, 0.0], [0.5, 2.0, 0.0]);
        assert!(both_orders(&a, &touching));
        // Tilted plane: x + y + z = 1, exact coordinates.
        let p = t([1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]);
        let q = t([0.5, 0.5, 0.0], [0.5, 0.0, 0.5], [-1.0, 1.0, 1.0]);
        assert!(both_orders(&p, &q));
        let r = t([-1.0, 1.0, 1.0], [-1.0, 2.0, 0.0], [-2.0, 2.0, 1.0]);
        assert!(!both_orders(&p, &r));
    }

    #[test]
    fn parallel_planes_do_not_intersect() {
        let a = t([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let b = t([0.0, 0.0, 1e-12], [1.0, 0.0, 1e-12], [0.0, 1.0, 1e-12]);
        assert!(!both_orders(&a, &b));
    }

    #[test]
    fn shared_edge_counts_only_when_folding_over() {
        let (u, v) = ([0.0, 0.0, 0.0], [1.0, 0.0, 0.0]);
        let a = t(u, v, [0.0, 1.0, 0.0]);
        let flat = t(v, u, [0.5, -1.0, 0.0]);
        assert!(triangles_intersect(&a, &flat)); // they touch along the edge
        assert!(!triangles_intersect_away_from_shared(&a, &flat));
        let bent = t(v, u, [0.5, -1.0, 0.7]);
        assert!(!triangles_intersect_away_from_shared(&a, &bent));
        let folded = t(v, u, [0.7, 0.5, 0.0]);
        assert!(triangles_intersect_away_from_shared(&a, &folded));
        assert!(triangles_intersect_away_from_shared(&folded, &a));
        // Folded almost flat but not coplanar: meets only on the edge.
        let nearly = t(v, u, [0.7, 0.5, 1e-9]);
        assert!(!triangles_intersect_away_from_shared(&a, &nearly));
        assert!(triangles_intersect_away_from_shared(&a, &a));
    }

    #[test]
    fn shared_vertex_counts_only_when_intersecting_elsewhere() {
        let o = [0.0, 0.0, 0.0];
        let a = t(o, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let fan_neighbor = t(o, [0.0, 1.0, 0.5], [-1.0, 0.0, 0.0]);
        assert!(!triangles_intersect_away_from_shared(&a, &fan_neighbor));
        // Through a's interior.
        let piercing = t(o, [0.5, 0.5, 1.0], [0.5, 0.5, -1.0]);
        assert!(triangles_intersect_away_from_shared(&a, &piercing));
        // Coplanar, overlapping a wedge from the shared vertex.
        let overlapping = t(o, [1.0, 1.0, 0.0], [-1.0, 2.0, 0.0]);
        assert!(triangles_intersect_away_from_shared(&a, &overlapping));
        // Coplanar, only the vertex in common.
        let apart = t(o, [-1.0, 0.0, 0.0], [0.0, -1.0, 0.0]);
        assert!(!triangles_intersect_away_from_shared(&a, &apart));
        // Touching along a ray from the shared vertex: b's edge lies along a's edge.
        let along = t(o, [0.5, 0.0, 0.0], [0.0, 0.0, 1.0]);
        assert!(triangles_intersect_away_from_shared(&a, &along));
    }

    /// The float filter of one shared corner never answers "apart" where the exact test finds an
    /// intersection, on random pairs around a shared corner: generic, nearly coplanar (a smooth
    /// surface's neighbours: the slow case it is there for), exactly coplanar and overlapping,
    /// folded onto each other, touching along a ray, slivers; and it answers most of the
    /// neighbours of a fine flat fan, where the exact test is slowest.
    #[test]
    fn the_shared_corner_filter_never_says_apart_where_they_intersect() {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut apart, mut intersecting, mut answered) = (0, 0, 0);
        for round in 0..40_000 {
            let v = DVec3::new(next(), next(), next());
            let mut corner = || DVec3::new(next(), next(), next());
            let (a1, b1, mut a2, mut b2) = (v + corner(), v + corner(), v + corner(), v + corner());
            match round % 6 {
                // Nearly coplanar: the second's corners lifted off the first's plane by 1e-12.
                1 | 2 => {
                    let n = (a1 - v).cross(b1 - v).normalize();
                    let flat = |p: DVec3| p - (p - v).dot(n) * n;
                    a2 = flat(a2) + 1e-12 * next() * n;
                    b2 = flat(b2) + 1e-12 * next() * n;
                }
                // In the first's plane, exactly when the plane is z = const.
                3 => {
                    a2.z = v.z;
                    b2.z = v.z;
                }
                // Along one of the first's edges (touching along a ray), or a sliver.
                4 => a2 = v + (a1 - v) * (0.5 + next()),
                5 => b2 = a2 + (a2 - v) * 1e-9,
                _ => {}
            }
            let (t1, t2) = ([v, a1, b1], [b2, v, a2]);
            let exact = intersect_away_from_shared_exactly(&t1, &t2);
            let filtered = certainly_apart(&t1, &t2);
            assert!(!(filtered && exact), "round {round}: {t1:?} {t2:?}");
            assert_eq!(intersect_away_from_shared(&t1, &t2), exact, "round {round}");
            intersecting += exact as usize;
            apart += filtered as usize;
        }
        assert!(intersecting > 1000 && apart > 10_000, "{intersecting} {apart}");
        // A fine fan, nearly flat: every pair of faces sharing only the apex meets there only,
        // and the filter says so.
        let count = 64;
        let ring: Vec<DVec3> = (0..count)
            .map(|k| {
                let a = std::f64::consts::TAU * k as f64 / count as f64;
                DVec3::new(a.cos(), a.sin(), 0.1 * a.cos() * a.sin())
            })
            .collect();
        let apex = DVec3::new(0.0, 0.0, 0.0);
        for i in 0..count {
            for j in i + 2..count {
                if (j + 1) % count == i {
                    continue;
                }
                let (t1, t2) = ([apex, ring[i], ring[(i + 1) % count]], [apex, ring[j], ring[(j + 1) % count]]);
                assert!(!intersect_away_from_shared_exactly(&t1, &t2));
                answered += certainly_apart(&t1, &t2) as usize;
            }
        }
        // All but the opposite wedges, whose boundary rays lie on one line: no strict side.
        assert_eq!(answered, count * (count - 3) / 2 - count / 2);
    }

    #[test]
    fn degenerate_triangles_are_their_segments() {
        let a = t([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]);
        let needle = t([0.2, 0.2, -1.0], [0.2, 0.2, 1.0], [0.2, 0.2, 0.5]);
        assert!(both_orders(&a, &needle));
        let short = t([0.2, 0.2, 0.5], [0.2, 0.2, 1.0], [0.2, 0.2, 0.7]);
        assert!(!both_orders(&a, &short));
        let point = t([0.2, 0.2, 0.0], [0.2, 0.2, 0.0], [0.2, 0.2, 0.0]);
        assert!(both_orders(&a, &point));
        assert!(both_orders(&needle, &point.map(|p| p + DVec3::new(0.0, 0.0, 0.3))));
    }

    /// Separating-axis test in floating point, as an independent reference on generic pairs.
    fn sat_separation(t1: &[DVec3; 3], t2: &[DVec3; 3]) -> f64 {
        let mut axes = vec![(t1[1] - t1[0]).cross(t1[2] - t1[0]), (t2[1] - t2[0]).cross(t2[2] - t2[0])];
        for i in 0..3 {
            for j in 0..3 {
                axes.push((t1[(i + 1) % 3] - t1[i]).cross(t2[(j + 1) % 3] - t2[j]));
            }
        }
        let mut best = f64::NEG_INFINITY;
        for axis in axes {
            if axis.length() < 1e-9 {
                continue;
            }
            let axis = axis.normalize();
            let (mut lo1, mut hi1, mut lo2, mut hi2) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
            for p in t1 {
                lo1 = lo1.min(p.dot(axis));
                hi1 = hi1.max(p.dot(axis));
            }
            for p in t2 {
                lo2 = lo2.min(p.dot(axis));
                hi2 = hi2.max(p.dot(axis));
            }
            best = best.max(lo2 - hi1).max(lo1 - hi2);
        }
        best // > 0: separated by that gap; < 0: overlapping on every axis
    }

    #[test]
    fn agrees_with_a_separating_axis_reference_on_random_pairs() {
        let mut lcg = Lcg::from_state(12345);
        let mut rnd = move || lcg.next_signed();
        let (mut yes, mut no) = (0, 0);
        for _ in 0..20000 {
            let c = DVec3::new(rnd(), rnd(), rnd()) * 0.6;
            let t1 = [0; 3].map(|_| DVec3::new(rnd(), rnd(), rnd()));
            let t2 = [0; 3].map(|_| c + DVec3::new(rnd(), rnd(), rnd()));
            let gap = sat_separation(&t1, &t2);
            if gap.abs() < 1e-9 {
                continue;
            }
            let exact = triangles_intersect(&t1, &t2);
            assert_eq!(exact, gap < 0.0, "{t1:?} {t2:?} gap {gap}");
            if exact {
                yes += 1;
            } else {
                no += 1;
            }
        }
        assert!(yes > 2000 && no > 2000, "{yes} {no}");
    }
}
