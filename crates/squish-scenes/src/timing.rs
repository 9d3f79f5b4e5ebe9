//! Timing of the factorizations of a region, for `squish bench` and the criterion benchmark
//! (thesis ch. 7 §5.2: the factorizations are the majority of the cost of a frame).

use std::time::{Duration, Instant};

use squish::linalg::{NumericFactor, Operator, SolveError, SparsePattern, SymbolicFactor};
use squish::mesh::{Topology, TriMesh, mean_edge_length};

/// Timings and sizes of the factorization of one region's heat operator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FactorizationTiming {
    /// Rows of the system (vertices of the region).
    pub vertices: usize,
    /// Stored entries of the matrix's lower triangle.
    pub matrix_nonzeros: usize,
    /// Stored entries of the Cholesky factor (fill-in included).
    pub factor_nonzeros: usize,
    /// Supernodes of the factor (dense column blocks).
    pub supernodes: usize,
    /// Building the sparsity pattern from the topology.
    pub pattern: Duration,
    /// Symbolic analysis (the fill-reducing order of fewer flops, elimination tree, supernodes):
    /// once per region.
    pub symbolic: Duration,
    /// First numeric factorization, storage allocation included.
    pub first_numeric: Duration,
    /// Fastest in-place numeric refactorization with new values (what a frame pays).
    pub refactorization: Duration,
}

/// Times the factorization of the heat operator `M + tK` (t = 10h², §5.1) of `mesh` — the
/// region's Laplacian made definite, with the exact pattern and cost of every system solved on
/// it. The refactorization is repeated `repetitions` times (at least once) and the fastest kept.
pub fn time_laplacian_factorization(
    mesh: &TriMesh,
    topology: &Topology,
    repetitions: usize,
) -> Result<FactorizationTiming, SolveError> {
    let start = Instant::now();
    let pattern = SparsePattern::shared(mesh, topology)?;
    let pattern_time = start.elapsed();

    let h = mean_edge_length(mesh, topology);
    let operator = Operator::heat(mesh, &pattern, None, 10.0 * h * h)?;

    let start = Instant::now();
    let symbolic = SymbolicFactor::analyze(&pattern)?;
    let symbolic_time = start.elapsed();

    let start = Instant::now();
    let mut factor = NumericFactor::factorize_new(&symbolic, operator.matrix())?;
    let first_numeric = start.elapsed();

    let mut refactorization = Duration::MAX;
    for _ in 0..repetitions.max(1) {
        factor.forget_previous_values();
        let start = Instant::now();
        factor.factorize(operator.matrix())?;
        refactorization = refactorization.min(start.elapsed());
    }
    Ok(FactorizationTiming {
        vertices: mesh.num_vertices(),
        matrix_nonzeros: pattern.nnz(),
        factor_nonzeros: symbolic.factor_len(),
        supernodes: symbolic.num_supernodes(),
        pattern: pattern_time,
        symbolic: symbolic_time,
        first_numeric,
        refactorization,
    })
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use squish::mesh::shapes;

    #[test]
    fn timing_reports_the_sizes_of_the_system() {
        let mesh = shapes::icosphere(1.0, 3);
        let topology = Topology::new(&mesh);
        let t = time_laplacian_factorization(&mesh, &topology, 2).unwrap();
        assert_eq!(t.vertices, 642);
        assert_eq!(t.matrix_nonzeros, 642 + topology.num_edges());
        assert!(t.factor_nonzeros >= t.matrix_nonzeros);
        assert!(t.refactorization > Duration::ZERO);
    }
}
