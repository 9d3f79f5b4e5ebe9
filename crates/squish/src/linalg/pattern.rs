//! The fixed sparsity pattern shared by every linear system solved on one working region
//! (thesis App. B and §5.1), and symmetric matrices stored on it.
//!
//! Every system of the pipeline — heat step `M + tK`, Poisson `K`, harmonic diffusions — has
//! nonzeros only on the diagonal and on mesh edges, and an edge constraint
//! `(1 − α)v_i + αv_j = b` only adds to `(i, i)`, `(i, j)` and `(j, j)`. So the pattern depends on
//! the region's connectivity alone: it is built once from the [`Topology`], and the symbolic
//! Cholesky analysis done on it is shared by every factorization on the region, across solves
//! and across animation frames (see [`super::SymbolicFactor`]).
//!
//! Storage: compressed sparse columns of the **lower** triangle (row ≥ column), rows sorted in
//! each column, the diagonal first. Because the topology's edges are sorted by `(lo, hi)`, column
//! `j` holds row `j` and then the `hi` end of every edge whose `lo` end is `j`, so the value index
//! ("slot") of each diagonal entry and each edge is known at construction: assembling values is
//! O(nnz) with no hashing and no search.

use std::sync::Arc;

use faer::sparse::{SymbolicSparseColMat, SymbolicSparseColMatRef};

use super::SolveError;
use crate::mesh::{Topology, TriMesh};

/// Marks an edge that has no slot (an edge that repeats a vertex, found only in degenerate faces).
pub const NO_SLOT: usize = usize::MAX;

/// The lower-triangular CSC pattern of a region's systems, with the slot of every diagonal entry,
/// every edge and every face's edges.
#[derive(Debug)]
pub struct SparsePattern {
    structure: SymbolicSparseColMat<usize>,
    diag_slot: Vec<usize>,
    edge_slot: Vec<usize>,
    /// `face_edge_slots[f][k]`: slot of the edge joining corners `k` and `k + 1` of face `f`.
    face_edge_slots: Vec<[usize; 3]>,
    triangles: Vec<[u32; 3]>,
}

impl SparsePattern {
    /// Builds the pattern of the region `mesh` with connectivity `topology`.
    pub fn new(mesh: &TriMesh, topology: &Topology) -> Result<Self, SolveError> {
        let n = mesh.num_vertices();
        if topology.num_vertices() != n {
            return Err(SolveError::DimensionMismatch {
                what: "topology (vertices)",
                expected: n,
                actual: topology.num_vertices(),
            });
        }
        if topology.num_faces() != mesh.num_triangles() {
            return Err(SolveError::DimensionMismatch {
                what: "topology (faces)",
                expected: mesh.num_triangles(),
                actual: topology.num_faces(),
            });
        }
        let edges = topology.edges();
        let mut col_ptr = vec![0usize; n + 1];
        for &[lo, hi] in edges {
            if lo != hi {
                col_ptr[lo as usize + 1] += 1;
            }
        }
        // One diagonal entry per column plus its edges.
        for j in 0..n {
            col_ptr[j + 1] += col_ptr[j] + 1;
        }
        let nnz = col_ptr[n];
        let mut row_idx = vec![0usize; nnz];
        let mut diag_slot = vec![0usize; n];
        let mut cursor = vec![0usize; n];
        for j in 0..n {
            diag_slot[j] = col_ptr[j];
            row_idx[col_ptr[j]] = j;
            cursor[j] = col_ptr[j] + 1;
        }
        // Edges come sorted by (lo, hi), so each column receives its rows in increasing order.
        let mut edge_slot = vec![NO_SLOT; edges.len()];
        for (e, &[lo, hi]) in edges.iter().enumerate() {
            if lo == hi {
                continue;
            }
            let slot = cursor[lo as usize];
            row_idx[slot] = hi as usize;
            edge_slot[e] = slot;
            cursor[lo as usize] += 1;
        }
        let face_edge_slots =
            (0..mesh.num_triangles() as u32).map(|f| topology.face_edges(f).map(|e| edge_slot[e as usize])).collect();
        let structure = SymbolicSparseColMat::new_checked(n, n, col_ptr, None, row_idx);
        Ok(Self { structure, diag_slot, edge_slot, face_edge_slots, triangles: mesh.triangles.clone() })
    }

    /// Builds the pattern and wraps it for sharing.
    pub fn shared(mesh: &TriMesh, topology: &Topology) -> Result<Arc<Self>, SolveError> {
        Self::new(mesh, topology).map(Arc::new)
    }

    /// Number of rows (= vertices of the region).
    pub fn num_vertices(&self) -> usize {
        self.diag_slot.len()
    }

    /// Number of faces of the region the pattern was built from.
    pub fn num_faces(&self) -> usize {
        self.triangles.len()
    }

    /// Number of stored entries (diagonal + one per edge).
    pub fn nnz(&self) -> usize {
        self.structure.row_idx().len()
    }

    /// Slot of the diagonal entry `(v, v)`.
    #[inline]
    pub fn diag_slot(&self, v: u32) -> usize {
        self.diag_slot[v as usize]
    }

    /// Slot of edge `e` (a topology edge id), or [`NO_SLOT`] for an edge repeating a vertex.
    #[inline]
    pub fn edge_slot(&self, e: u32) -> usize {
        self.edge_slot[e as usize]
    }

    /// Slots of the three edges of face `f` (entry `k` joins corners `k` and `k + 1`).
    #[inline]
    pub fn face_edge_slots(&self, f: usize) -> [usize; 3] {
        self.face_edge_slots[f]
    }

    /// The triangles of the region the pattern was built from.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// Slot of entry `(i, j)` (in either order), or `None` if `i ≠ j` share no edge or an index is
    /// out of range. A binary search in one column: for occasional lookups such as constraints.
    pub fn slot(&self, i: u32, j: u32) -> Option<usize> {
        let (col, row) = (i.min(j) as usize, i.max(j) as usize);
        if row >= self.num_vertices() {
            return None;
        }
        let col_ptr = self.structure.col_ptr();
        let start = col_ptr[col];
        let rows = &self.structure.row_idx()[start..col_ptr[col + 1]];
        rows.binary_search(&row).ok().map(|k| start + k)
    }

    /// The faer view of the lower-triangular structure.
    pub fn structure(&self) -> SymbolicSparseColMatRef<'_, usize> {
        self.structure.as_ref()
    }

    /// Column pointers of the CSC structure.
    pub fn col_ptr(&self) -> &[usize] {
        self.structure.col_ptr()
    }

    /// Row indices of the CSC structure.
    pub fn row_idx(&self) -> &[usize] {
        self.structure.row_idx()
    }
}

/// A symmetric matrix stored as the lower triangle of a [`SparsePattern`].
#[derive(Clone, Debug)]
pub struct SymmetricMatrix {
    pattern: Arc<SparsePattern>,
    values: Vec<f64>,
}

impl SymmetricMatrix {
    /// The zero matrix on `pattern`.
    pub fn zeros(pattern: &Arc<SparsePattern>) -> Self {
        Self { pattern: Arc::clone(pattern), values: vec![0.0; pattern.nnz()] }
    }

    /// The matrix on `pattern` with the given slot values.
    pub fn from_values(pattern: &Arc<SparsePattern>, values: Vec<f64>) -> Result<Self, SolveError> {
        if values.len() != pattern.nnz() {
            return Err(SolveError::DimensionMismatch {
                what: "matrix values",
                expected: pattern.nnz(),
                actual: values.len(),
            });
        }
        Ok(Self { pattern: Arc::clone(pattern), values })
    }

    /// The pattern the values live on.
    pub fn pattern(&self) -> &Arc<SparsePattern> {
        &self.pattern
    }

    /// Values by slot.
    pub fn values(&self) -> &[f64] {
        &self.values
    }

    /// Mutable values by slot.
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.values
    }

    /// Number of rows.
    pub fn dimension(&self) -> usize {
        self.pattern.num_vertices()
    }

    /// Entry `(i, j)`: zero outside the pattern.
    pub fn get(&self, i: u32, j: u32) -> f64 {
        self.pattern.slot(i, j).map_or(0.0, |s| self.values[s])
    }

    /// Diagonal entry `(v, v)`.
    pub fn diagonal(&self, v: u32) -> f64 {
        self.values[self.pattern.diag_slot(v)]
    }

    /// Sets every value to zero (keeps the storage).
    pub fn fill_zero(&mut self) {
        self.values.fill(0.0);
    }

    /// True if both matrices live on the same pattern (the same shared object).
    pub fn same_pattern(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.pattern, &other.pattern)
    }

    /// `self += scale · other`.
    pub fn add_scaled(&mut self, other: &Self, scale: f64) -> Result<(), SolveError> {
        if !self.same_pattern(other) {
            return Err(SolveError::PatternMismatch);
        }
        for (a, b) in self.values.iter_mut().zip(&other.values) {
            *a += scale * b;
        }
        Ok(())
    }

    /// `self += scale · diag(d)`.
    pub fn add_diagonal(&mut self, d: &[f64], scale: f64) -> Result<(), SolveError> {
        if d.len() != self.dimension() {
            return Err(SolveError::DimensionMismatch {
                what: "diagonal",
                expected: self.dimension(),
                actual: d.len(),
            });
        }
        for (v, &x) in d.iter().enumerate() {
            self.values[self.pattern.diag_slot[v]] += scale * x;
        }
        Ok(())
    }

    /// `y = self · x` using both triangles.
    pub fn mul_vec(&self, x: &[f64], y: &mut [f64]) -> Result<(), SolveError> {
        let n = self.dimension();
        for (what, len) in [("x", x.len()), ("y", y.len())] {
            if len != n {
                return Err(SolveError::DimensionMismatch { what, expected: n, actual: len });
            }
        }
        y.fill(0.0);
        let col_ptr = self.pattern.col_ptr();
        let row_idx = self.pattern.row_idx();
        for j in 0..n {
            let column = col_ptr[j]..col_ptr[j + 1];
            for (&i, &a) in row_idx[column.clone()].iter().zip(&self.values[column]) {
                y[i] += a * x[j];
                if i != j {
                    y[j] += a * x[i];
                }
            }
        }
        Ok(())
    }

    /// `self · x` as a new vector.
    pub fn apply(&self, x: &[f64]) -> Result<Vec<f64>, SolveError> {
        let mut y = vec![0.0; self.dimension()];
        self.mul_vec(x, &mut y)?;
        Ok(y)
    }

    /// The dense matrix, row by row (both triangles). For tests and debugging of small systems.
    pub fn to_dense(&self) -> Vec<Vec<f64>> {
        let n = self.dimension();
        let mut dense = vec![vec![0.0; n]; n];
        let col_ptr = self.pattern.col_ptr();
        let row_idx = self.pattern.row_idx();
        for j in 0..n {
            let column = col_ptr[j]..col_ptr[j + 1];
            for (&i, &a) in row_idx[column.clone()].iter().zip(&self.values[column]) {
                dense[i][j] = a;
                dense[j][i] = a;
            }
        }
        dense
    }

    /// The first non-finite value, as `(slot, value)`.
    pub(crate) fn first_non_finite(&self) -> Option<(usize, f64)> {
        // x·0 is NaN exactly when x is not finite; eight independent sums of them vectorize (an
        // early-exit search does not), and only a matrix that has one is searched.
        let mut lanes = [0.0f64; 8];
        let chunks = self.values.chunks_exact(8);
        let rest = chunks.remainder();
        for chunk in chunks {
            for (lane, &x) in lanes.iter_mut().zip(chunk) {
                *lane += x * 0.0;
            }
        }
        let clean = lanes.iter().chain(rest).all(|x| x.is_finite());
        if clean { None } else { self.values.iter().copied().enumerate().find(|(_, x)| !x.is_finite()) }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use crate::mesh::shapes;

    #[test]
    fn the_first_non_finite_value_is_found_wherever_it_is() {
        let mesh = shapes::icosphere(1.0, 1);
        let pattern = SparsePattern::shared(&mesh, &Topology::new(&mesh)).unwrap();
        let nnz = pattern.nnz();
        assert!(!nnz.is_multiple_of(8), "the test wants a remainder after the blocks of eight ({nnz})");
        let clean = SymmetricMatrix::from_values(&pattern, (0..nnz).map(|k| k as f64 - 7.5).collect()).unwrap();
        assert_eq!(clean.first_non_finite(), None);
        for at in [0, 5, 8, nnz / 2, nnz - 9, nnz - 1] {
            for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut m = clean.clone();
                m.values_mut()[at] = bad;
                // A later one too: the first is reported.
                m.values_mut()[nnz - 1] = if at == nnz - 1 { bad } else { f64::NAN };
                let (slot, value) = m.first_non_finite().unwrap();
                assert_eq!(slot, at);
                assert!(value.is_nan() == bad.is_nan() && (value.is_nan() || value == bad));
            }
        }
        // Huge finite values do not overflow the check.
        let huge = SymmetricMatrix::from_values(&pattern, vec![f64::MAX; nnz]).unwrap();
        assert_eq!(huge.first_non_finite(), None);
    }

    #[test]
    fn slots_index_the_lower_triangle_of_every_edge_and_diagonal() {
        let mesh = shapes::icosphere(1.0, 2);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::new(&mesh, &topology).unwrap();
        assert_eq!(pattern.nnz(), mesh.num_vertices() + topology.num_edges());
        let col_ptr = pattern.col_ptr();
        let row_idx = pattern.row_idx();
        let column_of = |slot: usize| col_ptr.partition_point(|&p| p <= slot) - 1;
        for v in 0..mesh.num_vertices() as u32 {
            let s = pattern.diag_slot(v);
            assert_eq!((row_idx[s], column_of(s)), (v as usize, v as usize));
            assert_eq!(pattern.slot(v, v), Some(s));
        }
        let mut seen = vec![false; pattern.nnz()];
        for (e, &[lo, hi]) in topology.edges().iter().enumerate() {
            let s = pattern.edge_slot(e as u32);
            assert_eq!((row_idx[s], column_of(s)), (hi as usize, lo as usize));
            assert_eq!(pattern.slot(hi, lo), Some(s));
            assert!(!seen[s]);
            seen[s] = true;
        }
        for f in 0..mesh.num_triangles() {
            let t = mesh.triangles[f];
            for k in 0..3 {
                assert_eq!(Some(pattern.face_edge_slots(f)[k]), pattern.slot(t[k], t[(k + 1) % 3]));
            }
        }
        // Two vertices that are not neighbours have no slot.
        let far = (1..mesh.num_vertices() as u32).find(|&v| topology.edge_between(0, v).is_none()).unwrap();
        assert_eq!(pattern.slot(0, far), None);
    }

    #[test]
    fn mul_vec_matches_the_dense_matrix() {
        let mesh = shapes::grid(1.0, 1.0, 3, 2);
        let topology = Topology::new(&mesh);
        let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
        let values = (0..pattern.nnz()).map(|s| (s as f64 * 0.37).sin()).collect();
        let a = SymmetricMatrix::from_values(&pattern, values).unwrap();
        let x: Vec<f64> = (0..a.dimension()).map(|i| (i as f64 * 1.3).cos()).collect();
        let y = a.apply(&x).unwrap();
        let dense = a.to_dense();
        for (i, row) in dense.iter().enumerate() {
            let expected: f64 = row.iter().zip(&x).map(|(a, b)| a * b).sum();
            assert!((y[i] - expected).abs() < 1e-14);
        }
    }

    #[test]
    fn matrices_on_different_patterns_do_not_mix() {
        let mesh = shapes::grid(1.0, 1.0, 2, 2);
        let topology = Topology::new(&mesh);
        let p1 = SparsePattern::shared(&mesh, &topology).unwrap();
        let p2 = SparsePattern::shared(&mesh, &topology).unwrap();
        let mut a = SymmetricMatrix::zeros(&p1);
        assert_eq!(a.add_scaled(&SymmetricMatrix::zeros(&p2), 1.0), Err(SolveError::PatternMismatch));
        assert!(a.add_scaled(&SymmetricMatrix::zeros(&p1), 1.0).is_ok());
    }
}
