//! Per-object parameters: the thesis' glossary (ARCHITECTURE.md) with its defaults.

use glam::DVec3;

use super::ParamError;
use super::value::DirectionFieldMethod;
use super::{Articulation, SkinParts, Uvs};

crate::choice! {
    /// How an object is divided into working regions 𝒲 (§4, §4.5, §7.5).
    #[derive(Default)]
    pub enum RegionChoice {
        /// The whole object is one region.
        #[default]
        Whole = "whole",
        /// Every connected component of the mesh is its own region (fingertips merged in one file).
        Components = "components",
        /// The faces whose vertices `region_mask` selects; each connected piece is a region.
        Mask = "mask",
        /// Automatic: the faces near the intersection (at least `region_distance` away from it);
        /// each connected piece is a region.
        Distance = "distance",
    }
}

impl RegionChoice {
    /// True for the automatic choice, which needs other objects.
    pub fn is_automatic(self) -> bool {
        self == Self::Distance
    }

    /// True when the object may hold several regions that can touch each other (self-contact).
    pub fn allows_self_contact(self) -> bool {
        matches!(self, Self::Components | Self::Mask)
    }
}

/// Per-vertex flags computed for the vertices asked for (a field that is costly to evaluate
/// everywhere, of which a stage needs a few vertices): `of(vertices)` gives their flags, false for
/// an id out of range. Equal when they share their function.
#[derive(Clone)]
pub struct VertexFlags(std::sync::Arc<FlagsOf>);

/// The function behind [`VertexFlags`].
type FlagsOf = dyn Fn(&[u32]) -> Vec<bool> + Send + Sync;

impl VertexFlags {
    pub fn new(flags: impl Fn(&[u32]) -> Vec<bool> + Send + Sync + 'static) -> Self {
        Self(std::sync::Arc::new(flags))
    }

    /// The flags of `vertices`, in their order.
    pub fn of(&self, vertices: &[u32]) -> Vec<bool> {
        (self.0)(vertices)
    }
}

impl std::fmt::Debug for VertexFlags {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("VertexFlags(..)")
    }
}

impl PartialEq for VertexFlags {
    fn eq(&self, other: &Self) -> bool {
        std::sync::Arc::ptr_eq(&self.0, &other.0)
    }
}

/// Parameters of one object. Public fields, `Default` = the thesis' defaults; the schema, typed
/// access by key and serde come from `#[derive(Params)]` (see [`super`]).
#[derive(Clone, Debug, PartialEq, super::Params)]
#[params(level = Object, check = check_fields)]
pub struct ObjectParams {
    /// The object keeps its shape: its surface is the contact surface and only the objects it
    /// touches deform.
    #[param(section = "§4.3")]
    pub rigid: bool,
    /// Pseudo-stiffness: of two objects in contact the stiffer deforms less; the contact surface
    /// lies at k̄ = k_b / (k_a + k_b) of the way between them.
    ///
    /// Only the ratio of the two objects' stiffnesses matters.
    #[param(symbol = "k", section = "§4.3", range = "(0, inf)", keyframable)]
    pub stiffness: f64,
    /// Extent of the deformation: the distance from the contact boundary at which it stops.
    ///
    /// A world-space distance measured along the surface (geodesic distance from ∂𝒞).
    #[param(
        symbol = "φ_max",
        section = "§5.1",
        unit = "scene units",
        range = "(0, inf)",
        keyframable,
        auto = "max(min(2·r, max(7·√(A/π), 2·h)), 1.5·√(A/π)): A the largest contact area of its pairs at this frame, r the object's size (area-weighted RMS distance to its centroid), h its mean edge length; calibrated against FEM (docs/plausibility.md)"
    )]
    pub extent: Option<f64>,
    /// Volume compensation: 0 no bulge, 1 the volume is preserved, more than 1 exaggerated.
    #[param(symbol = "γ", section = "§5.4.2", range = "[0, inf)", keyframable)]
    pub bulge: f64,
    /// Height of the bulge when the volume is not preserved (`preserve_volume = false`).
    #[param(symbol = "h_v", section = "§5.4.2", unit = "scene units", keyframable)]
    pub bulge_height: f64,
    /// Solve the bulge's height so that the volume is preserved exactly: a closed mesh keeps the
    /// volume it encloses, an open one (cloth, a ground patch) sweeps no net volume — what its
    /// contact pushes in bulges out around it (docs/decisions.md, "Open meshes bulge").
    #[param(section = "App. C", auto = "on (closed and open meshes)")]
    pub preserve_volume: Option<bool>,
    /// Abscissa of the profile curve's second control point v2 (where the bulge peaks).
    ///
    /// The abscissas must increase strictly within (0.2, 1): 0.2 < v2 < v3 < v4 < 1.
    #[param(
        symbol = "x(v₂)",
        section = "§5.4.1",
        range = "(0.2, 1)",
        keyframable,
        renamed_from = "profile.x2, profile.v2"
    )]
    pub profile_v2: f64,
    /// Abscissa of the profile curve's control point v3.
    #[param(
        symbol = "x(v₃)",
        section = "§5.4.1",
        range = "(0.2, 1)",
        keyframable,
        renamed_from = "profile.x3, profile.v3"
    )]
    pub profile_v3: f64,
    /// Abscissa of the profile curve's control point v4 (where the bulge fades out).
    #[param(
        symbol = "x(v₄)",
        section = "§5.4.1",
        range = "(0.2, 1)",
        keyframable,
        renamed_from = "profile.x4, profile.v4"
    )]
    pub profile_v4: f64,
    /// Amplitude of the wrinkles: a sinusoid added to the profile (0 = none).
    #[param(
        section = "§7.3.1, Figs. 7.18–7.19",
        unit = "scene units",
        keyframable,
        renamed_from = "wrinkles.amplitude, profile.wrinkle_amplitude"
    )]
    pub wrinkle_amplitude: f64,
    /// Number of wrinkles over the deformable region, from the contact boundary (u = 0) to its
    /// outer edge (u = 1).
    #[param(
        section = "§7.3.1, Figs. 7.18–7.19",
        unit = "cycles",
        range = "[0, inf)",
        keyframable,
        renamed_from = "wrinkles.frequency, profile.wrinkle_frequency"
    )]
    pub wrinkle_frequency: f64,
    /// The automatic anisotropic bulge map: more bulge where the surface is pushed sideways.
    #[param(
        symbol = "η",
        section = "§5.5.2, Eq. 5.6",
        keyframable,
        renamed_from = "anisotropic_bulge, anisotropy.enabled"
    )]
    pub anisotropy: bool,
    /// Exponent of the anisotropic bulge map.
    #[param(
        symbol = "ω",
        section = "§5.5.2, Eq. 5.6",
        range = "(0, inf)",
        keyframable,
        renamed_from = "anisotropy.exponent"
    )]
    pub anisotropy_exponent: f64,
    /// Offset of the anisotropic bulge map (at −1 or less no vertex would bulge).
    #[param(
        symbol = "ψ",
        section = "§5.5.2, Eq. 5.6",
        range = "(-1, inf)",
        keyframable,
        renamed_from = "anisotropy.offset"
    )]
    pub anisotropy_offset: f64,
    /// Painted bulge map: one weight per vertex multiplying the bulge (the thesis' radial and
    /// local brushes).
    #[param(symbol = "η", section = "§5.5.1", word = "uniform")]
    pub bulge_map: Option<Vec<f64>>,
    /// How the displacement directions are built: blended with the normals (method B) or by
    /// parallel transport (method A).
    #[param(section = "§5.2", renamed_from = "direction_method")]
    pub direction_field: DirectionFieldMethod,
    /// Normalize the diffused mapping direction where an object has several contacts.
    #[param(section = "§5.2.2", renamed_from = "normalize_diffused")]
    pub normalize_diffused_direction: bool,
    /// Time step of the heat method as a multiple of the squared mean edge length, t = factor·h².
    #[param(section = "§5.1", range = "(0, inf)")]
    pub heat_time_factor: f64,
    /// Radius of the parametrization domain as a multiple of the extent: the heat method runs
    /// within this many extents of the contact boundary.
    ///
    /// At least 1; `inf` solves on the whole working region as the thesis does. The result
    /// does not change beyond round-off as long as the domain holds the deformable region.
    #[param(section = "§5.1", range = "[1, inf]")]
    pub domain_factor: f64,
    /// How the object is divided into working regions: whole, one per connected component, from
    /// `region_mask`, or automatic around the intersection.
    #[param(section = "§4.5, §7.5")]
    pub region: RegionChoice,
    /// With `region = "distance"`: the least distance from the intersection that the automatic
    /// working region reaches.
    ///
    /// The region is widened to the parametrization domain (`domain_factor` × the extent), so
    /// 0 is a sensible value.
    #[param(section = "§4.5", unit = "scene units", range = "[0, inf)", keyframable)]
    pub region_distance: f64,
    /// With `region = "mask"`: one value per vertex; a vertex whose value rounds to k ≥ 1 belongs
    /// to mask k (a painted 0–1 mask selects the values ≥ 0.5).
    ///
    /// Each mask's connected pieces are working regions; two masks may be adjacent (a palm and
    /// its fingers) but no face may be in two.
    #[param(section = "§4.5", range = "[0, inf)", word = "none")]
    pub region_mask: Option<Vec<f64>>,
    /// Texture coordinates, per vertex or per triangle corner (seams), needed on both objects
    /// of a pair by method A's shared parametrization mapping (`mapping =
    /// "shared_parametrization"`); the mesh's own UVs.
    #[param(skip)]
    pub uvs: Option<Uvs>,
    /// Articulations whose two sides may fold onto each other (skinned joints, lips; thesis
    /// ch. 6), resolved before the contacts with other objects.
    #[param(skip)]
    pub self_contact: Vec<Articulation>,
    /// The parts of a skinned mesh whose touching pairs are pushed apart (self-contact beyond
    /// one articulation, issue 27), after the articulations. `None`: no part contact.
    #[param(skip)]
    pub self_contact_parts: Option<SkinParts>,
    /// With self-contact parts (`self_contact = "auto"`): after the contacts, smooth out what
    /// still passes through the skin (folds crumpled by the skinning, chords of a coarse mesh),
    /// the volume restored exactly by a band of vertices around each fold (the rest of the object
    /// keeps its positions); `false` keeps the method's own result (docs/decisions.md,
    /// "Untangling what is left").
    #[param(section = "beyond the thesis (issue 27)")]
    pub untangle: bool,
    /// Per object vertex: true where a cut region's border is *not* a border for the contact
    /// stage (the seam between the two sides of one self-contact, which an intersection of a
    /// fold reaches by nature; ch. 6). The deformation keeps every border vertex fixed. `None`:
    /// every cut border is a border. Set by the part contacts, not a user key.
    #[param(skip)]
    pub contact_open_border: Option<Vec<bool>>,
    /// Per object vertex: true where the vertex lies inside the other side of its cut region's
    /// contact (given to the contact stage instead of its flood fill, [`crate::contact::ContactSide::interior`]),
    /// asked for the vertices of the cut regions that the intersection stage reaches only
    /// ([`crate::contact::Interior::Asked`]).
    /// Set by the part contacts (a vertex inside the object's own volume: the flood fill cannot
    /// tell inside from outside across an open seam), not a user key. `None`: the contact stage decides.
    #[param(skip)]
    pub contact_interior: Option<VertexFlags>,
    /// The rest (bind) pose, one position per vertex, on which the articulations' partition of
    /// unity β is computed (§6.1.1). `None`: the frame's own mesh.
    #[param(skip)]
    pub rest_positions: Option<Vec<DVec3>>,
}

impl Default for ObjectParams {
    fn default() -> Self {
        Self {
            rigid: false,
            stiffness: 1.0,
            extent: None,
            bulge: 1.0,
            bulge_height: 0.0,
            preserve_volume: None,
            profile_v2: 1.0 / 3.0,
            profile_v3: 5.0 / 6.0,
            profile_v4: 11.0 / 12.0,
            wrinkle_amplitude: 0.0,
            wrinkle_frequency: 0.0,
            anisotropy: false,
            anisotropy_exponent: 2.0,
            anisotropy_offset: 0.0,
            bulge_map: None,
            direction_field: DirectionFieldMethod::Blended,
            normalize_diffused_direction: true,
            heat_time_factor: 10.0,
            domain_factor: 2.0,
            region: RegionChoice::Whole,
            region_distance: 0.0,
            region_mask: None,
            uvs: None,
            self_contact: Vec::new(),
            self_contact_parts: None,
            contact_open_border: None,
            contact_interior: None,
            untangle: true,
            rest_positions: None,
        }
    }
}

/// The least abscissa of v2: v1 lies at x ≤ 0.2 (§5.4.1).
pub const MIN_PROFILE_ABSCISSA: f64 = 0.2;

impl ObjectParams {
    /// A rigid object.
    pub fn rigid() -> Self {
        Self { rigid: true, ..Self::default() }
    }

    /// With another stiffness.
    pub fn with_stiffness(mut self, stiffness: f64) -> Self {
        self.stiffness = stiffness;
        self
    }

    /// With a fixed extent φ_max.
    pub fn with_extent(mut self, extent: f64) -> Self {
        self.extent = Some(extent);
        self
    }

    /// With another volume compensation γ.
    pub fn with_bulge(mut self, bulge: f64) -> Self {
        self.bulge = bulge;
        self
    }

    /// With the profile abscissas `[v2, v3, v4]`.
    pub fn with_profile(mut self, [v2, v3, v4]: [f64; 3]) -> Self {
        (self.profile_v2, self.profile_v3, self.profile_v4) = (v2, v3, v4);
        self
    }

    /// The profile abscissas `[v2, v3, v4]`.
    pub fn profile(&self) -> [f64; 3] {
        [self.profile_v2, self.profile_v3, self.profile_v4]
    }

    /// With a painted bulge map (one weight per vertex).
    pub fn with_bulge_map(mut self, bulge_map: Vec<f64>) -> Self {
        self.bulge_map = Some(bulge_map);
        self
    }

    /// With working regions chosen by `region` (`region_mask` and `region_distance` unchanged).
    pub fn with_region(mut self, region: RegionChoice) -> Self {
        self.region = region;
        self
    }

    /// With the automatic working region at least `distance` from the intersection.
    pub fn with_region_distance(mut self, distance: f64) -> Self {
        self.region = RegionChoice::Distance;
        self.region_distance = distance;
        self
    }

    /// With working regions from a mask: one value per vertex, rounded to the mask's number
    /// (0 outside; see [`ObjectParams::region_mask`]).
    pub fn with_region_mask(mut self, mask: Vec<f64>) -> Self {
        self.region = RegionChoice::Mask;
        self.region_mask = Some(mask);
        self
    }

    /// With working regions from several boolean masks (mask k of the list is label k + 1).
    pub fn with_region_masks(self, masks: &[Vec<bool>]) -> Self {
        let n = masks.iter().map(Vec::len).max().unwrap_or(0);
        let mut labels = vec![0.0; n];
        for (k, mask) in masks.iter().enumerate() {
            for (label, _) in labels.iter_mut().zip(mask).filter(|(_, m)| **m) {
                *label = (k + 1) as f64;
            }
        }
        self.with_region_mask(labels)
    }

    /// Conditions between fields: the profile's abscissas in order; a mask for masked regions.
    fn check_fields(&self) -> Result<(), ParamError> {
        let [v2, v3, v4] = self.profile();
        if !(MIN_PROFILE_ABSCISSA < v2 && v2 < v3 && v3 < v4 && v4 < 1.0) {
            return Err(ParamError::condition(
                "profile_v2",
                format!(
                    "the profile abscissas v2, v3, v4 are {v2}, {v3}, {v4}; they must increase strictly within (0.2, 1), e.g. the defaults 0.3333, 0.8333, 0.9167"
                ),
            ));
        }
        if self.region == RegionChoice::Mask && self.region_mask.is_none() {
            return Err(ParamError::condition(
                "region",
                "region = \"mask\" needs region_mask (one value per vertex, ≥ 0.5 inside); give it, or choose another region",
            ));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::{ParamValue, Params};

    #[test]
    fn masks_become_labels_and_back() {
        let p = ObjectParams::default().with_region_masks(&[vec![true, false, false], vec![false, false, true]]);
        assert_eq!(p.region, RegionChoice::Mask);
        assert_eq!(p.region_mask.as_deref(), Some(&[1.0, 0.0, 2.0][..]));
    }

    #[test]
    fn profile_out_of_order_is_an_error_naming_the_key() {
        let mut p = ObjectParams::default();
        p.set("profile_v2", &ParamValue::Number(0.9)).expect("in range alone");
        let err = p.validate().unwrap_err().to_string();
        assert!(err.starts_with("profile_v2:") && err.contains("increase strictly"), "{err}");
    }
}
