//! Exact geometric predicates and the symbolically perturbed crossing tests built on them.
//!
//! The contact stage (thesis §4.1) counts edge/face crossings between two meshes and tags edge
//! ends *interior* or *exterior* from the closest crossing; the mapping stage (§4.2.2) casts rays
//! along ±d̂ and intersects projected contour segments with projected mesh edges in 2D. Both break
//! if a crossing through a shared edge or vertex is missed or counted twice, which happens with
//! floating-point tests whenever a query passes exactly through a vertex (axis-aligned meshes,
//! symmetric scenes, rays along a coordinate axis). So every decision here is made with Shewchuk's
//! exact `orient2d`/`orient3d` (crate `robust`), and the degenerate cases are resolved by
//! *Simulation of Simplicity* (Edelsbrunner & Mücke 1990):
//!
//! - **3D segment–triangle crossing** ([`segment_triangle`]). The segment's endpoints are moved by
//!   infinitesimals, `a + η_a·e` and `b + η_b·e` with `e = (1, ε, ε²)` and `η_b ≪ η_a`; the mesh is
//!   left untouched. The perturbed segment is in general position with respect to every triangle,
//!   and the perturbation is the same for all triangles, so the answers are those of one real,
//!   slightly moved segment: a segment through a shared edge or vertex of a manifold surface
//!   crosses exactly one of the incident faces when it passes through the surface, and 0 or 2 when
//!   it only grazes it; an endpoint lying exactly in a face's plane is put on the side that `+e`
//!   points to (so a mesh vertex touching the other mesh gets the same side for all its edges);
//!   a segment lying in a face's plane never crosses that face. Zero-area faces are never crossed.
//! - **2D segment–segment crossing** ([`segment_segment_2d`]): the same construction with
//!   `e = (1, ε)` on the query segment, used for the projected-contour test of §4.2.2.
//!
//! The reported parameters (position along the segment, barycentric coordinates) are ratios of
//! the same determinants whose signs decide the crossing; they all share a sign, so the ratios have
//! no cancellation and lie in [0, 1] by construction, and a coordinate is exactly 0 when the
//! crossing is exactly on an edge or vertex.
//!
//! The closed-set tests at the end (no perturbation: touching counts) serve the exact
//! triangle–triangle test of [`super::tri_tri`].

use glam::{DVec2, DVec3};

use crate::stage::Work;
use robust::{Coord, Coord3D};

#[inline(always)]
fn c3(p: DVec3) -> Coord3D<f64> {
    Coord3D { x: p.x, y: p.y, z: p.z }
}

#[inline(always)]
fn c2(x: f64, y: f64) -> Coord<f64> {
    Coord { x, y }
}

/// `det[a − d, b − d, c − d]` with an exact sign (Shewchuk's `orient3d`): positive when `d` lies
/// on the back side of the counter-clockwise triangle `a, b, c`, i.e. `−(d − a)·((b − a) × (c − a))`.
///
/// A triangle lying in a coordinate plane (all three corners share one coordinate exactly, as
/// the faces of boxes, grids and most modelled parts do) factorizes exactly:
/// `orient3d = (a_k − d_k) · orient2d` of the corners projected along axis k, so its sign is
/// exact from a comparison and an exact `orient2d`, and the value carries two roundings. This
/// skips the adaptive stages of `orient3d`, which a point in (or a segment along) such a face
/// otherwise runs in full to prove an exact zero (a foot's side walls seen along the vertical;
/// `docs/speed.md`).
#[inline(always)]
pub(crate) fn orient3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    // One vector comparison decides whether any coordinate is shared (the common case: none).
    if (a.cmpeq(b) & b.cmpeq(c)).any() {
        return orient3d_in_coordinate_plane(a, b, c, d);
    }
    // Shewchuk's stage A (`robust::orient3d`'s first lines, the same operations in the same order
    // so the value is the same bits), inlined: it decides almost every call, and the call into
    // the full predicate, adaptive stages included, is then only made when the filter fails.
    let (ad, bd, cd) = (a - d, b - d, c - d);
    let (bdxcdy, cdxbdy) = (bd.x * cd.y, cd.x * bd.y);
    let (cdxady, adxcdy) = (cd.x * ad.y, ad.x * cd.y);
    let (adxbdy, bdxady) = (ad.x * bd.y, bd.x * ad.y);
    let det = ad.z * (bdxcdy - cdxbdy) + bd.z * (cdxady - adxcdy) + cd.z * (adxbdy - bdxady);
    let permanent = (bdxcdy.abs() + cdxbdy.abs()) * ad.z.abs()
        + (cdxady.abs() + adxcdy.abs()) * bd.z.abs()
        + (adxbdy.abs() + bdxady.abs()) * cd.z.abs();
    let errbound = ORIENT3D_ERRBOUND_A * permanent;
    if det > errbound || -det > errbound {
        return det;
    }
    robust::orient3d(c3(a), c3(b), c3(c), c3(d))
}

/// Shewchuk's `o3derrboundA`, (7 + 56ε)ε with ε = 2⁻⁵³, as `robust` defines it.
const ORIENT3D_ERRBOUND_A: f64 = (7.0 + 56.0 * ROBUST_EPSILON) * ROBUST_EPSILON;
/// `robust`'s ε (2⁻⁵³ written out in decimal there; the same double).
const ROBUST_EPSILON: f64 = 0.000_000_000_000_000_111_022_302_462_515_65;

/// [`orient3d`] for corners sharing a coordinate (kept out of line: the hot path stays small).
#[inline(never)]
fn orient3d_in_coordinate_plane(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> f64 {
    if a.z == b.z && b.z == c.z {
        // det[a − d, b − d, c − d] = (z₀ − d_z)·det[[a_x, a_y, 1], …].
        return (a.z - d.z) * robust::orient2d(c2(a.x, a.y), c2(b.x, b.y), c2(c.x, c.y));
    }
    if a.x == b.x && b.x == c.x {
        // The column of ones moved last by a cyclic permutation: (y, z).
        return (a.x - d.x) * robust::orient2d(c2(a.y, a.z), c2(b.y, b.z), c2(c.y, c.z));
    }
    // a.y == b.y == c.y; likewise: (z, x).
    (a.y - d.y) * robust::orient2d(c2(a.z, a.x), c2(b.z, b.x), c2(c.z, c.x))
}

/// `(b − a) × (c − a)` in 2D with an exact sign: positive when `a, b, c` turn counter-clockwise.
#[inline(always)]
pub(crate) fn orient2d(a: DVec2, b: DVec2, c: DVec2) -> f64 {
    robust::orient2d(c2(a.x, a.y), c2(b.x, b.y), c2(c.x, c.y))
}

/// The components of `(p − o) × (q − o)`, each with an exact sign: each one is a 2D orientation
/// of the points projected on a coordinate plane (yz, zx, xy).
#[inline]
pub(crate) fn cross_exact(o: DVec3, p: DVec3, q: DVec3) -> [f64; 3] {
    [
        robust::orient2d(c2(o.y, o.z), c2(p.y, p.z), c2(q.y, q.z)),
        robust::orient2d(c2(o.z, o.x), c2(p.z, p.x), c2(q.z, q.x)),
        robust::orient2d(c2(o.x, o.y), c2(p.x, p.y), c2(q.x, q.y)),
    ]
}

/// Sign (−1, 0 or +1) of the first non-zero entry: the sign of `v · (1, ε, ε²)` for an
/// infinitesimal ε.
#[inline]
fn lexicographic_sign(v: [f64; 3]) -> i8 {
    for x in v {
        if x > 0.0 {
            return 1;
        }
        if x < 0.0 {
            return -1;
        }
    }
    0
}

/// Sign of `x` as −1, 0 or +1 (unlike `f64::signum`, 0 for ±0).
#[inline(always)]
pub(crate) fn sign(x: f64) -> i8 {
    if x > 0.0 {
        1
    } else if x < 0.0 {
        -1
    } else {
        0
    }
}

/// A crossing of a segment with a triangle, as found by [`segment_triangle`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Crossing {
    /// Position along the segment, in [0, 1].
    pub t: f64,
    /// Barycentric coordinates on the triangle, each in [0, 1], summing to 1 up to round-off.
    pub bary: [f64; 3],
    /// The segment goes from the triangle's front (the side its counter-clockwise normal points
    /// to) to its back.
    pub entering: bool,
}

/// Sign of `orient3d(p0, p1, p2, x + η·e)`: exact, with the perturbation deciding when `x` is in
/// the plane. `normal_sign` is the lexicographic sign of the triangle's normal (computed lazily).
#[inline]
fn perturbed_plane_sign(value: f64, normal_sign: &mut Option<i8>, p: &[DVec3; 3]) -> i8 {
    let s = sign(value);
    if s != 0 {
        return s;
    }
    // orient3d(p0, p1, p2, x) = −(x − p0)·n, so moving x along e changes it by −η e·n.
    let n = *normal_sign.get_or_insert_with(|| lexicographic_sign(cross_exact(p[0], p[1], p[2])));
    -n
}

/// Sign of `orient3d(a', b', u, v)` for the perturbed endpoints `a' = a + η_a e`, `b' = b + η_b e`.
/// It is the orientation of the segment's line against the directed triangle edge `u → v`.
#[inline]
fn perturbed_edge_sign(value: f64, a: DVec3, b: DVec3, u: DVec3, v: DVec3) -> i8 {
    let s = sign(value);
    if s != 0 {
        return s;
    }
    // det[a − v, b − v, u − v] is linear in a with gradient (b − v) × (u − v) and linear in b with
    // gradient (u − v) × (a − v); the η_a η_b term is det[e, e, ·] = 0.
    let by_a = lexicographic_sign(cross_exact(v, b, u));
    if by_a != 0 {
        return by_a;
    }
    lexicographic_sign(cross_exact(v, u, a))
}

/// Crossing of the segment `[a, b]` with the triangle `p`, decided exactly under the symbolic
/// perturbation described in the module documentation. `None` if they do not cross.
#[inline]
pub(crate) fn segment_triangle(a: DVec3, b: DVec3, p: &[DVec3; 3]) -> Option<Crossing> {
    Work::count_triangle_tests(1);
    let sa = orient3d(p[0], p[1], p[2], a);
    let sb = orient3d(p[0], p[1], p[2], b);
    if (sa > 0.0 && sb > 0.0) || (sa < 0.0 && sb < 0.0) {
        return None;
    }
    let mut normal_sign = None;
    let side_a = perturbed_plane_sign(sa, &mut normal_sign, p);
    let side_b = perturbed_plane_sign(sb, &mut normal_sign, p);
    // A zero side means a zero-area triangle: it has no interior to cross.
    if side_a == 0 || side_b == 0 || side_a == side_b {
        return None;
    }
    let e01 = orient3d(a, b, p[0], p[1]);
    let s01 = perturbed_edge_sign(e01, a, b, p[0], p[1]);
    let e12 = orient3d(a, b, p[1], p[2]);
    let s12 = perturbed_edge_sign(e12, a, b, p[1], p[2]);
    if s01 != s12 {
        return None;
    }
    let e20 = orient3d(a, b, p[2], p[0]);
    let s20 = perturbed_edge_sign(e20, a, b, p[2], p[0]);
    if s20 != s01 {
        return None;
    }
    // The weight of a vertex is the determinant of the opposite edge. All three share the sign
    // s01 (or are 0) and not all are 0, so the sum does not cancel.
    let sum = e01 + e12 + e20;
    let bary = if sum != 0.0 {
        [e12 / sum, e20 / sum, e01 / sum]
    } else {
        // Unreachable in exact arithmetic (the line would lie in the plane); keep a valid answer.
        [1.0 / 3.0; 3]
    };
    let t = if sa == 0.0 {
        0.0
    } else if sb == 0.0 {
        1.0
    } else {
        (sa / (sa - sb)).clamp(0.0, 1.0)
    };
    Some(Crossing { t, bary, entering: side_a < 0 })
}

/// A crossing of two 2D segments, as found by [`segment_segment_2d`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Crossing2 {
    /// Position along the query segment `[p, q]`, in [0, 1].
    pub s: f64,
    /// Position along the other segment `[u, v]`, in [0, 1].
    pub t: f64,
}

/// Sign of `(v − u) × (x' − u)` with `x' = x + η e`, `e = (1, ε)`.
#[inline]
fn perturbed_side_2d(value: f64, u: DVec2, v: DVec2) -> i8 {
    let s = sign(value);
    if s != 0 {
        return s;
    }
    // Gradient in x: (v − u) × e = −(v − u)_y + ε (v − u)_x. Signs of float differences are exact.
    let dy = sign(u.y - v.y);
    if dy != 0 {
        return dy;
    }
    sign(v.x - u.x)
}

/// Crossing of the query segment `[p, q]` with the segment `[u, v]` in the plane, decided exactly
/// with the query endpoints perturbed as `p + η_p e`, `q + η_q e`, `e = (1, ε)`, `η_q ≪ η_p`.
/// A query through a shared endpoint of a chain of segments crosses exactly one of them (when it
/// passes through the chain); collinear overlapping segments never cross.
#[inline]
pub(crate) fn segment_segment_2d(p: DVec2, q: DVec2, u: DVec2, v: DVec2) -> Option<Crossing2> {
    let op = orient2d(u, v, p);
    let oq = orient2d(u, v, q);
    if (op > 0.0 && oq > 0.0) || (op < 0.0 && oq < 0.0) {
        return None;
    }
    let sp = perturbed_side_2d(op, u, v);
    let sq = perturbed_side_2d(oq, u, v);
    if sp == 0 || sq == 0 || sp == sq {
        return None;
    }
    let ou = orient2d(p, q, u);
    let ov = orient2d(p, q, v);
    if (ou > 0.0 && ov > 0.0) || (ou < 0.0 && ov < 0.0) {
        return None;
    }
    let su = perturbed_line_side_2d(ou, p, q, u);
    let sv = perturbed_line_side_2d(ov, p, q, v);
    if su == 0 || sv == 0 || su == sv {
        return None;
    }
    let s = if op == 0.0 {
        0.0
    } else if oq == 0.0 {
        1.0
    } else {
        (op / (op - oq)).clamp(0.0, 1.0)
    };
    let t = if ou == 0.0 {
        0.0
    } else if ov == 0.0 {
        1.0
    } else {
        (ou / (ou - ov)).clamp(0.0, 1.0)
    };
    Some(Crossing2 { s, t })
}

/// Sign of `orient2d(p', q', x)` for the perturbed query endpoints.
#[inline]
fn perturbed_line_side_2d(value: f64, p: DVec2, q: DVec2, x: DVec2) -> i8 {
    let s = sign(value);
    if s != 0 {
        return s;
    }
    // orient2d(p, q, x) = (p − x) × (q − x). Gradient in p: e × (q − x) = (q − x)_y − ε (q − x)_x;
    // gradient in q: (p − x) × e = −(p − x)_y + ε (p − x)_x.
    let by_p = sign(q.y - x.y);
    if by_p != 0 {
        return by_p;
    }
    let by_p = sign(x.x - q.x);
    if by_p != 0 {
        return by_p;
    }
    let by_q = sign(x.y - p.y);
    if by_q != 0 {
        return by_q;
    }
    sign(p.x - x.x)
}

// ---------------------------------------------------------------------------------------------
// Closed-set tests (touching counts), exact, for the triangle–triangle test.
// ---------------------------------------------------------------------------------------------

/// Drops coordinate `axis`, keeping a right-handed order of the two others (yz, zx, xy), so that
/// a 3D orientation seen along +axis is the 2D orientation of the projection.
#[inline]
pub(crate) fn project(p: DVec3, axis: usize) -> DVec2 {
    match axis {
        0 => DVec2::new(p.y, p.z),
        1 => DVec2::new(p.z, p.x),
        _ => DVec2::new(p.x, p.y),
    }
}

/// A coordinate axis along which the plane with exact normal components `n` projects one-to-one
/// (the largest component, so that the projection is also well conditioned), or `None` if `n = 0`.
#[inline]
pub(crate) fn projection_axis(n: [f64; 3]) -> Option<usize> {
    let mut best = None;
    let mut best_abs = 0.0;
    for (k, x) in n.iter().enumerate() {
        if x.abs() > best_abs {
            best_abs = x.abs();
            best = Some(k);
        }
    }
    best
}

/// Lexicographic order on points, used to order collinear points along their line.
#[inline]
pub(crate) fn lex_less(a: DVec3, b: DVec3) -> bool {
    (a.x, a.y, a.z) < (b.x, b.y, b.z)
}

#[inline]
fn lex_less_2d(a: DVec2, b: DVec2) -> bool {
    (a.x, a.y) < (b.x, b.y)
}

/// Closed 2D segments `[a, b]` and `[c, d]` share a point.
pub(crate) fn segments_touch_2d(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let o1 = sign(orient2d(a, b, c));
    let o2 = sign(orient2d(a, b, d));
    if o1 != 0 && o1 == o2 {
        return false;
    }
    let o3 = sign(orient2d(c, d, a));
    let o4 = sign(orient2d(c, d, b));
    if o3 != 0 && o3 == o4 {
        return false;
    }
    if o1 == 0 && o2 == 0 && o3 == 0 && o4 == 0 {
        // All four on one line (or points): overlap of the lexicographic ranges.
        let (a0, a1) = if lex_less_2d(b, a) { (b, a) } else { (a, b) };
        let (c0, c1) = if lex_less_2d(d, c) { (d, c) } else { (c, d) };
        return !lex_less_2d(a1, c0) && !lex_less_2d(c1, a0);
    }
    true
}

/// The closed 2D triangle `t` (non-degenerate) contains `x`.
pub(crate) fn point_in_triangle_2d(x: DVec2, t: &[DVec2; 3]) -> bool {
    let s = sign(orient2d(t[0], t[1], t[2]));
    let s0 = sign(orient2d(t[0], t[1], x));
    let s1 = sign(orient2d(t[1], t[2], x));
    let s2 = sign(orient2d(t[2], t[0], x));
    s0 != -s && s1 != -s && s2 != -s
}

/// Closed 2D segment `[a, b]` and closed non-degenerate triangle `t` share a point.
pub(crate) fn segment_touches_triangle_2d(a: DVec2, b: DVec2, t: &[DVec2; 3]) -> bool {
    point_in_triangle_2d(a, t)
        || point_in_triangle_2d(b, t)
        || (0..3).any(|k| segments_touch_2d(a, b, t[k], t[(k + 1) % 3]))
}

/// Closed non-degenerate coplanar 2D triangles share a point.
pub(crate) fn triangles_touch_2d(t1: &[DVec2; 3], t2: &[DVec2; 3]) -> bool {
    for i in 0..3 {
        for j in 0..3 {
            if segments_touch_2d(t1[i], t1[(i + 1) % 3], t2[j], t2[(j + 1) % 3]) {
                return true;
            }
        }
    }
    // No boundary contact: one contains the other, or they are disjoint.
    point_in_triangle_2d(t1[0], t2) || point_in_triangle_2d(t2[0], t1)
}

/// Closed segment `[a, b]` and closed non-degenerate triangle `p` (with exact normal components
/// `n`) share a point. `sa`, `sb` are `orient3d(p0, p1, p2, a)` and `(…, b)`.
pub(crate) fn segment_touches_triangle(a: DVec3, b: DVec3, sa: f64, sb: f64, p: &[DVec3; 3], n: [f64; 3]) -> bool {
    let (sa, sb) = (sign(sa), sign(sb));
    if sa != 0 && sa == sb {
        return false;
    }
    if sa == 0 && sb == 0 {
        let Some(axis) = projection_axis(n) else {
            return false;
        };
        let t = [project(p[0], axis), project(p[1], axis), project(p[2], axis)];
        return segment_touches_triangle_2d(project(a, axis), project(b, axis), &t);
    }
    if a == b {
        // Unreachable: a point off the plane has sa = sb ≠ 0.
        return false;
    }
    // The line ab meets the plane at one point, which the segment reaches; it lies in the closed
    // triangle iff the line's orientations against the three edges do not strictly disagree.
    let s01 = sign(orient3d(a, b, p[0], p[1]));
    let s12 = sign(orient3d(a, b, p[1], p[2]));
    let s20 = sign(orient3d(a, b, p[2], p[0]));
    !(s01 > 0 || s12 > 0 || s20 > 0) || !(s01 < 0 || s12 < 0 || s20 < 0)
}

/// Closed 3D segments `[a, b]` and `[c, d]` share a point (either may be a single point).
pub(crate) fn segments_touch_3d(a: DVec3, b: DVec3, c: DVec3, d: DVec3) -> bool {
    if orient3d(a, b, c, d) != 0.0 {
        return false;
    }
    // Coplanar: find a plane through them with a non-zero normal to project along.
    let normal = [cross_exact(a, b, c), cross_exact(a, b, d), cross_exact(c, d, a), cross_exact(c, d, b)]
        .into_iter()
        .find(|n| n.iter().any(|&x| x != 0.0));
    match normal.and_then(projection_axis) {
        Some(axis) => segments_touch_2d(project(a, axis), project(b, axis), project(c, axis), project(d, axis)),
        None => {
            // All four points on one line: overlap of the lexicographic ranges.
            let (a0, a1) = if lex_less(b, a) { (b, a) } else { (a, b) };
            let (c0, c1) = if lex_less(d, c) { (d, c) } else { (c, d) };
            !lex_less(a1, c0) && !lex_less(c1, a0)
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {

    #[test]
    fn axis_aligned_triangles_give_orient3d_exactly_signed() {
        // Corners sharing one coordinate, points on, above and below their plane, with
        // coordinates where the float determinant cancels: the factorized value has the exact
        // sign (the adaptive predicate's) and matches its value closely.
        let mut lcg = Lcg::from_state(7);
        let mut next = || (lcg.next_unit() - 0.5) * 8.0;
        for axis in 0..3 {
            for _ in 0..2000 {
                let plane = (next() * 4.0).round() / 4.0;
                let mut corner = || {
                    let mut p = [next(), next(), next()];
                    p[axis] = plane;
                    DVec3::from_array(p)
                };
                let (a, b, c) = (corner(), corner(), corner());
                let mut d = [next(), next(), next()];
                // A third of the points exactly in the plane, a third a hair off it.
                match (next() * 3.0) as i64 {
                    0 => d[axis] = plane,
                    1 => d[axis] = plane + f64::EPSILON * plane.abs().max(1.0),
                    _ => {}
                }
                let d = DVec3::from_array(d);
                let fast = orient3d(a, b, c, d);
                let exact = robust::orient3d(c3(a), c3(b), c3(c), c3(d));
                assert_eq!(sign(fast), sign(exact), "axis {axis}: {a} {b} {c} {d}");
                // Both are approximations of the exact determinant (robust returns its float estimate).
                assert!((fast - exact).abs() <= 1e-8 * exact.abs(), "{fast} vs {exact}");
            }
        }
    }
    use super::*;
    use crate::linalg::test_support::Lcg;

    #[test]
    fn the_inlined_orient3d_filter_returns_robusts_bits() {
        assert_eq!(ROBUST_EPSILON, 2f64.powi(-53));
        let mut rng = Lcg::new(13);
        let mut filtered = 0;
        for k in 0..30_000 {
            let mut point = || DVec3::new(rng.next_signed(), rng.next_signed(), rng.next_signed());
            let (a, b, c) = (point(), point(), point());
            // Generic points, then points nearly in the plane (the filter fails, robust decides).
            let d = if k % 3 == 0 { a + (b - a) * rng.next_signed() + (c - a) * rng.next_signed() } else { point() };
            let ours = orient3d(a, b, c, d);
            let theirs = robust::orient3d(c3(a), c3(b), c3(c), c3(d));
            assert_eq!(ours.to_bits(), theirs.to_bits(), "{a} {b} {c} {d}");
            filtered += usize::from(k % 3 == 0);
        }
        assert!(filtered > 9000);
    }

    fn tri() -> [DVec3; 3] {
        [DVec3::ZERO, DVec3::X, DVec3::Y]
    }

    #[test]
    fn orient3d_sign_convention() {
        // Below the counter-clockwise triangle (normal +z) is positive.
        let [a, b, c] = tri();
        assert!(orient3d(a, b, c, DVec3::new(0.2, 0.2, -1.0)) > 0.0);
        assert!(orient3d(a, b, c, DVec3::new(0.2, 0.2, 1.0)) < 0.0);
        assert_eq!(cross_exact(a, b, c).map(sign), [0, 0, 1]);
    }

    #[test]
    fn crossing_through_interior_has_consistent_parameters() {
        let p = tri();
        let a = DVec3::new(0.2, 0.3, 1.0);
        let b = DVec3::new(0.2, 0.3, -3.0);
        let hit = segment_triangle(a, b, &p).unwrap();
        assert!((hit.t - 0.25).abs() < 1e-15);
        assert!((hit.bary[0] - 0.5).abs() < 1e-15 && (hit.bary[1] - 0.2).abs() < 1e-15);
        assert!(hit.entering);
        let back = segment_triangle(b, a, &p).unwrap();
        assert!(!back.entering);
        assert!((back.t - 0.75).abs() < 1e-15);
        assert!(segment_triangle(a, DVec3::new(0.2, 0.3, 0.5), &p).is_none());
        assert!(segment_triangle(DVec3::new(2.0, 2.0, 1.0), DVec3::new(2.0, 2.0, -1.0), &p).is_none());
    }

    #[test]
    fn crossing_through_a_shared_edge_is_reported_once() {
        // Two triangles sharing the edge (1,0,0)-(0,1,0), consistently oriented.
        let t1 = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let t2 = [DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y];
        for (a, b) in [
            (DVec3::new(0.5, 0.5, 1.0), DVec3::new(0.5, 0.5, -1.0)),
            (DVec3::new(0.5, 0.5, -1.0), DVec3::new(0.5, 0.5, 1.0)),
            (DVec3::new(0.3, 0.3, 1.0), DVec3::new(0.7, 0.7, -1.0)),
            (DVec3::new(0.7, 0.7, 1.0), DVec3::new(0.3, 0.3, -1.0)),
        ] {
            let n = [segment_triangle(a, b, &t1), segment_triangle(a, b, &t2)].iter().flatten().count();
            assert_eq!(n, 1, "{a} {b}");
        }
    }

    #[test]
    fn endpoint_in_plane_is_classified_by_the_perturbation() {
        let p = tri();
        // a in the plane, inside the triangle; the normal is +z so e = (1, ε, ε²) has e·n = ε² > 0:
        // a is moved to the front, and a segment going down crosses at t = 0.
        let a = DVec3::new(0.2, 0.2, 0.0);
        let hit = segment_triangle(a, DVec3::new(0.2, 0.2, -1.0), &p).unwrap();
        assert_eq!(hit.t, 0.0);
        assert!(segment_triangle(a, DVec3::new(0.2, 0.2, 1.0), &p).is_none());
        // A segment lying in the plane never crosses.
        assert!(segment_triangle(DVec3::new(-1.0, 0.2, 0.0), DVec3::new(2.0, 0.2, 0.0), &p).is_none());
    }

    #[test]
    fn segments_2d_through_a_shared_endpoint_cross_once() {
        let (u, v, w) = (DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0), DVec2::new(2.0, 0.0));
        for (p, q) in [
            (DVec2::new(1.0, -1.0), DVec2::new(1.0, 1.0)),
            (DVec2::new(0.0, -1.0), DVec2::new(2.0, 1.0)),
            (DVec2::new(1.0, 1.0), DVec2::new(1.0, -1.0)),
        ] {
            let n = [segment_segment_2d(p, q, u, v), segment_segment_2d(p, q, v, w)].iter().flatten().count();
            assert_eq!(n, 1, "{p} {q}");
        }
        let hit = segment_segment_2d(DVec2::new(0.5, -1.0), DVec2::new(0.5, 3.0), u, v).unwrap();
        assert!((hit.s - 0.25).abs() < 1e-15 && (hit.t - 0.5).abs() < 1e-15);
        // Collinear overlap is not a crossing.
        assert!(segment_segment_2d(DVec2::new(-1.0, 0.0), DVec2::new(3.0, 0.0), u, v).is_none());
    }

    #[test]
    fn closed_segment_tests() {
        let (a, b) = (DVec2::new(0.0, 0.0), DVec2::new(1.0, 0.0));
        assert!(segments_touch_2d(a, b, DVec2::new(1.0, 0.0), DVec2::new(1.0, 5.0)));
        assert!(segments_touch_2d(a, b, DVec2::new(0.5, 0.0), DVec2::new(3.0, 0.0)));
        assert!(!segments_touch_2d(a, b, DVec2::new(1.5, 0.0), DVec2::new(3.0, 0.0)));
        assert!(!segments_touch_2d(a, b, DVec2::new(0.5, 0.1), DVec2::new(3.0, 0.1)));
        let (a3, b3) = (DVec3::ZERO, DVec3::new(1.0, 1.0, 1.0));
        assert!(segments_touch_3d(a3, b3, DVec3::splat(0.5), DVec3::new(0.5, 0.5, 7.0)));
        assert!(segments_touch_3d(a3, b3, DVec3::splat(1.0), DVec3::splat(2.0)));
        assert!(!segments_touch_3d(a3, b3, DVec3::splat(1.5), DVec3::splat(2.0)));
        assert!(!segments_touch_3d(a3, b3, DVec3::new(0.5, 0.5, 0.6), DVec3::new(0.5, 0.5, 7.0)));
    }
}
