//! The error type of the deformation stage (thesis ch. 5): invalid parameters, contact zones that
//! do not fit the region, and failed solves, each with the data to find the fault and a fix hint.

use crate::linalg::SolveError;

/// What went wrong while deforming a working region.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DeformError {
    #[error(
        "the deformation extent is {extent}; it is the geodesic distance φ_max from the contact boundary at which the deformation stops (a world-space length): give the object an extent > 0 or leave it automatic, e.g. a few times the contact radius"
    )]
    InvalidExtent { extent: f64 },
    #[error("object parameter {0}")]
    Parameter(Box<crate::params::ParamError>),
    #[error("parameter `{name}` is {value}: {hint}")]
    InvalidParameter { name: &'static str, value: f64, hint: &'static str },
    #[error(
        "profile abscissas x2 = {x2}, x3 = {x3}, x4 = {x4} must satisfy 0.2 < x2 < x3 < x4 < 1 (v1 can reach x = 0.2, and the profile must stay a function of u); the defaults are 1/3, 5/6, 11/12"
    )]
    InvalidProfile { x2: f64, x3: f64, x4: f64 },
    #[error(
        "the bulge map has {actual} values but the region has {expected} vertices: give one weight per region vertex"
    )]
    BulgeMapLength { expected: usize, actual: usize },
    #[error("the bulge map value at vertex {vertex} is {value}: bulge weights must be finite")]
    NonFiniteBulgeMap { vertex: usize, value: f64 },
    #[error("contact zone {zone} does not fit the region: {reason}")]
    InvalidZone { zone: usize, reason: String },
    #[error(
        "the region ({vertices} vertices, {faces} faces) is not the one the RegionSolver was built for ({solver_vertices} vertices, {solver_faces} faces, or other triangles): build one RegionSolver per working region and keep its connectivity"
    )]
    RegionMismatch { vertices: usize, faces: usize, solver_vertices: usize, solver_faces: usize },
    #[error(
        "the topology has {topology_vertices} vertices and {topology_faces} faces but the mesh {vertices} and {faces}: build the Topology from this mesh"
    )]
    TopologyMismatch { vertices: usize, faces: usize, topology_vertices: usize, topology_faces: usize },
    #[error("vertex {vertex} has a non-finite position {position:?}: clean the input mesh")]
    NonFinitePosition { vertex: usize, position: [f64; 3] },
    #[error(
        "the region's mean edge length is {mean_edge_length}; the heat step needs a positive length scale (is the region empty or collapsed to a point?)"
    )]
    DegenerateRegion { mean_edge_length: f64 },
    #[error(
        "{what} has {actual} entries but {expected} were expected: the inputs of a stage must come from the same region and frame"
    )]
    LengthMismatch { what: &'static str, expected: usize, actual: usize },
    #[error("the {stage} solve failed: {source}")]
    Solve {
        stage: &'static str,
        #[source]
        source: SolveError,
    },
    #[error(
        "the {stage} stage needs the Poisson factorization of this frame's parametrization: run `parametrize` on the same RegionSolver first"
    )]
    StaleFactorization { stage: &'static str },
}

impl DeformError {
    /// Wraps a solver error with the stage it happened in.
    pub(crate) fn solve(stage: &'static str) -> impl FnOnce(SolveError) -> Self {
        move |source| Self::Solve { stage, source }
    }

    /// Checks that `what` has `expected` entries.
    pub(crate) fn check_len(what: &'static str, expected: usize, actual: usize) -> Result<(), Self> {
        if expected == actual { Ok(()) } else { Err(Self::LengthMismatch { what, expected, actual }) }
    }
}

impl From<crate::params::ParamError> for DeformError {
    fn from(e: crate::params::ParamError) -> Self {
        Self::Parameter(Box::new(e))
    }
}
