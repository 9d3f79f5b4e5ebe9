//! Per-object parameters of the whole pipeline, named after the glossary of
//! `ARCHITECTURE.md` (thesis symbol → field) with the thesis' defaults. Per-pair parameters are
//! [`crate::contact::PairParams`].
//!
//! Scale-dependent defaults are derived from the geometry by the pipeline (see
//! [`super::automatic_extent`]), never hard-coded.

use glam::{DVec2, DVec3};
use serde::{Deserialize, Serialize};

use super::WorkingRegion;
use crate::contact::Stiffness;
use crate::deform::{DeformParams, DirectionFieldMethod, ProfileShape, Wrinkles};
use crate::skinning::Articulation;

/// Parameters of one object. Public fields, `Default` = the thesis' defaults, serde-ready
/// (missing fields take their defaults; unknown fields are errors).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct ObjectParams {
    /// A rigid object keeps its shape: the potential contact surface is its surface (§4.3).
    pub rigid: bool,
    /// k: pseudo-stiffness; the relative stiffness of a pair is k̄_l = k_l / (k_1 + k_2) (§4.3).
    /// Default 1.
    pub stiffness: f64,
    /// φ_max: deformation extent, the distance from the contact boundary where the deformation
    /// ends (§5.1), in world units. `None` = automatic (see [`super::automatic_extent`]).
    pub extent: Option<f64>,
    /// γ: volume compensation, 0 = none, 1 = preserve, > 1 exaggerate (§5.4.2). Default 1.
    pub bulge: f64,
    /// h_v in world units when the volume is not preserved (open meshes). Default 0.
    pub bulge_height: f64,
    /// Preserve the volume (App. C). `None` = automatic: on for closed meshes, off for open ones.
    pub preserve_volume: Option<bool>,
    /// Abscissas of the profile control points v2, v3, v4 (§5.4.1).
    pub profile: ProfileShape,
    /// Procedural modulation of the profile (Figs. 7.18–7.19).
    pub wrinkles: Wrinkles,
    /// Automatic anisotropic bulge map of Eq. 5.6. Default off.
    pub anisotropy: bool,
    /// ω of Eq. 5.6. Default 2.
    pub anisotropy_exponent: f64,
    /// ψ of Eq. 5.6. Default 0.
    pub anisotropy_offset: f64,
    /// Painted bulge map η, one value per vertex (§5.5.1). Default: uniform.
    pub bulge_map: Option<Vec<f64>>,
    /// Normalize the diffused mapping-direction field when a region has several contacts
    /// (§5.2.2). Default true.
    pub normalize_diffused_direction: bool,
    /// Heat-method time step as a multiple of the squared mean edge length (§5.1). Default 10.
    pub heat_time_factor: f64,
    /// Radius of the parametrization domain as a multiple of the extent: the heat method runs
    /// on the faces within `domain_factor·φ_max` of the contact boundary (§5.1; see
    /// [`crate::deform::parametrize`]). At least 1; a huge factor (`f64::INFINITY`, or `1e9` from a
    /// JSON/TOML file, which cannot hold infinity) solves on the whole working region as the thesis
    /// does. Default 2.
    pub domain_factor: f64,
    /// How the displacement direction field d is built: method B's blend with the normal (§5.2)
    /// or method A's parallel transport (§5.2 of the 2020 paper). Default blended.
    pub direction_field: DirectionFieldMethod,
    /// Per-vertex texture coordinates, one per vertex: needed by the shared-parametrization
    /// mapping ([`crate::contact::MappingMethod::SharedParametrization`]) on both objects of a
    /// pair. Default none.
    pub uvs: Option<Vec<DVec2>>,
    /// 𝒲: the working regions the pipeline processes (§4, §4.5, §7.5). Default: the whole
    /// object. See [`WorkingRegion`].
    pub region: WorkingRegion,
    /// Articulations whose two sides may fold onto each other (skinned joints, lips; thesis
    /// ch. 6), resolved before the contacts with other objects. Default: none.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub self_contact: Vec<Articulation>,
    /// The rest (bind) pose, one position per vertex, on which the articulations' partition of
    /// unity β is computed (§6.1.1). Default: the frame's own mesh.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rest_positions: Option<Vec<DVec3>>,
}

impl Default for ObjectParams {
    fn default() -> Self {
        let deform = DeformParams::default();
        Self {
            rigid: false,
            stiffness: 1.0,
            extent: None,
            bulge: deform.bulge,
            bulge_height: deform.bulge_height,
            preserve_volume: None,
            profile: deform.profile,
            wrinkles: deform.wrinkles,
            anisotropy: deform.anisotropic_bulge,
            anisotropy_exponent: deform.anisotropy_exponent,
            anisotropy_offset: deform.anisotropy_offset,
            bulge_map: None,
            normalize_diffused_direction: deform.normalize_diffused,
            heat_time_factor: deform.heat_time_factor,
            domain_factor: deform.domain_factor,
            direction_field: deform.direction_method,
            uvs: None,
            region: WorkingRegion::Whole,
            self_contact: Vec::new(),
            rest_positions: None,
        }
    }
}

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

    /// With other working regions.
    pub fn with_region(mut self, region: WorkingRegion) -> Self {
        self.region = region;
        self
    }

    /// With another volume compensation γ.
    pub fn with_bulge(mut self, bulge: f64) -> Self {
        self.bulge = bulge;
        self
    }

    /// The stiffness as the contact stage sees it.
    pub fn contact_stiffness(&self) -> Stiffness {
        if self.rigid { Stiffness::Rigid } else { Stiffness::Elastic(self.stiffness) }
    }

    /// The deformation parameters for a frame, given the resolved extent and whether the mesh is
    /// closed.
    pub fn deform_params(&self, extent: f64, closed: bool) -> DeformParams {
        DeformParams {
            extent,
            bulge: self.bulge,
            preserve_volume: self.preserve_volume.unwrap_or(closed),
            bulge_height: self.bulge_height,
            profile: self.profile,
            wrinkles: self.wrinkles,
            anisotropic_bulge: self.anisotropy,
            anisotropy_exponent: self.anisotropy_exponent,
            anisotropy_offset: self.anisotropy_offset,
            bulge_map: self.bulge_map.clone(),
            normalize_diffused: self.normalize_diffused_direction,
            heat_time_factor: self.heat_time_factor,
            domain_factor: self.domain_factor,
            direction_method: self.direction_field,
            ..DeformParams::default()
        }
    }
}
