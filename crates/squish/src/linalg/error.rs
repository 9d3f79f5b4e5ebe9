//! The one error type of the linear-algebra module: everything that can go wrong while assembling
//! or solving the diffusion systems of thesis App. B and §5.1, each variant carrying the data a
//! user needs to find the element at fault.

/// What went wrong while assembling or solving a linear system on a working region.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolveError {
    #[error("{what} has {actual} entries, expected {expected}")]
    DimensionMismatch { what: &'static str, expected: usize, actual: usize },
    #[error("{what} refers to vertex {vertex}, but the region has only {vertices} vertices")]
    VertexOutOfRange { what: &'static str, vertex: u32, vertices: usize },
    #[error("the two matrices are built on different sparsity patterns; rebuild them on the same region")]
    PatternMismatch,
    #[error(
        "face {face} is degenerate (twice its area is {twice_area:.3e} for a longest edge of {longest_edge:.3e}); cotangent weights are undefined, clean the mesh or give the face weight 0"
    )]
    DegenerateFace { face: usize, twice_area: f64, longest_edge: f64 },
    #[error("face {face} has weight {weight}; face weights are area ratios in [0, 1]")]
    InvalidFaceWeight { face: usize, weight: f64 },
    #[error(
        "invalid operator coefficients: mass {mass}, stiffness {stiffness} (both must be finite and non-negative, not both zero)"
    )]
    InvalidCoefficients { mass: f64, stiffness: f64 },
    #[error(
        "constraint {constraint} joins vertices {i} and {j}, which share no edge; an edge constraint must lie on a mesh edge"
    )]
    ConstraintNotOnEdge { constraint: usize, i: u32, j: u32 },
    #[error("constraint {constraint} has a non-finite parameter (alpha {alpha}, value {value})")]
    NonFiniteConstraint { constraint: usize, alpha: f64, value: f64 },
    #[error("constraint weight factor {factor} must be finite and positive")]
    InvalidWeightFactor { factor: f64 },
    #[error("boundary point {point} is on ({inside}, {outside}), which is no edge of the mesh")]
    EdgePointNotOnEdge { point: usize, inside: u32, outside: u32 },
    #[error(
        "boundary point {point} claims vertex {inside} is inside and {outside} outside, but the inside flags say {inside_flag} and {outside_flag}"
    )]
    EdgePointSides { point: usize, inside: u32, outside: u32, inside_flag: bool, outside_flag: bool },
    #[error("boundary points {first} and {second} lie on the same edge ({v0}, {v1})")]
    DuplicateEdgePoint { first: usize, second: usize, v0: u32, v1: u32 },
    #[error("boundary point {point} has a non-finite alpha {alpha}")]
    NonFiniteEdgePoint { point: usize, alpha: f64 },
    #[error("{what} has a non-finite value {value} at index {index}")]
    NonFiniteValue { what: &'static str, index: usize, value: f64 },
    #[error(
        "the matrix is not positive definite (faer stopped at pivot {pivot} of {dimension}); smallest diagonal entry {min_diagonal:e} at vertex {vertex}"
    )]
    NotPositiveDefinite { pivot: usize, dimension: usize, vertex: u32, min_diagonal: f64 },
    #[error("solve called before a successful numeric factorization")]
    NotFactorized,
    #[error("the constrained system is unusable after a failed reassembly; reassemble it successfully first")]
    NotAssembled,
    #[error("sparse analysis failed: {reason}")]
    Analysis { reason: String },
}
