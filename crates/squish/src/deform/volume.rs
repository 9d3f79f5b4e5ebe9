//! Volume preservation (thesis §5.4.2, App. C): the bulge height h_v that keeps the object's volume.
//!
//! Every deformed position is affine in h_v: `p′_i = p_i + h·l_i + c_i` with, on 𝒟,
//! `l_i = η_i·d_i·N₂(t_i)` and `c_i = d_i·(Σ_{k≠2} y_k N_k(t_i) + wrinkles(u_i))` (Eq. 5.5 with the
//! bulge map of §5.5), on 𝒞 `l_i = 0`, `c_i = p′_i − p_i` (the move onto 𝒮), elsewhere 0. The
//! signed volume `Σ_f det(p′_0 − o, p′_1 − o, p′_2 − o)/6` is therefore a cubic in h. We expand
//! the determinant of every face that has a moved vertex — the same polynomial as App. C's sum of
//! prism volumes (the prism between a face and its displaced copy is the difference of the two
//! cones from o) — relative to a reference point o (the region's centroid, for conditioning), and
//! solve `ΔV(h) = V(h) − V_input = 0` (γ = 1; γ is applied afterwards as `γ·h_v`).
//!
//! The working region may be part of a larger closed mesh: faces outside the region do not move,
//! so ΔV over the region's faces is the object's ΔV.
//!
//! **Open meshes** (issue 29; docs/decisions.md, "Open meshes bulge"): an open surface encloses no
//! volume, so what is kept is the signed volume *swept* by its displacement — the volume of the
//! closed surface made of the output, the input reversed, and the ruled strips swept by the
//! boundary edges that move ([`VolumeCubic::swept`]). For a closed mesh there is no strip and it
//! is the change of the enclosed volume; it does not depend on the reference point, so it is
//! invariant under rigid motions. Every strip `(i, j, j′, i′)`, i → j a boundary edge in its
//! face's order, is two triangles `(i, j, j′)`, `(i, j′, i′)`, whose cones from o add their terms
//! in h to the cubic. A cut working region's border does not move (the pipeline clamps the
//! extent), so its strips add nothing.
//!
//! Root choice: the smallest non-negative root (App. C: "the smallest positive one"), found
//! robustly without a companion matrix: the cubic is rescaled to `x = h/scale` (scale = the
//! extent), its critical points split `[0, 10⁶]` into monotone pieces, and the first piece whose
//! ends differ in sign is bisected to the last bit. Vanishing leading coefficients need no special
//! case (the derivative's roots are found by a stable quadratic formula that degrades to the
//! linear one). **No root** (e.g. the deformation already adds volume, or the bulge cannot
//! restore it): we take the `h ≥ 0` that minimizes `|ΔV(h)|` among 0 and the critical points —
//! the closest the bulge can get, continuous with the root case when a root appears at a
//! double zero — and report it (`exact = false`, the residual) in the stats.

use glam::DVec3;

use super::DeformError;
use crate::mesh::{Topology, TriMesh};

/// Bulge heights beyond this many extents are not searched (no meaningful deformation).
const MAX_SCALED_HEIGHT: f64 = 1e6;

/// Per vertex: `p′ = p + h·linear + constant` for the moved vertices.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AffineDisplacement {
    /// `l_i` (zero where the vertex does not depend on h).
    pub linear: Vec<DVec3>,
    /// `c_i`.
    pub constant: Vec<DVec3>,
    /// True for vertices that move (in 𝒞 or 𝒟).
    pub moved: Vec<bool>,
}

impl AffineDisplacement {
    /// No vertex moves.
    pub fn none(num_vertices: usize) -> Self {
        Self {
            linear: vec![DVec3::ZERO; num_vertices],
            constant: vec![DVec3::ZERO; num_vertices],
            moved: vec![false; num_vertices],
        }
    }
}

/// `det(x + t·y)` as a polynomial in t: `[det x, …, det y]` (columns `x_k + t·y_k`).
fn det_expansion(x: [DVec3; 3], y: [DVec3; 3]) -> [f64; 4] {
    let det = |a: DVec3, b: DVec3, c: DVec3| a.dot(b.cross(c));
    [
        det(x[0], x[1], x[2]),
        det(y[0], x[1], x[2]) + det(x[0], y[1], x[2]) + det(x[0], x[1], y[2]),
        det(x[0], y[1], y[2]) + det(y[0], x[1], y[2]) + det(y[0], y[1], x[2]),
        det(y[0], y[1], y[2]),
    ]
}

/// The volume change `ΔV(h) = Σ_k coefficients[k]·h^k` of a region under an affine displacement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VolumeCubic {
    /// `[c0, c1, c2, c3]`: ΔV(h) = c0 + c1 h + c2 h² + c3 h³.
    pub coefficients: [f64; 4],
}

/// The terms of one face in [`VolumeCubic::new`]: `det(q + c) − det(q)` and the coefficients of
/// h, h², h³ of `det(q + c + h·l)`, or `None` when none of its vertices moves.
fn face_terms(mesh: &TriMesh, tri: &[u32; 3], displacement: &AffineDisplacement, reference: DVec3) -> Option<[f64; 4]> {
    let [i, j, k] = tri.map(|v| v as usize);
    if !(displacement.moved[i] || displacement.moved[j] || displacement.moved[k]) {
        return None;
    }
    let q = [mesh.positions[i] - reference, mesh.positions[j] - reference, mesh.positions[k] - reference];
    let constant = [displacement.constant[i], displacement.constant[j], displacement.constant[k]];
    let linear = [displacement.linear[i], displacement.linear[j], displacement.linear[k]];
    // det(q + c) − det(q), without the cancellation of two large cones.
    let fixed = det_expansion(q, constant);
    let moved = [q[0] + constant[0], q[1] + constant[1], q[2] + constant[2]];
    let in_h = det_expansion(moved, linear);
    Some([fixed[1] + fixed[2] + fixed[3], in_h[1], in_h[2], in_h[3]])
}

/// The terms of the strip swept by boundary edge `e` in [`VolumeCubic::swept`], or `None` when
/// neither end moves.
fn strip_terms(
    mesh: &TriMesh,
    topology: &Topology,
    e: u32,
    displacement: &AffineDisplacement,
    reference: DVec3,
) -> Option<[f64; 4]> {
    let [a, b] = topology.edge(e);
    if !(displacement.moved[a as usize] || displacement.moved[b as usize]) {
        return None;
    }
    // The edge in the order of its one face, so that the strip closes the swept volume with
    // outward orientation.
    let face = mesh.triangles[topology.edge_faces(e)[0] as usize];
    let k = face.iter().position(|&v| v == a).unwrap_or(0);
    let [i, j] = if face[(k + 1) % 3] == b { [a, b] } else { [b, a] }.map(|v| v as usize);
    let q = |v: usize| mesh.positions[v] - reference;
    let moved = |v: usize| q(v) + displacement.constant[v];
    let (li, lj) = (displacement.linear[i], displacement.linear[j]);
    let first = det_expansion([q(i), q(j), moved(j)], [DVec3::ZERO, DVec3::ZERO, lj]);
    let second = det_expansion([q(i), moved(j), moved(i)], [DVec3::ZERO, lj, li]);
    Some([0, 1, 2, 3].map(|n| first[n] + second[n]))
}

/// The cubic from its faces' and strips' terms, summed in their order.
fn sum_terms<'t>(
    faces: impl Iterator<Item = &'t Option<[f64; 4]>>,
    strips: impl Iterator<Item = &'t Option<[f64; 4]>>,
) -> VolumeCubic {
    let mut c = [0.0; 4];
    for t in faces.flatten() {
        for (c, t) in c.iter_mut().zip(t) {
            *c += t;
        }
    }
    let mut cubic = VolumeCubic { coefficients: c.map(|x| x / 6.0) };
    let mut swept = [0.0; 4];
    for t in strips.flatten() {
        for (s, t) in swept.iter_mut().zip(t) {
            *s += t;
        }
    }
    for (c, s) in cubic.coefficients.iter_mut().zip(swept) {
        *c += s / 6.0;
    }
    cubic
}

/// The terms of [`VolumeCubic::swept`] per face and per boundary strip, kept between calls on one
/// region whose displacement changes at a few vertices (the rounds of the separation pass): only
/// the faces and strips around the vertices whose displacement changed (bit for bit) are
/// expanded again, and the terms are summed in the same order, so the cubic is
/// [`VolumeCubic::swept`]'s, bit for bit (tested).
#[derive(Clone, Debug, Default)]
pub struct SweptTerms {
    /// The displacement and reference point the terms are of.
    displacement: AffineDisplacement,
    reference: Option<DVec3>,
    faces: Vec<Option<[f64; 4]>>,
    /// Per boundary edge of the topology, in its order.
    strips: Vec<Option<[f64; 4]>>,
    /// Per face, the signed volume (×6) of its cone at the input positions about `reference`
    /// (empty until asked, [`SweptTerms::input_cones`]).
    cones: Vec<f64>,
}

impl SweptTerms {
    /// The displacement the terms are of.
    pub fn displacement(&self) -> &AffineDisplacement {
        &self.displacement
    }

    /// Brings the terms to the displacement given per vertex by `at` (moved, constant, linear),
    /// `whole` building all of it when the terms cannot be reused (another mesh, topology or
    /// reference, or none yet): only the faces and strips around the vertices whose displacement
    /// changed (bit for bit) are expanded again, and the cubic is summed in the same order as from
    /// scratch.
    fn update(
        &mut self,
        mesh: &TriMesh,
        topology: &Topology,
        reference: DVec3,
        whole: impl FnOnce() -> AffineDisplacement,
        at: impl Fn(usize) -> (bool, DVec3, DVec3),
    ) -> VolumeCubic {
        let bits = |p: DVec3| p.to_array().map(f64::to_bits);
        let n = mesh.num_vertices();
        let boundary = topology.boundary_edges();
        let reusable = self.reference.map(bits) == Some(bits(reference))
            && self.faces.len() == mesh.num_triangles()
            && self.strips.len() == boundary.len()
            && self.displacement.moved.len() == n;
        // The vertices whose displacement differs from the one the terms are of, written in.
        let changed: Vec<bool> = if reusable {
            let old = &mut self.displacement;
            (0..n)
                .map(|v| {
                    let (moved, constant, linear) = at(v);
                    let changed = old.moved[v] != moved
                        || bits(old.constant[v]) != bits(constant)
                        || bits(old.linear[v]) != bits(linear);
                    if changed {
                        (old.moved[v], old.constant[v], old.linear[v]) = (moved, constant, linear);
                    }
                    changed
                })
                .collect()
        } else {
            self.faces = vec![None; mesh.num_triangles()];
            self.strips = vec![None; boundary.len()];
            self.cones.clear();
            self.displacement = whole();
            vec![true; n]
        };
        self.reference = Some(reference);
        let displacement = &self.displacement;
        for (tri, slot) in mesh.triangles.iter().zip(self.faces.iter_mut()) {
            if tri.iter().any(|&v| changed[v as usize]) {
                *slot = face_terms(mesh, tri, displacement, reference);
            }
        }
        for (&e, slot) in boundary.iter().zip(self.strips.iter_mut()) {
            let [a, b] = topology.edge(e);
            if changed[a as usize] || changed[b as usize] {
                *slot = strip_terms(mesh, topology, e, displacement, reference);
            }
        }
        sum_terms(self.faces.iter(), self.strips.iter())
    }

    /// Per face of `triangles`, six times the signed volume of its cone from `reference` at the
    /// input `positions` (those the terms are of): computed at the first call after the terms
    /// were (re)built, kept after.
    pub(super) fn input_cones(&mut self, triangles: &[[u32; 3]], positions: &[DVec3], reference: DVec3) -> &[f64] {
        if self.cones.len() != triangles.len() {
            self.cones = triangles.iter().map(|tri| cone(positions, tri, reference)).collect();
        }
        &self.cones
    }

    /// [`Self::input_cones`] with the vertices the terms' displacement moves.
    pub(super) fn input_cones_and_moved(
        &mut self,
        triangles: &[[u32; 3]],
        positions: &[DVec3],
        reference: DVec3,
    ) -> (&[f64], &[bool]) {
        self.input_cones(triangles, positions, reference);
        (&self.cones, &self.displacement.moved)
    }
}

/// Six times the signed volume of the cone from `reference` over the triangle `tri` at `positions`.
#[inline]
pub(super) fn cone(positions: &[DVec3], tri: &[u32; 3], reference: DVec3) -> f64 {
    let [a, b, c] = tri.map(|v| positions[v as usize] - reference);
    a.dot(b.cross(c))
}

impl VolumeCubic {
    /// Expands ΔV(h) over the faces of `mesh` that have a moved vertex, relative to `reference`.
    pub fn new(mesh: &TriMesh, displacement: &AffineDisplacement, reference: DVec3) -> Result<Self, DeformError> {
        check_displacement(mesh, displacement)?;
        let faces: Vec<Option<[f64; 4]>> =
            mesh.triangles.iter().map(|tri| face_terms(mesh, tri, displacement, reference)).collect();
        Ok(sum_terms(faces.iter(), std::iter::empty()))
    }

    /// ΔV(h) of the volume swept by the region's displacement (see the module doc): [`Self::new`]
    /// plus the strips swept by the boundary edges of `topology` (the region's) that have a moved
    /// end. Equal to [`Self::new`] for a closed region.
    pub fn swept(
        mesh: &TriMesh,
        topology: &Topology,
        displacement: &AffineDisplacement,
        reference: DVec3,
    ) -> Result<Self, DeformError> {
        Self::swept_with(mesh, topology, displacement, reference, &mut SweptTerms::default())
    }

    /// [`Self::swept`], reusing the terms of the last call with `terms` (same mesh and topology)
    /// where the displacement did not change.
    pub fn swept_with(
        mesh: &TriMesh,
        topology: &Topology,
        displacement: &AffineDisplacement,
        reference: DVec3,
        terms: &mut SweptTerms,
    ) -> Result<Self, DeformError> {
        check_displacement(mesh, displacement)?;
        let at = |v: usize| (displacement.moved[v], displacement.constant[v], displacement.linear[v]);
        Ok(terms.update(mesh, topology, reference, || displacement.clone(), at))
    }

    /// [`Self::swept_with`] of `base` with `correction` (per vertex) added to its constant part,
    /// a vertex with a non-zero correction moving: the displacement is built in `terms`
    /// ([`SweptTerms::displacement`]) where it changed since their last call, not copied whole.
    pub fn swept_corrected(
        mesh: &TriMesh,
        topology: &Topology,
        base: &AffineDisplacement,
        correction: &[DVec3],
        reference: DVec3,
        terms: &mut SweptTerms,
    ) -> Result<Self, DeformError> {
        check_displacement(mesh, base)?;
        DeformError::check_len("correction", mesh.num_vertices(), correction.len())?;
        let at = |v: usize| {
            let c = correction[v];
            if c == DVec3::ZERO {
                (base.moved[v], base.constant[v], base.linear[v])
            } else {
                (true, base.constant[v] + c, base.linear[v])
            }
        };
        let whole = || {
            let mut d = base.clone();
            for (v, c) in correction.iter().enumerate() {
                if *c != DVec3::ZERO {
                    d.moved[v] = true;
                    d.constant[v] += *c;
                }
            }
            d
        };
        Ok(terms.update(mesh, topology, reference, whole, at))
    }

    /// ΔV(h).
    #[inline]
    pub fn eval(&self, h: f64) -> f64 {
        let [c0, c1, c2, c3] = self.coefficients;
        ((c3 * h + c2) * h + c1) * h + c0
    }
}

fn check_displacement(mesh: &TriMesh, displacement: &AffineDisplacement) -> Result<(), DeformError> {
    let n = mesh.num_vertices();
    DeformError::check_len("displacement (linear)", n, displacement.linear.len())?;
    DeformError::check_len("displacement (constant)", n, displacement.constant.len())?;
    DeformError::check_len("displacement (moved)", n, displacement.moved.len())
}

/// The signed volume swept by moving `mesh`'s vertices to `after` (see the module doc: the
/// enclosed volume's change for a closed mesh, the volume an open one keeps), relative to its
/// vertex centroid. `topology` is `mesh`'s.
pub fn swept_volume_change(mesh: &TriMesh, topology: &Topology, after: &[DVec3]) -> Result<f64, DeformError> {
    let n = mesh.num_vertices();
    DeformError::check_len("positions after", n, after.len())?;
    let mut displacement = AffineDisplacement::none(n);
    for (v, (a, b)) in mesh.positions.iter().zip(after).enumerate() {
        if a != b {
            displacement.moved[v] = true;
            displacement.constant[v] = *b - *a;
        }
    }
    let reference = crate::mesh::vertex_centroid(&mesh.positions);
    Ok(VolumeCubic::swept(mesh, topology, &displacement, reference)?.coefficients[0])
}

/// The bulge height found for a volume cubic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeightSolution {
    /// h_v.
    pub height: f64,
    /// True if `height` is a root (the volume is preserved); false for the no-root fallback.
    pub exact: bool,
    /// ΔV(height).
    pub residual: f64,
}

/// Real roots of `a x² + b x + c` (stable formula; degrades to the linear case when `a = 0`).
fn quadratic_roots(a: f64, b: f64, c: f64) -> ([f64; 2], usize) {
    if a == 0.0 {
        return if b == 0.0 { ([0.0; 2], 0) } else { ([-c / b, 0.0], 1) };
    }
    let disc = b * b - 4.0 * a * c;
    if disc < 0.0 {
        return ([0.0; 2], 0);
    }
    let q = -0.5 * (b + b.signum() * disc.sqrt());
    if q == 0.0 {
        // b = 0 and c = 0: double root at 0.
        return ([0.0, 0.0], 2);
    }
    let (r1, r2) = (q / a, c / q);
    ([r1.min(r2), r1.max(r2)], 2)
}

/// The root of `ΔV(h)` nearest 0 among h ≤ 0 (a dent), searching `h ∈ [−10⁶·scale, 0]`:
/// [`solve_bulge_height`] of the cubic mirrored by h → −h, its height negated.
pub fn solve_dent_height(cubic: &VolumeCubic, scale: f64) -> HeightSolution {
    let [c0, c1, c2, c3] = cubic.coefficients;
    let mirrored = solve_bulge_height(&VolumeCubic { coefficients: [c0, -c1, c2, -c3] }, scale);
    HeightSolution { height: -mirrored.height, ..mirrored }
}

/// The smallest non-negative root of `ΔV(h)` (see the module doc), searching `h ∈ [0, 10⁶·scale]`.
/// `scale` (> 0) is the problem's length scale (the extent).
pub fn solve_bulge_height(cubic: &VolumeCubic, scale: f64) -> HeightSolution {
    let scale = if scale.is_finite() && scale > 0.0 { scale } else { 1.0 };
    let [c0, c1, c2, c3] = cubic.coefficients;
    let mut e = [c0, c1 * scale, c2 * scale * scale, c3 * scale * scale * scale];
    let magnitude = e.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if magnitude == 0.0 || !magnitude.is_finite() {
        return HeightSolution { height: 0.0, exact: magnitude == 0.0, residual: c0 };
    }
    for x in &mut e {
        *x /= magnitude;
    }
    let p = |x: f64| ((e[3] * x + e[2]) * x + e[1]) * x + e[0];
    let exact = |x: f64| HeightSolution { height: x * scale, exact: true, residual: cubic.eval(x * scale) };
    if e[0] == 0.0 {
        return exact(0.0);
    }
    let (roots, count) = quadratic_roots(3.0 * e[3], 2.0 * e[2], e[1]);
    let mut breaks = [0.0; 4];
    let mut len = 1;
    for &r in &roots[..count] {
        if r > 0.0 && r < MAX_SCALED_HEIGHT && r > breaks[len - 1] {
            breaks[len] = r;
            len += 1;
        }
    }
    breaks[len] = MAX_SCALED_HEIGHT;
    len += 1;
    for w in breaks[..len].windows(2) {
        let (mut lo, mut hi) = (w[0], w[1]);
        let (plo, phi) = (p(lo), p(hi));
        if phi == 0.0 {
            return exact(hi);
        }
        if plo.signum() == phi.signum() {
            continue;
        }
        // Monotone on [lo, hi] with a sign change: bisect to adjacent floats.
        let lo_sign = plo.signum();
        loop {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            let pm = p(mid);
            if pm == 0.0 {
                return exact(mid);
            }
            if pm.signum() == lo_sign {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let x = if p(lo).abs() <= p(hi).abs() { lo } else { hi };
        return exact(x);
    }
    // No root: the h ≥ 0 closest to preserving the volume, among 0 and the critical points.
    let mut best = (0.0, p(0.0).abs());
    for &x in &breaks[1..len - 1] {
        if p(x).abs() < best.1 {
            best = (x, p(x).abs());
        }
    }
    let height = best.0 * scale;
    HeightSolution { height, exact: false, residual: cubic.eval(height) }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::deform::test_support::Rng;
    use crate::mesh::{shapes, signed_volume};

    fn cubic(c: [f64; 4]) -> VolumeCubic {
        VolumeCubic { coefficients: c }
    }

    #[test]
    fn smallest_positive_root_of_cubics_quadratics_and_lines() {
        // (h + 1)(h − 2)(h − 5) = h³ − 6h² + 3h + 10
        let s = solve_bulge_height(&cubic([10.0, 3.0, -6.0, 1.0]), 1.0);
        assert!(s.exact && (s.height - 2.0).abs() < 1e-14, "{s:?}");
        // Same with a length scale: roots scale with it.
        let s = solve_bulge_height(&cubic([10.0, 3.0 / 0.1, -6.0 / 0.01, 1.0 / 0.001]), 0.1);
        assert!(s.exact && (s.height - 0.2).abs() < 1e-14, "{s:?}");
        // Quadratic (h − 3)(h − 4) and line 2h − 1.
        let s = solve_bulge_height(&cubic([12.0, -7.0, 1.0, 0.0]), 1.0);
        assert!((s.height - 3.0).abs() < 1e-13);
        let s = solve_bulge_height(&cubic([-1.0, 2.0, 0.0, 0.0]), 1.0);
        assert!((s.height - 0.5).abs() < 1e-15);
        // A vanishing leading coefficient changes nothing: h − 2 + 1e-20 h³.
        let s = solve_bulge_height(&cubic([-2.0, 1.0, 0.0, 1e-20]), 1.0);
        assert!((s.height - 2.0).abs() < 1e-14);
        // The typical case: volume lost (c0 < 0), the bulge adds (c1 > 0), mild curvature.
        let s = solve_bulge_height(&cubic([-0.03, 0.5, -0.2, 0.05]), 0.8);
        assert!(s.exact && s.residual.abs() < 1e-17 && s.height > 0.0);
    }

    #[test]
    fn without_a_positive_root_the_closest_height_is_taken_and_reported() {
        // ΔV = h² + 1 > 0 everywhere: the minimum of |ΔV| over h ≥ 0 is at 0.
        let s = solve_bulge_height(&cubic([1.0, 0.0, 1.0, 0.0]), 1.0);
        assert_eq!((s.height, s.exact, s.residual), (0.0, false, 1.0));
        // ΔV = (h − 3)² + 0.5: the closest is h = 3, not 0.
        let s = solve_bulge_height(&cubic([9.5, -6.0, 1.0, 0.0]), 1.0);
        assert!(!s.exact && (s.height - 3.0).abs() < 1e-12 && (s.residual - 0.5).abs() < 1e-12, "{s:?}");
        // Only negative roots: (h + 1)(h + 2) → 0.
        let s = solve_bulge_height(&cubic([2.0, 3.0, 1.0, 0.0]), 1.0);
        assert_eq!((s.height, s.exact), (0.0, false));
        // Nothing depends on h and nothing changed: 0 is exact.
        let s = solve_bulge_height(&cubic([0.0; 4]), 1.0);
        assert!(s.exact && s.height == 0.0);
    }

    #[test]
    fn the_cubic_is_the_exact_volume_change() {
        let mesh = shapes::icosphere(1.3, 3);
        let mut rng = Rng::new(17);
        let n = mesh.num_vertices();
        let mut displacement = AffineDisplacement::none(n);
        for v in 0..n {
            if mesh.positions[v].z < 0.2 {
                displacement.moved[v] = true;
                displacement.linear[v] = DVec3::new(rng.signed(), rng.signed(), rng.signed()) * 0.1;
                displacement.constant[v] = DVec3::new(rng.signed(), rng.signed(), rng.signed()) * 0.05;
            }
        }
        let cubic = VolumeCubic::new(&mesh, &displacement, DVec3::new(0.1, -0.2, 0.3)).unwrap();
        assert!(VolumeCubic::new(&mesh, &AffineDisplacement::none(3), DVec3::ZERO).is_err());
        let v0 = signed_volume(&mesh);
        for h in [0.0, 0.3, -1.2, 2.5] {
            let mut moved = mesh.clone();
            for v in 0..n {
                moved.positions[v] += h * displacement.linear[v] + displacement.constant[v];
            }
            let exact = signed_volume(&moved) - v0;
            assert!((cubic.eval(h) - exact).abs() < 1e-13, "h = {h}: {} vs {exact}", cubic.eval(h));
        }
    }
}
