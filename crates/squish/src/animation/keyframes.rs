//! Keyframed parameters: a value that is either constant or given by keys on scene frames.
//!
//! The thesis animates the deformer's parameters (mapping direction d̂, relative stiffness k̄,
//! bulge factor γ; §7.3.2) with ordinary animation curves. [`Keyframed`] is that curve, on
//! *frames* rather than seconds (artists key on frames; fractional frames are sub-frames for
//! motion blur). Three interpolations:
//!
//! - [`KeyInterpolation::Linear`]: straight segments between keys;
//! - [`KeyInterpolation::Smooth`]: a C¹ monotone piecewise-cubic Hermite curve. Tangents are the
//!   Fritsch–Butland weighted harmonic mean of the two neighbouring slopes (the PCHIP rule), zero
//!   where the neighbouring slopes change sign or vanish (local extrema stay flat, like
//!   "auto-clamped" handles), and zero at the first and last key so that the curve joins the
//!   clamped constant outside the keyed range without a kink. With these tangents every segment
//!   is monotone, so the curve never leaves the range of its two keys: no overshoot, ever;
//! - [`KeyInterpolation::Step`]: the previous key's value, held.
//!
//! Outside the keyed range the first / last value holds. Vectors interpolate per component (a
//! keyed direction must be normalized by the caller). Booleans only step.
//!
//! How keys are spelled in files is the file layer's business (squish-io's scene files); here
//! they are checked by [`Keyframed::keys`].

use std::fmt;

use glam::DVec3;

/// How values between two keys are computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum KeyInterpolation {
    /// Straight segments between keys.
    #[default]
    Linear,
    /// Monotone cubic Hermite (C¹, never overshoots; flat at the ends and at local extrema).
    Smooth,
    /// The previous key's value until the next key.
    Step,
}

impl KeyInterpolation {
    /// Every interpolation, in the order of [`KeyInterpolation::name`]'s words.
    pub const ALL: [Self; 3] = [Self::Linear, Self::Smooth, Self::Step];

    /// Its name: `linear`, `smooth` or `step`.
    pub fn name(self) -> &'static str {
        match self {
            Self::Linear => "linear",
            Self::Smooth => "smooth",
            Self::Step => "step",
        }
    }

    /// The interpolation of a name.
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|i| i.name() == name)
    }
}

/// What is wrong with a list of keys.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum KeyframeError {
    #[error("the key list is empty; give at least one [frame, value] key, or a plain value")]
    Empty,
    #[error("key {key} has a non-finite frame or value; frames and values must be finite numbers")]
    NonFinite { key: usize },
    #[error(
        "key {key} is at frame {frame}, not after the previous key's frame {previous}; list keys in increasing frame order, one per frame"
    )]
    NotIncreasing { key: usize, previous: f64, frame: f64 },
    #[error("{what} cannot be interpolated \"{interpolation}\"; use interpolation = \"step\"")]
    StepOnly { what: &'static str, interpolation: &'static str },
}

/// A value type that can be keyframed: a fixed number of real components interpolated one by
/// one, or (with no components) a value that can only step.
pub trait KeyValue: Copy + PartialEq + fmt::Debug {
    /// Number of real components; 0 for values that only step (booleans).
    const COMPONENTS: usize;
    /// How the value is described in error messages ("a number", "true or false" …).
    const DESCRIPTION: &'static str;
    /// The interpolation used when a key list does not name one.
    const DEFAULT_INTERPOLATION: KeyInterpolation = KeyInterpolation::Linear;
    /// Component `i` (`i < COMPONENTS`).
    fn component(&self, i: usize) -> f64;
    /// The value whose component `i` is `f(i)`. Only called when `COMPONENTS > 0`.
    fn from_components(f: impl FnMut(usize) -> f64) -> Self;
}

impl KeyValue for f64 {
    const COMPONENTS: usize = 1;
    const DESCRIPTION: &'static str = "a number";
    fn component(&self, _: usize) -> f64 {
        *self
    }
    fn from_components(mut f: impl FnMut(usize) -> f64) -> Self {
        f(0)
    }
}

impl KeyValue for DVec3 {
    const COMPONENTS: usize = 3;
    const DESCRIPTION: &'static str = "a vector [x, y, z]";
    fn component(&self, i: usize) -> f64 {
        self[i]
    }
    fn from_components(mut f: impl FnMut(usize) -> f64) -> Self {
        DVec3::new(f(0), f(1), f(2))
    }
}

impl KeyValue for [f64; 2] {
    const COMPONENTS: usize = 2;
    const DESCRIPTION: &'static str = "two numbers [a, b]";
    fn component(&self, i: usize) -> f64 {
        self[i]
    }
    fn from_components(mut f: impl FnMut(usize) -> f64) -> Self {
        [f(0), f(1)]
    }
}

impl KeyValue for bool {
    const COMPONENTS: usize = 0;
    const DESCRIPTION: &'static str = "true or false";
    const DEFAULT_INTERPOLATION: KeyInterpolation = KeyInterpolation::Step;
    fn component(&self, _: usize) -> f64 {
        if *self { 1.0 } else { 0.0 }
    }
    fn from_components(mut f: impl FnMut(usize) -> f64) -> Self {
        f(0) != 0.0
    }
}

/// Validated keys: at least one, finite, strictly increasing frames, and (for smooth curves)
/// the tangent of every key, computed once.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyTrack<T> {
    frames: Vec<f64>,
    values: Vec<T>,
    interpolation: KeyInterpolation,
    /// Per key and component: the slope (value per frame) of the smooth curve. Empty unless
    /// the interpolation is `Smooth`.
    tangents: Vec<f64>,
}

/// A constant, or keys on frames with an interpolation.
#[derive(Clone, Debug, PartialEq)]
pub enum Keyframed<T> {
    Constant(T),
    Keys(KeyTrack<T>),
}

impl<T: Default> Default for Keyframed<T> {
    fn default() -> Self {
        Self::Constant(T::default())
    }
}

impl<T> From<T> for Keyframed<T> {
    fn from(value: T) -> Self {
        Self::Constant(value)
    }
}

impl<T: KeyValue> Keyframed<T> {
    /// A value that does not change.
    pub fn constant(value: T) -> Self {
        Self::Constant(value)
    }

    /// Keys `(frame, value)`, checked: at least one, finite frames and values, frames strictly
    /// increasing; booleans only with [`KeyInterpolation::Step`].
    pub fn keys(keys: Vec<(f64, T)>, interpolation: KeyInterpolation) -> Result<Self, KeyframeError> {
        Ok(Self::Keys(KeyTrack::new(keys, interpolation)?))
    }

    /// The value at `frame` (clamped to the first / last key outside the keyed range; a NaN
    /// frame gives the first key).
    pub fn at(&self, frame: f64) -> T {
        match self {
            Self::Constant(v) => *v,
            Self::Keys(track) => track.at(frame),
        }
    }

    /// True if the value is keyed (it may still be constant if all keys are equal).
    pub fn is_animated(&self) -> bool {
        matches!(self, Self::Keys(_))
    }

    /// The keys' frames (empty for a constant).
    pub fn key_frames(&self) -> &[f64] {
        match self {
            Self::Constant(_) => &[],
            Self::Keys(track) => &track.frames,
        }
    }

    /// Applies `f` to the constant or to every key value, keeping frames and interpolation.
    pub fn map<U: KeyValue>(&self, mut f: impl FnMut(T) -> U) -> Result<Keyframed<U>, KeyframeError> {
        match self {
            Self::Constant(v) => Ok(Keyframed::Constant(f(*v))),
            Self::Keys(track) => {
                let keys = track.frames.iter().zip(&track.values).map(|(&t, &v)| (t, f(v))).collect();
                Keyframed::keys(keys, track.interpolation)
            }
        }
    }
}

impl<T: KeyValue> KeyTrack<T> {
    /// See [`Keyframed::keys`].
    pub fn new(keys: Vec<(f64, T)>, interpolation: KeyInterpolation) -> Result<Self, KeyframeError> {
        if keys.is_empty() {
            return Err(KeyframeError::Empty);
        }
        if T::COMPONENTS == 0 && interpolation != KeyInterpolation::Step {
            return Err(KeyframeError::StepOnly { what: T::DESCRIPTION, interpolation: interpolation.name() });
        }
        for (key, (frame, value)) in keys.iter().enumerate() {
            if !frame.is_finite() || (0..T::COMPONENTS).any(|i| !value.component(i).is_finite()) {
                return Err(KeyframeError::NonFinite { key });
            }
            if key > 0 && *frame <= keys[key - 1].0 {
                return Err(KeyframeError::NotIncreasing { key, previous: keys[key - 1].0, frame: *frame });
            }
        }
        let (frames, values): (Vec<f64>, Vec<T>) = keys.into_iter().unzip();
        let tangents =
            if interpolation == KeyInterpolation::Smooth { smooth_tangents(&frames, &values) } else { Vec::new() };
        Ok(Self { frames, values, interpolation, tangents })
    }

    /// Key frames, increasing.
    pub fn frames(&self) -> &[f64] {
        &self.frames
    }

    /// Key values.
    pub fn values(&self) -> &[T] {
        &self.values
    }

    /// The interpolation.
    pub fn interpolation(&self) -> KeyInterpolation {
        self.interpolation
    }

    /// The value at `frame`; see [`Keyframed::at`].
    pub fn at(&self, frame: f64) -> T {
        let last = self.frames.len() - 1;
        if frame.is_nan() || frame <= self.frames[0] {
            return self.values[0];
        }
        if frame >= self.frames[last] {
            return self.values[last];
        }
        // frames[k] <= frame < frames[k + 1]; frames strictly increase, so the span is positive.
        let k = self.frames.partition_point(|&f| f <= frame) - 1;
        let (f0, f1) = (self.frames[k], self.frames[k + 1]);
        let (a, b) = (self.values[k], self.values[k + 1]);
        let h = f1 - f0;
        let s = (frame - f0) / h;
        match self.interpolation {
            KeyInterpolation::Step => a,
            KeyInterpolation::Linear => T::from_components(|i| a.component(i) + (b.component(i) - a.component(i)) * s),
            KeyInterpolation::Smooth => {
                let n = T::COMPONENTS;
                let s2 = s * s;
                let s3 = s2 * s;
                let (h00, h10, h01, h11) = (2.0 * s3 - 3.0 * s2 + 1.0, s3 - 2.0 * s2 + s, 3.0 * s2 - 2.0 * s3, s3 - s2);
                T::from_components(|i| {
                    h00 * a.component(i)
                        + h10 * h * self.tangents[k * n + i]
                        + h01 * b.component(i)
                        + h11 * h * self.tangents[(k + 1) * n + i]
                })
            }
        }
    }
}

/// Per key and component, the slope of the monotone cubic Hermite curve: zero at the ends and
/// where the neighbouring secants change sign or vanish, otherwise the Fritsch–Butland weighted
/// harmonic mean `(w1 + w2) / (w1/δ0 + w2/δ1)` with `w1 = 2h1 + h0`, `w2 = h1 + 2h0`. That mean
/// is at most 3·min(δ0, δ1) in magnitude, the Fritsch–Carlson bound that keeps every segment
/// monotone.
fn smooth_tangents<T: KeyValue>(frames: &[f64], values: &[T]) -> Vec<f64> {
    let n = T::COMPONENTS;
    let mut tangents = vec![0.0; frames.len() * n];
    for k in 1..frames.len().saturating_sub(1) {
        let h0 = frames[k] - frames[k - 1];
        let h1 = frames[k + 1] - frames[k];
        for i in 0..n {
            let d0 = (values[k].component(i) - values[k - 1].component(i)) / h0;
            let d1 = (values[k + 1].component(i) - values[k].component(i)) / h1;
            if d0 * d1 > 0.0 {
                let w1 = 2.0 * h1 + h0;
                let w2 = h1 + 2.0 * h0;
                tangents[k * n + i] = (w1 + w2) / (w1 / d0 + w2 / d1);
            }
        }
    }
    tangents
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn tangents_are_zero_at_ends_and_extrema() {
        let k =
            Keyframed::keys(vec![(0.0, 0.0), (1.0, 1.0), (2.0, 0.0), (4.0, 2.0), (5.0, 3.0)], KeyInterpolation::Smooth)
                .unwrap();
        let Keyframed::Keys(track) = &k else { unreachable!() };
        assert_eq!(track.tangents[0], 0.0);
        assert_eq!(track.tangents[1], 0.0);
        assert_eq!(track.tangents[2], 0.0);
        assert!(track.tangents[3] > 0.0);
        assert_eq!(track.tangents[4], 0.0);
    }
}
