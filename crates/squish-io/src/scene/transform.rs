//! An object's placement in a scene file: `transform = { translate, rotate, scale }`, each part
//! keyframable ([`Keyed`]), and the value types of its rotation and scale with their scene-file
//! spellings ([`SceneValue`]). Applied as T·R·S to the mesh of each frame, after glTF posing
//! (`docs/scene-format.md`).

use glam::DVec3;
use serde::{Deserialize, Serialize};
use squish::animation::KeyValue;

use super::keys::{Keyed, SceneValue};

/// `transform = { translate, rotate, scale }`, each keyframable; applied as T·R·S.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Transform {
    pub translate: Keyed<DVec3>,
    /// Axis and angle in degrees, `[x, y, z, degrees]`.
    pub rotate: Keyed<AxisAngle>,
    /// Uniform (`2.0`) or per axis (`[sx, sy, sz]`).
    pub scale: Keyed<Scale>,
}

impl Default for Transform {
    fn default() -> Self {
        use squish::animation::Keyframed;
        Self {
            translate: Keyed(Keyframed::constant(DVec3::ZERO)),
            rotate: Keyed(Keyframed::constant(AxisAngle::default())),
            scale: Keyed(Keyframed::constant(Scale::default())),
        }
    }
}

impl Transform {
    /// True if the transform is the identity at every frame.
    pub fn is_identity(&self) -> bool {
        *self == Self::default()
    }
}

/// A rotation as `[x, y, z, degrees]`. Keys interpolate axis and angle per component (the axis
/// is normalized when used), so a key at 0° and one at 720° about the same axis spin twice.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisAngle {
    pub axis: DVec3,
    pub degrees: f64,
}

impl Default for AxisAngle {
    fn default() -> Self {
        Self { axis: DVec3::Z, degrees: 0.0 }
    }
}

impl KeyValue for AxisAngle {
    const COMPONENTS: usize = 4;
    const DESCRIPTION: &'static str = "an axis and an angle in degrees [x, y, z, degrees]";
    fn component(&self, i: usize) -> f64 {
        if i < 3 { self.axis[i] } else { self.degrees }
    }
    fn from_components(mut f: impl FnMut(usize) -> f64) -> Self {
        Self { axis: DVec3::new(f(0), f(1), f(2)), degrees: f(3) }
    }
}

/// A scale per axis; reads from a number (uniform) or `[sx, sy, sz]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scale(pub DVec3);

impl Default for Scale {
    fn default() -> Self {
        Self(DVec3::ONE)
    }
}

impl KeyValue for Scale {
    const COMPONENTS: usize = 3;
    const DESCRIPTION: &'static str = "a scale (a number, or [sx, sy, sz])";
    fn component(&self, i: usize) -> f64 {
        self.0[i]
    }
    fn from_components(mut f: impl FnMut(usize) -> f64) -> Self {
        Self(DVec3::new(f(0), f(1), f(2)))
    }
}

impl SceneValue for AxisAngle {}
impl SceneValue for Scale {
    const BROADCAST: bool = true;
}
