//! Sparse Cholesky factorization with symbolic reuse (thesis ch. 7 §5.2: factorizations dominate
//! the cost of a frame), on faer's low-level API.
//!
//! The symbolic analysis (AMD fill-reducing ordering, elimination tree, supernodal structure)
//! depends on the [`SparsePattern`] only, so it is done once per working region
//! ([`SymbolicFactor`], shared through an `Arc`) and reused by every numeric factorization on that
//! region — heat step, Poisson, diffusions — across solves and across animation frames.
//! A [`NumericFactor`] owns the values of `L` and its scratch memory and refactorizes in place when
//! only the matrix values change: no allocation after the first factorization.
//!
//! Everything runs with `Par::Seq`: our systems are small (10³–10⁵ unknowns), where faer's
//! multithreading costs more than it gains; the pipeline runs independent regions and frames in
//! parallel with rayon instead. Sequential faer is deterministic: the same matrix gives
//! bit-identical factors and solutions.

use std::sync::Arc;

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization};
use faer::perm::PermRef;
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::linalg::cholesky::{
    CholeskySymbolicParams, LltRef, SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
    factorize_symbolic_cholesky, simplicial, supernodal,
};
use faer::sparse::utils::permute_self_adjoint_to_unsorted;
use faer::sparse::{FaerError, SparseColMatRef, SymbolicSparseColMat};
use faer::{Conj, MatMut, Par, Side};

use super::{SolveError, SparsePattern, SymmetricMatrix};

/// Systems with at least this many rows always use faer's supernodal (blocked) factorization.
///
/// faer picks simplicial or supernodal from the ratio flops / nnz(L) of the AMD ordering. On our
/// surface Laplacians that heuristic picks simplicial for flat or moderately sized regions (an
/// open 109 × 109 grid, a 1.5k-vertex ball), where the supernodal factorization is nevertheless
/// about twice as fast (grid: 6.9 → 3.2 ms; ball: 0.63 → 0.33 ms, for a solve 0.3 ms resp.
/// 0.03 ms slower), and a frame factorizes once per solve or two. Below ~500 rows the two are
/// within a few microseconds; we keep faer's choice there.
const SUPERNODAL_MIN_DIMENSION: usize = 1000;

/// The symbolic Cholesky analysis of one region's pattern, shared by all its factorizations.
///
/// It also records where faer's symmetric permutation `PAPᵀ` puts each stored value, so that a
/// numeric factorization gathers the values into that layout with one indexed copy and calls
/// faer's numeric kernel directly, instead of having faer recompute the permuted pattern every
/// time (`permute_self_adjoint_to_unsorted` cost about a sixth of each factorization). The layout
/// is computed by that same faer function, once, on the slot numbers, so the kernel receives
/// exactly the matrix faer would have built: the factors are bit-identical.
#[derive(Debug)]
pub struct SymbolicFactor {
    pattern: Arc<SparsePattern>,
    symbolic: SymbolicCholesky<usize>,
    /// `PAPᵀ`'s pattern, in the triangle the numeric kernel reads (upper for simplicial, lower for
    /// supernodal), in faer's own entry order.
    permuted: SymbolicSparseColMat<usize>,
    /// Entry `k` of `permuted` is value slot `permuted_slot[k]` of the region's matrices.
    permuted_slot: Vec<usize>,
    factorize_scratch: StackReq,
}

impl SymbolicFactor {
    /// Runs the symbolic analysis (AMD ordering + elimination tree) of `pattern`.
    pub fn analyze(pattern: &Arc<SparsePattern>) -> Result<Arc<Self>, SolveError> {
        let supernodal_flop_ratio_threshold = if pattern.num_vertices() >= SUPERNODAL_MIN_DIMENSION {
            SupernodalThreshold::FORCE_SUPERNODAL
        } else {
            SupernodalThreshold::AUTO
        };
        let params = CholeskySymbolicParams { supernodal_flop_ratio_threshold, ..Default::default() };
        let analysis_error = |e: &dyn std::fmt::Debug| SolveError::Analysis { reason: format!("{e:?}") };
        let symbolic = factorize_symbolic_cholesky(pattern.structure(), Side::Lower, SymmetricOrdering::Amd, params)
            .map_err(|e| analysis_error(&e))?;
        let (permuted, permuted_slot) = permuted_layout(pattern, &symbolic).map_err(|e| analysis_error(&e))?;
        let factorize_scratch = match symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(_) => {
                simplicial::factorize_simplicial_numeric_llt_scratch::<usize, f64>(symbolic.nrows())
            }
            SymbolicCholeskyRaw::Supernodal(raw) => {
                supernodal::factorize_supernodal_numeric_llt_scratch::<usize, f64>(raw, Par::Seq, Default::default())
            }
        };
        Ok(Arc::new(Self { pattern: Arc::clone(pattern), symbolic, permuted, permuted_slot, factorize_scratch }))
    }

    /// The pattern this analysis belongs to.
    pub fn pattern(&self) -> &Arc<SparsePattern> {
        &self.pattern
    }

    /// Number of rows.
    pub fn dimension(&self) -> usize {
        self.symbolic.nrows()
    }

    /// Number of stored values of the factor `L` (fill-in included).
    pub fn factor_len(&self) -> usize {
        self.symbolic.len_val()
    }

    /// True if faer chose its supernodal (blocked) algorithm for this pattern.
    pub fn is_supernodal(&self) -> bool {
        matches!(self.symbolic.raw(), SymbolicCholeskyRaw::Supernodal(_))
    }
}

/// `PAPᵀ`'s pattern as faer's numeric factorization builds it from the region's lower triangle,
/// and the value slot of each of its entries (see [`SymbolicFactor`]).
fn permuted_layout(
    pattern: &SparsePattern,
    symbolic: &SymbolicCholesky<usize>,
) -> Result<(SymbolicSparseColMat<usize>, Vec<usize>), FaerError> {
    let n = pattern.num_vertices();
    let nnz = pattern.nnz();
    let out_side = match symbolic.raw() {
        SymbolicCholeskyRaw::Simplicial(_) => Side::Upper,
        SymbolicCholeskyRaw::Supernodal(_) => Side::Lower,
    };
    let identity: Vec<usize> = (0..n).collect();
    let (forward, inverse) = symbolic.perm().map_or((&identity[..], &identity[..]), |p| p.arrays());
    let perm = PermRef::new_checked(forward, inverse, n);
    // Slot numbers travel as values (exact in f64 below 2⁵³).
    let slots: Vec<f64> = (0..nnz).map(|k| k as f64).collect();
    let a = SparseColMatRef::new(pattern.structure(), &slots);
    let (mut values, mut col_ptr, mut row_idx) = (vec![0.0; nnz], vec![0usize; n + 1], vec![0usize; nnz]);
    let mut buffer = MemBuffer::try_new(StackReq::new::<usize>(n)).map_err(|_| FaerError::OutOfMemory)?;
    permute_self_adjoint_to_unsorted(
        &mut values,
        &mut col_ptr,
        &mut row_idx,
        a,
        perm,
        Side::Lower,
        out_side,
        MemStack::new(&mut buffer),
    );
    let permuted_slot = values.iter().map(|&v| v as usize).collect();
    // faer leaves the rows of each column unsorted, and its kernel reads them in that order.
    let structure = SymbolicSparseColMat::new_unsorted_checked(n, n, col_ptr, None, row_idx);
    Ok((structure, permuted_slot))
}

/// A numeric `LLᵀ` factorization on a shared [`SymbolicFactor`], refactorizable in place.
pub struct NumericFactor {
    symbolic: Arc<SymbolicFactor>,
    l_values: Vec<f64>,
    /// The matrix's values in the permuted layout of [`SymbolicFactor`].
    permuted_values: Vec<f64>,
    factorize_buffer: MemBuffer,
    solve_buffer: MemBuffer,
    /// Number of right-hand-side columns `solve_buffer` is sized for.
    solve_columns: usize,
    factorized: bool,
}

impl std::fmt::Debug for NumericFactor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NumericFactor")
            .field("dimension", &self.symbolic.dimension())
            .field("factor_len", &self.l_values.len())
            .field("solve_columns", &self.solve_columns)
            .field("factorized", &self.factorized)
            .finish()
    }
}

fn alloc_buffer(req: StackReq) -> Result<MemBuffer, SolveError> {
    MemBuffer::try_new(req)
        .map_err(|_| SolveError::Analysis { reason: "out of memory for the factorization scratch".into() })
}

impl NumericFactor {
    /// Allocates the factor's storage (nothing is factorized yet).
    pub fn new(symbolic: &Arc<SymbolicFactor>) -> Result<Self, SolveError> {
        let solve_columns = 1;
        Ok(Self {
            l_values: vec![0.0; symbolic.factor_len()],
            permuted_values: vec![0.0; symbolic.permuted_slot.len()],
            factorize_buffer: alloc_buffer(symbolic.factorize_scratch)?,
            solve_buffer: alloc_buffer(symbolic.symbolic.solve_in_place_scratch::<f64>(solve_columns, Par::Seq))?,
            solve_columns,
            symbolic: Arc::clone(symbolic),
            factorized: false,
        })
    }

    /// Allocates and factorizes `matrix`.
    pub fn factorize_new(symbolic: &Arc<SymbolicFactor>, matrix: &SymmetricMatrix) -> Result<Self, SolveError> {
        let mut factor = Self::new(symbolic)?;
        factor.factorize(matrix)?;
        Ok(factor)
    }

    /// The shared symbolic analysis.
    pub fn symbolic(&self) -> &Arc<SymbolicFactor> {
        &self.symbolic
    }

    /// True after a successful factorization.
    pub fn is_factorized(&self) -> bool {
        self.factorized
    }

    /// Factorizes `matrix` (on the same pattern as the symbolic analysis) in place, reusing the
    /// storage of any previous factorization. A matrix that is not positive definite, or has a
    /// non-finite value, is an error and leaves the factor unusable until the next success.
    pub fn factorize(&mut self, matrix: &SymmetricMatrix) -> Result<(), SolveError> {
        self.factorized = false;
        let pattern = &self.symbolic.pattern;
        if !Arc::ptr_eq(matrix.pattern(), pattern) {
            return Err(SolveError::PatternMismatch);
        }
        if let Some((slot, value)) = matrix.first_non_finite() {
            return Err(SolveError::NonFiniteValue { what: "matrix", index: slot, value });
        }
        // What faer's `factorize_numeric_llt` does, minus recomputing the permuted pattern.
        let values = matrix.values();
        for (permuted, &slot) in self.permuted_values.iter_mut().zip(&self.symbolic.permuted_slot) {
            *permuted = values[slot];
        }
        let a = SparseColMatRef::new(self.symbolic.permuted.as_ref(), &self.permuted_values);
        let stack = MemStack::new(&mut self.factorize_buffer);
        let result = match self.symbolic.symbolic.raw() {
            SymbolicCholeskyRaw::Simplicial(raw) => simplicial::factorize_simplicial_numeric_llt(
                &mut self.l_values,
                a,
                LltRegularization::default(),
                raw,
                stack,
            ),
            SymbolicCholeskyRaw::Supernodal(raw) => supernodal::factorize_supernodal_numeric_llt(
                &mut self.l_values,
                a,
                LltRegularization::default(),
                raw,
                Par::Seq,
                stack,
                Default::default(),
            ),
        };
        match result {
            Ok(_) => {
                self.factorized = true;
                Ok(())
            }
            Err(LltError::NonPositivePivot { index }) => {
                let n = matrix.dimension();
                let (vertex, min_diagonal) = (0..n as u32)
                    .map(|v| (v, matrix.diagonal(v)))
                    .fold((0, f64::INFINITY), |best, (v, d)| if d < best.1 { (v, d) } else { best });
                Err(SolveError::NotPositiveDefinite { pivot: index, dimension: n, vertex, min_diagonal })
            }
        }
    }

    /// Solves `A x = rhs` in place (`rhs` has one entry per vertex).
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolveError> {
        self.solve_columns_in_place(rhs, 1)
    }

    /// Solves `A X = B` in place for `columns` right-hand sides stored column after column in
    /// `rhs` (column-major, `dimension × columns`).
    pub fn solve_columns_in_place(&mut self, rhs: &mut [f64], columns: usize) -> Result<(), SolveError> {
        if !self.factorized {
            return Err(SolveError::NotFactorized);
        }
        let n = self.symbolic.dimension();
        if rhs.len() != n * columns {
            return Err(SolveError::DimensionMismatch {
                what: "right-hand sides",
                expected: n * columns,
                actual: rhs.len(),
            });
        }
        if let Some((index, &value)) = rhs.iter().enumerate().find(|(_, x)| !x.is_finite()) {
            return Err(SolveError::NonFiniteValue { what: "right-hand side", index, value });
        }
        if columns == 0 {
            return Ok(());
        }
        if columns > self.solve_columns {
            self.solve_buffer = alloc_buffer(self.symbolic.symbolic.solve_in_place_scratch::<f64>(columns, Par::Seq))?;
            self.solve_columns = columns;
        }
        let llt = LltRef::new(&self.symbolic.symbolic, &self.l_values);
        let b = MatMut::from_column_major_slice_mut(rhs, n, columns);
        llt.solve_in_place_with_conj(Conj::No, b, Par::Seq, MemStack::new(&mut self.solve_buffer));
        Ok(())
    }

    /// Solves `A x = rhs` into a new vector.
    pub fn solve(&mut self, rhs: &[f64]) -> Result<Vec<f64>, SolveError> {
        let mut x = rhs.to_vec();
        self.solve_in_place(&mut x)?;
        Ok(x)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::test_support::Lcg;
    use crate::linalg::{
        ConstrainedSystem, ConstraintParams, EdgeConstraint, Operator, cotangent_stiffness, lumped_mass,
    };
    use crate::mesh::{Topology, shapes};

    fn residual(a: &SymmetricMatrix, x: &[f64], b: &[f64]) -> f64 {
        let ax = a.apply(x).unwrap();
        ax.iter().zip(b).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max)
    }

    #[test]
    fn solves_and_refactorizes_on_a_shared_analysis() {
        let mesh = shapes::icosphere(1.0, 3);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
        let k = cotangent_stiffness(&mesh, &pattern, None).unwrap();
        let mass = lumped_mass(&mesh, None).unwrap();
        let mut rng = Lcg::new(5);
        let b: Vec<f64> = (0..mesh.num_vertices()).map(|_| rng.next_signed()).collect();

        let mut a1 = k.clone();
        a1.add_diagonal(&mass, 1.0).unwrap();
        let mut a2 = k.clone();
        let random_diagonal: Vec<f64> = (0..mesh.num_vertices()).map(|_| 0.1 + rng.next_unit()).collect();
        a2.add_diagonal(&random_diagonal, 1.0).unwrap();

        let mut factor = NumericFactor::factorize_new(&symbolic, &a1).unwrap();
        let x1 = factor.solve(&b).unwrap();
        assert!(residual(&a1, &x1, &b) < 1e-12);
        // Refactorize with new values on the same storage; compare with a fresh factorization.
        let l_ptr = factor.l_values.as_ptr();
        factor.factorize(&a2).unwrap();
        assert_eq!(l_ptr, factor.l_values.as_ptr(), "refactorization must reuse L's storage");
        let x2 = factor.solve(&b).unwrap();
        let fresh =
            NumericFactor::factorize_new(&SymbolicFactor::analyze(&pattern).unwrap(), &a2).unwrap().solve(&b).unwrap();
        for (p, q) in x2.iter().zip(&fresh) {
            assert!((p - q).abs() < 1e-12);
        }
        assert!(residual(&a2, &x2, &b) < 1e-12);
        // Determinism: the same input gives bit-identical output.
        factor.factorize(&a1).unwrap();
        assert_eq!(factor.solve(&b).unwrap(), x1);
    }

    #[test]
    fn multi_column_solves_match_single_solves() {
        let mesh = shapes::grid(1.0, 1.0, 12, 9);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
        let op = Operator::heat(&mesh, &pattern, None, 0.01).unwrap();
        let mut factor = NumericFactor::factorize_new(&symbolic, op.matrix()).unwrap();
        let n = mesh.num_vertices();
        let mut rng = Lcg::new(9);
        let b: Vec<f64> = (0..3 * n).map(|_| rng.next_signed()).collect();
        let mut x = b.clone();
        factor.solve_columns_in_place(&mut x, 3).unwrap();
        for c in 0..3 {
            let single = factor.solve(&b[c * n..(c + 1) * n]).unwrap();
            for (p, q) in single.iter().zip(&x[c * n..(c + 1) * n]) {
                assert!((p - q).abs() < 1e-13);
            }
        }
    }

    #[test]
    fn factors_are_bit_identical_to_faers_own_numeric_factorization() {
        // Simplicial (small sphere) and supernodal (grid, larger sphere) analyses: the prepermuted
        // values give exactly the factor faer computes from the unpermuted matrix.
        for mesh in [shapes::icosphere(1.0, 2), shapes::grid(1.0, 1.0, 40, 31), shapes::icosphere(1.0, 4)] {
            let topology = Topology::new(&mesh);
            let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
            let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
            let op = Operator::heat(&mesh, &pattern, None, 0.3).unwrap();
            let ours = NumericFactor::factorize_new(&symbolic, op.matrix()).unwrap();
            let mut theirs = vec![0.0; symbolic.factor_len()];
            let mut buffer =
                MemBuffer::new(symbolic.symbolic.factorize_numeric_llt_scratch::<f64>(Par::Seq, Default::default()));
            symbolic
                .symbolic
                .factorize_numeric_llt::<f64>(
                    &mut theirs,
                    SparseColMatRef::new(pattern.structure(), op.matrix().values()),
                    Side::Lower,
                    LltRegularization::default(),
                    Par::Seq,
                    MemStack::new(&mut buffer),
                    Default::default(),
                )
                .unwrap();
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&ours.l_values), bits(&theirs), "{} rows", mesh.num_vertices());
        }
    }

    #[test]
    fn large_regions_factorize_supernodally_small_ones_as_faer_chooses() {
        // A flat grid is where faer's own heuristic picks the slower simplicial factorization.
        let mesh = shapes::grid(1.0, 1.0, 40, 40);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
        assert!(mesh.num_vertices() >= SUPERNODAL_MIN_DIMENSION && symbolic.is_supernodal());
        let op = Operator::heat(&mesh, &pattern, None, 1e-3).unwrap();
        let mut rng = Lcg::new(3);
        let b: Vec<f64> = (0..mesh.num_vertices()).map(|_| rng.next_signed()).collect();
        let x = NumericFactor::factorize_new(&symbolic, op.matrix()).unwrap().solve(&b).unwrap();
        assert!(residual(op.matrix(), &x, &b) < 1e-12);

        let small = shapes::icosphere(1.0, 2);
        let pattern = SparsePattern::shared(&small, &Topology::new(&small)).unwrap();
        assert!(!SymbolicFactor::analyze(&pattern).unwrap().is_supernodal());
    }

    #[test]
    fn a_matrix_that_is_not_positive_definite_is_an_error() {
        let mesh = shapes::icosphere(1.0, 2);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
        // The thesis' sign with our K: (−K + 100 CᵀC) is indefinite.
        let op = Operator::stiffness(&mesh, &pattern, None).unwrap();
        let system =
            ConstrainedSystem::new(&op, &[EdgeConstraint::vertex(0, 1.0)], &ConstraintParams::default()).unwrap();
        let mut wrong_sign = system.matrix().clone();
        let k = cotangent_stiffness(&mesh, &pattern, None).unwrap();
        wrong_sign.add_scaled(&k, -2.0).unwrap();
        let mut factor = NumericFactor::new(&symbolic).unwrap();
        assert!(matches!(factor.factorize(&wrong_sign), Err(SolveError::NotPositiveDefinite { .. })));
        assert_eq!(factor.solve(&vec![0.0; mesh.num_vertices()]), Err(SolveError::NotFactorized));
        // A NaN in the matrix is reported before factorizing.
        let mut nan = system.matrix().clone();
        nan.values_mut()[3] = f64::NAN;
        assert!(matches!(factor.factorize(&nan), Err(SolveError::NonFiniteValue { index: 3, .. })));
        // And the right system still works afterwards.
        factor.factorize(system.matrix()).unwrap();
        assert!(factor.is_factorized());
    }
}
