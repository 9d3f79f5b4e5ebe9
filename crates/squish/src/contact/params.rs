//! Parameters of the contact definition (thesis chapter 4, method B): the pseudo-stiffness of each
//! object (§4.3) and the per-pair knobs — the contact spread τ (Eq. 4.3), an optional user mapping
//! direction (§4.2.2, "she or he can specify it manually and even key-frame it") and the angle of
//! the safeguard of §4.4.2.
//!
//! Defaults are the thesis' values: τ = 0, automatic direction (Eq. 4.1), safeguard 80°, and a
//! stiffness of 1 (only the ratio k_a / (k_a + k_b) matters).
//!
//! Method A's alternatives are chosen per pair: [`ContactMethod::Ball`] (ball testing, §4.4.1, see
//! [`super::ball`]) instead of the geometric criterion, and [`MappingMethod::SharedParametrization`]
//! (§4.2.1, see [`super::uv_mapping`]) instead of the unique mapping direction. Both default to
//! method B, so configurations written before they existed keep their meaning.

use glam::DVec3;

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

/// How the contact zone 𝒞 is extracted from the potential contact surface (thesis §4.4).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ContactMethod {
    /// Method B's geometric criterion δᵀn′ ≥ ε_c (§4.4.2, Eq. 4.2–4.4), driven by τ. Handles
    /// elastic–elastic contacts.
    #[default]
    Geometric,
    /// Method A's ball testing and ball sliding (§4.4.1): a vertex is in 𝒞 when a ball of radius
    /// `radius` (r_s, world units) rolled inside the elastic object touches it without touching the
    /// rest of the projected surface. r_s is the elastic object's pseudo-stiffness: a larger ball
    /// gives a smaller zone (Fig. 4.10). Needs exactly one rigid object; `radius` should stay below
    /// the elastic object's local thickness (the ball must fit inside it, §4.4.1 discussion).
    Ball {
        /// r_s, world units; finite and positive.
        radius: f64,
    },
}

/// How the points of one working region are matched on the other (thesis §4.2).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MappingMethod {
    /// Method B's unique mapping direction d̂ and farthest hits along it (§4.2.2).
    #[default]
    UniqueDirection,
    /// Method A's shared parametrization (§4.2.1): both meshes carry UVs
    /// ([`super::ContactSide::with_uvs`]); intersection points are matched in UV space by an
    /// affine map plus a harmonic correction, and the mapping regions are the intersection regions.
    SharedParametrization,
}

/// Per-pair parameters of the contact definition.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct PairParams {
    /// τ of Eq. 4.3: the contact threshold is ε_c = m_𝒮 + τ·σ_𝒮. Larger τ → smaller contact
    /// zones (Fig. 4.11); negative values enlarge them. Scale-free. Default: 0.
    pub contact_tau: f64,
    /// Mapping direction d̂ given by the user (normalized here; it overrides Eq. 4.1 and is
    /// expected to point along the second object's normals, like the automatic one).
    /// `None` (default) = automatic (Eq. 4.1).
    pub direction: Option<DVec3>,
    /// Safeguard angle in degrees (§4.4.2): a point stays out of the contact zone if its own
    /// normal or the normal of its match makes more than this angle with the mapping direction.
    /// Default: 80.
    pub safeguard_angle_degrees: f64,
    /// How 𝒞 is extracted. Default: the geometric criterion (method B).
    pub contact_method: ContactMethod,
    /// How the meshes are matched. Default: the unique mapping direction (method B).
    pub mapping: MappingMethod,
    /// An upper bound on ε_c (world units): `ε_c = min(m_𝒮 + τ·σ_𝒮, max)`. With 0 every
    /// penetrating point of the mapping regions is in contact, whatever the spread of depths —
    /// what self-contact uses (ch. 6), where no interpenetration may remain. Default: none.
    pub max_contact_threshold: Option<f64>,
    /// A lower bound on ε_c in units of the typical penetration depth P (see
    /// [`super::zone::CriterionStats::penetration`]): `ε_c ≥ −floor·P`. Where the mapping regions
    /// face each other across wide gaps (the two sides of a fold), m_𝒮 + τσ_𝒮 is far below 0
    /// and would pull in points up to that gap away as soon as the contact starts — a jump.
    /// With the floor, the zone starts as the penetrating points and grows with the penetration.
    /// Default: none (the thesis' criterion).
    pub contact_threshold_floor: Option<f64>,
}

impl Default for PairParams {
    fn default() -> Self {
        Self {
            contact_tau: 0.0,
            direction: None,
            safeguard_angle_degrees: 80.0,
            contact_method: ContactMethod::Geometric,
            mapping: MappingMethod::UniqueDirection,
            max_contact_threshold: None,
            contact_threshold_floor: None,
        }
    }
}

impl PairParams {
    /// Sets τ.
    pub fn with_contact_tau(mut self, tau: f64) -> Self {
        self.contact_tau = tau;
        self
    }

    /// Sets a user mapping direction (or `None` for the automatic one).
    pub fn with_direction(mut self, direction: Option<DVec3>) -> Self {
        self.direction = direction;
        self
    }

    /// Sets the safeguard angle, in degrees.
    pub fn with_safeguard_angle(mut self, degrees: f64) -> Self {
        self.safeguard_angle_degrees = degrees;
        self
    }

    /// Sets the contact-zone method (e.g. `ContactMethod::Ball { radius }`).
    pub fn with_contact_method(mut self, method: ContactMethod) -> Self {
        self.contact_method = method;
        self
    }

    /// Sets the mapping method.
    pub fn with_mapping(mut self, mapping: MappingMethod) -> Self {
        self.mapping = mapping;
        self
    }

    /// Checks the values: finite τ, safeguard angle in [0°, 180°], user direction finite and
    /// non-zero. Returns the normalized user direction, if any.
    pub fn validate(&self) -> Result<Option<DVec3>, ContactError> {
        if !self.contact_tau.is_finite() {
            return Err(ContactError::InvalidParameter {
                name: "contact_tau",
                value: self.contact_tau,
                hint: "use a finite number (0 = the mean penetration, larger = smaller zones)",
            });
        }
        let angle = self.safeguard_angle_degrees;
        if !(angle.is_finite() && (0.0..=180.0).contains(&angle)) {
            return Err(ContactError::InvalidParameter {
                name: "safeguard_angle_degrees",
                value: angle,
                hint: "use an angle between 0 and 180 degrees (the thesis uses 80)",
            });
        }
        if let ContactMethod::Ball { radius } = self.contact_method
            && !(radius.is_finite() && radius > 0.0)
        {
            return Err(ContactError::InvalidParameter {
                name: "contact_method.Ball.radius",
                value: radius,
                hint: "the ball radius r_s is a finite positive length in world units (larger = stiffer, smaller zones)",
            });
        }
        if let Some(max) = self.max_contact_threshold
            && !max.is_finite()
        {
            return Err(ContactError::InvalidParameter {
                name: "max_contact_threshold",
                value: max,
                hint: "use a finite distance (0 = every penetrating point is in contact) or leave it unset",
            });
        }
        if let Some(floor) = self.contact_threshold_floor
            && !(floor.is_finite() && floor >= 0.0)
        {
            return Err(ContactError::InvalidParameter {
                name: "contact_threshold_floor",
                value: floor,
                hint: "use a factor ≥ 0 of the penetration depth (1 = the typical depth) or leave it unset",
            });
        }
        match self.direction {
            None => Ok(None),
            Some(d) => match d.try_normalize() {
                Some(unit) => Ok(Some(unit)),
                None => Err(ContactError::InvalidDirection { direction: d.to_array() }),
            },
        }
    }

    /// cos of the safeguard angle.
    pub fn safeguard_cosine(&self) -> f64 {
        self.safeguard_angle_degrees.to_radians().cos()
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

    #[test]
    fn params_defaults_builders_and_validation() {
        let p = PairParams::default();
        assert_eq!((p.contact_tau, p.direction, p.safeguard_angle_degrees), (0.0, None, 80.0));
        assert!((p.safeguard_cosine() - 80f64.to_radians().cos()).abs() < 1e-15);
        let p = p.with_contact_tau(0.5).with_direction(Some(DVec3::new(0.0, 0.0, 2.0))).with_safeguard_angle(70.0);
        assert_eq!(p.validate().unwrap(), Some(DVec3::Z));
        assert!(matches!(
            PairParams::default().with_direction(Some(DVec3::ZERO)).validate(),
            Err(ContactError::InvalidDirection { .. })
        ));
        assert!(PairParams::default().with_contact_tau(f64::INFINITY).validate().is_err());
        assert!(PairParams::default().with_safeguard_angle(200.0).validate().is_err());
        // Serde round trip, and missing fields take their defaults.
        let json = serde_json::to_string(&p).unwrap();
        assert_eq!(serde_json::from_str::<PairParams>(&json).unwrap(), p);
        let partial: PairParams = serde_json::from_str(r#"{"contact_tau": 1.0}"#).unwrap();
        assert_eq!(partial, PairParams::default().with_contact_tau(1.0));
        let s: Stiffness = serde_json::from_str(r#""Rigid""#).unwrap();
        assert!(s.is_rigid());
    }

    #[test]
    fn method_a_choices_default_to_method_b_and_round_trip() {
        let p = PairParams::default();
        assert_eq!((p.contact_method, p.mapping), (ContactMethod::Geometric, MappingMethod::UniqueDirection));
        // A configuration written before the methods existed keeps method B.
        let old: PairParams = serde_json::from_str(r#"{"contact_tau": 0.5, "safeguard_angle_degrees": 70.0}"#).unwrap();
        assert_eq!(old, PairParams::default().with_contact_tau(0.5).with_safeguard_angle(70.0));
        let a = PairParams::default()
            .with_contact_method(ContactMethod::Ball { radius: 0.25 })
            .with_mapping(MappingMethod::SharedParametrization);
        let json = serde_json::to_string(&a).unwrap();
        assert!(json.contains("ball") && json.contains("shared_parametrization"), "{json}");
        assert_eq!(serde_json::from_str::<PairParams>(&json).unwrap(), a);
        let parsed: PairParams = serde_json::from_str(r#"{"contact_method": {"ball": {"radius": 2.0}}}"#).unwrap();
        assert_eq!(parsed.contact_method, ContactMethod::Ball { radius: 2.0 });
        assert!(a.validate().is_ok());
        for radius in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            let err = PairParams::default().with_contact_method(ContactMethod::Ball { radius }).validate().unwrap_err();
            assert!(err.to_string().contains("radius"), "{err}");
        }
    }
}
