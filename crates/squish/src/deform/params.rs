//! Parameters of the deformation stage (thesis ch. 5, §7.3), with the thesis' defaults.
//!
//! `extent` (φ_max) has no default: it is a world-space distance that depends on the scene, so
//! [`DeformParams::default`] leaves it unset (NaN) and [`super::deform_region`] rejects it until
//! the caller (the pipeline derives one from the geometry) sets it, e.g. with
//! [`DeformParams::new`].

use super::DeformError;
use super::profile::{ProfileShape, Wrinkles};
use crate::linalg::DEFAULT_CONSTRAINT_WEIGHT_FACTOR;

/// How the displacement direction field `d` is built (thesis §5.2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum DirectionFieldMethod {
    /// Method B (§5.2.2, Eq. 5.4): the mapping directions (diffused when there are several zones)
    /// blended with the input normals, `d = normalize(w(u)·d̄ + (1 − w(u))·n)`, `w = (1 − u²)⁶`.
    #[default]
    Blended,
    /// Method A (§5.2.1): the directions' tangent parts, as angles (arcsin remapping), diffused
    /// over 𝒟 with parallel transport (complex connection Laplacian) from the displacement
    /// directions at ∂𝒞 to the normals at ∂𝒟, remapped to the uniform parametrization u (u/u′
    /// correction). Costs two more factorizations per frame. See [`super::transport_field`].
    ParallelTransport,
}

/// Parameters of [`super::deform_region`]. Public fields, `Default` = the thesis' defaults (except
/// `extent`, see the module doc), `with_*` builders, serde-ready (missing fields take defaults).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct DeformParams {
    /// φ_max: the geodesic distance from ∂𝒞 where the deformation ends (§5.1), world units.
    /// Required: finite and positive. Unset (NaN) by default; an unset extent is left out when
    /// serializing (JSON has no NaN), so default parameters round-trip.
    #[serde(skip_serializing_if = "is_unset")]
    pub extent: f64,
    /// γ: volume compensation, 0 = none, 1 = preserve, > 1 exaggerate (§5.4.2). Default 1.
    pub bulge: f64,
    /// Solve `h_v` so that the object's volume is preserved (App. C). Meaningful for closed
    /// objects only; the caller sets it (on for closed meshes, off for open ones). Default true.
    pub preserve_volume: bool,
    /// `h_v` in world units when `preserve_volume` is off. Default 0.
    pub bulge_height: f64,
    /// Abscissas of the profile's control points `v2, v3, v4` (§5.4.1).
    pub profile: ProfileShape,
    /// Sinusoidal modulation of the profile (Figs. 7.18–7.19). Default none.
    pub wrinkles: Wrinkles,
    /// Multiply the bulge map by the automatic anisotropic map of Eq. 5.6. Default false (the
    /// uniform bulge of the standard pipeline, Fig. 5.6a).
    pub anisotropic_bulge: bool,
    /// ω of Eq. 5.6. Default 2.
    pub anisotropy_exponent: f64,
    /// ψ of Eq. 5.6. Default 0.
    pub anisotropy_offset: f64,
    /// Painted bulge map η, one weight per region vertex (§5.5.1). Default `None` (all 1).
    pub bulge_map: Option<Vec<f64>>,
    /// Normalize the diffused mapping-direction field d̄ when there are several zones (§5.2.2:
    /// the thesis does). `false` keeps it unnormalized so the direction falls back to the
    /// normal where zone directions cancel (needed by skinning, ch. 6). Default true.
    pub normalize_diffused: bool,
    /// The heat step's time as a multiple of the squared mean edge length, `t = factor·h²`
    /// (§5.1). Default 10.
    pub heat_time_factor: f64,
    /// h, the length scale of the heat time `t = heat_time_factor·h²`, of the slope confidence
    /// (§5.3) and of the transport field's target blend (§5.2.1). `None` (default): the region's
    /// mean edge length. The pipeline gives every region its object's h, so that
    /// where the cut falls does not change the result.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub edge_length: Option<f64>,
    /// Least-squares constraint weight factor `λ = factor × operator scale` (App. B). Default 100.
    pub constraint_weight_factor: f64,
    /// How the direction field is built. Default [`DirectionFieldMethod::Blended`].
    pub direction_method: DirectionFieldMethod,
    /// The radius of the parametrization domain 𝒫 as a multiple of φ_max (see
    /// [`super::parametrize()`]): φ is solved on the faces within `domain_factor·φ_max` of ∂𝒞
    /// along edges, so the result does not depend on the rest of the region. At least 1;
    /// `f64::INFINITY` solves on the whole region as the thesis does. Default 2.
    pub domain_factor: f64,
    /// The domain radius in world units, overriding `domain_factor·extent` when set. The pipeline
    /// sets it when it re-solves a region with a clamped extent, so that the second solve sees
    /// the same domain, hence the same φ. Default `None`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub domain_radius: Option<f64>,
}

/// Default [`DeformParams::domain_factor`].
pub const DEFAULT_DOMAIN_FACTOR: f64 = 2.0;

/// True for an unset (NaN) extent, which serde leaves out.
fn is_unset(extent: &f64) -> bool {
    extent.is_nan()
}

impl Default for DeformParams {
    fn default() -> Self {
        Self {
            extent: f64::NAN,
            bulge: 1.0,
            preserve_volume: true,
            bulge_height: 0.0,
            profile: ProfileShape::default(),
            wrinkles: Wrinkles::default(),
            anisotropic_bulge: false,
            anisotropy_exponent: 2.0,
            anisotropy_offset: 0.0,
            bulge_map: None,
            normalize_diffused: true,
            heat_time_factor: 10.0,
            edge_length: None,
            constraint_weight_factor: DEFAULT_CONSTRAINT_WEIGHT_FACTOR,
            direction_method: DirectionFieldMethod::Blended,
            domain_factor: DEFAULT_DOMAIN_FACTOR,
            domain_radius: None,
        }
    }
}

impl DeformParams {
    /// The defaults with the given extent φ_max.
    pub fn new(extent: f64) -> Self {
        Self { extent, ..Self::default() }
    }

    /// With another extent φ_max.
    pub fn with_extent(mut self, extent: f64) -> Self {
        self.extent = extent;
        self
    }

    /// With another volume compensation γ.
    pub fn with_bulge(mut self, bulge: f64) -> Self {
        self.bulge = bulge;
        self
    }

    /// With volume preservation on or off.
    pub fn with_preserve_volume(mut self, preserve_volume: bool) -> Self {
        self.preserve_volume = preserve_volume;
        self
    }

    /// With a fixed bulge height (used when volume preservation is off).
    pub fn with_bulge_height(mut self, bulge_height: f64) -> Self {
        self.bulge_height = bulge_height;
        self
    }

    /// With other profile abscissas.
    pub fn with_profile(mut self, profile: ProfileShape) -> Self {
        self.profile = profile;
        self
    }

    /// With wrinkles of amplitude `amplitude` (world units) and `frequency` cycles.
    pub fn with_wrinkles(mut self, amplitude: f64, frequency: f64) -> Self {
        self.wrinkles = Wrinkles { amplitude, frequency };
        self
    }

    /// With the anisotropic bulge map of Eq. 5.6 on or off.
    pub fn with_anisotropic_bulge(mut self, on: bool) -> Self {
        self.anisotropic_bulge = on;
        self
    }

    /// With the anisotropy exponent ω and offset ψ of Eq. 5.6 (and the map switched on).
    pub fn with_anisotropy(mut self, exponent: f64, offset: f64) -> Self {
        self.anisotropic_bulge = true;
        self.anisotropy_exponent = exponent;
        self.anisotropy_offset = offset;
        self
    }

    /// With a painted bulge map (one weight per region vertex).
    pub fn with_bulge_map(mut self, bulge_map: Vec<f64>) -> Self {
        self.bulge_map = Some(bulge_map);
        self
    }

    /// With the diffused direction field normalized or not.
    pub fn with_normalize_diffused(mut self, normalize: bool) -> Self {
        self.normalize_diffused = normalize;
        self
    }

    /// With another heat time factor.
    pub fn with_heat_time_factor(mut self, factor: f64) -> Self {
        self.heat_time_factor = factor;
        self
    }

    /// With another constraint weight factor.
    pub fn with_constraint_weight_factor(mut self, factor: f64) -> Self {
        self.constraint_weight_factor = factor;
        self
    }

    /// With another parametrization-domain factor.
    pub fn with_domain_factor(mut self, factor: f64) -> Self {
        self.domain_factor = factor;
        self
    }

    /// The radius of the parametrization domain in world units.
    pub fn domain_radius(&self) -> f64 {
        self.domain_radius_for(self.extent)
    }

    /// The radius of the parametrization domain in world units for the extent `extent`.
    pub fn domain_radius_for(&self, extent: f64) -> f64 {
        self.domain_radius.unwrap_or(self.domain_factor * extent)
    }

    /// With another direction-field method.
    pub fn with_direction_method(mut self, method: DirectionFieldMethod) -> Self {
        self.direction_method = method;
        self
    }

    /// Checks every parameter that does not depend on the region (the bulge map's length is
    /// checked against the region by [`super::deform_region`]).
    pub fn validate(&self) -> Result<(), DeformError> {
        if !(self.extent.is_finite() && self.extent > 0.0) {
            return Err(DeformError::InvalidExtent { extent: self.extent });
        }
        let finite = |name: &'static str, value: f64, hint: &'static str| {
            if value.is_finite() { Ok(()) } else { Err(DeformError::InvalidParameter { name, value, hint }) }
        };
        let positive = |name: &'static str, value: f64, hint: &'static str| {
            if value.is_finite() && value > 0.0 {
                Ok(())
            } else {
                Err(DeformError::InvalidParameter { name, value, hint })
            }
        };
        finite("bulge", self.bulge, "γ must be finite (0 cancels the bulge, 1 preserves the volume, > 1 exaggerates)")?;
        finite("bulge_height", self.bulge_height, "the bulge height is a finite world-space length")?;
        finite("wrinkles.amplitude", self.wrinkles.amplitude, "the wrinkle amplitude is a finite world-space length")?;
        finite("wrinkles.frequency", self.wrinkles.frequency, "the wrinkle frequency is a finite number of cycles")?;
        self.profile.validate()?;
        if !(self.anisotropy_exponent.is_finite() && self.anisotropy_exponent >= 0.0) {
            return Err(DeformError::InvalidParameter {
                name: "anisotropy_exponent",
                value: self.anisotropy_exponent,
                hint: "ω must be finite and non-negative (default 2)",
            });
        }
        finite("anisotropy_offset", self.anisotropy_offset, "ψ must be finite (default 0)")?;
        positive(
            "heat_time_factor",
            self.heat_time_factor,
            "the heat time factor must be finite and positive (default 10)",
        )?;
        positive(
            "constraint_weight_factor",
            self.constraint_weight_factor,
            "the constraint weight factor must be finite and positive (default 100)",
        )?;
        if let Some(h) = self.edge_length.filter(|&h| !(h.is_finite() && h > 0.0)) {
            return Err(DeformError::InvalidParameter {
                name: "edge_length",
                value: h,
                hint: "the length scale h must be finite and positive (leave it unset for the region's mean edge length)",
            });
        }
        if self.domain_factor.is_nan() || self.domain_factor < 1.0 {
            return Err(DeformError::InvalidParameter {
                name: "domain_factor",
                value: self.domain_factor,
                hint: "the parametrization domain must hold the deformable region: at least 1 (default 2; a huge factor such as 1e9 solves on the whole region)",
            });
        }
        if let Some(radius) = self.domain_radius.filter(|&r| r.is_nan() || r < self.extent) {
            return Err(DeformError::InvalidParameter {
                name: "domain_radius",
                value: radius,
                hint: "the parametrization domain must hold the deformable region: radius ≥ the extent",
            });
        }
        if let Some((vertex, &value)) = self.bulge_map.iter().flatten().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(DeformError::NonFiniteBulgeMap { vertex, value });
        }
        Ok(())
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_thesis_values_and_extent_is_required() {
        let p = DeformParams::default();
        assert_eq!(p.bulge, 1.0);
        assert_eq!((p.anisotropy_exponent, p.anisotropy_offset), (2.0, 0.0));
        assert_eq!(p.heat_time_factor, 10.0);
        assert_eq!(p.constraint_weight_factor, 100.0);
        assert!(p.normalize_diffused);
        assert!(matches!(p.validate(), Err(DeformError::InvalidExtent { .. })));
        assert!(DeformParams::new(0.5).validate().is_ok());
        for extent in [0.0, -1.0, f64::INFINITY] {
            assert!(matches!(DeformParams::new(extent).validate(), Err(DeformError::InvalidExtent { .. })));
        }
    }

    #[test]
    fn bad_parameters_are_errors_with_hints() {
        let base = DeformParams::new(1.0);
        let cases = [
            base.clone().with_bulge(f64::NAN),
            base.clone().with_heat_time_factor(0.0),
            base.clone().with_constraint_weight_factor(-1.0),
            base.clone().with_anisotropy(-2.0, 0.0),
            base.clone().with_wrinkles(f64::INFINITY, 1.0),
            base.clone().with_bulge_map(vec![1.0, f64::NAN]),
            base.clone().with_profile(ProfileShape { x2: 0.9, x3: 0.5, x4: 0.95 }),
            base.clone().with_domain_factor(0.5),
            base.clone().with_domain_factor(f64::NAN),
            DeformParams { domain_radius: Some(0.5), ..base.clone() },
            DeformParams { edge_length: Some(0.0), ..base.clone() },
        ];
        for params in cases {
            let err = params.validate().unwrap_err();
            assert!(!err.to_string().is_empty());
        }
    }

    #[test]
    fn params_round_trip_through_json_and_missing_fields_take_defaults() {
        let p = DeformParams::new(0.7).with_bulge(1.5).with_bulge_map(vec![1.0, 0.5]).with_anisotropy(3.0, 0.1);
        let json = serde_json::to_string(&p).unwrap();
        let back: DeformParams = serde_json::from_str(&json).unwrap();
        assert_eq!(back, p);
        let defaults: DeformParams =
            serde_json::from_str(&serde_json::to_string(&DeformParams::default()).unwrap()).unwrap();
        assert!(defaults.extent.is_nan() && defaults.validate().is_err());
        let partial: DeformParams = serde_json::from_str(r#"{"extent": 2.0, "bulge": 0.5}"#).unwrap();
        assert_eq!(partial, DeformParams::new(2.0).with_bulge(0.5));
    }
}
