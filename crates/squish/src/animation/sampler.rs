//! Keyframe samplers: key times, values and an interpolation, evaluated at any time (glTF 2.0
//! animation samplers, spec §3.11 and Appendix C).

use glam::{DQuat, DVec3};

use super::AnimationError;

/// How values between two keys are computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum Interpolation {
    /// Linear interpolation; spherical (shortest arc) for rotations.
    #[default]
    Linear,
    /// The value of the previous key, held until the next key.
    Step,
    /// Cubic Hermite spline with an in-tangent and an out-tangent per key (values are stored as
    /// `[in_0, v_0, out_0, in_1, v_1, out_1, …]`, as in glTF). Tangents are per unit of time:
    /// between keys `k` and `k + 1`, the Hermite tangents are `Δt · out_k` and `Δt · in_(k+1)`.
    CubicSpline,
}

impl Interpolation {
    /// The glTF name (`LINEAR`, `STEP`, `CUBICSPLINE`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Linear => "LINEAR",
            Self::Step => "STEP",
            Self::CubicSpline => "CUBICSPLINE",
        }
    }
}

/// A value type that can be keyframed.
pub trait Keyframe: Copy {
    /// Interpolates linearly between `a` (at `s = 0`) and `b` (at `s = 1`).
    fn interpolate_linear(a: Self, b: Self, s: f64) -> Self;
    /// The cubic Hermite blend `h00 p0 + h10 m0 + h01 p1 + h11 m1` of values and (already scaled)
    /// tangents, followed by whatever projection keeps the value valid (normalizing a rotation).
    fn hermite(p0: Self, m0: Self, p1: Self, m1: Self, s: f64) -> Self;
    /// True if every component is finite.
    fn is_finite_value(&self) -> bool;
    /// Scales a tangent by a time span.
    fn scaled(self, factor: f64) -> Self;
}

/// Hermite basis at `s`: (h00, h10, h01, h11).
fn hermite_basis(s: f64) -> [f64; 4] {
    let s2 = s * s;
    let s3 = s2 * s;
    [2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, -2.0 * s3 + 3.0 * s2, s3 - s2]
}

impl Keyframe for f64 {
    fn interpolate_linear(a: Self, b: Self, s: f64) -> Self {
        a + (b - a) * s
    }
    fn hermite(p0: Self, m0: Self, p1: Self, m1: Self, s: f64) -> Self {
        let [h00, h10, h01, h11] = hermite_basis(s);
        h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1
    }
    fn is_finite_value(&self) -> bool {
        self.is_finite()
    }
    fn scaled(self, factor: f64) -> Self {
        self * factor
    }
}

impl Keyframe for DVec3 {
    fn interpolate_linear(a: Self, b: Self, s: f64) -> Self {
        a + (b - a) * s
    }
    fn hermite(p0: Self, m0: Self, p1: Self, m1: Self, s: f64) -> Self {
        let [h00, h10, h01, h11] = hermite_basis(s);
        h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1
    }
    fn is_finite_value(&self) -> bool {
        self.is_finite()
    }
    fn scaled(self, factor: f64) -> Self {
        self * factor
    }
}

impl Keyframe for DQuat {
    fn interpolate_linear(a: Self, b: Self, s: f64) -> Self {
        slerp_shortest(a, b, s)
    }
    fn hermite(p0: Self, m0: Self, p1: Self, m1: Self, s: f64) -> Self {
        let [h00, h10, h01, h11] = hermite_basis(s);
        let q = p0 * h00 + m0 * h10 + p1 * h01 + m1 * h11;
        // glTF: the spline runs on the raw components and the result is normalized. A spline
        // through q and -q may pass near zero; fall back to the nearer key then.
        let len = q.length();
        if len > 1e-12 {
            q / len
        } else if s < 0.5 {
            p0
        } else {
            p1
        }
    }
    fn is_finite_value(&self) -> bool {
        self.is_finite()
    }
    fn scaled(self, factor: f64) -> Self {
        self * factor
    }
}

/// Spherical linear interpolation of unit quaternions along the shortest arc (`b` is negated
/// when `a · b < 0`, since `q` and `-q` are the same rotation). Falls back to a normalized
/// linear interpolation when the quaternions are nearly equal, where slerp's `1/sin θ` would
/// lose precision.
pub fn slerp_shortest(a: DQuat, b: DQuat, s: f64) -> DQuat {
    let mut b = b;
    let mut cos = a.dot(b);
    if cos < 0.0 {
        b = -b;
        cos = -cos;
    }
    let q = if cos > 1.0 - 1e-12 {
        a + (b - a) * s
    } else {
        let theta = cos.min(1.0).acos();
        let sin = theta.sin();
        a * (((1.0 - s) * theta).sin() / sin) + b * ((s * theta).sin() / sin)
    };
    q.normalize()
}

/// Key times and values with an interpolation. Invariants (checked by [`Sampler::new`]): at
/// least one key, finite times in non-decreasing order, finite values, one value per key (three
/// for [`Interpolation::CubicSpline`]), unit rotations.
///
/// glTF requires strictly increasing times; equal consecutive times are accepted here and
/// make a jump (the later key wins from that time on), which is what exporters that write them
/// intend.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(try_from = "SamplerParts<T>", bound(deserialize = "T: Keyframe + serde::Deserialize<'de>"))]
pub struct Sampler<T> {
    times: Vec<f64>,
    values: Vec<T>,
    interpolation: Interpolation,
}

/// The serialized form of a [`Sampler`]; deserialization goes through [`Sampler::new`] so that
/// a sampler read from a file upholds the same invariants as one built in code.
#[derive(serde::Deserialize)]
struct SamplerParts<T> {
    times: Vec<f64>,
    values: Vec<T>,
    interpolation: Interpolation,
}

impl<T: Keyframe> TryFrom<SamplerParts<T>> for Sampler<T> {
    type Error = AnimationError;
    fn try_from(parts: SamplerParts<T>) -> Result<Self, Self::Error> {
        Self::new(parts.times, parts.values, parts.interpolation)
    }
}

impl<T: Keyframe> Sampler<T> {
    /// Checks the invariants and builds the sampler. Rotations are not normalized here: use
    /// [`Sampler::new_rotation`] for quaternion keys from a file.
    pub fn new(times: Vec<f64>, values: Vec<T>, interpolation: Interpolation) -> Result<Self, AnimationError> {
        if times.is_empty() {
            return Err(AnimationError::EmptySampler);
        }
        let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        if values.len() != per_key * times.len() {
            return Err(AnimationError::ValueCount {
                times: times.len(),
                values: values.len(),
                expected: per_key * times.len(),
                interpolation: interpolation.name(),
            });
        }
        for (key, &time) in times.iter().enumerate() {
            let values_finite = values[per_key * key..per_key * (key + 1)].iter().all(Keyframe::is_finite_value);
            if !time.is_finite() || !values_finite {
                return Err(AnimationError::NonFinite { key });
            }
            if key > 0 && time < times[key - 1] {
                return Err(AnimationError::TimesNotIncreasing { key, previous: times[key - 1], time });
            }
        }
        Ok(Self { times, values, interpolation })
    }

    /// Key times.
    pub fn times(&self) -> &[f64] {
        &self.times
    }

    /// Values (three per key for cubic splines: in-tangent, value, out-tangent).
    pub fn values(&self) -> &[T] {
        &self.values
    }

    /// The interpolation.
    pub fn interpolation(&self) -> Interpolation {
        self.interpolation
    }

    /// Time of the first key.
    pub fn start_time(&self) -> f64 {
        self.times[0]
    }

    /// Time of the last key.
    pub fn end_time(&self) -> f64 {
        self.times[self.times.len() - 1]
    }

    /// The value (not a tangent) of key `k`.
    pub fn key_value(&self, k: usize) -> T {
        match self.interpolation {
            Interpolation::CubicSpline => self.values[3 * k + 1],
            _ => self.values[k],
        }
    }

    /// The value at `time`, clamped to the first / last key outside the keyed range.
    pub fn sample(&self, time: f64) -> T {
        let last = self.times.len() - 1;
        // NaN gives the first key: a defined value rather than a NaN pose.
        if time.is_nan() || time <= self.times[0] {
            return self.key_value(0);
        }
        if time >= self.times[last] {
            return self.key_value(last);
        }
        // The last key at or before `time`; then times[k] <= time < times[k + 1], so the span is
        // strictly positive even with repeated key times.
        let k = self.times.partition_point(|&t| t <= time) - 1;
        let (t0, t1) = (self.times[k], self.times[k + 1]);
        let span = t1 - t0;
        let s = (time - t0) / span;
        match self.interpolation {
            Interpolation::Step => self.values[k],
            Interpolation::Linear => T::interpolate_linear(self.values[k], self.values[k + 1], s),
            Interpolation::CubicSpline => {
                let p0 = self.values[3 * k + 1];
                let m0 = self.values[3 * k + 2].scaled(span);
                let p1 = self.values[3 * (k + 1) + 1];
                let m1 = self.values[3 * (k + 1)].scaled(span);
                T::hermite(p0, m0, p1, m1, s)
            }
        }
    }
}

impl Sampler<DQuat> {
    /// Builds a rotation sampler, normalizing every key value (files store f32 or quantized
    /// quaternions that are only approximately unit). Tangents of cubic splines are left as
    /// they are: they are derivatives, not rotations. A zero quaternion is an error.
    pub fn new_rotation(
        times: Vec<f64>,
        mut values: Vec<DQuat>,
        interpolation: Interpolation,
    ) -> Result<Self, AnimationError> {
        let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
        let offset = if interpolation == Interpolation::CubicSpline { 1 } else { 0 };
        for (i, q) in values.iter_mut().enumerate() {
            if i % per_key != offset {
                continue;
            }
            let len = q.length();
            if len == 0.0 {
                return Err(AnimationError::ZeroRotation { key: i / per_key });
            }
            *q /= len;
        }
        Self::new(times, values, interpolation)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    #[test]
    fn linear_interpolates_and_clamps() {
        let s = Sampler::new(vec![1.0, 3.0], vec![10.0, 20.0], Interpolation::Linear).unwrap();
        assert_eq!(s.sample(2.0), 15.0);
        assert_eq!(s.sample(2.5), 17.5);
        assert_eq!(s.sample(0.0), 10.0, "clamped before the first key");
        assert_eq!(s.sample(9.0), 20.0, "clamped after the last key");
        assert_eq!(s.sample(f64::NAN), 10.0);
    }

    #[test]
    fn step_holds_the_previous_key() {
        let s = Sampler::new(vec![0.0, 1.0, 2.0], vec![DVec3::X, DVec3::Y, DVec3::Z], Interpolation::Step).unwrap();
        assert_eq!(s.sample(0.0), DVec3::X);
        assert_eq!(s.sample(0.999), DVec3::X);
        assert_eq!(s.sample(1.0), DVec3::Y);
        assert_eq!(s.sample(1.5), DVec3::Y);
        assert_eq!(s.sample(2.0), DVec3::Z);
    }

    #[test]
    fn repeated_times_make_a_jump() {
        let s = Sampler::new(vec![0.0, 1.0, 1.0, 2.0], vec![0.0, 1.0, 5.0, 6.0], Interpolation::Linear).unwrap();
        assert_eq!(s.sample(0.5), 0.5);
        assert_eq!(s.sample(1.0), 5.0);
        assert_eq!(s.sample(1.5), 5.5);
    }

    #[test]
    fn cubic_spline_matches_hand_computed_hermite() {
        // Keys at t = 0 (value 0, out-tangent 1) and t = 2 (value 1, in-tangent 0). Over the span
        // Δt = 2 the Hermite tangents are m0 = 2·1 = 2 and m1 = 2·0 = 0, so at s = 1/2:
        // h00 = 1/2, h10 = 1/8, h01 = 1/2, h11 = -1/8 → 0·1/2 + 2·1/8 + 1·1/2 + 0 = 0.75.
        let values = vec![
            9.0, 0.0, 1.0, // key 0: in (unused), value, out
            0.0, 1.0, 9.0, // key 1: in, value, out (unused)
        ];
        let s = Sampler::new(vec![0.0, 2.0], values, Interpolation::CubicSpline).unwrap();
        assert!((s.sample(1.0) - 0.75).abs() < 1e-15);
        // At s = 1/4: h00 = 27/32, h10 = 9/64, h01 = 5/32, h11 = -3/64 → 2·9/64 + 5/32 = 0.4375.
        assert!((s.sample(0.5) - 0.4375).abs() < 1e-15);
        assert_eq!(s.sample(-1.0), 0.0);
        assert_eq!(s.sample(5.0), 1.0);
    }

    #[test]
    fn cubic_spline_with_consistent_tangents_reproduces_a_cubic() {
        // f(t) = t³ − t, f'(t) = 3t² − 1, keys at 0, 0.5, 2: a cubic Hermite spline with exact
        // tangents reproduces any cubic exactly.
        let f = |t: f64| DVec3::new(t * t * t - t, 2.0 * t, -t * t * t);
        let df = |t: f64| DVec3::new(3.0 * t * t - 1.0, 2.0, -3.0 * t * t);
        let times = vec![0.0, 0.5, 2.0];
        let values = times.iter().flat_map(|&t| [df(t), f(t), df(t)]).collect();
        let s = Sampler::new(times, values, Interpolation::CubicSpline).unwrap();
        for t in [0.1, 0.25, 0.49, 0.7, 1.3, 1.99] {
            assert!((s.sample(t) - f(t)).length() < 1e-13, "t = {t}");
        }
    }

    #[test]
    fn slerp_midpoint_is_the_half_angle_rotation() {
        let a = DQuat::IDENTITY;
        let b = DQuat::from_rotation_z(FRAC_PI_2);
        let m = slerp_shortest(a, b, 0.5);
        assert!(m.dot(DQuat::from_rotation_z(FRAC_PI_2 / 2.0)) > 1.0 - 1e-14);
        // Shortest path: -b is the same rotation, the midpoint must not go the long way round.
        let m2 = slerp_shortest(a, -b, 0.5);
        assert!(m2.dot(DQuat::from_rotation_z(FRAC_PI_2 / 2.0)).abs() > 1.0 - 1e-14);
        // Constant angular speed: a quarter of the way is a quarter of the angle.
        let c = DQuat::from_rotation_x(0.8 * PI);
        let q = slerp_shortest(a, c, 0.25);
        assert!(q.dot(DQuat::from_rotation_x(0.2 * PI)).abs() > 1.0 - 1e-14);
    }

    #[test]
    fn linear_rotation_sampler_uses_slerp() {
        let s = Sampler::new_rotation(
            vec![0.0, 1.0],
            vec![DQuat::IDENTITY, DQuat::from_rotation_y(PI * 0.9) * 2.0],
            Interpolation::Linear,
        )
        .unwrap();
        let q = s.sample(0.5);
        assert!(q.dot(DQuat::from_rotation_y(PI * 0.45)).abs() > 1.0 - 1e-14);
        assert!((q.length() - 1.0).abs() < 1e-14);
    }

    #[test]
    fn cubic_rotation_is_normalized() {
        let q0 = DQuat::IDENTITY;
        let q1 = DQuat::from_rotation_z(1.0);
        let zero = DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0);
        let s = Sampler::new_rotation(vec![0.0, 1.0], vec![zero, q0, zero, zero, q1, zero], Interpolation::CubicSpline)
            .unwrap();
        let q = s.sample(0.5);
        assert!((q.length() - 1.0).abs() < 1e-14);
        // Zero tangents and symmetric basis: the midpoint is the normalized average = slerp(0.5).
        assert!(q.dot(DQuat::from_rotation_z(0.5)) > 1.0 - 1e-14);
    }

    #[test]
    fn deserialization_checks_invariants() {
        let s = Sampler::new(vec![0.0, 1.0], vec![1.0, 2.0], Interpolation::Step).unwrap();
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<Sampler<f64>>(&json).unwrap(), s);
        let bad = r#"{"times":[],"values":[],"interpolation":"Linear"}"#;
        assert!(serde_json::from_str::<Sampler<f64>>(bad).is_err());
    }

    #[test]
    fn invalid_samplers_are_rejected() {
        assert_eq!(Sampler::<f64>::new(vec![], vec![], Interpolation::Linear), Err(AnimationError::EmptySampler));
        assert!(matches!(
            Sampler::new(vec![0.0, 1.0], vec![1.0], Interpolation::Linear),
            Err(AnimationError::ValueCount { expected: 2, .. })
        ));
        assert!(matches!(
            Sampler::new(vec![0.0, 1.0], vec![1.0, 2.0], Interpolation::CubicSpline),
            Err(AnimationError::ValueCount { expected: 6, .. })
        ));
        assert!(matches!(
            Sampler::new(vec![1.0, 0.0], vec![1.0, 2.0], Interpolation::Step),
            Err(AnimationError::TimesNotIncreasing { key: 1, .. })
        ));
        assert!(matches!(
            Sampler::new(vec![0.0, f64::NAN], vec![1.0, 2.0], Interpolation::Step),
            Err(AnimationError::NonFinite { key: 1 })
        ));
        assert!(matches!(
            Sampler::new_rotation(vec![0.0], vec![DQuat::from_xyzw(0.0, 0.0, 0.0, 0.0)], Interpolation::Step),
            Err(AnimationError::ZeroRotation { key: 0 })
        ));
    }
}
