//! Per-pair parameters of the contact definition (thesis ch. 4): τ, the mapping direction, the
//! safeguard angle, and method A's alternatives, chosen per pair.

use glam::DVec3;

use super::ParamError;

crate::choice! {
    /// How the contact zone 𝒞 is extracted from the potential contact surface (§4.4).
    #[derive(Default)]
    pub enum ContactMethod {
        /// Method B's geometric criterion δᵀn′ ≥ ε_c = m + τσ (§4.4.2): elastic–elastic and
        /// rigid–elastic contacts.
        #[default]
        Geometric = "geometric",
        /// Method A's ball testing and sliding with radius `ball_radius` (§4.4.1): a vertex is in
        /// 𝒞 when a ball rolled inside the elastic object touches it. Exactly one object rigid.
        Ball = "ball",
    }
}

crate::choice! {
    /// How the points of one object are matched on the other (§4.2).
    #[derive(Default)]
    pub enum MappingMethod {
        /// Method B's unique mapping direction d̂ and farthest hits along it (§4.2.2).
        #[default]
        UniqueDirection = "unique_direction",
        /// Method A's shared parametrization (§4.2.1): both meshes need UVs; points are matched
        /// in UV space.
        SharedParametrization = "shared_parametrization",
    }
}

/// Parameters of a pair of objects that may touch. `Default` = the thesis' defaults (method B,
/// τ = 0, automatic direction, 80° safeguard).
#[derive(Clone, Copy, Debug, PartialEq, super::Params)]
#[params(level = Pair, check = check_fields)]
pub struct PairParams {
    /// Whether the pair is processed (keyed with steps to switch a contact on and off).
    #[param(keyframable)]
    pub enabled: bool,
    /// Contact spread: the contact threshold is ε_c = m + τσ of the penetration depths; larger τ,
    /// smaller contact zone (negative values enlarge it).
    ///
    /// For τ > 0, ε_c is capped at the typical penetration depth, so that the zone never vanishes
    /// while the meshes penetrate (docs/decisions.md, "τ clamp").
    #[param(symbol = "τ", section = "§4.4.2, Eq. 4.3", keyframable)]
    pub contact_tau: f64,
    /// Mapping direction, along which the objects are matched; oriented along the second
    /// object's normals (its length does not matter).
    #[param(
        symbol = "d̂",
        section = "§4.2.2, Eq. 4.1",
        keyframable,
        auto = "from the two intersection regions' normals at each frame (Eq. 4.1)"
    )]
    pub direction: Option<DVec3>,
    /// Angle between a normal and the mapping direction beyond which a point cannot be in
    /// contact.
    #[param(
        section = "§4.4.2",
        unit = "degrees",
        range = "[0, 180]",
        keyframable,
        renamed_from = "safeguard_angle_degrees"
    )]
    pub safeguard_angle: f64,
    /// How the contact zone is found: `geometric` (method B) or `ball` (method A, one object
    /// rigid, with `ball_radius`).
    #[param(section = "§4.4")]
    pub contact_method: ContactMethod,
    /// Radius of method A's virtual ball: the elastic object's pseudo-stiffness (a larger ball,
    /// a smaller contact zone). Required with `contact_method = "ball"`.
    ///
    /// It should stay below the elastic object's local thickness: the ball must fit inside it.
    #[param(symbol = "r_s", section = "§4.4.1", unit = "scene units", range = "(0, inf)", keyframable, word = "none")]
    pub ball_radius: Option<f64>,
    /// How points are matched: `unique_direction` (method B) or `shared_parametrization`
    /// (method A, both meshes with UVs).
    #[param(section = "§4.2")]
    pub mapping: MappingMethod,
    /// Distance left between the two outputs across the contact zone: each side stops short of
    /// the contact surface 𝒮 by its share of it (the share it moves, k̄ of its partner), so that
    /// their triangles do not interleave. 0 gives the thesis' coincident surfaces.
    ///
    /// It grows with the penetration from 0 at the first touch (it is never more than the typical
    /// penetration depth), so that the motion stays continuous (docs/decisions.md, "Contact gap").
    #[param(
        section = "§4.3",
        unit = "scene units",
        range = "[0, inf)",
        keyframable,
        auto = "0.1 × the mean length of the edges of the two contact zones (the coarser side's)"
    )]
    pub contact_gap: Option<f64>,
    /// An upper bound on ε_c (world units): with 0 every penetrating point of the mapping regions
    /// is in contact, whatever the spread of depths — what self-contact uses (ch. 6), where no
    /// interpenetration may remain. `None`: the thesis' criterion.
    #[param(skip)]
    pub max_contact_threshold: Option<f64>,
    /// A lower bound on ε_c in units of the typical penetration depth P (see
    /// [`crate::contact::CriterionStats::penetration`]): `ε_c ≥ −floor·P`. Where the mapping
    /// regions face each other across wide gaps (the two sides of a fold), m + τσ is far below 0
    /// and would pull in points up to that gap away as soon as the contact starts — a jump. With
    /// the floor, the zone starts as the penetrating points and grows with the penetration.
    /// `None`: the thesis' criterion.
    #[param(skip)]
    pub contact_threshold_floor: Option<f64>,
}

impl Default for PairParams {
    fn default() -> Self {
        Self {
            enabled: true,
            contact_tau: 0.0,
            direction: None,
            safeguard_angle: 80.0,
            contact_method: ContactMethod::Geometric,
            ball_radius: None,
            mapping: MappingMethod::UniqueDirection,
            contact_gap: None,
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
        self.safeguard_angle = degrees;
        self
    }

    /// Method A's ball testing with radius `radius` (r_s).
    pub fn with_ball(mut self, radius: f64) -> Self {
        self.contact_method = ContactMethod::Ball;
        self.ball_radius = Some(radius);
        self
    }

    /// Sets the mapping method.
    pub fn with_mapping(mut self, mapping: MappingMethod) -> Self {
        self.mapping = mapping;
        self
    }

    /// Sets the contact gap (`None`: automatic; `Some(0.0)`: the thesis' coincident surfaces).
    pub fn with_contact_gap(mut self, gap: Option<f64>) -> Self {
        self.contact_gap = gap;
        self
    }

    /// The ball radius r_s when the contact method is the ball (`None` for the geometric
    /// criterion).
    pub fn ball(&self) -> Option<f64> {
        match self.contact_method {
            ContactMethod::Ball => self.ball_radius,
            ContactMethod::Geometric => None,
        }
    }

    /// cos of the safeguard angle.
    pub fn safeguard_cosine(&self) -> f64 {
        self.safeguard_angle.to_radians().cos()
    }

    /// Conditions between fields and of the fields that are not user parameters.
    fn check_fields(&self) -> Result<(), ParamError> {
        if self.contact_method == ContactMethod::Ball && self.ball_radius.is_none() {
            return Err(ParamError::condition(
                "ball_radius",
                "contact_method = \"ball\" needs ball_radius (r_s, in scene units; larger = stiffer, smaller zones)",
            ));
        }
        if let Some(max) = self.max_contact_threshold
            && !max.is_finite()
        {
            return Err(ParamError::condition("max_contact_threshold", format!("{max} must be a finite distance")));
        }
        if let Some(floor) = self.contact_threshold_floor
            && !(floor.is_finite() && floor >= 0.0)
        {
            return Err(ParamError::condition("contact_threshold_floor", format!("{floor} must be finite and ≥ 0")));
        }
        Ok(())
    }
}
