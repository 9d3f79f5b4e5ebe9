//! The inputs of the deformation stage (thesis ch. 5, §7.3): the object's parameters
//! ([`ObjectParams`]: profile, bulge, wrinkles, anisotropy, heat time …) and what the pipeline
//! resolves for a region at a frame (the extent, volume preservation, length scale, domain).
//!
//! `extent` (φ_max) has no default: it is a world-space distance that depends on the scene, so
//! [`DeformParams::default`] leaves it unset (NaN) and [`super::deform_region`] rejects it until
//! the caller (the pipeline derives one from the geometry) sets it, e.g. with
//! [`DeformParams::new`].

use std::borrow::Cow;

use super::DeformError;
use super::profile::{ProfileShape, Wrinkles};
use crate::linalg::DEFAULT_CONSTRAINT_WEIGHT_FACTOR;
use crate::params::{DirectionFieldMethod, ObjectParams, Params};

/// Parameters of [`super::deform_region`]: the object's own ([`DeformParams::object`], borrowed
/// from the frame or owned) and the values resolved for this region and frame.
#[derive(Clone, Debug, PartialEq)]
pub struct DeformParams<'a> {
    /// The object's parameters. Its `bulge_map`, `extent`, `preserve_volume` and region fields
    /// are not read: the resolved values below stand for them.
    pub object: Cow<'a, ObjectParams>,
    /// φ_max: the geodesic distance from ∂𝒞 where the deformation ends (§5.1), world units.
    /// Required: finite and positive. Unset (NaN) by default.
    pub extent: f64,
    /// Solve `h_v` so that the object's volume is preserved (App. C). Meaningful for closed
    /// objects only; the caller sets it (on for closed meshes, off for open ones). Default true.
    pub preserve_volume: bool,
    /// Painted bulge map η, one weight per vertex of the region (§5.5.1). `None`: all 1.
    pub bulge_map: Option<Vec<f64>>,
    /// h, the length scale of the heat time `t = heat_time_factor·h²`, of the slope confidence
    /// (§5.3) and of the transport field's target blend (§5.2.1). `None` (default): the region's
    /// mean edge length. The pipeline gives every region its object's h, so that where the cut
    /// falls does not change the result.
    pub edge_length: Option<f64>,
    /// Least-squares constraint weight factor `λ = factor × operator scale` (App. B). Default 100.
    pub constraint_weight_factor: f64,
    /// The domain radius in world units, overriding `domain_factor·extent` when set. The pipeline
    /// sets it when it re-solves a region with a clamped extent, so that the second solve sees
    /// the same domain, hence the same φ. Default `None`.
    pub domain_radius: Option<f64>,
}

impl Default for DeformParams<'_> {
    fn default() -> Self {
        Self {
            object: Cow::Owned(ObjectParams::default()),
            extent: f64::NAN,
            preserve_volume: true,
            bulge_map: None,
            edge_length: None,
            constraint_weight_factor: DEFAULT_CONSTRAINT_WEIGHT_FACTOR,
            domain_radius: None,
        }
    }
}

impl<'a> DeformParams<'a> {
    /// The defaults with the given extent φ_max.
    pub fn new(extent: f64) -> Self {
        Self { extent, ..Self::default() }
    }

    /// The parameters of `object` for a region, with its resolved extent and volume preservation
    /// (the bulge map is the caller's to set: one value per region vertex).
    pub fn of(object: &'a ObjectParams, extent: f64, preserve_volume: bool) -> Self {
        Self { object: Cow::Borrowed(object), extent, preserve_volume, ..Self::default() }
    }

    fn object_mut(&mut self) -> &mut ObjectParams {
        self.object.to_mut()
    }

    /// With another extent φ_max.
    pub fn with_extent(mut self, extent: f64) -> Self {
        self.extent = extent;
        self
    }

    /// With another volume compensation γ.
    pub fn with_bulge(mut self, bulge: f64) -> Self {
        self.object_mut().bulge = bulge;
        self
    }

    /// With volume preservation on or off.
    pub fn with_preserve_volume(mut self, preserve_volume: bool) -> Self {
        self.preserve_volume = preserve_volume;
        self
    }

    /// With a fixed bulge height (used when volume preservation is off).
    pub fn with_bulge_height(mut self, bulge_height: f64) -> Self {
        self.object_mut().bulge_height = bulge_height;
        self
    }

    /// With other profile abscissas.
    pub fn with_profile(mut self, profile: ProfileShape) -> Self {
        let o = self.object_mut();
        (o.profile_v2, o.profile_v3, o.profile_v4) = (profile.x2, profile.x3, profile.x4);
        self
    }

    /// With wrinkles of amplitude `amplitude` (world units) and `frequency` cycles.
    pub fn with_wrinkles(mut self, amplitude: f64, frequency: f64) -> Self {
        let o = self.object_mut();
        (o.wrinkle_amplitude, o.wrinkle_frequency) = (amplitude, frequency);
        self
    }

    /// With the anisotropic bulge map of Eq. 5.6 on or off.
    pub fn with_anisotropic_bulge(mut self, on: bool) -> Self {
        self.object_mut().anisotropy = on;
        self
    }

    /// With the anisotropy exponent ω and offset ψ of Eq. 5.6 (and the map switched on).
    pub fn with_anisotropy(mut self, exponent: f64, offset: f64) -> Self {
        let o = self.object_mut();
        (o.anisotropy, o.anisotropy_exponent, o.anisotropy_offset) = (true, exponent, offset);
        self
    }

    /// With a painted bulge map (one weight per region vertex).
    pub fn with_bulge_map(mut self, bulge_map: Vec<f64>) -> Self {
        self.bulge_map = Some(bulge_map);
        self
    }

    /// With the diffused direction field normalized or not.
    pub fn with_normalize_diffused(mut self, normalize: bool) -> Self {
        self.object_mut().normalize_diffused_direction = normalize;
        self
    }

    /// With another heat time factor.
    pub fn with_heat_time_factor(mut self, factor: f64) -> Self {
        self.object_mut().heat_time_factor = factor;
        self
    }

    /// With another constraint weight factor.
    pub fn with_constraint_weight_factor(mut self, factor: f64) -> Self {
        self.constraint_weight_factor = factor;
        self
    }

    /// With another parametrization-domain factor.
    pub fn with_domain_factor(mut self, factor: f64) -> Self {
        self.object_mut().domain_factor = factor;
        self
    }

    /// With another direction-field method.
    pub fn with_direction_field(mut self, method: DirectionFieldMethod) -> Self {
        self.object_mut().direction_field = method;
        self
    }

    /// The profile's abscissas.
    pub fn profile(&self) -> ProfileShape {
        let [x2, x3, x4] = self.object.profile();
        ProfileShape { x2, x3, x4 }
    }

    /// The profile's wrinkles.
    pub fn wrinkles(&self) -> Wrinkles {
        Wrinkles { amplitude: self.object.wrinkle_amplitude, frequency: self.object.wrinkle_frequency }
    }

    /// The radius of the parametrization domain in world units.
    pub fn domain_radius(&self) -> f64 {
        self.domain_radius_for(self.extent)
    }

    /// The radius of the parametrization domain in world units for the extent `extent`.
    pub fn domain_radius_for(&self, extent: f64) -> f64 {
        self.domain_radius.unwrap_or(self.object.domain_factor * extent)
    }

    /// Checks every parameter that does not depend on the region (the bulge map's length is
    /// checked against the region by [`super::deform_region`]).
    pub fn validate(&self) -> Result<(), DeformError> {
        if !(self.extent.is_finite() && self.extent > 0.0) {
            return Err(DeformError::InvalidExtent { extent: self.extent });
        }
        self.object.validate()?;
        let invalid = |name: &'static str, value: f64, hint: &'static str| {
            Err(DeformError::InvalidParameter { name, value, hint })
        };
        if !(self.constraint_weight_factor.is_finite() && self.constraint_weight_factor > 0.0) {
            return invalid(
                "constraint_weight_factor",
                self.constraint_weight_factor,
                "the constraint weight factor must be finite and positive (default 100)",
            );
        }
        if let Some(h) = self.edge_length.filter(|&h| !(h.is_finite() && h > 0.0)) {
            return invalid(
                "edge_length",
                h,
                "the length scale h must be finite and positive (leave it unset for the region's mean edge length)",
            );
        }
        if let Some(radius) = self.domain_radius.filter(|&r| r.is_nan() || r < self.extent) {
            return invalid(
                "domain_radius",
                radius,
                "the parametrization domain must hold the deformable region: radius ≥ the extent",
            );
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
    fn defaults_are_the_objects_and_extent_is_required() {
        let p = DeformParams::default();
        assert_eq!(*p.object, ObjectParams::default());
        assert_eq!(p.constraint_weight_factor, 100.0);
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
    fn a_borrowed_object_is_not_copied_until_changed() {
        let object = ObjectParams::default().with_bulge(1.5);
        let p = DeformParams::of(&object, 0.4, false);
        assert!(matches!(p.object, Cow::Borrowed(_)));
        assert_eq!((p.object.bulge, p.extent, p.preserve_volume), (1.5, 0.4, false));
        let changed = p.with_bulge(2.0);
        assert_eq!((changed.object.bulge, object.bulge), (2.0, 1.5));
    }
}
