//! Supernodal symbolic Cholesky analysis of a symmetric pattern in a given fill-reducing order
//! (thesis ch. 7 §5.2: the factorizations dominate a frame, and their analyses come with them).
//!
//! From the lower triangle of `A` and an ordering it computes, in O(nnz(A) · α) plus the size of
//! the supernodal row patterns:
//! 1. the **elimination tree** of `PAPᵀ` (Liu's algorithm: ancestors with path compression);
//! 2. its **postorder** (children in increasing order), composed with the ordering, so that every
//!    subtree is a contiguous range of columns (the same fill: a postorder is an equivalent order);
//! 3. the **column counts** of `L` by Gilbert, Ng and Peyton's method: a row subtree of `L` is
//!    known from its leaves, and the leaves from the first descendants in postorder, so the counts
//!    come without visiting the entries of `L` (a walk over them costs as much as a numeric
//!    factorization of a small system);
//! 4. the **fundamental supernodes** (a column joins the previous one when it is its only child in
//!    the tree and its count is one less), then **relaxed amalgamation**: a supernode absorbs the
//!    child just before it in the postorder when the merged block stays small or mostly nonzero.
//!    The rule and its thresholds are CHOLMOD's as faer uses them by default
//!    ([`RELAX`]: up to 4 columns always, up to 16 with ≤ 80 % zeros, up to 48 with ≤ 10 %,
//!    beyond with ≤ 5 %); our numeric kernel was tuned on those supernodes;
//! 5. the **row pattern** of every supernode below its diagonal block (those of its last column,
//!    as many as its count says), filled row by row by climbing the supernodal tree from each
//!    entry of `A`, so that it comes out sorted.
//!
//! **Why our own.** A contact that moves changes the coupled rows of a system every frame, and
//! the submatrix on them ([`super::NumericFactor`]) needs a new analysis each time, which with
//! faer's analysis cost half as much as the numeric factorizations it served. faer counts the columns by walking every entry of `L`, builds its structure in several
//! passes, and keeps a custom order as given; this one counts in near-linear time, writes the
//! structure our kernel ([`super::supernodal`]) reads and `A`'s permuted layout directly, and
//! postorders the restricted order, whose chains then form wider supernodes (a faster numeric
//! factorization on the same fill). Measurements in `docs/speed.md`.
//! The AMD ordering itself stays faer's ([`amd_order`]); the alternative, nested dissection, is
//! [`super::dissection`].

use faer::dyn_stack::{MemBuffer, MemStack};
use faer::sparse::SymbolicSparseColMatRef;
use faer::sparse::linalg::amd;

use super::SolveError;

/// Relaxed amalgamation thresholds `(columns, zero fraction)`: two supernodes of `n` columns in
/// total with a fraction `z` of explicit zeros once merged are merged if `n ≤ columns` and
/// `z ≤ zero fraction` for one of the pairs (CHOLMOD's rule, faer's default values).
pub(super) const RELAX: [(usize, f64); 4] = [(4, 1.0), (16, 0.8), (48, 0.1), (usize::MAX, 0.05)];

const NONE: usize = usize::MAX;

/// The structure of a supernodal factor `L` of `PAPᵀ` and the layout of `PAPᵀ` itself.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct SupernodalStructure {
    /// `forward[new] = old` row; `inverse[old] = new`.
    pub forward: Vec<usize>,
    pub inverse: Vec<usize>,
    /// Supernode `s` holds columns `begin[s]..begin[s + 1]`.
    pub begin: Vec<usize>,
    /// The rows of supernode `s` below its diagonal block:
    /// `row_idx[pattern_ptr[s]..pattern_ptr[s + 1]]`, increasing.
    pub pattern_ptr: Vec<usize>,
    pub row_idx: Vec<usize>,
    /// `PAPᵀ`'s lower triangle by column (rows unsorted): entry `k` is row `a_row_idx[k]` of its
    /// column and holds the value slot `a_slot[k]` of the analyzed matrix.
    pub a_col_ptr: Vec<usize>,
    pub a_row_idx: Vec<usize>,
    pub a_slot: Vec<usize>,
}

/// The AMD fill-reducing order of the lower-triangular `structure` (faer's AMD, default
/// control): `order[new] = old`.
pub(super) fn amd_order(structure: SymbolicSparseColMatRef<'_, usize>) -> Result<Vec<usize>, SolveError> {
    let n = structure.nrows();
    let analysis_error = |e: &dyn std::fmt::Debug| SolveError::Analysis { reason: format!("{e:?}") };
    let (mut forward, mut inverse) = (vec![0usize; n], vec![0usize; n]);
    let scratch = amd::order_maybe_unsorted_scratch::<usize>(n, structure.compute_nnz());
    let mut buffer = MemBuffer::try_new(scratch).map_err(|e| analysis_error(&e))?;
    amd::order_maybe_unsorted(&mut forward, &mut inverse, structure, Default::default(), MemStack::new(&mut buffer))
        .map_err(|e| analysis_error(&e))?;
    Ok(forward)
}

#[cfg(test)]
impl SupernodalStructure {
    pub fn dimension(&self) -> usize {
        self.forward.len()
    }

    pub fn num_supernodes(&self) -> usize {
        self.begin.len() - 1
    }

    /// Stored values of `L`: each supernode is a dense block of its columns × (its columns + its
    /// pattern rows).
    pub fn factor_len(&self) -> usize {
        (0..self.num_supernodes())
            .map(|s| {
                let width = self.begin[s + 1] - self.begin[s];
                width * (width + self.pattern_ptr[s + 1] - self.pattern_ptr[s])
            })
            .sum()
    }
}

/// Analyzes the symmetric matrix whose lower triangle has the pattern `col_ptr`, `row_idx` (`n`
/// columns, rows ≥ their column, each row at most once per column), whose entry `k` holds value
/// slot `slot[k]` (`None`: slot `k`), in the fill-reducing order `order` (`order[new] = old`).
pub(super) fn analyze(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    slot: Option<&[usize]>,
    order: &[usize],
) -> Result<SupernodalStructure, SolveError> {
    Ok(Elimination::checked(n, col_ptr, row_idx, slot, order)?.into_structure())
}

/// The multiply-adds of a factorization of the symmetric matrix whose lower triangle is `col_ptr`,
/// `row_idx` in the order `order` (`order[new] = old`, a permutation): `Σ_j c_j²` over the column
/// counts of `L` (the elimination's own cost, before supernodes pad it), found in O(nnz(A) · α).
#[cfg(test)]
pub(super) fn factorization_flops(n: usize, col_ptr: &[usize], row_idx: &[usize], order: &[usize]) -> f64 {
    let mut order_inverse = vec![0; n];
    for (new, &old) in order.iter().enumerate() {
        order_inverse[old] = new;
    }
    eliminate(n, col_ptr, row_idx, None, order, &order_inverse).flops()
}

impl Elimination {
    /// Steps 1–3 of [`analyze`] after checking its arguments: an analysis that chooses between
    /// orders by their [`Self::flops`] finishes the chosen one with [`Self::into_structure`]
    /// instead of eliminating it again.
    pub(super) fn checked(
        n: usize,
        col_ptr: &[usize],
        row_idx: &[usize],
        slot: Option<&[usize]>,
        order: &[usize],
    ) -> Result<Self, SolveError> {
        let invalid = |reason: String| Err(SolveError::Analysis { reason });
        if col_ptr.len() != n + 1 || order.len() != n || col_ptr.windows(2).any(|w| w[0] > w[1]) {
            return invalid(format!("a pattern of {n} columns needs {} column pointers, increasing", n + 1));
        }
        let nnz = col_ptr[n];
        if row_idx.len() < nnz || slot.is_some_and(|s| s.len() < nnz) {
            return invalid(format!("the pattern has {nnz} entries but fewer row indices or slots"));
        }
        for j in 0..n {
            if let Some(&i) = row_idx[col_ptr[j]..col_ptr[j + 1]].iter().find(|&&i| i < j || i >= n) {
                return invalid(format!("entry ({i}, {j}) is not in the lower triangle of a {n} × {n} matrix"));
            }
        }
        let mut order_inverse = vec![NONE; n];
        for (new, &old) in order.iter().enumerate() {
            if old >= n || order_inverse[old] != NONE {
                return invalid(format!("the ordering is not a permutation of 0..{n} (row {old})"));
            }
            order_inverse[old] = new;
        }
        Ok(eliminate(n, col_ptr, row_idx, slot, order, &order_inverse))
    }

    /// The multiply-adds of a factorization in this order: `Σ_j c_j²` over the column counts of
    /// `L` (the elimination's own cost, before supernodes pad it).
    pub(super) fn flops(&self) -> f64 {
        self.counts.iter().map(|&c| (c * c) as f64).sum()
    }

    /// Steps 4–5: the supernodes and their row patterns.
    pub(super) fn into_structure(self) -> SupernodalStructure {
        let Self { upper, post, post_inverse, forward, inverse, parent, a_col_ptr, a_row_idx, a_slot, counts } = self;
        let begin = relaxed_supernodes(&parent, &counts);
        // Row i of A below the diagonal, in the final order: the given order's upper column of the
        // node that became i (a row of A lies on its columns' ancestors, which the postorder keeps
        // after them, so every j < i).
        let row_entries = |i: usize| upper.column(post[i]).iter().map(|&k| post_inverse[k]);
        let (pattern_ptr, pattern) = supernode_patterns(&parent, &counts, &begin, row_entries);
        SupernodalStructure { forward, inverse, begin, pattern_ptr, row_idx: pattern, a_col_ptr, a_row_idx, a_slot }
    }
}

/// Steps 1–3 of the analysis (module doc) of a checked pattern and order.
pub(super) struct Elimination {
    /// The strict upper triangle of `A` in the given order.
    upper: Pattern,
    /// `post[new] = k`: the postorder of the elimination tree, and its inverse.
    post: Vec<usize>,
    post_inverse: Vec<usize>,
    /// The final order (the postorder composed with the given one) and its inverse.
    forward: Vec<usize>,
    inverse: Vec<usize>,
    /// The elimination tree in the final order.
    parent: Vec<usize>,
    /// `PAPᵀ`'s lower triangle in the final order, with the value slots.
    a_col_ptr: Vec<usize>,
    a_row_idx: Vec<usize>,
    a_slot: Vec<usize>,
    /// The column counts of `L`.
    counts: Vec<usize>,
}

/// 1–2. The elimination tree in the given order (`order_inverse[old] = new`), then its postorder
/// composed with the order; 3. the column counts.
fn eliminate(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    slot: Option<&[usize]>,
    order: &[usize],
    order_inverse: &[usize],
) -> Elimination {
    let upper = Pattern::upper(n, col_ptr, row_idx, order_inverse);
    let tree = elimination_tree(&upper);
    let post = postorder(&tree);
    let forward: Vec<usize> = post.iter().map(|&k| order[k]).collect();
    let mut inverse = vec![0; n];
    for (new, &old) in forward.iter().enumerate() {
        inverse[old] = new;
    }
    let mut post_inverse = vec![0; n];
    for (new, &k) in post.iter().enumerate() {
        post_inverse[k] = new;
    }
    let parent: Vec<usize> = post.iter().map(|&k| if tree[k] == NONE { NONE } else { post_inverse[tree[k]] }).collect();
    let (a_col_ptr, a_row_idx, a_slot) = lower_in_order(n, col_ptr, row_idx, slot, &inverse);
    let counts = column_counts(&parent, &a_col_ptr, &a_row_idx);
    Elimination { upper, post, post_inverse, forward, inverse, parent, a_col_ptr, a_row_idx, a_slot, counts }
}

/// A pattern by columns.
struct Pattern {
    ptr: Vec<usize>,
    idx: Vec<usize>,
}

impl Pattern {
    /// The strict upper triangle of `PAPᵀ` by column (column `max(p, q)` holds row `min(p, q)`),
    /// from `A`'s lower triangle and `inverse[old] = new`.
    fn upper(n: usize, col_ptr: &[usize], row_idx: &[usize], inverse: &[usize]) -> Self {
        let place = |p: usize, q: usize| (p != q).then(|| (p.max(q), p.min(q)));
        let (ptr, idx) = permuted_by_column(n, col_ptr, row_idx, inverse, place, |_, _| {});
        Self { ptr, idx }
    }

    fn column(&self, k: usize) -> &[usize] {
        &self.idx[self.ptr[k]..self.ptr[k + 1]]
    }
}

/// The lower triangle of `PAPᵀ` by column (column `min(p, q)` holds row `max(p, q)`) and the value
/// slot of each entry.
fn lower_in_order(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    slot: Option<&[usize]>,
    inverse: &[usize],
) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
    let mut slots = vec![0; col_ptr[n]];
    let place = |p: usize, q: usize| Some((p.min(q), p.max(q)));
    let (ptr, rows) = permuted_by_column(n, col_ptr, row_idx, inverse, place, |at, k| {
        slots[at] = slot.map_or(k, |s| s[k]);
    });
    (ptr, rows, slots)
}

/// The entries of `A`'s lower triangle renumbered by `inverse[old] = new` and bucketed by column
/// (a counting sort): `place(p, q)` gives the (column, row) of the entry at new indices (row p,
/// column q), `None` to leave it out; `placed(position, k)` is told where entry `k` went.
fn permuted_by_column(
    n: usize,
    col_ptr: &[usize],
    row_idx: &[usize],
    inverse: &[usize],
    place: impl Fn(usize, usize) -> Option<(usize, usize)>,
    mut placed: impl FnMut(usize, usize),
) -> (Vec<usize>, Vec<usize>) {
    // Plain loops over the columns (a flat-mapped iterator of entries compiles to slower code).
    let mut ptr = vec![0usize; n + 1];
    for j in 0..n {
        let q = inverse[j];
        for &i in &row_idx[col_ptr[j]..col_ptr[j + 1]] {
            if let Some((column, _)) = place(inverse[i], q) {
                ptr[column + 1] += 1;
            }
        }
    }
    for k in 0..n {
        ptr[k + 1] += ptr[k];
    }
    let mut next = ptr.clone();
    let mut rows = vec![0; ptr[n]];
    for j in 0..n {
        let q = inverse[j];
        for k in col_ptr[j]..col_ptr[j + 1] {
            if let Some((column, row)) = place(inverse[row_idx[k]], q) {
                let at = next[column];
                rows[at] = row;
                placed(at, k);
                next[column] = at + 1;
            }
        }
    }
    (ptr, rows)
}

/// The elimination tree (`NONE` for roots) from the strict upper triangle by column (Liu).
fn elimination_tree(upper: &Pattern) -> Vec<usize> {
    let n = upper.ptr.len() - 1;
    let mut parent = vec![NONE; n];
    let mut ancestor = vec![NONE; n];
    for k in 0..n {
        for &i in upper.column(k) {
            // Climb from i to the root of its current subtree, pointing the path at k.
            let mut r = i;
            while ancestor[r] != NONE && ancestor[r] != k {
                let next = ancestor[r];
                ancestor[r] = k;
                r = next;
            }
            if ancestor[r] == NONE {
                ancestor[r] = k;
                parent[r] = k;
            }
        }
    }
    parent
}

/// A postorder of the forest `parent`: `post[new] = node`, children in increasing order, roots
/// in increasing order.
fn postorder(parent: &[usize]) -> Vec<usize> {
    let n = parent.len();
    let (mut head, mut next) = (vec![NONE; n], vec![NONE; n]);
    for j in (0..n).rev() {
        if parent[j] != NONE {
            next[j] = head[parent[j]];
            head[parent[j]] = j;
        }
    }
    let mut post = Vec::with_capacity(n);
    let mut stack = Vec::new();
    for root in (0..n).filter(|&j| parent[j] == NONE) {
        stack.push(root);
        while let Some(&p) = stack.last() {
            let child = head[p];
            if child == NONE {
                stack.pop();
                post.push(p);
            } else {
                head[p] = next[child];
                stack.push(child);
            }
        }
    }
    post
}

/// Entries of each column of `L` (diagonal included), for a postordered tree `parent` and the
/// lower triangle of the matrix by column (Gilbert, Ng and Peyton).
///
/// Row `i` of `L` is the subtree of the tree spanned by the columns `j < i` with `A(i, j) ≠ 0`
/// (its row subtree), so each such `j` adds 1 to the counts of the path from `j` up to `i`. Only
/// the leaves of row subtrees matter: `j` is one when no earlier column of row `i` lies in `j`'s
/// subtree, i.e. when `first[j]` (its first descendant in postorder) is beyond the largest
/// `first` seen in row `i`. A leaf adds 1 at `j`, and every leaf after the first one of its row
/// removes 1 at the lowest common ancestor with the previous leaf, where the two paths meet
/// (found with a path-compressed union–find over the columns done so far). Each column's count
/// is then the sum of these differences over its subtree.
fn column_counts(parent: &[usize], a_col_ptr: &[usize], a_row_idx: &[usize]) -> Vec<usize> {
    let n = parent.len();
    let mut delta = vec![0i64; n];
    let mut first = vec![NONE; n];
    for k in 0..n {
        if first[k] == NONE {
            delta[k] = 1; // a leaf of the tree: its own row subtree's leaf, the diagonal
        }
        let mut j = k;
        while j != NONE && first[j] == NONE {
            first[j] = k;
            j = parent[j];
        }
    }
    let mut ancestor: Vec<usize> = (0..n).collect();
    let (mut max_first, mut previous_leaf) = (vec![NONE; n], vec![NONE; n]);
    for j in 0..n {
        if parent[j] != NONE {
            delta[parent[j]] -= 1;
        }
        for &i in &a_row_idx[a_col_ptr[j]..a_col_ptr[j + 1]] {
            if i <= j || (max_first[i] != NONE && first[j] <= max_first[i]) {
                continue;
            }
            max_first[i] = first[j];
            let previous = previous_leaf[i];
            previous_leaf[i] = j;
            delta[j] += 1;
            if previous != NONE {
                let mut q = previous;
                while q != ancestor[q] {
                    q = ancestor[q];
                }
                let mut s = previous;
                while s != q {
                    let up = ancestor[s];
                    ancestor[s] = q;
                    s = up;
                }
                delta[q] -= 1;
            }
        }
        if parent[j] != NONE {
            ancestor[j] = parent[j];
        }
    }
    for j in 0..n {
        if parent[j] != NONE {
            delta[parent[j]] += delta[j];
        }
    }
    delta
        .into_iter()
        .map(|d| {
            debug_assert!(d >= 1, "a column of L holds at least its diagonal");
            d as usize
        })
        .collect()
}

/// The first column of every relaxed supernode, and `n` at the end (see the module doc).
fn relaxed_supernodes(parent: &[usize], counts: &[usize]) -> Vec<usize> {
    let n = parent.len();
    let mut children = vec![0usize; n];
    for &p in parent {
        if p != NONE {
            children[p] += 1;
        }
    }
    // Fundamental supernodes: j + 1 continues j's when j is its only child and one row shorter.
    let mut fundamental = Vec::new();
    for j in 0..n {
        let continues = j > 0 && parent[j - 1] == j && children[j] == 1 && counts[j - 1] == counts[j] + 1;
        if !continues {
            fundamental.push(j);
        }
    }
    fundamental.push(n);
    let supernodes = fundamental.len() - 1;
    let last = |s: usize| fundamental[s + 1] - 1;
    // Merge each supernode's group into the next supernode when it is that one's child (the child
    // just before its parent in postorder), under the thresholds.
    let mut group_start = fundamental[..supernodes].to_vec();
    let mut group_zeros = vec![0usize; supernodes];
    let mut merged_into_next = vec![false; supernodes];
    for s in 0..supernodes.saturating_sub(1) {
        let p = s + 1;
        // Only a fundamental supernode's first column has children outside it, so s is p's child
        // exactly when its last column's parent is p's first.
        if parent[last(s)] != fundamental[p] {
            continue;
        }
        let child_size = fundamental[p] - group_start[s];
        let parent_size = fundamental[p + 1] - fundamental[p];
        let (child_degree, parent_degree) = (counts[last(s)] - 1, counts[last(p)] - 1);
        // Every child column gains the parent's rows it lacks.
        let new_zeros = (parent_size + parent_degree).saturating_sub(child_degree) * child_size;
        let zeros = new_zeros + group_zeros[s] + group_zeros[p];
        let merge = new_zeros == 0 || {
            let columns = child_size + parent_size;
            let entries = columns * (columns + 1) / 2 + parent_degree * columns;
            RELAX.iter().any(|&(most, fraction)| columns <= most && zeros as f64 <= entries as f64 * fraction)
        };
        if merge {
            group_start[p] = group_start[s];
            group_zeros[p] = zeros;
            merged_into_next[s] = true;
        }
    }
    let mut begin: Vec<usize> = (0..supernodes).filter(|&s| !merged_into_next[s]).map(|s| group_start[s]).collect();
    begin.push(n);
    begin
}

/// The row pattern of every supernode below its diagonal block, increasing: `(pattern_ptr, rows)`.
///
/// Every column of a supernode descends from its last one, so the supernode's rows below its
/// block are those of its last column, `counts[last] − 1` of them: the storage is laid out from
/// the counts. Row `i` of `L` lies in the pattern of exactly the supernodes its row subtree passes
/// through below `i`, so each entry `A(i, j)`, `j < i`, climbs the supernodal tree from `j`'s
/// supernode, appending `i` to each supernode not yet visited for `i`, and stops at the one holding
/// `i`. Rows are visited in increasing order, so the patterns come out sorted, without merging
/// children's patterns or sorting. `row_entries(i)` lists the columns `j < i` of row `i` of `A`.
fn supernode_patterns<R: Iterator<Item = usize>>(
    parent: &[usize],
    counts: &[usize],
    begin: &[usize],
    row_entries: impl Fn(usize) -> R,
) -> (Vec<usize>, Vec<usize>) {
    let n = parent.len();
    let supernodes = begin.len() - 1;
    let mut super_of = vec![0usize; n];
    for s in 0..supernodes {
        super_of[begin[s]..begin[s + 1]].fill(s);
    }
    let super_parent: Vec<usize> = (0..supernodes)
        .map(|s| {
            let up = parent[begin[s + 1] - 1];
            if up == NONE { NONE } else { super_of[up] }
        })
        .collect();
    let mut pattern_ptr = Vec::with_capacity(supernodes + 1);
    pattern_ptr.push(0);
    for s in 0..supernodes {
        let below = counts[begin[s + 1] - 1] - 1;
        pattern_ptr.push(pattern_ptr[s] + below);
    }
    let mut next = pattern_ptr[..supernodes].to_vec();
    let mut rows = vec![0usize; pattern_ptr[supernodes]];
    let mut mark = vec![NONE; supernodes];
    for i in 0..n {
        let home = super_of[i];
        mark[home] = i;
        for j in row_entries(i) {
            let mut s = super_of[j];
            while mark[s] != i {
                mark[s] = i;
                rows[next[s]] = i;
                next[s] += 1;
                s = super_parent[s];
            }
        }
    }
    debug_assert!((0..supernodes).all(|s| next[s] == pattern_ptr[s + 1]), "pattern lengths match the counts");
    (pattern_ptr, rows)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::linalg::SparsePattern;
    use crate::linalg::test_support::Lcg;
    use crate::mesh::{Topology, shapes};

    /// The lower triangle of a mesh's pattern and a random ordering.
    fn mesh_pattern(mesh: &crate::TriMesh, seed: u64) -> (usize, Vec<usize>, Vec<usize>, Vec<usize>) {
        let topology = Topology::new(mesh);
        let pattern = SparsePattern::new(mesh, &topology).unwrap();
        let n = mesh.num_vertices();
        let mut order: Vec<usize> = (0..n).collect();
        let mut rng = Lcg::new(seed);
        for k in (1..n).rev() {
            order.swap(k, rng.next_index(k + 1));
        }
        (n, pattern.col_ptr().to_vec(), pattern.row_idx().to_vec(), order)
    }

    /// The structure of `L` by brute-force symbolic elimination: column j's rows below the
    /// diagonal are A's and those of every earlier column whose first row below its diagonal is j.
    fn brute_force_columns(s: &SupernodalStructure) -> Vec<Vec<usize>> {
        let n = s.dimension();
        let mut columns: Vec<std::collections::BTreeSet<usize>> = vec![Default::default(); n];
        for (j, column) in columns.iter_mut().enumerate() {
            column.extend(s.a_row_idx[s.a_col_ptr[j]..s.a_col_ptr[j + 1]].iter().copied().filter(|&i| i > j));
        }
        for j in 0..n {
            if let Some(&p) = columns[j].iter().next() {
                let below: Vec<usize> = columns[j].iter().copied().filter(|&i| i > p).collect();
                columns[p].extend(below);
            }
        }
        columns.into_iter().map(|c| c.into_iter().collect()).collect()
    }

    #[test]
    fn counts_and_patterns_hold_the_fill_of_l() {
        let meshes = [shapes::icosphere(1.0, 2), shapes::grid(1.0, 1.0, 17, 12), shapes::capsule(0.3, 1.0, 12, 4, 6)];
        for (m, mesh) in meshes.iter().enumerate() {
            for seed in 0..3 {
                let (n, col_ptr, row_idx, order) = mesh_pattern(mesh, seed);
                let s = analyze(n, &col_ptr, &row_idx, None, &order).unwrap();
                let truth = brute_force_columns(&s);
                // Column counts (Gilbert–Ng–Peyton) against the brute-force fill.
                let upper = Pattern::upper(n, &s.a_col_ptr, &s.a_row_idx, &(0..n).collect::<Vec<_>>());
                let parent = elimination_tree(&upper);
                assert_eq!(postorder(&parent), (0..n).collect::<Vec<_>>(), "mesh {m}: the final order is postordered");
                let counts = column_counts(&parent, &s.a_col_ptr, &s.a_row_idx);
                for j in 0..n {
                    assert_eq!(counts[j], truth[j].len() + 1, "mesh {m} seed {seed}: count of column {j}");
                    assert_eq!(parent[j], truth[j].first().copied().unwrap_or(NONE), "mesh {m}: parent of {j}");
                }
                // Each supernode's block holds its columns' fill: the rows of column j below the
                // block are in the pattern, and the block has no row above its columns.
                for sn in 0..s.num_supernodes() {
                    let (first, end) = (s.begin[sn], s.begin[sn + 1]);
                    let pattern = &s.row_idx[s.pattern_ptr[sn]..s.pattern_ptr[sn + 1]];
                    assert!(pattern.windows(2).all(|w| w[0] < w[1]) && pattern.iter().all(|&i| i >= end));
                    let mut union = std::collections::BTreeSet::new();
                    for column in &truth[first..end] {
                        union.extend(column.iter().copied().filter(|&i| i >= end));
                    }
                    assert_eq!(pattern, union.into_iter().collect::<Vec<_>>(), "mesh {m}: supernode {sn}");
                }
                assert!(s.factor_len() >= truth.iter().map(|c| c.len() + 1).sum::<usize>());
            }
        }
    }

    #[test]
    fn factorization_flops_are_the_squared_column_counts_of_the_fill() {
        let meshes = [shapes::icosphere(1.0, 2), shapes::grid(1.0, 1.0, 17, 12)];
        for (m, mesh) in meshes.iter().enumerate() {
            for seed in 0..3 {
                let (n, col_ptr, row_idx, order) = mesh_pattern(mesh, 20 + seed);
                let s = analyze(n, &col_ptr, &row_idx, None, &order).unwrap();
                let truth: f64 = brute_force_columns(&s).iter().map(|c| ((c.len() + 1) * (c.len() + 1)) as f64).sum();
                assert_eq!(factorization_flops(n, &col_ptr, &row_idx, &order), truth, "mesh {m} seed {seed}");
            }
        }
    }

    #[test]
    fn relaxed_supernodes_match_faers_on_a_postordered_order() {
        // faer's analysis uses the same relaxation rule and thresholds but keeps a custom order
        // as given (it postorders only its own AMD orders), so it is given our postordered one.
        // Random orders (much fill, many merge decisions near the thresholds) must then give
        // factors of the same size.
        use faer::Side;
        use faer::perm::PermRef;
        use faer::sparse::linalg::SupernodalThreshold;
        use faer::sparse::linalg::cholesky::{CholeskySymbolicParams, SymmetricOrdering, factorize_symbolic_cholesky};
        for (m, mesh) in [shapes::icosphere(1.0, 3), shapes::grid(1.0, 1.0, 30, 20)].iter().enumerate() {
            let topology = Topology::new(mesh);
            let pattern = SparsePattern::new(mesh, &topology).unwrap();
            for seed in 0..4 {
                let (n, col_ptr, row_idx, order) = mesh_pattern(mesh, 10 + seed);
                let ours = analyze(n, &col_ptr, &row_idx, None, &order).unwrap();
                let params = CholeskySymbolicParams {
                    supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
                    ..Default::default()
                };
                let ordering = SymmetricOrdering::Custom(PermRef::new_checked(&ours.forward, &ours.inverse, n));
                let theirs = factorize_symbolic_cholesky(pattern.structure(), Side::Lower, ordering, params).unwrap();
                assert_eq!(ours.factor_len(), theirs.len_val(), "mesh {m} seed {seed}");
                let faer::sparse::linalg::cholesky::SymbolicCholeskyRaw::Supernodal(raw) = theirs.raw() else {
                    panic!("supernodal")
                };
                assert_eq!(ours.begin, raw.supernode_begin().iter().copied().chain([n]).collect::<Vec<_>>());
            }
        }
    }

    #[test]
    fn permutation_and_layout_keep_every_entry() {
        let (n, col_ptr, row_idx, order) = mesh_pattern(&shapes::icosphere(1.0, 2), 5);
        let slots: Vec<usize> = (0..row_idx.len()).map(|k| 1000 + 3 * k).collect();
        let s = analyze(n, &col_ptr, &row_idx, Some(&slots), &order).unwrap();
        for old in 0..n {
            assert_eq!(s.forward[s.inverse[old]], old);
        }
        // Every entry (i, j) of A lands at (max, min) of its new indices with its slot.
        let mut seen = std::collections::BTreeSet::new();
        for j in 0..n {
            for k in s.a_col_ptr[j]..s.a_col_ptr[j + 1] {
                assert!(s.a_row_idx[k] >= j);
                seen.insert((
                    s.forward[s.a_row_idx[k]].max(s.forward[j]),
                    s.forward[s.a_row_idx[k]].min(s.forward[j]),
                    s.a_slot[k],
                ));
            }
        }
        let expected: std::collections::BTreeSet<_> = (0..n)
            .flat_map(|j| (col_ptr[j]..col_ptr[j + 1]).map(move |k| (k, j)))
            .map(|(k, j)| (row_idx[k], j, slots[k]))
            .collect();
        assert_eq!(seen, expected);
    }

    #[test]
    fn small_supernodes_are_merged_and_large_sparse_ones_are_not() {
        // A path 0 – 1 – … – 9 in natural order: every column has one row below, so only the last
        // two columns form a fundamental supernode; relaxation merges the chain into one block of
        // ten columns (36 explicit zeros of 55 entries, under the 80 % of ≤ 16 columns).
        let n = 10;
        let col_ptr: Vec<usize> = (0..=n).map(|j| (2 * j).min(2 * n - 1)).collect();
        let row_idx: Vec<usize> = (0..n).flat_map(|j| if j + 1 < n { vec![j, j + 1] } else { vec![j] }).collect();
        let s = analyze(n, &col_ptr, &row_idx, None, &(0..n).collect::<Vec<_>>()).unwrap();
        assert_eq!(s.begin, vec![0, n]);
        // A star: leaves 0..8 joined to the centre 8 only. Leaves are children of 8 with one row
        // each; only the one just before 8 may merge, and merging a 1-column leaf with the
        // centre adds no zero (its row is the centre).
        let n = 9;
        let mut col_ptr = vec![0];
        let mut row_idx = Vec::new();
        for j in 0..n {
            row_idx.push(j);
            if j + 1 < n {
                row_idx.push(n - 1);
            }
            col_ptr.push(row_idx.len());
        }
        let s = analyze(n, &col_ptr, &row_idx, None, &(0..n).collect::<Vec<_>>()).unwrap();
        assert_eq!(*s.begin.last().unwrap(), n);
        assert_eq!(s.begin[s.begin.len() - 2], 7, "the last leaf joins the centre: {:?}", s.begin);
        assert_eq!(s.num_supernodes(), 8);
    }

    #[test]
    fn forests_diagonals_and_empty_matrices_are_analyzed() {
        // Two separate meshes (an elimination forest of two trees, as two contact zones' domains
        // give), in a random order.
        let mut two = shapes::icosphere(1.0, 2);
        two.append(&shapes::grid(1.0, 1.0, 9, 7));
        let (n, col_ptr, row_idx, order) = mesh_pattern(&two, 4);
        let s = analyze(n, &col_ptr, &row_idx, None, &order).unwrap();
        let truth = brute_force_columns(&s);
        let upper = Pattern::upper(n, &s.a_col_ptr, &s.a_row_idx, &(0..n).collect::<Vec<_>>());
        let parent = elimination_tree(&upper);
        assert_eq!(parent.iter().filter(|&&p| p == NONE).count(), 2, "one root per mesh");
        let counts = column_counts(&parent, &s.a_col_ptr, &s.a_row_idx);
        assert!((0..n).all(|j| counts[j] == truth[j].len() + 1));
        // A diagonal matrix: every column is a root of its own, and relaxation merges a supernode
        // only into its parent, so each stays a 1 × 1 block.
        let n = 6;
        let col_ptr: Vec<usize> = (0..=n).collect();
        let row_idx: Vec<usize> = (0..n).collect();
        let s = analyze(n, &col_ptr, &row_idx, None, &[5, 4, 3, 2, 1, 0]).unwrap();
        assert_eq!(s.num_supernodes(), n, "roots are never merged");
        assert_eq!(s.factor_len(), n);
        assert!(s.row_idx.is_empty());
        // The empty matrix.
        let s = analyze(0, &[0], &[], None, &[]).unwrap();
        assert_eq!((s.num_supernodes(), s.factor_len(), s.dimension()), (0, 0, 0));
    }

    #[test]
    fn invalid_input_is_an_error() {
        let (n, col_ptr, row_idx, _) = mesh_pattern(&shapes::icosphere(1.0, 1), 1);
        let mut repeated: Vec<usize> = (0..n).collect();
        repeated[3] = 4;
        assert!(analyze(n, &col_ptr, &row_idx, None, &repeated).is_err());
        assert!(analyze(n, &col_ptr[..n], &row_idx, None, &(0..n).collect::<Vec<_>>()).is_err());
        let mut upper = row_idx.clone();
        upper[col_ptr[5]] = 2;
        assert!(analyze(n, &col_ptr, &upper, None, &(0..n).collect::<Vec<_>>()).is_err());
    }
}
