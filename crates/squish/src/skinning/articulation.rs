//! An articulation of a skinned mesh whose two sides fold onto each other (thesis ch. 6): the two
//! overlapping working regions 𝒲₁, 𝒲₂ (§6.1.1), the mapping direction d̂ (§6.1.2) and the
//! per-articulation parameters.
//!
//! 𝒲₁ is the *parent* side (an upper arm, a thigh, an upper lip), 𝒲₂ the *child* side (the
//! forearm, the shin, the lower lip); their common vertices form the shared region ℛ.
//!
//! **Direction (§6.1.2).** From the positions of three consecutive joints q₀ (start of the parent
//! bone), q₁ (the articulation), q₂ (end of the child bone), the thesis takes "the vector
//! orthogonal to the bisector of the bones lying within their supporting plane" and writes it as
//! `normalize((q₁ − q₀) + (q₂ − q₁))`. The two agree only for bones of equal length; we follow the
//! geometric definition, `d̂ = normalize(b̂₁ + b̂₂)` with the unit bone directions b̂, which does not
//! tilt toward the longer bone. Oriented this way d̂ points from the parent side's inner skin to
//! the child side's across the fold (bend a forearm up from a horizontal upper arm: d̂ points up),
//! i.e. along 𝒲₁'s normals inside the fold. For a pair of non-adjacent bones that move together
//! (lips) the direction is given ([`ArticulationDirection::Fixed`]), with the same orientation:
//! from 𝒲₁ toward 𝒲₂.
//!
//! **Regions from skinning weights.** For a parent joint P and a child joint C (C's bone is the
//! child side), 𝒲₁ = {v : w_P(v) ≥ w_min} and 𝒲₂ = {v : Σ_{J ∈ subtree(C)} w_J(v) ≥ w_min}: the
//! parent bone's own influence, and everything the child bone carries (a shin carries its foot).
//! ℛ is then the blend zone of the skinning around the articulation, where linear blend skinning
//! collapses the skin and the crease forms — roughly symmetric about it, as §6.1.1 asks.

use glam::DVec3;
use serde::{Deserialize, Serialize};

use super::SkinWeights;

/// How d̂ is obtained at a frame (§6.1.2; see the module doc for the orientation).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ArticulationDirection {
    /// From the world positions of three consecutive joints `[q₀, q₁, q₂]` at this frame: start of
    /// the parent bone, the articulation, end of the child bone.
    Joints([DVec3; 3]),
    /// Given (a keyframed value evaluated at this frame, e.g. for lips), from 𝒲₁ toward 𝒲₂.
    Fixed(DVec3),
}

impl Default for ArticulationDirection {
    fn default() -> Self {
        Self::Fixed(DVec3::ZERO)
    }
}

/// Why an articulation cannot be processed. Every variant says what to change.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ArticulationError {
    #[error(
        "the joints give no direction (the bones are degenerate or fold exactly onto each other: {joints:?}); \
         give the direction instead"
    )]
    DegenerateJoints { joints: [[f64; 3]; 3] },
    #[error(
        "the direction {direction:?} is zero or not finite; give a non-zero direction from region 1 toward region 2"
    )]
    InvalidDirection { direction: [f64; 3] },
    #[error("{what} is empty; {fix}")]
    EmptyRegion { what: &'static str, fix: &'static str },
    #[error("region {region} lists vertex {vertex}, but the mesh has {count} vertices")]
    VertexOutOfRange { region: usize, vertex: u32, count: usize },
    #[error("joint {joint} is not a joint of the skin (it has {count} joints)")]
    JointOutOfRange { joint: usize, count: usize },
    #[error("joint {child} is not a child of joint {parent} in the skin's hierarchy; name two consecutive joints")]
    NotConsecutive { parent: usize, child: usize },
    #[error("{stage}: {message}")]
    Numerical { stage: &'static str, message: String },
    #[error("{name} = {value}: {hint}")]
    InvalidParameter { name: &'static str, value: f64, hint: &'static str },
}

/// The unit direction d̂ for this frame (see the module doc).
pub fn articulation_direction(direction: &ArticulationDirection) -> Result<DVec3, ArticulationError> {
    match *direction {
        ArticulationDirection::Joints(q) => {
            let degenerate = || ArticulationError::DegenerateJoints { joints: q.map(|p| p.to_array()) };
            let (b1, b2) = (q[1] - q[0], q[2] - q[1]);
            if !(b1.is_finite() && b2.is_finite()) {
                return Err(degenerate());
            }
            let scale = b1.length().max(b2.length());
            if scale <= 0.0 || b1.length() <= 1e-12 * scale || b2.length() <= 1e-12 * scale {
                return Err(degenerate());
            }
            let sum = b1.normalize() + b2.normalize();
            // Bones folded exactly back onto each other leave no supporting plane.
            if sum.length() <= 1e-9 {
                return Err(degenerate());
            }
            Ok(sum.normalize())
        }
        ArticulationDirection::Fixed(d) => {
            if d.is_finite() && d.length() > 0.0 {
                Ok(d.normalize())
            } else {
                Err(ArticulationError::InvalidDirection { direction: d.to_array() })
            }
        }
    }
}

/// Parameters of one articulation (thesis ch. 6, with §7.1.3's values as defaults where it gives
/// them). The deformation's own parameters (profile, bulge map, γ …) are the object's.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ArticulationParams {
    /// τ of the contact criterion ε_c = m + τσ (§4.4.2). The thesis uses −1 for skinning
    /// (Figs. 7.7, 7.8): a larger zone, so that the whole fold is in contact. Default −1.
    pub contact_tau: f64,
    /// Pseudo-stiffnesses of the two sides, k₁ and k₂ (§4.3); equal by default (k̄ = 0.5, as in
    /// the thesis' figures).
    pub stiffness: [f64; 2],
    /// φ_max in world units. `None`: automatic (see [`super::plan_articulation`]).
    pub extent: Option<f64>,
    /// Weight of the regional term β in the crease cut's energy (Eq. 6.1 has 1).
    pub cut_regional_weight: f64,
    /// Angle beyond which a point cannot be in contact (§4.4.2). Default 80°.
    pub safeguard_angle_degrees: f64,
    /// Distance left between the two sides where they touch (world units). `None`: automatic,
    /// half the mean edge length (see [`super::self_contact::GAP_FRACTION`]).
    pub contact_gap: Option<f64>,
}

impl Default for ArticulationParams {
    fn default() -> Self {
        Self {
            contact_tau: -1.0,
            stiffness: [1.0, 1.0],
            extent: None,
            cut_regional_weight: 1.0,
            safeguard_angle_degrees: 80.0,
            contact_gap: None,
        }
    }
}

impl ArticulationParams {
    /// Checks every value.
    pub fn validate(&self) -> Result<(), ArticulationError> {
        let invalid = |name, value, hint| Err(ArticulationError::InvalidParameter { name, value, hint });
        if !self.contact_tau.is_finite() {
            return invalid("contact_tau", self.contact_tau, "τ must be finite");
        }
        for k in self.stiffness {
            if !(k.is_finite() && k > 0.0) {
                return invalid("stiffness", k, "both stiffnesses must be finite and positive");
            }
        }
        if let Some(e) = self.extent
            && !(e.is_finite() && e > 0.0)
        {
            return invalid("extent", e, "the extent is a finite, positive distance");
        }
        if let Some(g) = self.contact_gap
            && !(g.is_finite() && g >= 0.0)
        {
            return invalid("contact_gap", g, "the gap is a finite distance ≥ 0");
        }
        if !(self.cut_regional_weight.is_finite() && self.cut_regional_weight >= 0.0) {
            return invalid("cut_regional_weight", self.cut_regional_weight, "the weight must be finite and ≥ 0");
        }
        let a = self.safeguard_angle_degrees;
        if !(a.is_finite() && a > 0.0 && a <= 90.0) {
            return invalid("safeguard_angle_degrees", a, "the angle must lie in (0°, 90°]");
        }
        Ok(())
    }
}

/// One articulation of an object: its two overlapping working regions (object vertex ids), its
/// direction at this frame and its parameters.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Articulation {
    /// Name used in messages and reports ("left knee").
    pub name: String,
    /// 𝒲₁ (parent side) and 𝒲₂ (child side) as object vertex ids; they must overlap (ℛ).
    pub regions: [Vec<u32>; 2],
    /// d̂ at this frame.
    pub direction: ArticulationDirection,
    pub params: ArticulationParams,
}

/// 𝒲₁ and 𝒲₂ from skinning weights (see the module doc): `parents[j]` is the parent of skin
/// joint j in the skin's hierarchy (`None` for a root or a parent outside the skin), `parent` and
/// `child` two consecutive skin joints, `min_weight` the influence from which a vertex belongs
/// to a side (in (0, 1]). Returns sorted vertex lists.
pub fn regions_from_skin_weights(
    weights: &SkinWeights,
    parents: &[Option<usize>],
    parent: usize,
    child: usize,
    min_weight: f64,
) -> Result<[Vec<u32>; 2], ArticulationError> {
    let count = parents.len();
    for joint in [parent, child] {
        if joint >= count {
            return Err(ArticulationError::JointOutOfRange { joint, count });
        }
    }
    if parents[child] != Some(parent) {
        return Err(ArticulationError::NotConsecutive { parent, child });
    }
    if !(min_weight.is_finite() && min_weight > 0.0 && min_weight <= 1.0) {
        return Err(ArticulationError::InvalidParameter {
            name: "min_weight",
            value: min_weight,
            hint: "the smallest influence that puts a vertex in a region lies in (0, 1]",
        });
    }
    // Joints carried by the child bone: its subtree in the skin's hierarchy.
    let mut carried = vec![false; count];
    for (j, carried_j) in carried.iter_mut().enumerate() {
        let mut k = Some(j);
        // A hierarchy has no cycle deeper than the joint count; the bound keeps bad data finite.
        for _ in 0..=count {
            match k {
                Some(x) if x == child => {
                    *carried_j = true;
                    break;
                }
                Some(x) => k = parents.get(x).copied().flatten(),
                None => break,
            }
        }
    }
    let mut sides = [Vec::new(), Vec::new()];
    for (v, (joints, w)) in weights.joints().iter().zip(weights.weights()).enumerate() {
        let (mut w_parent, mut w_child) = (0.0, 0.0);
        for (&j, &x) in joints.iter().zip(w) {
            let j = j as usize;
            if j == parent {
                w_parent += x;
            } else if carried.get(j).copied().unwrap_or(false) {
                w_child += x;
            }
        }
        if w_parent >= min_weight {
            sides[0].push(v as u32);
        }
        if w_child >= min_weight {
            sides[1].push(v as u32);
        }
    }
    let [first, second] = &sides;
    if first.is_empty() {
        return Err(ArticulationError::EmptyRegion {
            what: "region 1 (the parent joint's influence)",
            fix: "check the joint names or lower min_weight",
        });
    }
    if second.is_empty() {
        return Err(ArticulationError::EmptyRegion {
            what: "region 2 (the child joint's influence)",
            fix: "check the joint names or lower min_weight",
        });
    }
    Ok(sides)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn direction_is_orthogonal_to_the_bisector_in_the_bones_plane() {
        // Upper arm along +x, forearm bent up by 150° from straight.
        let bend = 150f64.to_radians();
        let q = [DVec3::new(-2.0, 0.0, 0.0), DVec3::ZERO, DVec3::new(bend.cos(), bend.sin(), 0.0) * 0.5];
        let d = articulation_direction(&ArticulationDirection::Joints(q)).unwrap();
        let (b1, b2) = ((q[1] - q[0]).normalize(), (q[2] - q[1]).normalize());
        let bisector = b2 - b1;
        assert!(d.dot(bisector).abs() < 1e-12, "orthogonal to the bisector");
        assert!(d.dot(b1.cross(b2)).abs() < 1e-12, "in the bones' plane");
        assert!(d.y > 0.9, "points from the upper arm toward the forearm: {d}");
        // Bone lengths do not tilt it (the thesis' formula would with lengths 2 and 0.5).
        let long = [q[0] * 3.0, q[1], q[2]];
        let d_long = articulation_direction(&ArticulationDirection::Joints(long)).unwrap();
        assert!((d - d_long).length() < 1e-12);
        // For equal lengths it is the thesis' formula.
        let equal = [DVec3::new(-1.0, 0.0, 0.0), DVec3::ZERO, DVec3::new(bend.cos(), bend.sin(), 0.0)];
        let thesis = ((equal[1] - equal[0]) + (equal[2] - equal[1])).normalize();
        let ours = articulation_direction(&ArticulationDirection::Joints(equal)).unwrap();
        assert!((thesis - ours).length() < 1e-12);
    }

    #[test]
    fn degenerate_directions_are_errors() {
        let folded = [DVec3::X, DVec3::ZERO, DVec3::X];
        assert!(matches!(
            articulation_direction(&ArticulationDirection::Joints(folded)),
            Err(ArticulationError::DegenerateJoints { .. })
        ));
        let coincident = [DVec3::ZERO, DVec3::ZERO, DVec3::X];
        assert!(articulation_direction(&ArticulationDirection::Joints(coincident)).is_err());
        assert!(articulation_direction(&ArticulationDirection::Fixed(DVec3::ZERO)).is_err());
        assert!(articulation_direction(&ArticulationDirection::Fixed(DVec3::new(f64::NAN, 0.0, 1.0))).is_err());
        let d = articulation_direction(&ArticulationDirection::Fixed(DVec3::new(0.0, -3.0, 0.0))).unwrap();
        assert_eq!(d, DVec3::new(0.0, -1.0, 0.0));
    }

    #[test]
    fn regions_from_weights_follow_the_hierarchy() {
        // Joints: 0 root → 1 thigh → 2 shin → 3 foot. Vertices: thigh only, thigh/shin blend,
        // shin only, foot only, root only.
        let parents = [None, Some(0), Some(1), Some(2)];
        let weights = SkinWeights::new(
            vec![[1, 0, 0, 0], [1, 2, 0, 0], [2, 0, 0, 0], [3, 0, 0, 0], [0, 0, 0, 0]],
            vec![
                [1.0, 0.0, 0.0, 0.0],
                [0.5, 0.5, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
            ],
        )
        .unwrap();
        let [w1, w2] = regions_from_skin_weights(&weights, &parents, 1, 2, 0.05).unwrap();
        assert_eq!(w1, vec![0, 1]);
        assert_eq!(w2, vec![1, 2, 3], "the shin carries the foot");
        assert!(matches!(
            regions_from_skin_weights(&weights, &parents, 1, 3, 0.05),
            Err(ArticulationError::NotConsecutive { .. })
        ));
        assert!(matches!(
            regions_from_skin_weights(&weights, &parents, 1, 9, 0.05),
            Err(ArticulationError::JointOutOfRange { .. })
        ));
        assert!(regions_from_skin_weights(&weights, &parents, 1, 2, 0.0).is_err());
    }

    #[test]
    fn parameters_are_checked() {
        assert!(ArticulationParams::default().validate().is_ok());
        let bad = [
            ArticulationParams { contact_tau: f64::NAN, ..Default::default() },
            ArticulationParams { stiffness: [1.0, 0.0], ..Default::default() },
            ArticulationParams { extent: Some(-1.0), ..Default::default() },
            ArticulationParams { cut_regional_weight: -1.0, ..Default::default() },
            ArticulationParams { safeguard_angle_degrees: 95.0, ..Default::default() },
        ];
        for p in bad {
            assert!(p.validate().is_err(), "{p:?}");
        }
    }
}
