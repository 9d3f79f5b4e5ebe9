//! The displacement profile 𝓗 (thesis §5.4.1): an open uniform cubic 2D B-spline
//! `f(t) = Σ_k v_k N_k(t)`, `t ∈ [0, 1]`, knots `(0, 0, 0, 0, 1/3, 2/3, 1, 1, 1, 1)`, six control
//! points per vertex, evaluated as a function of the radial parameter `u` by
//! `𝓗(u) = f₂(f₁⁻¹(u))`.
//!
//! Control points (decisions):
//! - `v0 = (0, −a)`: `𝓗(0) = −a`. Amplitudes are signed (see [`super::guide`]): a vertex at the
//!   contact boundary moves by `−a·d`.
//! - `v1` on the ellipse arc of THESIS-NOTES item 5 (the table version, not the algorithm box):
//!   centre `(0, −a)`, semi-axes `0.2` along x and `0.4·|a|` along y, on the line of slope `s`
//!   through `v0`: `x1 = 0.2·|a| / √(a² + s²/4)` (0.2 when `a = s = 0`), `y1 = −a + s·x1`. The
//!   curve's tangent at `t = 0` is `v1 − v0`, so `𝓗′(0) = s` exactly (world units per unit of u)
//!   for either sign of `a`, as long as `a ≠ 0`. When `a = 0` and `s ≠ 0`, `v1 = v0`: the slope
//!   handle vanishes with the amplitude (the ellipse has no height), and the initial slope is that
//!   of `v2 − v0`. This is the thesis' design (the slope is expressed relative to the amplitude);
//!   it is continuous in `(a, s)`.
//! - `v2 = (x2, γ·η·h_v)`: the bulge ordinate, set by the volume stage.
//! - `v3 = (x3, 0)`, `v4 = (x4, 0)`, `v5 = (1, 0)`: three aligned points give `𝓗(1) = 𝓗′(1) =
//!   𝓗″(1) = 0`, a C² junction with the undeformed surface at ∂𝒟.
//!
//! Abscissas `(x2, x3, x4)` default to `(1/3, 5/6, 11/12)` and must satisfy
//! `0.2 < x2 < x3 < x4 < 1`: with `0 ≤ x1 ≤ 0.2` the abscissas of the control polygon increase, so
//! `f₁` is increasing (a B-spline's derivative is a spline of the control-point differences, all
//! non-negative here) and 𝓗 is a function of u.
//!
//! Inversion of `f₁`: the secant method safeguarded by bisection on a bracket (f₁ is monotone),
//! to `|f₁(t) − u| ≤ 1e-14`.
//!
//! Optional wrinkles (Figs. 7.18–7.19, "adding a sinusoid to the profile curve"): `𝓗(u) +=
//! A·sin(2π·f·u)·64·(u(1 − u))³`. The window `64(u(1 − u))³` peaks at 1 for `u = ½` and has a
//! triple zero at both ends, so the modulation vanishes with zero slope at `u = 0` (the contact
//! boundary keeps its amplitude and slope) and with zero slope and curvature at `u = 1` (the C²
//! junction at ∂𝒟 is kept). `A` is in world units, `f` in cycles over `[0, 1]`.

use super::DeformError;

/// The knot vector of the profile spline.
const KNOTS: [f64; 10] = [0.0, 0.0, 0.0, 0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0, 1.0, 1.0, 1.0];

/// Largest abscissa of `v1` (reached when the slope vanishes): `x2` must exceed it.
pub const MAX_SECOND_ABSCISSA: f64 = crate::params::MIN_PROFILE_ABSCISSA;

/// Tolerance of the inversion of `f₁`.
const INVERSION_TOLERANCE: f64 = 1e-14;

/// User-editable abscissas of the control points `v2`, `v3`, `v4` (thesis Fig. 5.4, Fig. 7.18).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct ProfileShape {
    /// Abscissa of `v2`, the bulge control point. Default 1/3.
    pub x2: f64,
    /// Abscissa of `v3`. Default 5/6.
    pub x3: f64,
    /// Abscissa of `v4`. Default 11/12.
    pub x4: f64,
}

impl Default for ProfileShape {
    /// The object parameters' defaults ([`crate::ObjectParams::profile_v2`] …).
    fn default() -> Self {
        let [x2, x3, x4] = crate::ObjectParams::default().profile();
        Self { x2, x3, x4 }
    }
}

impl ProfileShape {
    /// Checks `0.2 < x2 < x3 < x4 < 1` (and finiteness).
    pub fn validate(&self) -> Result<(), DeformError> {
        let Self { x2, x3, x4 } = *self;
        let ordered = MAX_SECOND_ABSCISSA < x2 && x2 < x3 && x3 < x4 && x4 < 1.0;
        if ordered { Ok(()) } else { Err(DeformError::InvalidProfile { x2, x3, x4 }) }
    }
}

/// Procedural sinusoidal modulation of the profile (wrinkles, thesis Figs. 7.18–7.19).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct Wrinkles {
    /// Amplitude `A` in world units (0 = no wrinkles, the default).
    pub amplitude: f64,
    /// Frequency `f` in cycles over the deformable region's radial range `u ∈ [0, 1]`.
    pub frequency: f64,
}

impl Wrinkles {
    /// The modulation `A·sin(2π·f·u)·64·(u(1 − u))³` added to 𝓗(u) (0 outside `[0, 1]`).
    #[inline]
    pub fn at(&self, u: f64) -> f64 {
        if self.amplitude == 0.0 || !(0.0..=1.0).contains(&u) {
            return 0.0;
        }
        let window = u * (1.0 - u);
        self.amplitude * (std::f64::consts::TAU * self.frequency * u).sin() * 64.0 * window * window * window
    }
}

/// The six cubic B-spline basis functions `N_k(t)` of the profile's knot vector at `t` (clamped
/// to `[0, 1]`). They are non-negative and sum to 1.
pub fn basis(t: f64) -> [f64; 6] {
    let (span, _, cubic) = span_basis(t);
    let mut out = [0.0; 6];
    out[span - 3..=span].copy_from_slice(&cubic);
    out
}

/// The knot span `k ∈ {3, 4, 5}` holding `t` (clamped to `[0, 1]`; t = 1 belongs to the last
/// span) and the basis functions that are nonzero on it: the quadratic `N_{k−2..k, 2}` and the
/// cubic `N_{k−3..k, 3}` (Cox–de Boor triangle).
fn span_basis(t: f64) -> (usize, [f64; 3], [f64; 4]) {
    let t = t.clamp(0.0, 1.0);
    let span = if t < KNOTS[4] {
        3
    } else if t < KNOTS[5] {
        4
    } else {
        5
    };
    span_basis_in(t, span)
}

/// [`span_basis`] on the given knot span (3, 4 or 5), which must hold `t` in its closure.
fn span_basis_in(t: f64, span: usize) -> (usize, [f64; 3], [f64; 4]) {
    let mut n = [0.0f64; 4];
    let mut quadratic = [0.0f64; 3];
    let mut left = [0.0f64; 4];
    let mut right = [0.0f64; 4];
    n[0] = 1.0;
    for j in 1..=3 {
        left[j] = t - KNOTS[span + 1 - j];
        right[j] = KNOTS[span + j] - t;
        let mut saved = 0.0;
        for r in 0..j {
            let denominator = right[r + 1] + left[j - r];
            let temp = if denominator == 0.0 { 0.0 } else { n[r] / denominator };
            n[r] = saved + right[r + 1] * temp;
            saved = left[j - r] * temp;
        }
        n[j] = saved;
        if j == 2 {
            quadratic.copy_from_slice(&n[..3]);
        }
    }
    (span, quadratic, n)
}

/// The abscissa of `v1` for amplitude `a` and slope `s`: `0.2·|a| / √(a² + s²/4)`, 0.2 when both
/// vanish (see the module doc).
#[inline]
pub fn second_abscissa(amplitude: f64, slope: f64) -> f64 {
    let norm = amplitude.hypot(0.5 * slope);
    if norm == 0.0 || !norm.is_finite() {
        // a = s = 0: a flat start; an infinite slope: a vertical start.
        return if norm == 0.0 { MAX_SECOND_ABSCISSA } else { 0.0 };
    }
    MAX_SECOND_ABSCISSA * amplitude.abs() / norm
}

/// One vertex's profile curve: abscissas and ordinates of its six control points.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    /// Abscissas `x_0 … x_5`.
    pub x: [f64; 6],
    /// Ordinates `y_0 … y_5` (`y_2` is the bulge ordinate).
    pub y: [f64; 6],
}

impl Profile {
    /// The profile with amplitude `a` (𝓗(0) = −a), slope `s` (𝓗′(0) = s when a ≠ 0) and bulge
    /// ordinate `bulge` (= γ·η·h_v) for the given abscissas.
    pub fn new(shape: &ProfileShape, amplitude: f64, slope: f64, bulge: f64) -> Self {
        let x1 = second_abscissa(amplitude, slope);
        Self {
            x: [0.0, x1, shape.x2, shape.x3, shape.x4, 1.0],
            y: [-amplitude, -amplitude + slope * x1, bulge, 0.0, 0.0, 0.0],
        }
    }

    /// The curve point `f(t) = (f₁(t), f₂(t))`.
    pub fn point(&self, t: f64) -> (f64, f64) {
        let n = basis(t);
        let mut p = (0.0, 0.0);
        for ((x, y), n) in self.x.iter().zip(&self.y).zip(&n) {
            p.0 += x * n;
            p.1 += y * n;
        }
        p
    }

    /// `f₁(t)`.
    #[inline]
    pub fn abscissa(&self, t: f64) -> f64 {
        let n = basis(t);
        (0..6).map(|k| self.x[k] * n[k]).sum()
    }

    /// `f₁(t)` and `f₁′(t)` (the derivative of a cubic B-spline is the quadratic B-spline of the
    /// control-point differences `3(x_{i+1} − x_i)/(k_{i+4} − k_{i+1})`).
    #[inline]
    fn abscissa_and_slope(&self, t: f64) -> (f64, f64) {
        let (span, quadratic, cubic) = span_basis(t);
        let value = (0..4).map(|r| self.x[span - 3 + r] * cubic[r]).sum();
        let slope = (0..3)
            .map(|r| {
                let i = span - 3 + r;
                3.0 * (self.x[i + 1] - self.x[i]) / (KNOTS[i + 4] - KNOTS[i + 1]) * quadratic[r]
            })
            .sum();
        (value, slope)
    }

    /// `t = f₁⁻¹(u)` for `u ∈ [0, 1]` (clamped): Newton iterations from `t = u` kept inside a
    /// bracket, bisecting whenever the Newton step would leave the bracket or not halve the step
    /// before last (f₁ is increasing: the bracket guarantees convergence, Newton makes it take a
    /// few steps; formerly secant steps took about three times as many evaluations).
    pub fn parameter_at(&self, u: f64) -> f64 {
        if u.is_nan() || u <= 0.0 {
            return 0.0;
        }
        if u >= 1.0 {
            return 1.0;
        }
        increasing_inverse(u, u, |t| self.abscissa_and_slope(t))
    }

    /// 𝓗(u) = f₂(f₁⁻¹(u)) (without wrinkles); 0 for `u ≥ 1`.
    pub fn height(&self, u: f64) -> f64 {
        self.point(self.parameter_at(u)).1
    }
}

/// The profile at one vertex split into what the volume stage needs: 𝓗(u) = `bulge_weight`·y₂ +
/// `fixed`, affine in the bulge ordinate `y₂` (thesis Eq. 5.5, App. C).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProfileSample {
    /// `N₂(t)` at `t = f₁⁻¹(u)`: the weight of the bulge ordinate.
    pub bulge_weight: f64,
    /// `Σ_{k≠2} y_k N_k(t)` plus the wrinkle modulation.
    pub fixed: f64,
}

/// The `t ∈ [0, 1]` where the increasing function `f` reaches `u` (`f_and_slope(t)` = (f(t),
/// f′(t))), to `|f(t) − u| ≤ 1e-14`: Newton iterations from `start` kept inside a bracket,
/// bisecting whenever the Newton step would leave the bracket or not halve the step before last
/// (the bracket guarantees convergence, Newton makes it take a few steps).
fn increasing_inverse(u: f64, start: f64, f_and_slope: impl Fn(f64) -> (f64, f64)) -> f64 {
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    let (mut step, mut step_before) = (1.0f64, 1.0f64);
    let mut t = start;
    for _ in 0..200 {
        let (value, slope) = f_and_slope(t);
        let r = value - u;
        if r.abs() <= INVERSION_TOLERANCE {
            return t;
        }
        if r < 0.0 {
            lo = t;
        } else {
            hi = t;
        }
        if hi - lo <= f64::EPSILON * hi {
            return 0.5 * (lo + hi);
        }
        let newton = t - r / slope;
        let previous = step_before;
        step_before = step;
        if newton > lo && newton < hi && (2.0 * r).abs() <= (previous * slope).abs() {
            step = (newton - t).abs();
            t = newton;
        } else {
            step = 0.5 * (hi - lo);
            t = lo + step;
        }
    }
    0.5 * (lo + hi)
}

/// The profile's basis functions as cubic polynomials on each knot span, for sampling many
/// vertices' profiles (one inversion of f₁ each) at a fraction of the cost of Cox–de Boor.
///
/// On span `k` (`t ∈ [k/3, (k+1)/3]`, local parameter `τ = 3t − k ∈ [0, 1]`) every `N_i` is a
/// cubic in τ; its power-basis coefficients are found once by interpolating the Cox–de Boor
/// values at τ = 0, ⅓, ⅔, 1. A vertex's f₁ on the span is then `Σ_i x_i N_i`, four coefficients,
/// and only `x₁` changes from vertex to vertex. The inversion brackets u between the span's end
/// values and runs safeguarded Newton steps on the cubic to the same tolerance as
/// [`Profile::parameter_at`] (|f₁(t) − u| ≤ 1e-14), so both give the same t up to that tolerance.
#[derive(Clone, Debug, PartialEq)]
pub struct ProfileSampler {
    shape: ProfileShape,
    /// `[span][i]`: power coefficients (τ⁰ … τ³) of `N_i` on the span.
    basis: [[[f64; 4]; 6]; 3],
    /// f₁ on each span without the `x₁·N₁` term (the part shared by every vertex).
    shared: [[f64; 4]; 3],
}

impl ProfileSampler {
    /// Precomputes the span polynomials for the abscissas `shape`.
    pub fn new(shape: &ProfileShape) -> Self {
        let mut basis = [[[0.0; 4]; 6]; 3];
        for (span, polynomials) in basis.iter_mut().enumerate() {
            // Values at τ = 0, ⅓, ⅔, 1 (t just inside the span's ends at τ = 1: the basis is
            // continuous, and span_basis puts t = (k+1)/3 in the next span).
            let values: Vec<[f64; 6]> = (0..4)
                .map(|q| {
                    let t = (span as f64 + q as f64 / 3.0) / 3.0;
                    let (k, _, cubic) = span_basis_in(t, span + 3);
                    let mut out = [0.0; 6];
                    out[k - 3..=k].copy_from_slice(&cubic);
                    out
                })
                .collect();
            for (i, polynomial) in polynomials.iter_mut().enumerate() {
                *polynomial = cubic_through([values[0][i], values[1][i], values[2][i], values[3][i]]);
            }
        }
        let x = [0.0, 0.0, shape.x2, shape.x3, shape.x4, 1.0];
        let mut shared = [[0.0; 4]; 3];
        for (span, coefficients) in shared.iter_mut().enumerate() {
            for (i, &xi) in x.iter().enumerate() {
                for (c, b) in coefficients.iter_mut().zip(&basis[span][i]) {
                    *c += xi * b;
                }
            }
        }
        Self { shape: *shape, basis, shared }
    }

    /// f₁'s coefficients on `span` for the second abscissa `x1`.
    #[inline]
    fn abscissa_polynomial(&self, span: usize, x1: f64) -> [f64; 4] {
        let (shared, n1) = (&self.shared[span], &self.basis[span][1]);
        [shared[0] + x1 * n1[0], shared[1] + x1 * n1[1], shared[2] + x1 * n1[2], shared[3] + x1 * n1[3]]
    }

    /// The span and local parameter τ with f₁ = u, for the second abscissa `x1`.
    fn invert(&self, x1: f64, u: f64) -> (usize, f64) {
        if u.is_nan() || u <= 0.0 {
            return (0, 0.0);
        }
        if u >= 1.0 {
            return (2, 1.0);
        }
        // f₁ at the interior knots: the span's polynomial at τ = 1 is the sum of its coefficients.
        let end_of = |span: usize| self.abscissa_polynomial(span, x1).iter().sum::<f64>();
        let span = if u < end_of(0) {
            0
        } else if u < end_of(1) {
            1
        } else {
            2
        };
        let c = self.abscissa_polynomial(span, x1);
        // Start from the chord of the span.
        let (start, end) = (c[0], c.iter().sum::<f64>());
        let tau = if end > start { ((u - start) / (end - start)).clamp(0.0, 1.0) } else { 0.5 };
        let tau = increasing_inverse(u, tau, |tau| {
            (c[0] + tau * (c[1] + tau * (c[2] + tau * c[3])), c[1] + tau * (2.0 * c[2] + tau * 3.0 * c[3]))
        });
        (span, tau)
    }

    /// `N_i` at local parameter `tau` of `span`.
    #[inline]
    fn basis_at(&self, span: usize, i: usize, tau: f64) -> f64 {
        let c = &self.basis[span][i];
        c[0] + tau * (c[1] + tau * (c[2] + tau * c[3]))
    }

    /// Samples the profile of a vertex with amplitude `a`, slope `s` at parameter `u` (from the
    /// tabulated basis; the same values as building its [`Profile`]).
    pub fn sample(&self, wrinkles: &Wrinkles, amplitude: f64, slope: f64, u: f64) -> ProfileSample {
        let x1 = second_abscissa(amplitude, slope);
        let (span, tau) = self.invert(x1, u);
        // At t = 1 only N₅ is non-zero; the polynomials would leave round-off there.
        let n = if span == 2 && tau >= 1.0 { [0.0; 3] } else { [0, 1, 2].map(|i| self.basis_at(span, i, tau)) };
        let (y0, y1) = (-amplitude, -amplitude + slope * x1);
        ProfileSample { bulge_weight: n[2], fixed: y0 * n[0] + y1 * n[1] + wrinkles.at(u) }
    }

    /// The abscissas the sampler was built for.
    pub fn shape(&self) -> &ProfileShape {
        &self.shape
    }
}

/// The power coefficients of the cubic through `(q/3, values[q])`, q = 0..3.
fn cubic_through(values: [f64; 4]) -> [f64; 4] {
    // Newton's divided differences on the nodes 0, ⅓, ⅔, 1, expanded to the power basis.
    let h = 1.0 / 3.0;
    let d1 = [(values[1] - values[0]) / h, (values[2] - values[1]) / h, (values[3] - values[2]) / h];
    let d2 = [(d1[1] - d1[0]) / (2.0 * h), (d1[2] - d1[1]) / (2.0 * h)];
    let d3 = (d2[1] - d2[0]) / (3.0 * h);
    // p(τ) = v0 + d1₀ τ + d2₀ τ(τ − h) + d3 τ(τ − h)(τ − 2h)
    [values[0], d1[0] - d2[0] * h + d3 * 2.0 * h * h, d2[0] - d3 * 3.0 * h, d3]
}

/// Samples the profile of a vertex with amplitude `a`, slope `s` at parameter `u`, from scratch:
/// the reference [`ProfileSampler::sample`] is tested against.
#[cfg(test)]
pub fn sample(shape: &ProfileShape, wrinkles: &Wrinkles, amplitude: f64, slope: f64, u: f64) -> ProfileSample {
    let profile = Profile::new(shape, amplitude, slope, 0.0);
    let n = basis(profile.parameter_at(u));
    let fixed = profile.y[0] * n[0] + profile.y[1] * n[1] + wrinkles.at(u);
    ProfileSample { bulge_weight: n[2], fixed }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn profile(a: f64, s: f64, bulge: f64) -> Profile {
        Profile::new(&ProfileShape::default(), a, s, bulge)
    }

    #[test]
    fn the_span_polynomial_sampler_matches_cox_de_boor() {
        let wrinkles = Wrinkles { amplitude: 0.01, frequency: 3.0 };
        for shape in [ProfileShape::default(), ProfileShape { x2: 0.25, x3: 0.5, x4: 0.9 }] {
            let sampler = ProfileSampler::new(&shape);
            // Basis polynomials reproduce Cox–de Boor on every span.
            for k in 0..=300 {
                let t = k as f64 / 300.0;
                let span = ((3.0 * t) as usize).min(2);
                let tau = 3.0 * t - span as f64;
                let exact = basis(t);
                for (i, &e) in exact.iter().enumerate() {
                    assert!((sampler.basis_at(span, i, tau) - e).abs() < 1e-14, "t = {t}, N{i}");
                }
            }
            let mut worst = 0.0f64;
            for &(a, s) in &[(0.3, 0.5), (-0.2, -1.0), (0.0, 0.7), (0.0, 0.0), (1e-9, 3.0), (0.05, 40.0), (2.0, -0.01)]
            {
                for k in 0..=400 {
                    let u = k as f64 / 400.0 + if k % 7 == 0 { 1e-13 } else { 0.0 };
                    let fast = sampler.sample(&wrinkles, a, s, u);
                    let slow = sample(&shape, &wrinkles, a, s, u);
                    let scale = 1.0 + a.abs() + s.abs();
                    worst = worst
                        .max((fast.fixed - slow.fixed).abs() / scale)
                        .max((fast.bulge_weight - slow.bulge_weight).abs());
                }
            }
            // Both invert f₁ to 1e-14; where f₁′ vanishes (a = 0, s ≠ 0, at u → 0) the parameters
            // may differ by √1e-14, but there the sampled values are flat too.
            assert!(worst < 1e-10, "largest difference {worst:e}");
            assert_eq!(sampler.sample(&wrinkles, 0.3, 0.5, 0.0).fixed, -0.3);
            assert_eq!(sampler.sample(&wrinkles, 0.3, 0.5, 1.0), ProfileSample { bulge_weight: 0.0, fixed: 0.0 });
        }
    }

    #[test]
    fn basis_is_a_partition_of_unity_and_interpolates_the_ends() {
        for k in 0..=1000 {
            let t = k as f64 / 1000.0;
            let n = basis(t);
            assert!(n.iter().all(|&x| x >= -1e-15), "t = {t}: {n:?}");
            assert!((n.iter().sum::<f64>() - 1.0).abs() < 1e-14, "t = {t}");
        }
        assert_eq!(basis(0.0), [1.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
        assert_eq!(basis(1.0), [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        // Continuity across the interior knots.
        for knot in [1.0 / 3.0, 2.0 / 3.0] {
            let (a, b) = (basis(knot - 1e-12), basis(knot + 1e-12));
            for k in 0..6 {
                assert!((a[k] - b[k]).abs() < 1e-10);
            }
        }
    }

    #[test]
    fn profile_starts_at_minus_the_amplitude_with_the_requested_slope() {
        // Finite differences of 𝓗 at u = 0, both signs of a and s, steep and flat slopes.
        for &(a, s) in &[(0.3, 0.5), (0.3, -0.5), (-0.2, 0.7), (-0.2, -0.1), (0.05, 4.0), (1.0, 0.0), (0.01, -2.0)] {
            for bulge in [0.0, 0.4] {
                let p = profile(a, s, bulge);
                assert_eq!(p.height(0.0), -a);
                let du = 1e-9;
                let slope = (p.height(du) - p.height(0.0)) / du;
                // The second-order term of 𝓗 at 0 makes the one-sided difference O(du · 𝓗″).
                assert!((slope - s).abs() < 2e-5 * (1.0 + s.abs()), "a = {a}, s = {s}: slope {slope}");
            }
        }
    }

    #[test]
    fn profile_joins_the_surface_with_zero_value_slope_and_curvature() {
        for &(a, s, bulge) in &[(0.3, 0.5, 0.2), (-0.2, -1.0, 0.5), (0.0, 0.0, 1.0)] {
            let p = profile(a, s, bulge);
            assert_eq!(p.height(1.0), 0.0);
            // 𝓗(1 − δ) = O(δ³): value, slope and curvature vanish at u = 1.
            for delta in [1e-2, 5e-3, 2.5e-3] {
                let h = p.height(1.0 - delta);
                assert!(h.abs() < 60.0 * bulge.abs().max(1e-3) * delta * delta * delta, "δ = {delta}: {h}");
            }
            let (h1, h2) = (p.height(1.0 - 0.01), p.height(1.0 - 0.005));
            // Cubic decay: halving δ divides 𝓗 by about 8.
            if h1.abs() > 1e-12 {
                let ratio = h1 / h2;
                assert!((ratio - 8.0).abs() < 0.5, "decay ratio {ratio}");
            }
        }
    }

    #[test]
    fn the_abscissa_slope_is_its_derivative() {
        for &(a, s) in &[(0.3, 0.5), (0.0, 3.0), (1e-6, 1e3), (-0.4, 0.2)] {
            let p = profile(a, s, 0.3);
            for k in 1..200 {
                let t = k as f64 / 200.0;
                let e = 1e-6;
                let numeric = (p.abscissa(t + e) - p.abscissa(t - e)) / (2.0 * e);
                let (value, slope) = p.abscissa_and_slope(t);
                assert!((value - p.abscissa(t)).abs() <= 1e-15, "t = {t}");
                assert!((slope - numeric).abs() <= 1e-6 * (1.0 + slope.abs()), "a = {a}, s = {s}, t = {t}");
            }
        }
    }

    #[test]
    fn abscissa_is_increasing_and_inversion_is_accurate() {
        for &(a, s) in &[(0.3, 0.5), (0.0, 3.0), (0.0, 0.0), (1e-6, 1e3), (-0.4, 0.2)] {
            let p = profile(a, s, 0.3);
            let mut previous = -1.0;
            for k in 0..=2000 {
                let x = p.abscissa(k as f64 / 2000.0);
                assert!(x >= previous, "f1 must be non-decreasing (a = {a}, s = {s})");
                previous = x;
            }
            for k in 0..=997 {
                let u = k as f64 / 997.0;
                let t = p.parameter_at(u);
                assert!((p.abscissa(t) - u).abs() <= 1e-13, "a = {a}, s = {s}, u = {u}");
            }
        }
    }

    #[test]
    fn shape_validation_rejects_unordered_abscissas() {
        assert!(ProfileShape::default().validate().is_ok());
        for (x2, x3, x4) in [(0.2, 0.5, 0.9), (0.5, 0.4, 0.9), (0.3, 0.6, 1.0), (f64::NAN, 0.5, 0.9)] {
            let err = ProfileShape { x2, x3, x4 }.validate().unwrap_err();
            assert!(err.to_string().contains("0.2 < x2 < x3 < x4 < 1"), "{err}");
        }
    }

    #[test]
    fn wrinkles_vanish_with_their_derivatives_at_the_ends() {
        let w = Wrinkles { amplitude: 0.1, frequency: 3.5 };
        assert_eq!(w.at(0.0), 0.0);
        assert_eq!(w.at(1.0), 0.0);
        let d = 1e-3;
        // Triple zeros: w(δ) = O(δ³) at both ends.
        assert!(w.at(d).abs() < 64.0 * 0.1 * 25.0 * d.powi(4) + 1e-15);
        assert!(w.at(1.0 - d).abs() < 64.0 * 0.1 * d.powi(3) + 1e-15);
        assert!((w.at(0.5) - 0.1 * (std::f64::consts::PI * 3.5).sin()).abs() < 1e-15);
    }

    #[test]
    fn samples_are_affine_in_the_bulge_ordinate() {
        let shape = ProfileShape::default();
        let wrinkles = Wrinkles { amplitude: 0.02, frequency: 2.0 };
        for &(a, s, u) in &[(0.3, 0.5, 0.1), (-0.1, 1.0, 0.5), (0.0, 0.4, 0.8)] {
            let sample = sample(&shape, &wrinkles, a, s, u);
            for bulge in [0.0, 0.7, -0.3] {
                let direct = Profile::new(&shape, a, s, bulge).height(u) + wrinkles.at(u);
                let affine = sample.fixed + bulge * sample.bulge_weight;
                assert!((direct - affine).abs() < 1e-14, "{direct} vs {affine}");
            }
        }
    }
}
