//! Local node transforms: translation–rotation–scale or a general matrix (glTF `node.matrix`).

use glam::{DMat4, DQuat, DVec3};

/// A transform decomposed as translation, rotation (unit quaternion) and scale; its matrix is
/// `T · R · S`, so scale applies first.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Trs {
    pub translation: DVec3,
    pub rotation: DQuat,
    pub scale: DVec3,
}

impl Default for Trs {
    fn default() -> Self {
        Self::IDENTITY
    }
}

impl Trs {
    /// The identity transform.
    pub const IDENTITY: Self = Self { translation: DVec3::ZERO, rotation: DQuat::IDENTITY, scale: DVec3::ONE };

    /// The matrix `T · R · S`.
    pub fn matrix(&self) -> DMat4 {
        DMat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// Decomposes an affine matrix without shear (a negative determinant is carried by the scale).
    /// A sheared matrix has no exact decomposition; the result is then the closest-looking TRS
    /// that glam's decomposition gives, which is why [`NodeTransform::Matrix`] exists.
    pub fn from_matrix(m: DMat4) -> Self {
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        Self { translation, rotation, scale }
    }
}

/// A node's local transform, as a file gives it: decomposed, or as a matrix (which may hold
/// shear that no TRS can represent, so it is kept as is until something animates the node).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum NodeTransform {
    Trs(Trs),
    Matrix(DMat4),
}

impl Default for NodeTransform {
    fn default() -> Self {
        Self::Trs(Trs::IDENTITY)
    }
}

impl NodeTransform {
    /// The transform as a matrix.
    pub fn matrix(&self) -> DMat4 {
        match self {
            Self::Trs(trs) => trs.matrix(),
            Self::Matrix(m) => *m,
        }
    }

    /// The transform decomposed (see [`Trs::from_matrix`] for matrices).
    pub fn to_trs(&self) -> Trs {
        match self {
            Self::Trs(trs) => *trs,
            Self::Matrix(m) => Trs::from_matrix(*m),
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn trs_matrix_applies_scale_then_rotation_then_translation() {
        let trs = Trs {
            translation: DVec3::new(1.0, 2.0, 3.0),
            rotation: DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2),
            scale: DVec3::new(2.0, 1.0, 1.0),
        };
        // x scaled to 2, rotated onto +y, then translated.
        let p = trs.matrix().transform_point3(DVec3::X);
        assert!((p - DVec3::new(1.0, 4.0, 3.0)).length() < 1e-12, "{p}");
        let back = Trs::from_matrix(trs.matrix());
        assert!((back.translation - trs.translation).length() < 1e-12);
        assert!((back.scale - trs.scale).length() < 1e-12);
        assert!(back.rotation.dot(trs.rotation).abs() > 1.0 - 1e-12);
    }
}
