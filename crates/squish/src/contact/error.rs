//! Errors of the contact definition. Each variant carries the data needed to find the fault and
//! says what to do about it. "No intersection" is not an error: it gives an empty result.

use crate::spatial::SpatialError;

/// What went wrong while defining the contact between two working regions.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ContactError {
    #[error(
        "the intersection region of object '{object}' reaches vertex {vertex}, which lies on the border where its \
         working region was cut out of the full mesh: the intersection is not closed inside the working region \
         (thesis §4.1, discussion); use a larger working region (e.g. a wider distance band) so that it contains the \
         whole intersection"
    )]
    IntersectionReachesBorder { object: String, vertex: u32 },
    #[error("both objects are rigid: nothing can deform; give at least one of them a finite stiffness")]
    BothRigid,
    #[error("object '{object}' has stiffness {value}; use a finite positive number, or make it rigid")]
    InvalidStiffness { object: String, value: f64 },
    #[error(
        "the mapping direction {direction:?} is zero or not finite; give a non-zero direction, or leave it automatic"
    )]
    InvalidDirection { direction: [f64; 3] },
    #[error("pair parameter {0}")]
    Parameter(Box<crate::params::ParamError>),
    #[error(
        "object '{object}': {what} has {got} entries but the working region needs {expected}; build it from the same \
         working-region mesh"
    )]
    InputMismatch { object: String, what: &'static str, expected: usize, got: usize },
    #[error(
        "the automatic mapping direction is undefined: the normals over the intersection regions cancel out \
         (Eq. 4.1); give the pair's mapping direction (its `direction` parameter, e.g. [0, 0, 1])"
    )]
    DirectionUndefined,
    #[error(
        "ball testing needs one rigid object (thesis §4.4.1): use contact_method = \"geometric\" \
         or make one object rigid"
    )]
    BallTestingNeedsOneRigid,
    #[error(
        "object '{object}' has no UVs, but the shared-parametrization mapping (thesis §4.2.1) matches the meshes in UV \
         space: give both meshes UVs or use mapping = \"unique_direction\""
    )]
    MissingUvs { object: String },
    #[error("object '{object}': the shared-parametrization mapping failed: {reason}")]
    UvMapping { object: String, reason: String },
    #[error(transparent)]
    Spatial(#[from] SpatialError),
}

impl From<crate::params::ParamError> for ContactError {
    fn from(e: crate::params::ParamError) -> Self {
        Self::Parameter(Box::new(e))
    }
}
