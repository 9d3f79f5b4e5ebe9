//! Parameters of an articulation of a skinned object whose two sides fold onto each other
//! (thesis ch. 6), and the articulation itself as the pipeline receives it.

use glam::DVec3;

/// Parameters of one articulation (thesis ch. 6, with the values of its figures as defaults).
/// The deformation's own parameters (profile, bulge map, γ …) are its object's.
#[derive(Clone, Debug, PartialEq, super::Params)]
#[params(level = Articulation)]
pub struct ArticulationParams {
    /// Contact spread: the contact threshold is ε_c = m + τσ; larger τ, smaller contact zone.
    ///
    /// −1 by default, the value of every skinning figure of the thesis (Figs. 7.7, 7.8, 7.13):
    /// a larger zone, so that the whole fold is in contact.
    #[param(symbol = "τ", section = "§4.4.2, ch. 6", keyframable)]
    pub contact_tau: f64,
    /// Pseudo-stiffnesses of region 1 (the parent side) and region 2 (the child side); one
    /// number gives both.
    #[param(symbol = "k₁, k₂", section = "§4.3", range = "(0, inf)", keyframable)]
    pub stiffness: [f64; 2],
    /// Extent of the deformation: the distance from the contact boundary at which it stops.
    #[param(
        symbol = "φ_max",
        section = "§5.1",
        unit = "scene units",
        range = "(0, inf)",
        keyframable,
        auto = "max(2·r, 2.5·√(A/π)): r the limb's radius (RMS radius of the shared region on the rest pose), A the contact area"
    )]
    pub extent: Option<f64>,
    /// Weight of the regional term β in the crease cut's energy.
    #[param(section = "§6.1.2, Eq. 6.1", range = "[0, inf)", keyframable)]
    pub cut_regional_weight: f64,
    /// Angle between a normal and the mapping direction beyond which a point cannot be in
    /// contact.
    #[param(
        section = "§4.4.2",
        unit = "degrees",
        range = "(0, 90]",
        keyframable,
        renamed_from = "safeguard_angle_degrees"
    )]
    pub safeguard_angle: f64,
    /// Distance left between the two sides where they touch.
    #[param(unit = "scene units", range = "[0, inf)", keyframable, auto = "half the mean edge length of the regions")]
    pub contact_gap: Option<f64>,
    /// With regions read from a skin's joints: the skinning weight from which a vertex belongs to
    /// a region.
    #[param(section = "§6.1.1", range = "(0, 1]")]
    pub min_weight: f64,
    /// Mapping direction, from region 1 toward region 2.
    #[param(
        symbol = "d̂",
        section = "§6.1.2",
        keyframable,
        word = "joints",
        auto = "from the joints' world positions at each frame: normalize(b̂₁ + b̂₂), b̂ the unit directions of the parent and child bones"
    )]
    pub direction: Option<DVec3>,
}

impl Default for ArticulationParams {
    fn default() -> Self {
        Self {
            contact_tau: -1.0,
            stiffness: [1.0, 1.0],
            extent: None,
            cut_regional_weight: 1.0,
            safeguard_angle: 80.0,
            contact_gap: None,
            min_weight: 0.05,
            direction: None,
        }
    }
}

/// One articulation of an object at a frame: its two overlapping working regions (object vertex
/// ids), the positions of its three joints when its direction comes from them, and its parameters.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Articulation {
    /// Name used in messages and reports ("left knee").
    pub name: String,
    /// 𝒲₁ (parent side) and 𝒲₂ (child side) as object vertex ids; they must overlap (ℛ).
    pub regions: [Vec<u32>; 2],
    /// World positions at this frame of the start of the parent bone, the articulation and the
    /// end of the child bone; needed when [`ArticulationParams::direction`] is `None` (`joints`).
    pub joints: Option<[DVec3; 3]>,
    pub params: ArticulationParams,
    /// Found by `self_contact = "auto"` rather than asked for: a frame where it fails leaves it
    /// inactive (zero displacement) and reports why ([`crate::skinning::ArticulationStats::error`])
    /// instead of failing the frame.
    pub automatic: bool,
}

/// The parts of a skinned mesh between which self-contact is resolved beyond the articulations
/// (issue 27; see [`crate::skinning::parts_from_skin`]): one label per face.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SkinParts {
    /// Per face: its part, `0..names.len()`.
    pub face_parts: Vec<u32>,
    /// Per part: its name (its joint's) for messages and reports.
    pub names: Vec<String>,
    /// Part pairs `[a, b]` (a < b, sorted) of a parent and a child joint: their folds are left
    /// to the articulations (ch. 6, the crease cut), never resolved as a contact of two parts.
    pub parent_child: Vec<[u32; 2]>,
}

impl SkinParts {
    /// Parts painted as one label per face (no parent/child pair).
    pub fn from_face_labels(face_parts: Vec<u32>) -> Self {
        let count = face_parts.iter().map(|&p| p as usize + 1).max().unwrap_or(0);
        Self { face_parts, names: (0..count).map(|k| format!("part {k}")).collect(), parent_child: Vec::new() }
    }

    /// True if the pair of parts a, b is left to the articulations.
    pub fn is_left_to_articulations(&self, a: u32, b: u32) -> bool {
        self.parent_child.binary_search(&[a.min(b), a.max(b)]).is_ok()
    }

    /// The name of part `k`.
    pub fn name(&self, k: u32) -> &str {
        self.names.get(k as usize).map_or("?", String::as_str)
    }
}
