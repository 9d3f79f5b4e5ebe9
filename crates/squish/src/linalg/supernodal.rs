//! Our numeric supernodal Cholesky on the structure of [`super::symbolic`], with partial refactorization
//! (thesis ch. 7 §5.2: "localize and adjust the problems" instead of refactorizing everything,
//! after Herholz et al.).
//!
//! **Why our own kernel.** faer's numeric factorization always recomputes every supernode. Most
//! frames change only part of a system: an object that does not move keeps its cotangent weights
//! bit for bit, and only the faces near the moving contact boundary ∂𝒞 (cut weights, edge
//! constraints, the fade of 𝒫, the border of 𝒟) get new values. A supernode of `L` depends on its
//! own columns of `A` and on the supernodes below it in the elimination tree that update it, so
//! when neither changed its values are exactly those of the previous factorization. Only the
//! changed supernodes and their ancestors are recomputed; the rest of `L` is kept.
//!
//! **Same result as a fresh factorization, bit for bit.** A supernode is computed by the same code
//! from the same inputs whether it is recomputed or kept (the kernels are sequential and their
//! order is fixed), so by induction over the elimination tree (and over frames) the factor does
//! not depend on which factorization came before: frames stay independent, and the output is the
//! same whatever order, split or thread count processes them. A factorization that failed, or a
//! factor built for other values of another analysis, is recomputed whole.
//!
//! **Algorithm.** Left-looking supernodal LLᵀ in faer's supernodal storage (supernode `s` holds columns
//! `begin[s]..end[s]` as one column-major block: the dense diagonal block, then the rows of its
//! pattern). For supernode `s`: scatter `A`'s columns; subtract
//! the update `L_d,rows·L_d,colsᵀ` of every descendant `d` whose pattern meets `s`'s columns
//! (direct loops for thin descendants, faer's matrix product for wide ones); factorize the
//! diagonal block and solve the rows below it (direct loops for narrow supernodes, faer's dense
//! Cholesky and triangular solve for wide ones). Most supernodes of a surface Laplacian have one to
//! four columns, where direct loops avoid the cost of dense-kernel calls. The solves
//! ([`SupernodalPlan::solve_rows_in_place`]) walk the same storage supernode by supernode in a
//! fixed order (several right-hand sides share one pass over `L`): the forward pass accumulates a
//! supernode's contributions to its pattern rows densely and scatters them once, the backward pass
//! gathers the pattern rows once and takes each column's dot product in four interleaved partial
//! sums (independent chains instead of one dependent one; the order is fixed, so the result is
//! too).
//!
//! A contact moving on a static object recomputes the supernodes around it and their ancestors
//! (the top separators, which every change reaches, hold most of the flops). Timings against
//! faer's numeric factorization and against one scatter or gather per entry: `docs/speed.md`.

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::{LltError, LltRegularization, cholesky_in_place, cholesky_in_place_scratch};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::sparse::SparseColMatRef;
use faer::{Accum, MatMut, MatRef, Par};

/// Supernodes at most this wide are factorized with direct loops; wider ones with faer's dense
/// Cholesky and triangular solve (tuned: `docs/speed.md`).
const DIRECT_WIDTH: usize = 8;

/// Descendant updates of at most this many multiply-adds use direct loops; larger ones faer's
/// matrix product (tuned: `docs/speed.md`).
const DIRECT_UPDATE_FLOPS: usize = 64;

/// Right-hand sides solved together in one pass (more are solved in groups of this many).
pub(super) const SOLVE_BLOCK: usize = 4;

/// The structure of a supernodal factor as our kernel walks it, derived once from the analysis.
#[derive(Debug)]
pub(super) struct SupernodalPlan {
    n: usize,
    begin: Vec<usize>,
    end: Vec<usize>,
    pattern_ptr: Vec<usize>,
    pattern_len: Vec<usize>,
    row_idx: Vec<usize>,
    val_ptr: Vec<usize>,
    /// The supernode of each column.
    super_of_col: Vec<u32>,
    /// `descendants[descendant_ptr[s]..descendant_ptr[s + 1]]`: the supernodes whose pattern meets
    /// the columns of `s`, increasing (they update `s`).
    descendant_ptr: Vec<usize>,
    descendants: Vec<u32>,
    /// Largest `rows below the first column of s × columns of s` over all updates.
    max_update: usize,
    dense_scratch: StackReq,
}

/// Scratch memory of [`SupernodalPlan::factorize`], reused across factorizations.
#[derive(Default)]
pub(super) struct Workspace {
    global_to_local: Vec<usize>,
    row_map: Vec<usize>,
    update: Vec<f64>,
    recomputed: Vec<bool>,
    /// The dense kernels' scratch and its size in bytes.
    dense: Option<(MemBuffer, usize)>,
}

impl std::fmt::Debug for Workspace {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Workspace").field("update", &self.update.len()).finish()
    }
}

impl SupernodalPlan {
    /// The plan of `n` columns in the supernodes `begin` (supernode `s` holds columns
    /// `begin[s]..begin[s + 1]`) whose rows below their blocks are
    /// `row_idx[pattern_ptr[s]..pattern_ptr[s + 1]]` (see [`super::symbolic::SupernodalStructure`]).
    pub(super) fn new(n: usize, mut begin: Vec<usize>, mut pattern_ptr: Vec<usize>, row_idx: Vec<usize>) -> Self {
        let n_super = begin.len() - 1;
        let end = begin[1..].to_vec();
        begin.truncate(n_super);
        let pattern_len: Vec<usize> = pattern_ptr.windows(2).map(|w| w[1] - w[0]).collect();
        pattern_ptr.truncate(n_super);
        let mut val_ptr = Vec::with_capacity(n_super + 1);
        val_ptr.push(0);
        for s in 0..n_super {
            let width = end[s] - begin[s];
            val_ptr.push(val_ptr[s] + width * (width + pattern_len[s]));
        }
        let mut super_of_col = vec![0u32; n];
        for s in 0..n_super {
            super_of_col[begin[s]..end[s]].fill(s as u32);
        }
        // Descendant lists in compressed rows: count, then fill in increasing d.
        let super_of_col_ref = &super_of_col;
        let targets = |d: usize| {
            let pattern = &row_idx[pattern_ptr[d]..][..pattern_len[d]];
            let mut last = u32::MAX;
            pattern.iter().filter_map(move |&row| {
                let s = super_of_col_ref[row];
                (s != last).then(|| {
                    last = s;
                    s
                })
            })
        };
        let mut descendant_ptr = vec![0usize; n_super + 1];
        for d in 0..n_super {
            for s in targets(d) {
                descendant_ptr[s as usize + 1] += 1;
            }
        }
        for s in 0..n_super {
            descendant_ptr[s + 1] += descendant_ptr[s];
        }
        let mut next = descendant_ptr.clone();
        let mut descendants = vec![0u32; descendant_ptr[n_super]];
        let mut max_update = 0;
        for d in 0..n_super {
            let pattern = &row_idx[pattern_ptr[d]..][..pattern_len[d]];
            for s in targets(d) {
                let s = s as usize;
                descendants[next[s]] = d as u32;
                next[s] += 1;
                let first = pattern.partition_point(|&r| r < begin[s]);
                let mid = pattern[first..].partition_point(|&r| r < end[s]);
                max_update = max_update.max((pattern.len() - first) * mid);
            }
        }
        let widest = (0..n_super).map(|s| end[s] - begin[s]).max().unwrap_or(0);
        let dense_scratch = cholesky_in_place_scratch::<f64>(widest, Par::Seq, Default::default());
        Self {
            n,
            begin,
            end,
            pattern_ptr,
            pattern_len,
            row_idx,
            val_ptr,
            super_of_col,
            descendant_ptr,
            descendants,
            max_update,
            dense_scratch,
        }
    }

    /// Stored values of `L`: every supernode a dense block of its columns × (its columns + its
    /// pattern rows).
    pub(super) fn factor_len(&self) -> usize {
        self.val_ptr[self.len()]
    }

    /// Number of supernodes.
    pub(super) fn len(&self) -> usize {
        self.begin.len()
    }

    /// The supernode holding column `j`.
    #[inline]
    pub(super) fn supernode_of(&self, j: usize) -> usize {
        self.super_of_col[j] as usize
    }

    fn pattern(&self, s: usize) -> &[usize] {
        &self.row_idx[self.pattern_ptr[s]..][..self.pattern_len[s]]
    }

    /// Factorizes `a` (lower triangle, faer's permuted layout; rows within a column in any order)
    /// into `l` (faer's supernodal storage). With `changed: Some(flags)` (one per supernode: its
    /// columns of `a` differ from the matrix `l` was computed from), only the changed supernodes
    /// and those they update, transitively, are recomputed; `None` recomputes everything.
    /// Returns the columns recomputed and their multiply-adds (`Σ c_j²` over them, `c_j` the
    /// column's count of rows from the diagonal down).
    pub(super) fn factorize(
        &self,
        a: SparseColMatRef<'_, usize, f64>,
        l: &mut [f64],
        changed: Option<&[bool]>,
        work: &mut Workspace,
    ) -> Result<(usize, u64), LltError> {
        let n_super = self.len();
        work.global_to_local.clear();
        work.global_to_local.resize(self.n, usize::MAX);
        work.recomputed.clear();
        work.recomputed.resize(n_super, false);
        if work.update.len() < self.max_update {
            work.update.resize(self.max_update, 0.0);
        }
        if work.dense.as_ref().is_none_or(|(_, bytes)| *bytes < self.dense_scratch.size_bytes()) {
            work.dense = Some((MemBuffer::new(self.dense_scratch), self.dense_scratch.size_bytes()));
        }
        let (mut count, mut flops) = (0, 0u64);
        for s in 0..n_super {
            let descendants = &self.descendants[self.descendant_ptr[s]..self.descendant_ptr[s + 1]];
            let needed = changed.is_none_or(|c| c[s]) || descendants.iter().any(|&d| work.recomputed[d as usize]);
            if !needed {
                continue;
            }
            work.recomputed[s] = true;
            let width = self.end[s] - self.begin[s];
            count += width;
            let rows = (width + self.pattern_len[s]) as u64;
            flops += (0..width as u64).map(|k| (rows - k) * (rows - k)).sum::<u64>();
            self.factorize_supernode(s, descendants, a, l, work)?;
        }
        Ok((count, flops))
    }

    fn factorize_supernode(
        &self,
        s: usize,
        descendants: &[u32],
        a: SparseColMatRef<'_, usize, f64>,
        l: &mut [f64],
        work: &mut Workspace,
    ) -> Result<(), LltError> {
        let (begin, end) = (self.begin[s], self.end[s]);
        let width = end - begin;
        let pattern = self.pattern(s);
        let rows = width + pattern.len();
        for (i, &row) in pattern.iter().enumerate() {
            work.global_to_local[row] = width + i;
        }
        let (head, tail) = l.split_at_mut(self.val_ptr[s]);
        let block = &mut tail[..self.val_ptr[s + 1] - self.val_ptr[s]];
        block.fill(0.0);
        // A's columns (lower triangle).
        for j in begin..end {
            let column = &mut block[(j - begin) * rows..][..rows];
            for (i, &value) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
                if i < j {
                    continue;
                }
                let local = if i < end { i - begin } else { work.global_to_local[i] };
                column[local] += value;
            }
        }
        // Updates from the descendants: L_s −= L_d[rows from s on] · L_d[rows in s]ᵀ.
        let head: &[f64] = head;
        for &d in descendants {
            let d = d as usize;
            let d_pattern = self.pattern(d);
            let d_width = self.end[d] - self.begin[d];
            let d_rows = d_width + d_pattern.len();
            let ld = &head[self.val_ptr[d]..self.val_ptr[d + 1]];
            let first = d_pattern.partition_point(|&r| r < begin);
            let mid = d_pattern[first..].partition_point(|&r| r < end);
            let below = d_pattern.len() - first;
            // Target row of each of d's rows from `first` on.
            work.row_map.clear();
            work.row_map
                .extend(d_pattern[first..].iter().map(|&r| if r < end { r - begin } else { work.global_to_local[r] }));
            let update = &mut work.update[..below * mid];
            if d_width * below * mid <= DIRECT_UPDATE_FLOPS {
                // Column c of the update holds rows c.. (the lower triangle of the square part).
                for c in 0..mid {
                    let out = &mut update[c * below..][c..below];
                    out.fill(0.0);
                    for k in 0..d_width {
                        let lk = &ld[k * d_rows + d_width + first..][..below];
                        let coefficient = lk[c];
                        for (o, &x) in out.iter_mut().zip(&lk[c..]) {
                            *o += x * coefficient;
                        }
                    }
                }
            } else {
                let lhs = MatRef::from_column_major_slice_with_stride(&ld[d_width + first..], below, d_width, d_rows);
                let rhs = lhs.subrows(0, mid).transpose();
                let dst = MatMut::from_column_major_slice_mut(update, below, mid);
                matmul(dst, Accum::Replace, lhs, rhs, 1.0, Par::Seq);
            }
            for c in 0..mid {
                let column = &mut block[work.row_map[c] * rows..][..rows];
                for (&target, &value) in work.row_map[c..].iter().zip(&update[c * below + c..(c + 1) * below]) {
                    column[target] -= value;
                }
            }
        }
        for &row in pattern {
            work.global_to_local[row] = usize::MAX;
        }
        // The diagonal block and the rows below it.
        if width <= DIRECT_WIDTH {
            for j in 0..width {
                let (done, rest) = block.split_at_mut(j * rows);
                let column = &mut rest[..rows];
                for k in 0..j {
                    let lk = &done[k * rows..][..rows];
                    let coefficient = lk[j];
                    for (x, &y) in column[j..].iter_mut().zip(&lk[j..]) {
                        *x -= y * coefficient;
                    }
                }
                let pivot = column[j];
                // A NaN pivot fails too.
                if pivot.is_nan() || pivot <= 0.0 {
                    return Err(LltError::NonPositivePivot { index: begin + j });
                }
                let diagonal = pivot.sqrt();
                column[j] = diagonal;
                let inverse = 1.0 / diagonal;
                for x in &mut column[j + 1..] {
                    *x *= inverse;
                }
            }
        } else {
            let whole = MatMut::from_column_major_slice_with_stride_mut(block, rows, width, rows);
            let (mut top, bottom) = whole.split_at_row_mut(width);
            let (buffer, _) = work.dense.get_or_insert_with(|| (MemBuffer::new(self.dense_scratch), 0));
            let stack = MemStack::new(buffer);
            cholesky_in_place(top.rb_mut(), LltRegularization::default(), Par::Seq, stack, Default::default())
                .map_err(|error| match error {
                    LltError::NonPositivePivot { index } => LltError::NonPositivePivot { index: begin + index },
                })?;
            solve_lower_triangular_in_place(top.rb().conjugate(), bottom.transpose_mut(), Par::Seq);
        }
        Ok(())
    }

    /// `x ← L⁻ᵀL⁻¹x` on the factor `l` (permuted order) for `k` right-hand sides stored row by row
    /// (`x[i·k + c]`): one pass over `L` for all of them. Each column goes through exactly the
    /// operations, in the same order, of a solve on its own, so its solution does not depend on
    /// how many columns are solved together (faer's blocked solve rounds differently with one
    /// column and with two). Memory bound: `L` is read once per pass whatever `k`.
    pub(super) fn solve_rows_in_place(&self, l: &[f64], x: &mut [f64], k: usize) {
        match k {
            1 => self.solve_rows::<1>(l, x),
            2 => self.solve_rows::<2>(l, x),
            3 => self.solve_rows::<3>(l, x),
            _ => self.solve_rows::<4>(l, x),
        }
    }

    fn solve_rows<const K: usize>(&self, l: &[f64], x: &mut [f64]) {
        // The pattern rows' contributions of one supernode, accumulated densely before they are
        // scattered (one indirect write per row instead of one per row and column).
        let mut below: Vec<[f64; K]> = Vec::new();
        for s in 0..self.len() {
            let (begin, width) = (self.begin[s], self.end[s] - self.begin[s]);
            let pattern = self.pattern(s);
            let rows = width + pattern.len();
            let block = &l[self.val_ptr[s]..self.val_ptr[s + 1]];
            // A zero right-hand side has nothing to propagate (skipping can only turn a −0 of the
            // result into +0): one that is zero but near ∂𝒞 (the heat step, the guide) only
            // reaches the elimination-tree ancestors of its non-zeros.
            if x[begin * K..(begin + width) * K].iter().all(|&v| v == 0.0) {
                continue;
            }
            if width == 1 {
                // Half the supernodes of a surface Laplacian: scatter directly (no buffer).
                let at = begin * K;
                let active: [bool; K] = std::array::from_fn(|c| x[at + c] != 0.0);
                let xj: [f64; K] = std::array::from_fn(|c| if active[c] { x[at + c] / block[0] } else { x[at + c] });
                x[at..at + K].copy_from_slice(&xj);
                for (&row, &value) in pattern.iter().zip(&block[1..]) {
                    for c in 0..K {
                        if active[c] {
                            x[row * K + c] -= value * xj[c];
                        }
                    }
                }
                continue;
            }
            below.clear();
            below.resize(pattern.len(), [0.0; K]);
            for j in 0..width {
                let column = &block[j * rows..(j + 1) * rows];
                let at = (begin + j) * K;
                let active: [bool; K] = std::array::from_fn(|c| x[at + c] != 0.0);
                if !active.contains(&true) {
                    continue;
                }
                let xj: [f64; K] = std::array::from_fn(|c| if active[c] { x[at + c] / column[j] } else { x[at + c] });
                x[at..at + K].copy_from_slice(&xj);
                for (i, &value) in column.iter().enumerate().take(width).skip(j + 1) {
                    for c in 0..K {
                        if active[c] {
                            x[(begin + i) * K + c] -= value * xj[c];
                        }
                    }
                }
                if active.iter().all(|&a| a) {
                    for (sum, &value) in below.iter_mut().zip(&column[width..]) {
                        for c in 0..K {
                            sum[c] += value * xj[c];
                        }
                    }
                } else {
                    for (sum, &value) in below.iter_mut().zip(&column[width..]) {
                        for c in 0..K {
                            if active[c] {
                                sum[c] += value * xj[c];
                            }
                        }
                    }
                }
            }
            for (&row, sum) in pattern.iter().zip(&below) {
                for c in 0..K {
                    x[row * K + c] -= sum[c];
                }
            }
        }
        let mut gathered: Vec<[f64; K]> = Vec::new();
        for s in (0..self.len()).rev() {
            let (begin, width) = (self.begin[s], self.end[s] - self.begin[s]);
            let pattern = self.pattern(s);
            let rows = width + pattern.len();
            let block = &l[self.val_ptr[s]..self.val_ptr[s + 1]];
            if width == 1 {
                let at = begin * K;
                let below = dot_indexed::<K>(&block[1..], pattern, x);
                for c in 0..K {
                    x[at + c] = (x[at + c] - below[c]) / block[0];
                }
                continue;
            }
            // The pattern rows' values, gathered once for all the supernode's columns.
            gathered.clear();
            gathered.extend(pattern.iter().map(|&row| std::array::from_fn::<f64, K, _>(|c| x[row * K + c])));
            for j in (0..width).rev() {
                let column = &block[j * rows..(j + 1) * rows];
                let at = (begin + j) * K;
                let below = dot_rows::<K>(&column[width..], &gathered);
                let mut sum: [f64; K] = std::array::from_fn(|c| x[at + c] - below[c]);
                for (i, &value) in column.iter().enumerate().take(width).skip(j + 1) {
                    for c in 0..K {
                        sum[c] -= value * x[(begin + i) * K + c];
                    }
                }
                for c in 0..K {
                    x[at + c] = sum[c] / column[j];
                }
            }
        }
    }
}

/// `Σ_i values[i]·x[rows[i]·K + c]` for each column c (the rows read in place); see
/// [`partial_sums`].
#[inline]
fn dot_indexed<const K: usize>(values: &[f64], rows: &[usize], x: &[f64]) -> [f64; K] {
    partial_sums(values, |i| std::array::from_fn(|c| x[rows[i] * K + c]))
}

/// `Σ_i values[i]·rows[i][c]` for each column c (the rows gathered beforehand); see
/// [`partial_sums`].
#[inline]
fn dot_rows<const K: usize>(values: &[f64], rows: &[[f64; K]]) -> [f64; K] {
    partial_sums(values, |i| rows[i])
}

/// `Σ_i values[i]·row(i)[c]` for each column c in four interleaved partial sums (term i goes to
/// sum i mod 4) combined in a fixed order: the same rounding for a column whatever `K` (and
/// whatever the thread count), and four independent chains instead of one long dependent one.
#[inline(always)]
fn partial_sums<const K: usize>(values: &[f64], row: impl Fn(usize) -> [f64; K]) -> [f64; K] {
    let mut partial = [[0.0f64; K]; 4];
    let chunks = values.chunks_exact(4);
    let (remainder, full) = (chunks.remainder(), values.len() - values.len() % 4);
    for (k, chunk) in chunks.enumerate() {
        for (lane, &value) in chunk.iter().enumerate() {
            let r = row(4 * k + lane);
            for c in 0..K {
                partial[lane][c] += value * r[c];
            }
        }
    }
    for (lane, &value) in remainder.iter().enumerate() {
        let r = row(full + lane);
        for c in 0..K {
            partial[lane][c] += value * r[c];
        }
    }
    std::array::from_fn(|c| (partial[0][c] + partial[1][c]) + (partial[2][c] + partial[3][c]))
}
