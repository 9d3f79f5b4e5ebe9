//! Sparse Cholesky factorization with symbolic reuse (thesis ch. 7 §5.2: factorizations dominate
//! the cost of a frame): faer's AMD ordering or our nested dissection, our symbolic analysis and
//! numeric kernel.
//!
//! The symbolic analysis (a fill-reducing ordering — faer's AMD, or our nested dissection
//! ([`super::dissection`]) when it needs fewer flops — then our elimination tree, postorder,
//! column counts and relaxed supernodes, [`super::symbolic`]) depends on the [`SparsePattern`] only, so it is done once per working region
//! ([`SymbolicFactor`], shared through an `Arc`) and reused by every numeric factorization on that
//! region — heat step, Poisson, diffusions — across solves and across animation frames.
//! A [`NumericFactor`] owns the values of `L` and its scratch memory and refactorizes in place when
//! only the matrix values change: no allocation after the first factorization (when the coupled
//! rows below change, the submatrix's storage is resized in place, growing only when needed).
//!
//! **Partial refactorization.** The numeric factorization and the solves are ours
//! ([`super::supernodal`]): a factor remembers the values it was computed from, and a new
//! factorization recomputes only the supernodes whose columns changed and their ancestors in the
//! elimination tree, keeping the rest of `L` — bit-identical to a fresh factorization, so frames
//! stay independent of each other. A static object pressed by a moving one changes only around the
//! contact (its cotangent weights are the same bits every frame).
//!
//! **Decoupled rows.** Most systems of a frame are local: the faces outside the parametrization
//! domain 𝒫 or outside 𝒟 weigh 0, so their vertices' rows hold only a diagonal (a pin) and are
//! decoupled from every other row. Factorizing the region's whole pattern then spends most of its
//! flops on zeros. When at most [`REDUCE_MAX_COUPLED_FRACTION`] of the rows are coupled (a row is
//! coupled when one of its off-diagonal values is not exactly 0), [`NumericFactor`] factorizes only
//! the coupled rows' principal submatrix and solves the decoupled rows as 1 × 1 blocks. This is the
//! same linear system split into independent blocks, so the solution is the same up to round-off.
//! The submatrix is ordered by the region's AMD ordering restricted to its rows (a restriction
//! of a fill-reducing ordering stays a good one, and it costs no new AMD run), so its symbolic
//! analysis is only the elimination tree and the supernodal structure, in near-linear time
//! ([`super::symbolic`]; the restricted order is postordered again there, which keeps its fill
//! and lets the supernodes be as wide as the tree allows). That analysis is kept and
//! reused as long as the same rows are coupled (a contact that does not move, a still shot), and
//! shared by the factors of a region that couple the same rows (the heat and Poisson steps, whose
//! face weights are the same): the [`SymbolicFactor`] keeps the last few. It depends only on the
//! set of rows, so a cached and a fresh analysis give bit-identical factors.
//!
//! Everything runs with `Par::Seq`: our systems are small (10³–10⁵ unknowns), where faer's
//! multithreading costs more than it gains; the pipeline runs independent regions and frames in
//! parallel with rayon instead. The kernels are sequential with a fixed order: the same matrix
//! gives bit-identical factors and solutions, and a column's solution does not depend on how many
//! columns are solved together.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use faer::linalg::cholesky::llt::factor::LltError;
use faer::sparse::{SparseColMatRef, SymbolicSparseColMat};

use super::dissection;
use super::supernodal::{SOLVE_BLOCK, SupernodalPlan, Workspace};
use super::symbolic;
use super::{SolveError, SparsePattern, SymmetricMatrix};
use crate::stage::Work;

/// The coupled rows are factorized alone when they are at most this fraction of the rows (see the
/// module doc). Above it the saved flops no longer pay for the submatrix's symbolic analysis when
/// the coupled set changes every frame.
pub const REDUCE_MAX_COUPLED_FRACTION: f64 = 0.75;

/// Systems with fewer rows are always factorized whole: their factorization costs about as much
/// as the analysis of a submatrix.
pub const REDUCE_MIN_DIMENSION: usize = 256;

/// [`NumericFactor::factorize_within`] factorizes at most this fraction more rows than the
/// matrix couples to avoid an analysis of its own. An analysis costs about as much as the numeric
/// factorization of the same rows, and the flops grow faster than the rows (measured cases:
/// `docs/speed.md`).
pub const WITHIN_MAX_EXTRA_ROWS: f64 = 0.6;

/// Coupled-row analyses a [`SymbolicFactor`] keeps for its factors (a region's frame couples two
/// sets: 𝒫's for the heat and Poisson steps, 𝒟's for the guide).
const RECENT_ROW_ANALYSES: usize = 3;

/// The symbolic analysis of one symmetric structure ([`super::symbolic`]): the permutation, the
/// supernodal structure of `L`, and where `PAPᵀ` puts each of the matrix's value slots, so that
/// a numeric factorization gathers the values into the permuted order with one indexed copy (and
/// sees which columns changed).
#[derive(Debug)]
struct Analysis {
    /// `forward[new] = old` row; `inverse[old] = new`.
    forward: Vec<usize>,
    inverse: Vec<usize>,
    /// `PAPᵀ`'s pattern, lower triangle, rows unsorted within a column.
    permuted: SymbolicSparseColMat<usize>,
    /// Entry `k` of `permuted` is value slot `permuted_slot[k]` of the region's matrices.
    permuted_slot: Vec<usize>,
    /// Our numeric kernel's walk of the supernodes ([`super::supernodal`]).
    plan: SupernodalPlan,
}

impl Analysis {
    /// Analyzes the lower triangle `col_ptr`, `row_idx` of `n` columns, whose entry `k` holds the
    /// region's value slot `entry_slot[k]` (`None`: slot `k`), in the fill-reducing order `order`
    /// (`order[new] = old`).
    fn new(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        entry_slot: Option<&[usize]>,
        order: &[usize],
    ) -> Result<Self, SolveError> {
        Ok(Self::from_structure(n, symbolic::analyze(n, col_ptr, row_idx, entry_slot, order)?))
    }

    /// The analysis of an `n`-column structure computed already.
    fn from_structure(n: usize, structure: symbolic::SupernodalStructure) -> Self {
        let symbolic::SupernodalStructure {
            forward,
            inverse,
            begin,
            pattern_ptr,
            row_idx,
            a_col_ptr,
            a_row_idx,
            a_slot,
        } = structure;
        let plan = SupernodalPlan::new(n, begin, pattern_ptr, row_idx);
        let permuted = SymbolicSparseColMat::new_unsorted_checked(n, n, a_col_ptr, None, a_row_idx);
        Self { forward, inverse, permuted, permuted_slot: a_slot, plan }
    }
}

/// The analysis of the principal submatrix on one set of coupled rows.
#[derive(Debug)]
struct RowsAnalysis {
    /// Per region row: in the submatrix.
    coupled: Vec<bool>,
    /// The submatrix's rows, increasing region rows.
    rows: Vec<usize>,
    analysis: Analysis,
}

/// The fill-reducing order of a [`SymbolicFactor`]'s whole pattern.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FillOrder {
    /// faer's AMD: the quicker analysis (the automatic working regions, analyzed again whenever
    /// their faces change, take their object's, restricted: [`SymbolicFactor::analyze_in_rank_order`]).
    Amd,
    /// Whichever of AMD and our nested dissection (the private `linalg::dissection`) needs fewer
    /// flops: up to 1.8× fewer on round closed objects, for an analysis about twice as long.
    #[default]
    FewerFlops,
}

/// The symbolic analysis of one region's pattern, shared by all its factorizations.
#[derive(Debug)]
pub struct SymbolicFactor {
    pattern: Arc<SparsePattern>,
    analysis: Analysis,
    /// The region's AMD order (`order[new] = old`) when the whole analysis is in the dissection's
    /// order (`None`: it is AMD's, postordered): its restriction orders the submatrices of coupled
    /// rows (see [`Self::analyze`]).
    amd_order: Option<Vec<usize>>,
    /// The last coupled-row analyses, most recent first (at most [`RECENT_ROW_ANALYSES`]).
    recent_rows: Mutex<Vec<Arc<RowsAnalysis>>>,
}

impl SymbolicFactor {
    /// Runs the symbolic analysis of `pattern`: the whole pattern in the fill-reducing order of
    /// the two, AMD and nested dissection (`linalg::dissection`, leaves in AMD order), whose
    /// factorization needs fewer flops (AMD on a tie), then the elimination tree and supernodes.
    ///
    /// Submatrices of coupled rows stay in AMD's order restricted to them, whichever order the
    /// whole pattern got: the dissection's restriction gives costlier factors and slower analyses
    /// on a moving cap, and choosing between the two for each new set of rows costs more than it
    /// saves (`docs/speed.md`).
    pub fn analyze(pattern: &Arc<SparsePattern>) -> Result<Arc<Self>, SolveError> {
        Self::analyze_in(pattern, FillOrder::FewerFlops)
    }

    /// [`Self::analyze`] with the whole pattern in the given kind of order.
    pub fn analyze_in(pattern: &Arc<SparsePattern>, fill_order: FillOrder) -> Result<Arc<Self>, SolveError> {
        let amd = symbolic::amd_order(pattern.structure())?;
        let n = pattern.num_vertices();
        let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
        // Steps 1–3 of each candidate order; the chosen one is finished, not eliminated again.
        let amd_elimination = symbolic::Elimination::checked(n, col_ptr, row_idx, None, &amd)?;
        let dissection = match fill_order {
            FillOrder::Amd => None,
            FillOrder::FewerFlops => {
                let mut amd_rank = vec![0; n];
                for (rank, &v) in amd.iter().enumerate() {
                    amd_rank[v] = rank;
                }
                let order = dissection::nested_dissection_order(n, col_ptr, row_idx, &amd_rank);
                let elimination = symbolic::Elimination::checked(n, col_ptr, row_idx, None, &order)?;
                (elimination.flops() < amd_elimination.flops()).then_some(elimination)
            }
        };
        let (analysis, amd_order) = match dissection {
            Some(elimination) => (Analysis::from_structure(n, elimination.into_structure()), Some(amd)),
            None => (Analysis::from_structure(n, amd_elimination.into_structure()), None),
        };
        Ok(Arc::new(Self { pattern: Arc::clone(pattern), analysis, amd_order, recent_rows: Mutex::new(Vec::new()) }))
    }

    /// [`Self::analyze`] in the order of `rank` (row v before row w when `rank[v] < rank[w]`):
    /// an order of a larger pattern restricted to this one's rows ([`Self::amd_ranks`] of a whole
    /// object for a region cut out of it), without an ordering of its own.
    pub fn analyze_in_rank_order(pattern: &Arc<SparsePattern>, rank: &[usize]) -> Result<Arc<Self>, SolveError> {
        let n = pattern.num_vertices();
        if rank.len() != n {
            return Err(SolveError::Analysis { reason: format!("{} ranks for {n} rows", rank.len()) });
        }
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_unstable_by_key(|&v| (rank[v], v));
        let elimination = symbolic::Elimination::checked(n, pattern.col_ptr(), pattern.row_idx(), None, &order)?;
        let analysis = Analysis::from_structure(n, elimination.into_structure());
        Ok(Arc::new(Self {
            pattern: Arc::clone(pattern),
            analysis,
            amd_order: None,
            recent_rows: Mutex::new(Vec::new()),
        }))
    }

    /// Each row's place in AMD's order of `pattern` (`rank[v]`), for [`Self::analyze_in_rank_order`].
    pub fn amd_ranks(pattern: &SparsePattern) -> Result<Vec<usize>, SolveError> {
        let order = symbolic::amd_order(pattern.structure())?;
        let mut rank = vec![0; order.len()];
        for (k, &v) in order.iter().enumerate() {
            rank[v] = k;
        }
        Ok(rank)
    }

    /// True if the whole pattern is in the nested-dissection order, false if in AMD's (see
    /// [`Self::analyze`]).
    pub fn uses_nested_dissection(&self) -> bool {
        self.amd_order.is_some()
    }

    /// The pattern this analysis belongs to.
    pub fn pattern(&self) -> &Arc<SparsePattern> {
        &self.pattern
    }

    /// Number of rows.
    pub fn dimension(&self) -> usize {
        self.analysis.forward.len()
    }

    /// Number of stored values of the factor `L` (fill-in included).
    pub fn factor_len(&self) -> usize {
        self.analysis.plan.factor_len()
    }

    /// Supernodes of the factor: the dense column blocks our kernel works on.
    pub fn num_supernodes(&self) -> usize {
        self.analysis.plan.len()
    }

    /// The analysis of the submatrix on the rows marked in `coupled`: a recent one when the same
    /// rows were analyzed, else a new one (then `true`), remembered for the region's other factors.
    fn rows_analysis(&self, coupled: &[bool]) -> Result<(Arc<RowsAnalysis>, bool), SolveError> {
        // A poisoned lock only means another thread panicked while holding it; the list is valid.
        let recent = |f: &mut dyn FnMut(&mut Vec<Arc<RowsAnalysis>>)| {
            let mut guard = self.recent_rows.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
            f(&mut guard);
        };
        let mut found = None;
        recent(&mut |list| found = list.iter().find(|r| r.coupled == coupled).map(Arc::clone));
        if let Some(found) = found {
            return Ok((found, false));
        }
        let rows: Vec<usize> = (0..coupled.len()).filter(|&v| coupled[v]).collect();
        let mut local = vec![usize::MAX; coupled.len()];
        for (k, &v) in rows.iter().enumerate() {
            local[v] = k;
        }
        let analysis = self.analyze_rows(&rows, &local, coupled)?;
        let analyzed = Arc::new(RowsAnalysis { coupled: coupled.to_vec(), rows, analysis });
        recent(&mut |list| {
            list.insert(0, Arc::clone(&analyzed));
            list.truncate(RECENT_ROW_ANALYSES);
        });
        Ok((analyzed, true))
    }

    /// The analysis of the principal submatrix on `rows` (increasing region rows), ordered by this
    /// analysis' ordering restricted to them. `local[v]` must be the position of row `v` in `rows`
    /// for every row in `rows`.
    fn analyze_rows(&self, rows: &[usize], local: &[usize], in_rows: &[bool]) -> Result<Analysis, SolveError> {
        let m = rows.len();
        let (col_ptr, row_idx) = (self.pattern.col_ptr(), self.pattern.row_idx());
        let mut sub_col_ptr = Vec::with_capacity(m + 1);
        let mut sub_row_idx = Vec::new();
        let mut entry_slot = Vec::new();
        sub_col_ptr.push(0);
        for &j in rows {
            for (slot, &i) in row_idx.iter().enumerate().take(col_ptr[j + 1]).skip(col_ptr[j]) {
                if in_rows[i] {
                    // `rows` increases, so the lower triangle stays lower and rows stay sorted.
                    sub_row_idx.push(local[i]);
                    entry_slot.push(slot);
                }
            }
            sub_col_ptr.push(sub_row_idx.len());
        }
        let amd_order = self.amd_order.as_ref().unwrap_or(&self.analysis.forward);
        let sub_forward: Vec<usize> = amd_order.iter().filter(|&&v| in_rows[v]).map(|&v| local[v]).collect();
        Analysis::new(m, &sub_col_ptr, &sub_row_idx, Some(&entry_slot), &sub_forward)
    }
}

/// The numeric factor `L` of one [`Analysis`] and its scratch memory.
struct Numeric {
    l_values: Vec<f64>,
    /// The matrix's values in the permuted layout of the analysis: those `l_values` were computed
    /// from when `valid`.
    permuted_values: Vec<f64>,
    /// `l_values` is the factor of `permuted_values` (a partial refactorization may start from it).
    valid: bool,
    /// Per supernode: its columns changed in the factorization under way.
    changed: Vec<bool>,
    /// Columns the last factorization recomputed.
    recomputed_columns: usize,
    /// Their multiply-adds (`Σ c_j²`).
    recomputed_flops: u64,
    work: Workspace,
    /// One permuted right-hand side.
    permuted_rhs: Vec<f64>,
}

impl Numeric {
    fn new(analysis: &Analysis) -> Result<Self, SolveError> {
        Ok(Self {
            l_values: vec![0.0; analysis.plan.factor_len()],
            permuted_values: vec![0.0; analysis.permuted_slot.len()],
            valid: false,
            changed: Vec::new(),
            recomputed_columns: 0,
            recomputed_flops: 0,
            work: Workspace::default(),
            permuted_rhs: Vec::new(),
        })
    }

    /// This factor's storage resized for another analysis: the memory of a previous submatrix is
    /// reused (a contact that moves changes the coupled rows every frame; fresh allocations
    /// there cost page faults). The next factorization is a whole one.
    fn reuse_for(mut self, analysis: &Analysis) -> Result<Self, SolveError> {
        self.l_values.clear();
        self.l_values.resize(analysis.plan.factor_len(), 0.0);
        self.permuted_values.clear();
        self.permuted_values.resize(analysis.permuted_slot.len(), 0.0);
        self.valid = false;
        Ok(self)
    }

    /// Factorizes the matrix whose value slots are `values`: gathers them into the permuted
    /// layout, marks the supernodes whose columns changed since the factor was last computed, and
    /// recomputes those and their ancestors ([`super::supernodal`]; everything when the factor is
    /// not valid).
    fn factorize(&mut self, analysis: &Analysis, values: &[f64]) -> Result<(), LltError> {
        let plan = &analysis.plan;
        let partial = self.valid;
        self.valid = false;
        self.changed.clear();
        self.changed.resize(plan.len(), false);
        let col_ptr = analysis.permuted.col_ptr();
        for j in 0..analysis.permuted.ncols() {
            let mut differs = false;
            for k in col_ptr[j]..col_ptr[j + 1] {
                let value = values[analysis.permuted_slot[k]];
                // Bitwise: −0 and +0 may give different factors.
                if value.to_bits() != self.permuted_values[k].to_bits() {
                    self.permuted_values[k] = value;
                    differs = true;
                }
            }
            if differs {
                self.changed[plan.supernode_of(j)] = true;
            }
        }
        let a = SparseColMatRef::new(analysis.permuted.as_ref(), &self.permuted_values);
        let changed = partial.then_some(self.changed.as_slice());
        (self.recomputed_columns, self.recomputed_flops) =
            plan.factorize(a, &mut self.l_values, changed, &mut self.work)?;
        self.valid = true;
        Ok(())
    }

    /// Solves in place for `columns` column-major right-hand sides of the analysis' dimension.
    fn solve(&mut self, analysis: &Analysis, rhs: &mut [f64], columns: usize) -> Result<(), SolveError> {
        let n = analysis.forward.len();
        let (forward, inverse) = (&analysis.forward, &analysis.inverse);
        let mut columns: Vec<&mut [f64]> = rhs.chunks_exact_mut(n.max(1)).take(columns).collect();
        for group in columns.chunks_mut(SOLVE_BLOCK) {
            let k = group.len();
            // Rows interleaved: x[i·k + c] is row i of column c, in the permuted order.
            let x = &mut self.permuted_rhs;
            x.resize(n * k, 0.0);
            for (c, column) in group.iter().enumerate() {
                for i in 0..n {
                    x[i * k + c] = column[forward[i]];
                }
            }
            analysis.plan.solve_rows_in_place(&self.l_values, &mut x[..n * k], k);
            for (c, column) in group.iter_mut().enumerate() {
                for (old, value) in column.iter_mut().enumerate() {
                    *value = x[inverse[old] * k + c];
                }
            }
        }
        Ok(())
    }
}

/// The coupled rows' principal submatrix: its analysis (kept while the same rows are coupled) and
/// its factor.
struct ReducedSystem {
    shared: Arc<RowsAnalysis>,
    numeric: Numeric,
    /// Gathered right-hand sides.
    rhs: Vec<f64>,
}

/// How the last successful factorization was done.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Layout {
    /// Not factorized (or the last factorization failed).
    None,
    /// The region's whole pattern.
    Whole,
    /// The coupled rows alone ([`ReducedSystem`], absent when no row is coupled), the others as
    /// 1 × 1 blocks.
    Reduced,
}

/// A numeric `LLᵀ` factorization on a shared [`SymbolicFactor`], refactorizable in place.
pub struct NumericFactor {
    symbolic: Arc<SymbolicFactor>,
    /// The factor on the whole pattern, allocated on first use.
    whole: Option<Numeric>,
    reduced: Option<ReducedSystem>,
    layout: Layout,
    /// Scratch of the coupled-row detection.
    coupled: Vec<bool>,
    /// The diagonal of the decoupled rows (their 1 × 1 blocks) in the reduced layout.
    diagonal: Vec<f64>,
    reduced_analyses: usize,
    /// Rows of the analyses this factor needed (its own or shared), summed.
    analyzed_rows: u64,
    /// Time those analyses took.
    analysis_time: Duration,
    /// False: always factorize the whole pattern (tests compare the two layouts).
    reduce: bool,
}

impl std::fmt::Debug for NumericFactor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NumericFactor")
            .field("dimension", &self.symbolic.dimension())
            .field("layout", &self.layout)
            .field("factorized_rows", &self.factorized_rows())
            .field("reduced_analyses", &self.reduced_analyses)
            .finish()
    }
}

impl NumericFactor {
    /// Prepares a factor (nothing is factorized or allocated yet).
    pub fn new(symbolic: &Arc<SymbolicFactor>) -> Result<Self, SolveError> {
        Ok(Self {
            symbolic: Arc::clone(symbolic),
            whole: None,
            reduced: None,
            layout: Layout::None,
            coupled: Vec::new(),
            diagonal: Vec::new(),
            reduced_analyses: 0,
            analyzed_rows: 0,
            analysis_time: Duration::ZERO,
            reduce: true,
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
        self.layout != Layout::None
    }

    /// Number of rows the last factorization ran the Cholesky kernel on: the region's dimension,
    /// or the coupled rows alone (see the module doc); 0 when not factorized.
    pub fn factorized_rows(&self) -> usize {
        match self.layout {
            Layout::None => 0,
            Layout::Whole => self.symbolic.dimension(),
            Layout::Reduced => self.reduced.as_ref().map_or(0, |r| r.shared.rows.len()),
        }
    }

    /// Number of symbolic analyses of coupled-row submatrices run so far (one each time the set
    /// of coupled rows changes).
    pub fn reduced_analyses(&self) -> usize {
        self.reduced_analyses
    }

    /// Rows of the analyses of coupled-row submatrices this factor needed, whether it ran them or
    /// took them from another factor of the same pattern (their [`crate::stage::Work`]: the same
    /// whatever the threads).
    pub fn analyzed_rows(&self) -> u64 {
        self.analyzed_rows
    }

    /// Total time of those analyses (part of the factorizations' time).
    pub fn analysis_time(&self) -> Duration {
        self.analysis_time
    }

    /// Makes the next factorization a whole one (for timing the kernel): forgets the values the
    /// factor was computed from, so no part of it is kept.
    pub fn forget_previous_values(&mut self) {
        if let Some(whole) = &mut self.whole {
            whole.valid = false;
        }
        if let Some(reduced) = &mut self.reduced {
            reduced.numeric.valid = false;
        }
    }

    /// Columns of `L` the last factorization computed: all of them for a whole factorization,
    /// those whose values changed and their ancestors for a partial one (see
    /// `linalg::supernodal`).
    pub fn recomputed_columns(&self) -> usize {
        match self.layout {
            Layout::None => 0,
            Layout::Whole => self.whole.as_ref().map_or(0, |w| w.recomputed_columns),
            Layout::Reduced => self.reduced.as_ref().map_or(0, |r| r.numeric.recomputed_columns),
        }
    }

    /// Multiply-adds of the last factorization (`Σ c_j²` over the columns it recomputed, see
    /// [`Self::recomputed_columns`]; 0 when not factorized): its [`crate::stage::Work`].
    pub fn recomputed_flops(&self) -> u64 {
        match self.layout {
            Layout::None => 0,
            Layout::Whole => self.whole.as_ref().map_or(0, |w| w.recomputed_flops),
            Layout::Reduced => self.reduced.as_ref().map_or(0, |r| r.numeric.recomputed_flops),
        }
    }

    /// Factorizes `matrix` (on the same pattern as the symbolic analysis) in place, reusing the
    /// storage of any previous factorization. A matrix that is not positive definite, or has a
    /// non-finite value, is an error and leaves the factor unusable until the next success.
    pub fn factorize(&mut self, matrix: &SymmetricMatrix) -> Result<(), SolveError> {
        self.factorize_within(matrix, None)
    }

    /// The rows the last factorization coupled (`true` per region row), when it factorized a
    /// submatrix on them; `None` after a whole factorization or a failure.
    pub fn coupled_rows(&self) -> Option<&[bool]> {
        match (self.layout, &self.reduced) {
            (Layout::Reduced, Some(reduced)) => Some(&reduced.shared.coupled),
            _ => None,
        }
    }

    /// [`Self::factorize`], on the rows `other` (a factor of the same region, factorized in the
    /// same frame) last factorized instead of this matrix's own coupled rows, when those are
    /// among them and not many fewer (at most 60% more, `WITHIN_MAX_EXTRA_ROWS`): the analysis of
    /// `other`'s rows is already made (the region's own one when `other` factorized the whole
    /// region), and an analysis costs more than factorizing a few extra rows. The extra rows have
    /// no off-diagonal value here, so they add their 1 × 1 pivots and exact zeros; the other rows
    /// are eliminated in `other`'s order, so the factor equals the one of [`Self::factorize`] up
    /// to round-off.
    /// `other` must be a function of the current matrices only (not of the frames before), for the
    /// result not to depend on the order frames are computed in. `None`, a factor of another
    /// region or an unfactorized one: [`Self::factorize`].
    pub fn factorize_within(
        &mut self,
        matrix: &SymmetricMatrix,
        other: Option<&NumericFactor>,
    ) -> Result<(), SolveError> {
        self.layout = Layout::None;
        if !Arc::ptr_eq(matrix.pattern(), &self.symbolic.pattern) {
            return Err(SolveError::PatternMismatch);
        }
        if let Some((slot, value)) = matrix.first_non_finite() {
            return Err(SolveError::NonFiniteValue { what: "matrix", index: slot, value });
        }
        let values = matrix.values();
        let mut coupled_rows = self.mark_coupled_rows(values);
        let other = other.filter(|o| Arc::ptr_eq(&o.symbolic, &self.symbolic));
        if let (Some(count), Some(other)) = (coupled_rows, other) {
            let limit = count as f64 * (1.0 + WITHIN_MAX_EXTRA_ROWS);
            match (other.layout, other.coupled_rows()) {
                (Layout::Whole, _) if self.coupled.len() as f64 <= limit => coupled_rows = None,
                (Layout::Reduced, Some(within)) => {
                    let wider = other.factorized_rows();
                    let contains = self.coupled.iter().zip(within).all(|(&c, &w)| w || !c);
                    if contains && wider as f64 <= limit {
                        self.coupled.copy_from_slice(within);
                        coupled_rows = Some(wider);
                    }
                }
                _ => {}
            }
        }
        let result = match coupled_rows {
            Some(count) => self.factorize_reduced(values, count),
            None => self.factorize_whole(values),
        };
        match result {
            Ok(layout) => {
                self.layout = layout;
                Ok(())
            }
            Err(FactorizeError::Solve(error)) => Err(error),
            Err(FactorizeError::NotPositiveDefinite { pivot }) => {
                let n = matrix.dimension();
                let (vertex, min_diagonal) = (0..n as u32)
                    .map(|v| (v, matrix.diagonal(v)))
                    .fold((0, f64::INFINITY), |best, (v, d)| if d < best.1 { (v, d) } else { best });
                Err(SolveError::NotPositiveDefinite { pivot, dimension: n, vertex, min_diagonal })
            }
        }
    }

    /// Marks the rows with a non-zero off-diagonal value in `self.coupled`; returns their number
    /// when the reduced layout should be used.
    fn mark_coupled_rows(&mut self, values: &[f64]) -> Option<usize> {
        let pattern = &self.symbolic.pattern;
        let n = pattern.num_vertices();
        if n < REDUCE_MIN_DIMENSION || !self.reduce {
            return None;
        }
        self.coupled.clear();
        self.coupled.resize(n, false);
        let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
        let coupled = self.coupled.as_mut_slice();
        for j in 0..n {
            // Branch-free: the entries of a column are mostly non-zero off the diagonal.
            let mut any = false;
            for (&i, &value) in row_idx[col_ptr[j]..col_ptr[j + 1]].iter().zip(&values[col_ptr[j]..col_ptr[j + 1]]) {
                let link = (i != j) & (value != 0.0);
                coupled[i] |= link;
                any |= link;
            }
            coupled[j] |= any;
        }
        let count = self.coupled.iter().filter(|&&c| c).count();
        (count as f64 <= REDUCE_MAX_COUPLED_FRACTION * n as f64).then_some(count)
    }

    fn factorize_whole(&mut self, values: &[f64]) -> Result<Layout, FactorizeError> {
        let analysis = &self.symbolic.analysis;
        let whole = match &mut self.whole {
            Some(whole) => whole,
            None => self.whole.insert(Numeric::new(analysis)?),
        };
        whole.factorize(analysis, values)?;
        Ok(Layout::Whole)
    }

    fn factorize_reduced(&mut self, values: &[f64], coupled_rows: usize) -> Result<Layout, FactorizeError> {
        let pattern = Arc::clone(&self.symbolic.pattern);
        self.diagonal.clear();
        for (v, &coupled) in self.coupled.iter().enumerate() {
            let d = values[pattern.diag_slot(v as u32)];
            if !coupled && d <= 0.0 {
                return Err(FactorizeError::NotPositiveDefinite { pivot: v });
            }
            self.diagonal.push(if coupled { 0.0 } else { d });
        }
        if coupled_rows == 0 {
            self.reduced = None;
            return Ok(Layout::Reduced);
        }
        let reusable = self.reduced.as_ref().is_some_and(|r| r.shared.coupled == self.coupled);
        if !reusable {
            let start = Instant::now();
            let (shared, new) = self.symbolic.rows_analysis(&self.coupled)?;
            // Counted whether analyzed here or taken from another factor's: which of two
            // factors in parallel analyzes first depends on the threads, the rows needed do not.
            self.analyzed_rows += coupled_rows as u64;
            if new {
                self.reduced_analyses += 1;
                self.analysis_time += start.elapsed();
            }
            let (numeric, rhs) = match self.reduced.take() {
                Some(previous) => (previous.numeric.reuse_for(&shared.analysis)?, previous.rhs),
                None => (Numeric::new(&shared.analysis)?, Vec::new()),
            };
            self.reduced = Some(ReducedSystem { shared, numeric, rhs });
        }
        let reduced = self.reduced.as_mut().ok_or(SolveError::NotFactorized)?;
        reduced.numeric.factorize(&reduced.shared.analysis, values)?;
        Ok(Layout::Reduced)
    }

    /// Solves `A x = rhs` in place (`rhs` has one entry per vertex).
    pub fn solve_in_place(&mut self, rhs: &mut [f64]) -> Result<(), SolveError> {
        self.solve_columns_in_place(rhs, 1)
    }

    /// Solves `A X = B` in place for `columns` right-hand sides stored column after column in
    /// `rhs` (column-major, `dimension × columns`).
    pub fn solve_columns_in_place(&mut self, rhs: &mut [f64], columns: usize) -> Result<(), SolveError> {
        if self.layout == Layout::None {
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
        match self.layout {
            Layout::Reduced => {
                for column in rhs.chunks_exact_mut(n) {
                    for (x, &d) in column.iter_mut().zip(&self.diagonal) {
                        if d != 0.0 {
                            *x /= d;
                        }
                    }
                }
                let Some(reduced) = self.reduced.as_mut() else { return Ok(()) };
                let rows = &reduced.shared.rows;
                let m = rows.len();
                Work::count_rows((m * columns) as u64);
                reduced.rhs.clear();
                for column in rhs.chunks_exact(n) {
                    reduced.rhs.extend(rows.iter().map(|&v| column[v]));
                }
                reduced.numeric.solve(&reduced.shared.analysis, &mut reduced.rhs, columns)?;
                for (column, solved) in rhs.chunks_exact_mut(n).zip(reduced.rhs.chunks_exact(m)) {
                    for (&v, &x) in rows.iter().zip(solved) {
                        column[v] = x;
                    }
                }
                Ok(())
            }
            _ => {
                let whole = self.whole.as_mut().ok_or(SolveError::NotFactorized)?;
                Work::count_rows((n * columns) as u64);
                whole.solve(&self.symbolic.analysis, rhs, columns)
            }
        }
    }

    /// Solves `A x = rhs` into a new vector.
    pub fn solve(&mut self, rhs: &[f64]) -> Result<Vec<f64>, SolveError> {
        let mut x = rhs.to_vec();
        self.solve_in_place(&mut x)?;
        Ok(x)
    }
}

/// Why a factorization failed, before the error is dressed with the matrix's figures.
enum FactorizeError {
    NotPositiveDefinite { pivot: usize },
    Solve(SolveError),
}

impl From<SolveError> for FactorizeError {
    fn from(error: SolveError) -> Self {
        Self::Solve(error)
    }
}

impl From<LltError> for FactorizeError {
    fn from(error: LltError) -> Self {
        match error {
            LltError::NonPositivePivot { index } => Self::NotPositiveDefinite { pivot: index },
        }
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
    use glam::DVec3;

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
        let l_ptr = factor.whole.as_ref().unwrap().l_values.as_ptr();
        factor.factorize(&a2).unwrap();
        assert_eq!(l_ptr, factor.whole.as_ref().unwrap().l_values.as_ptr(), "refactorization must reuse L's storage");
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

    /// A cap cut out of a sphere, analyzed in the sphere's AMD order restricted to it: the
    /// sphere's own ranks give AMD's analysis of the sphere, and the cap's factor solves its
    /// system with fill close to the cap's own AMD order.
    #[test]
    fn a_cut_region_in_its_objects_order_factorizes_and_solves() {
        let sphere = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&sphere);
        let pattern = SparsePattern::shared(&sphere, &topology).unwrap();
        let ranks = SymbolicFactor::amd_ranks(&pattern).unwrap();
        let in_ranks = SymbolicFactor::analyze_in_rank_order(&pattern, &ranks).unwrap();
        let amd = SymbolicFactor::analyze_in(&pattern, FillOrder::Amd).unwrap();
        assert_eq!(in_ranks.factor_len(), amd.factor_len());
        assert!(SymbolicFactor::analyze_in_rank_order(&pattern, &ranks[1..]).is_err());

        let faces = (0..sphere.num_triangles() as u32).filter(|&f| sphere.corners(f as usize)[0].z > -0.3);
        let cap = crate::mesh::SubMesh::from_faces(&sphere, faces);
        let cap_topology = Topology::new(&cap.mesh);
        let cap_pattern = SparsePattern::shared(&cap.mesh, &cap_topology).unwrap();
        let cap_ranks: Vec<usize> = cap.parent_vertex.iter().map(|&v| ranks[v as usize]).collect();
        let symbolic = SymbolicFactor::analyze_in_rank_order(&cap_pattern, &cap_ranks).unwrap();
        let own = SymbolicFactor::analyze_in(&cap_pattern, FillOrder::Amd).unwrap();
        assert!(
            (symbolic.factor_len() as f64) < 1.5 * own.factor_len() as f64,
            "{} {}",
            symbolic.factor_len(),
            own.factor_len()
        );
        let mut a = cotangent_stiffness(&cap.mesh, &cap_pattern, None).unwrap();
        a.add_diagonal(&lumped_mass(&cap.mesh, None).unwrap(), 1.0).unwrap();
        let mut rng = Lcg::new(8);
        let b: Vec<f64> = (0..cap.mesh.num_vertices()).map(|_| rng.next_signed()).collect();
        let x = NumericFactor::factorize_new(&symbolic, &a).unwrap().solve(&b).unwrap();
        assert!(residual(&a, &x, &b) < 1e-12);
    }

    /// A 60 × 60 grid whose faces weigh 1 inside a disk of the given radius and 0 outside (the
    /// stiffness + mass of a heat step, outside vertices pinned by +1 on their diagonal).
    fn disk_system(radius: f64) -> (Arc<SymbolicFactor>, SymmetricMatrix) {
        let mesh = shapes::grid(2.0, 2.0, 60, 60);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let weights: Vec<f64> = mesh
            .triangles
            .iter()
            .map(|t| {
                let inside = t.iter().all(|&v| mesh.positions[v as usize].truncate().length() < radius);
                if inside { 1.0 } else { 0.0 }
            })
            .collect();
        let mut a = Operator::heat(&mesh, &pattern, Some(&weights), 0.01).unwrap().matrix().clone();
        for v in 0..mesh.num_vertices() as u32 {
            if a.diagonal(v) == 0.0 {
                let slot = pattern.diag_slot(v);
                a.values_mut()[slot] = 1.0;
            }
        }
        (SymbolicFactor::analyze(&pattern).unwrap(), a)
    }

    #[test]
    fn decoupled_rows_are_left_out_of_the_factorization_with_the_same_solution() {
        let (symbolic, a) = disk_system(0.5);
        let n = a.dimension();
        let mut rng = Lcg::new(17);
        let b: Vec<f64> = (0..2 * n).map(|_| rng.next_signed()).collect();

        let mut whole = NumericFactor::new(&symbolic).unwrap();
        whole.reduce = false;
        whole.factorize(&a).unwrap();
        assert_eq!(whole.factorized_rows(), n);
        let mut reduced = NumericFactor::factorize_new(&symbolic, &a).unwrap();
        let coupled = reduced.factorized_rows();
        assert!(coupled > 0 && coupled < n / 5, "{coupled} of {n} rows");
        assert_eq!(reduced.reduced_analyses(), 1);

        let mut x_whole = b.clone();
        whole.solve_columns_in_place(&mut x_whole, 2).unwrap();
        let mut x_reduced = b.clone();
        reduced.solve_columns_in_place(&mut x_reduced, 2).unwrap();
        for column in 0..2 {
            let (range, rhs) = (column * n..(column + 1) * n, &b[column * n..(column + 1) * n]);
            assert!(residual(&a, &x_reduced[range.clone()], rhs) < 1e-12);
            let difference =
                x_whole[range.clone()].iter().zip(&x_reduced[range]).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
            assert!(difference < 1e-12, "column {column}: {difference}");
        }
        // The decoupled rows are exactly b / 1.
        let decoupled = (0..n).find(|&v| a.diagonal(v as u32) == 1.0).unwrap();
        assert_eq!(x_reduced[decoupled], b[decoupled]);

        // New values on the same coupled rows reuse the analysis and match a fresh factor bit for bit.
        let mut scaled = a.clone();
        for value in scaled.values_mut() {
            *value *= 1.5;
        }
        reduced.factorize(&scaled).unwrap();
        assert_eq!(reduced.reduced_analyses(), 1, "same coupled rows: no new analysis");
        let mut fresh = NumericFactor::factorize_new(&symbolic, &scaled).unwrap();
        let bits = |v: Vec<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(reduced.solve(&b[..n]).unwrap()), bits(fresh.solve(&b[..n]).unwrap()));

        // A second factor coupling the same rows (the Poisson step after the heat step) reuses the
        // region's recent analysis.
        let mut second = NumericFactor::factorize_new(&symbolic, &a).unwrap();
        assert_eq!(second.reduced_analyses(), 0, "shared with the first factor");
        assert_eq!(bits(second.solve(&b[..n]).unwrap()), bits(x_reduced[..n].to_vec()));

        // Other coupled rows: a new analysis; a disk covering most of the grid: the whole pattern.
        let (_, wider) = disk_system(0.6);
        let wider = SymmetricMatrix::from_values(symbolic.pattern(), wider.values().to_vec()).unwrap();
        reduced.factorize(&wider).unwrap();
        assert_eq!(reduced.reduced_analyses(), 2);
        assert!(reduced.factorized_rows() > coupled);
        // The previous submatrix's storage is reused: still bit-identical to a fresh factor.
        let mut fresh = NumericFactor::factorize_new(&symbolic, &wider).unwrap();
        assert_eq!(bits(reduced.solve(&b[..n]).unwrap()), bits(fresh.solve(&b[..n]).unwrap()));
        let (_, narrower) = disk_system(0.4);
        let narrower = SymmetricMatrix::from_values(symbolic.pattern(), narrower.values().to_vec()).unwrap();
        reduced.factorize(&narrower).unwrap();
        let mut fresh = NumericFactor::factorize_new(&symbolic, &narrower).unwrap();
        assert_eq!(bits(reduced.solve(&b[..n]).unwrap()), bits(fresh.solve(&b[..n]).unwrap()));
        assert!(residual(&narrower, &reduced.solve(&b[..n]).unwrap(), &b[..n]) < 1e-12);
        let (_, most) = disk_system(10.0);
        reduced.factorize(&SymmetricMatrix::from_values(symbolic.pattern(), most.values().to_vec()).unwrap()).unwrap();
        assert_eq!(reduced.factorized_rows(), n);
    }

    #[test]
    fn a_factor_within_anothers_rows_reuses_their_analysis_with_the_same_solution() {
        let (symbolic, heat) = disk_system(0.5);
        let n = heat.dimension();
        let mut rng = Lcg::new(23);
        let b: Vec<f64> = (0..n).map(|_| rng.next_signed()).collect();
        let heat_factor = NumericFactor::factorize_new(&symbolic, &heat).unwrap();
        let within = heat_factor.coupled_rows().unwrap().to_vec();
        let heat_rows = heat_factor.factorized_rows();
        assert_eq!(within.iter().filter(|&&c| c).count(), heat_rows);

        // A system on a slightly smaller disk (as 𝒟 inside the parametrized domain), with other
        // values: it couples a subset of the heat system's rows.
        let (_, smaller) = disk_system(0.45);
        let mut guide = SymmetricMatrix::from_values(symbolic.pattern(), smaller.values().to_vec()).unwrap();
        for value in guide.values_mut() {
            *value *= 2.0;
        }
        let mut own = NumericFactor::factorize_new(&symbolic, &guide).unwrap();
        let own_rows = own.factorized_rows();
        assert!(own_rows < heat_rows && (heat_rows as f64) < 1.5 * own_rows as f64, "{own_rows} {heat_rows}");
        assert_eq!(own.reduced_analyses(), 1);

        let mut reusing = NumericFactor::new(&symbolic).unwrap();
        reusing.factorize_within(&guide, Some(&heat_factor)).unwrap();
        assert_eq!(reusing.factorized_rows(), heat_rows, "factorized on the heat system's rows");
        assert_eq!(reusing.reduced_analyses(), 0, "with the heat system's analysis");
        let (x_own, x_within) = (own.solve(&b).unwrap(), reusing.solve(&b).unwrap());
        let difference = x_own.iter().zip(&x_within).map(|(p, q)| (p - q).abs()).fold(0.0, f64::max);
        assert!(difference < 1e-12, "{difference}");
        assert!(residual(&guide, &x_within, &b) < 1e-12);
        // The rows outside the guide's own coupling are b / diagonal (through √d twice).
        let extra = (0..n).find(|&v| within[v] && !own.coupled_rows().unwrap()[v]).unwrap();
        let expected = b[extra] / guide.diagonal(extra as u32);
        assert!((x_within[extra] - expected).abs() <= 4.0 * f64::EPSILON * expected.abs());

        // Rows outside `within`, or many fewer rows than it: the factor analyzes its own rows.
        let (_, larger) = disk_system(0.55);
        let larger = SymmetricMatrix::from_values(symbolic.pattern(), larger.values().to_vec()).unwrap();
        reusing.factorize_within(&larger, Some(&heat_factor)).unwrap();
        assert!(reusing.factorized_rows() > heat_rows);
        let (_, tiny) = disk_system(0.2);
        let tiny = SymmetricMatrix::from_values(symbolic.pattern(), tiny.values().to_vec()).unwrap();
        reusing.factorize_within(&tiny, Some(&heat_factor)).unwrap();
        assert!(reusing.factorized_rows() < heat_rows / 2);
        assert!(residual(&tiny, &reusing.solve(&b).unwrap(), &b) < 1e-12);
        // After a whole factorization of the heat system, a guide coupling most rows is factorized
        // whole too (no analysis), one coupling few rows on its own rows.
        let mut whole = NumericFactor::new(&symbolic).unwrap();
        whole.reduce = false;
        whole.factorize(&heat).unwrap();
        assert!(whole.coupled_rows().is_none());
        let (_, most) = disk_system(0.95);
        let most = SymmetricMatrix::from_values(symbolic.pattern(), most.values().to_vec()).unwrap();
        let mut own_most = NumericFactor::factorize_new(&symbolic, &most).unwrap();
        let most_rows = own_most.factorized_rows();
        assert!((most_rows as f64) < 0.75 * n as f64 && n as f64 <= 1.6 * most_rows as f64, "{most_rows} of {n}");
        let mut reusing = NumericFactor::new(&symbolic).unwrap();
        reusing.factorize_within(&most, Some(&whole)).unwrap();
        assert_eq!((reusing.factorized_rows(), reusing.reduced_analyses()), (n, 0));
        let (x_own, x_whole) = (own_most.solve(&b).unwrap(), reusing.solve(&b).unwrap());
        assert!(x_own.iter().zip(&x_whole).all(|(p, q)| (p - q).abs() < 1e-12));
        reusing.factorize_within(&tiny, Some(&whole)).unwrap();
        assert!(reusing.factorized_rows() < heat_rows / 2);
        // A factor of another region is ignored.
        let (other_symbolic, other_heat) = disk_system(0.5);
        let elsewhere = NumericFactor::factorize_new(&other_symbolic, &other_heat).unwrap();
        reusing.factorize_within(&guide, Some(&elsewhere)).unwrap();
        assert_eq!(reusing.factorized_rows(), own_rows);
    }

    #[test]
    fn a_decoupled_row_without_a_positive_diagonal_is_not_positive_definite() {
        let (symbolic, a) = disk_system(0.5);
        let mut bad = a.clone();
        let decoupled = (0..a.dimension() as u32).find(|&v| a.diagonal(v) == 1.0).unwrap();
        let slot = symbolic.pattern().diag_slot(decoupled);
        bad.values_mut()[slot] = 0.0;
        let mut factor = NumericFactor::new(&symbolic).unwrap();
        assert!(matches!(factor.factorize(&bad), Err(SolveError::NotPositiveDefinite { .. })));
        assert!(!factor.is_factorized());
        assert_eq!(factor.factorized_rows(), 0);
        factor.factorize(&a).unwrap();
        assert!(factor.is_factorized());
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
        // Columns solved together (one pass over L) are bit for bit the columns solved alone, in
        // groups of any size, with zero and sparse columns among them.
        let mut b = b;
        b.extend((0..2 * n).map(|i| if i < n || i % 17 == 0 { 0.0 } else { 1.0 }));
        for columns in [2, 3, 5] {
            let mut x = b[..columns * n].to_vec();
            factor.solve_columns_in_place(&mut x, columns).unwrap();
            for c in 0..columns {
                let single = factor.solve(&b[c * n..(c + 1) * n]).unwrap();
                let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&single), bits(&x[c * n..(c + 1) * n]), "column {c} of {columns}");
            }
        }
    }

    #[test]
    fn factors_match_faers_own_analysis_and_factorization() {
        // Our analysis and kernel (thin and wide supernodes: a small sphere, a grid, a larger
        // sphere) against faer's symbolic and numeric factorization of the same matrix: the same
        // AMD ordering gives a factor of the same size (the same supernode relaxation rule), and
        // the solutions agree to round-off.
        use faer::Side;
        use faer::sparse::linalg::SupernodalThreshold;
        use faer::sparse::linalg::cholesky::{CholeskySymbolicParams, SymmetricOrdering, factorize_symbolic_cholesky};
        use faer::sparse::linalg::solvers::{Llt, SymbolicLlt};
        for mesh in [shapes::icosphere(1.0, 2), shapes::grid(1.0, 1.0, 40, 31), shapes::icosphere(1.0, 5)] {
            let topology = Topology::new(&mesh);
            let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
            let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
            let op = Operator::heat(&mesh, &pattern, None, 0.3).unwrap();
            let mut ours = NumericFactor::factorize_new(&symbolic, op.matrix()).unwrap();
            let supernodal = CholeskySymbolicParams {
                supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                ..Default::default()
            };
            let theirs_symbolic =
                factorize_symbolic_cholesky(pattern.structure(), Side::Lower, SymmetricOrdering::Amd, supernodal)
                    .unwrap();
            // The dissection is kept only when it needs fewer flops (the large sphere, not the
            // grid): then the factor is smaller than AMD's, else the same size.
            let rows = mesh.num_vertices();
            if symbolic.uses_nested_dissection() {
                assert!(symbolic.factor_len() < theirs_symbolic.len_val(), "{rows} rows: factor size");
            } else {
                assert_eq!(symbolic.factor_len(), theirs_symbolic.len_val(), "{rows} rows: factor size");
            }
            assert_eq!(symbolic.uses_nested_dissection(), rows == 10242, "{rows} rows: order kept");
            let amd = SymbolicFactor::analyze_in(&pattern, FillOrder::Amd).unwrap();
            assert!(!amd.uses_nested_dissection());
            assert_eq!(amd.factor_len(), theirs_symbolic.len_val(), "{rows} rows: factor size in AMD's order");
            let theirs = Llt::try_new_with_symbolic(
                SymbolicLlt::try_new(pattern.structure(), Side::Lower).unwrap(),
                SparseColMatRef::new(pattern.structure(), op.matrix().values()),
                Side::Lower,
            )
            .unwrap();
            let n = mesh.num_vertices();
            let mut rng = Lcg::new(8);
            let b: Vec<f64> = (0..n).map(|_| rng.next_signed()).collect();
            let x = ours.solve(&b).unwrap();
            let mut y = faer::Mat::from_fn(n, 1, |i, _| b[i]);
            faer::linalg::solvers::SolveCore::solve_in_place_with_conj(&theirs, faer::Conj::No, y.as_mut());
            let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
            let worst = (0..n).fold(0.0f64, |m, i| m.max((x[i] - y[(i, 0)]).abs()));
            assert!(worst <= 1e-11 * scale, "{n} rows: {worst:e} of {scale:e}");
            assert!(residual(op.matrix(), &x, &b) < 1e-12);
        }
    }

    /// The heat operator of a sphere whose face weights fade inside `caps` (centre, radius): what a
    /// static object's system looks like when contacts move on it.
    fn sphere_with_caps(caps: &[(DVec3, f64)]) -> (Arc<SymbolicFactor>, SymmetricMatrix) {
        let mesh = shapes::icosphere(1.0, 4);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let weights: Vec<f64> = mesh
            .triangles
            .iter()
            .map(|t| {
                let centre: DVec3 = t.iter().map(|&v| mesh.positions[v as usize]).sum::<DVec3>() / 3.0;
                caps.iter().fold(1.0, |w: f64, &(c, r)| w.min(((centre - c).length() / r).clamp(0.05, 1.0)))
            })
            .collect();
        let a = Operator::heat(&mesh, &pattern, Some(&weights), 0.01).unwrap().matrix().clone();
        (SymbolicFactor::analyze(&pattern).unwrap(), a)
    }

    #[test]
    fn local_changes_refactorize_part_of_the_factor_with_a_fresh_factors_bits() {
        let poles = [DVec3::Z, -DVec3::Z, DVec3::X];
        let (symbolic, first) = sphere_with_caps(&[(poles[0], 0.3)]);
        let n = first.dimension();
        let values = |caps: &[(DVec3, f64)]| {
            SymmetricMatrix::from_values(symbolic.pattern(), sphere_with_caps(caps).1.values().to_vec()).unwrap()
        };
        let frames = [
            values(&[(poles[0], 0.3)]),
            values(&[(poles[0], 0.32)]),
            values(&[(poles[0], 0.32), (poles[1], 0.2)]),
            values(&[(poles[2], 0.25)]),
            first.clone(),
            first.clone(),
        ];
        let mut rng = Lcg::new(21);
        let b: Vec<f64> = (0..n).map(|_| rng.next_signed()).collect();
        let bits = |v: Vec<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut kept = NumericFactor::new(&symbolic).unwrap();
        kept.reduce = false;
        let mut recomputed = Vec::new();
        for (k, a) in frames.iter().enumerate() {
            kept.factorize(a).unwrap();
            recomputed.push(kept.whole.as_ref().unwrap().recomputed_columns);
            let mut fresh = NumericFactor::new(&symbolic).unwrap();
            fresh.reduce = false;
            fresh.factorize(a).unwrap();
            assert_eq!(
                bits(kept.whole.as_ref().unwrap().l_values.clone()),
                bits(fresh.whole.as_ref().unwrap().l_values.clone()),
                "frame {k}"
            );
            assert_eq!(bits(kept.solve(&b).unwrap()), bits(fresh.solve(&b).unwrap()), "frame {k}");
        }
        println!("columns recomputed per frame: {recomputed:?} of {n}");
        assert_eq!(recomputed[0], n, "the first factorization is whole");
        assert!(recomputed[1] < n / 2, "a cap that grows changes part of the factor: {}", recomputed[1]);
        assert_eq!(recomputed[5], 0, "the same matrix twice: nothing to recompute");
        // A failed factorization leaves nothing to start from: the next one is whole and right.
        let mut broken = frames[2].clone();
        let slot = symbolic.pattern().diag_slot(7);
        broken.values_mut()[slot] = -1.0;
        assert!(kept.factorize(&broken).is_err());
        kept.factorize(&frames[1]).unwrap();
        assert_eq!(kept.whole.as_ref().unwrap().recomputed_columns, n);
        let mut fresh = NumericFactor::new(&symbolic).unwrap();
        fresh.reduce = false;
        fresh.factorize(&frames[1]).unwrap();
        assert_eq!(bits(kept.solve(&b).unwrap()), bits(fresh.solve(&b).unwrap()));
    }

    #[test]
    fn regions_of_every_size_factorize_supernodally() {
        for mesh in [shapes::grid(1.0, 1.0, 40, 40), shapes::icosphere(1.0, 1)] {
            let topology = Topology::new(&mesh);
            let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
            let symbolic = SymbolicFactor::analyze(&pattern).unwrap();
            assert!(symbolic.num_supernodes() > 0);
            let op = Operator::heat(&mesh, &pattern, None, 1e-3).unwrap();
            let mut rng = Lcg::new(3);
            let b: Vec<f64> = (0..mesh.num_vertices()).map(|_| rng.next_signed()).collect();
            let x = NumericFactor::factorize_new(&symbolic, op.matrix()).unwrap().solve(&b).unwrap();
            assert!(residual(op.matrix(), &x, &b) < 1e-12);
        }
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
