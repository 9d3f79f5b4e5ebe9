//! The pseudo-stiffness of an object as the contact stage sees it (thesis §4.3), and the relative
//! stiffnesses of a pair. The per-pair parameters are [`crate::params::PairParams`].

use super::ContactError;

/// Pseudo-stiffness k of an object (§4.3). Only the relative stiffness k̄_a = k_a / (k_a + k_b)
/// matters; a rigid object has k = ∞: k̄ = 1 for it and 0 for the other, so that the potential
/// contact surface 𝒮 is the rigid object's surface.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Stiffness {
    /// A finite, positive pseudo-stiffness.
    Elastic(f64),
    /// An object that keeps its shape.
    Rigid,
}

impl Default for Stiffness {
    /// `Elastic(1.0)`: two default objects share the deformation equally.
    fn default() -> Self {
        Self::Elastic(1.0)
    }
}

impl Stiffness {
    /// The stiffness of an object with these parameters.
    pub fn of(params: &crate::params::ObjectParams) -> Self {
        if params.rigid { Self::Rigid } else { Self::Elastic(params.stiffness) }
    }

    /// True for [`Stiffness::Rigid`].
    pub fn is_rigid(&self) -> bool {
        matches!(self, Self::Rigid)
    }
}

/// Relative stiffnesses `[k̄_a, k̄_b]` (they sum to 1). Errors: both objects rigid, or a
/// stiffness that is not a finite positive number (named by `names`).
pub fn relative_stiffness(a: Stiffness, b: Stiffness, names: [&str; 2]) -> Result<[f64; 2], ContactError> {
    for (s, name) in [a, b].iter().zip(names) {
        if let Stiffness::Elastic(k) = *s
            && !(k.is_finite() && k > 0.0)
        {
            return Err(ContactError::InvalidStiffness { object: name.to_string(), value: k });
        }
    }
    match (a, b) {
        (Stiffness::Rigid, Stiffness::Rigid) => Err(ContactError::BothRigid),
        (Stiffness::Rigid, _) => Ok([1.0, 0.0]),
        (_, Stiffness::Rigid) => Ok([0.0, 1.0]),
        (Stiffness::Elastic(ka), Stiffness::Elastic(kb)) => {
            // 1 / (1 + k_b/k_a) rather than k_a / (k_a + k_b): no overflow for huge stiffnesses.
            let ka_bar = 1.0 / (1.0 + kb / ka);
            Ok([ka_bar, 1.0 - ka_bar])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_stiffness_rules() {
        let names = ["a", "b"];
        assert_eq!(relative_stiffness(Stiffness::Elastic(1.0), Stiffness::Elastic(3.0), names).unwrap(), [0.25, 0.75]);
        assert_eq!(relative_stiffness(Stiffness::Rigid, Stiffness::Elastic(3.0), names).unwrap(), [1.0, 0.0]);
        assert_eq!(relative_stiffness(Stiffness::Elastic(2.0), Stiffness::Rigid, names).unwrap(), [0.0, 1.0]);
        assert!(matches!(relative_stiffness(Stiffness::Rigid, Stiffness::Rigid, names), Err(ContactError::BothRigid)));
        let err = relative_stiffness(Stiffness::Elastic(1.0), Stiffness::Elastic(-2.0), names).unwrap_err();
        assert!(err.to_string().contains("b") && err.to_string().contains("-2"), "{err}");
        assert!(relative_stiffness(Stiffness::Elastic(f64::NAN), Stiffness::Rigid, names).is_err());
    }
}
