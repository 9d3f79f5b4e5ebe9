//! Linear algebra of the deformer (thesis App. B "Laplacian and constraints", §5.1, §5.3): the
//! cotangent Laplacian with cut-face weights, the lumped mass matrix, gradient and divergence,
//! least-squares edge constraints, and sparse Cholesky factorizations with symbolic reuse.
//!
//! # Conventions and decisions
//! - **Sign.** We use the positive semi-definite stiffness `K = −L` (the thesis' `L` is negative
//!   semi-definite): `K_ij = −½(w_f cot α_ij + w_g cot β_ij)` for `i ≠ j`, `K_ii = −Σ_j K_ij`.
//!   Soft constraints minimize `½vᵀAv + ½λ‖Cv − b‖²`, so `(A + λCᵀC)v = λCᵀb`. The thesis'
//!   `(L + βCᵀC)v = βCᵀb` with β = −100 is the same system multiplied by −1 (THESIS-NOTES item 3).
//! - **Constraint weight.** `λ = 100 × s`, where `s` is the operator's scale
//!   ([`Operator::constraint_scale`]): 1 for `K`, `t` for the heat step `M + tK` (whose `tK` part
//!   dominates). Cotangents are scale-free, so constraint rows stay ~10× the operator rows (App. B)
//!   whatever the size of the mesh.
//! - **Gradient/divergence.** Heat-method convention (Crane et al. 2013) with
//!   `div(grad u) = −K u`; the Poisson step `Δφ = ∇·X` is `K φ = −div X`.
//! - **Cut faces.** Faces crossed by the domain boundary weigh their stiffness and mass by their
//!   kept area fraction (App. B); a mixed edge without a boundary point is cut at its midpoint.
//! - **Pinning.** Vertices nothing can determine (zero rows, or components without constraint or
//!   mass) get +1 on the diagonal and a caller-given default value; the pattern never changes.
//! - **One pattern per region.** Every system on a region has nonzeros on the diagonal and the
//!   mesh edges only, so the symbolic analysis is done once and shared; numeric factors
//!   refactorize in place. Everything is sequential inside a solve (`Par::Seq`) and deterministic.
//!
//! # Typical use (heat method of §5.1)
//! ```
//! # use squish::linalg::*;
//! # use squish::mesh::{shapes, Topology, mean_edge_length};
//! # fn main() -> Result<(), SolveError> {
//! let mesh = shapes::grid(2.0, 2.0, 20, 20);
//! let topology = Topology::new(&mesh);
//! let pattern = SparsePattern::shared(&mesh, &topology)?;     // once per region
//! let symbolic = SymbolicFactor::analyze(&pattern)?;          // once per region
//! let h = mean_edge_length(&mesh, &topology);
//! let heat = Operator::heat(&mesh, &pattern, None, 10.0 * h * h)?;
//! let source = [EdgeConstraint::vertex(220, 1.0)];
//! let mut solver = ConstrainedSolver::new(&symbolic, &heat, &source, &ConstraintParams::default())?;
//! let v = solver.solve(&RightHandSide::default())?;
//! let x: Vec<_> = face_gradients(&mesh, &v)?.iter().map(|g| -g.normalize_or_zero()).collect();
//! let load: Vec<f64> = integrated_divergence(&mesh, &x, None)?.iter().map(|d| -d).collect();
//! let poisson = Operator::stiffness(&mesh, &pattern, None)?;
//! let zero = [EdgeConstraint::vertex(220, 0.0)];
//! let mut solver = ConstrainedSolver::new(&symbolic, &poisson, &zero, &ConstraintParams::default())?;
//! let distance = solver.solve(&RightHandSide { load: Some(&load), ..Default::default() })?;
//! assert!((distance[225] - 0.5).abs() < 0.025); // vertex 225 is 0.5 from the source
//! # Ok(())
//! # }
//! ```

mod cholesky;
pub(crate) mod constraints;
mod cut_weights;
mod dissection;
mod error;
mod laplacian;
mod operators;
mod pattern;
mod solve;
mod supernodal;
mod symbolic;

#[cfg(test)]
pub(crate) mod test_support;

pub use cholesky::{FillOrder, NumericFactor, SymbolicFactor};
pub use constraints::{
    ConstrainedSystem, ConstraintParams, DEFAULT_CONSTRAINT_WEIGHT_FACTOR, EdgeConstraint,
    NEGLIGIBLE_CONSTRAINT_COEFFICIENT, NEGLIGIBLE_FACE_WEIGHT,
};
pub use cut_weights::{DEFAULT_CUT_ALPHA, EdgePoint, cut_face_weights};
pub use error::SolveError;
pub use laplacian::{Operator, cotangent_stiffness, lumped_mass};
pub use operators::{face_gradients, integrated_divergence};
pub use pattern::{NO_SLOT, SparsePattern, SymmetricMatrix};
pub use solve::{ConstrainedSolver, RightHandSide, solve_harmonic};
