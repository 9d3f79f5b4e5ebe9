//! Cost of the sparse Cholesky factorizations of a region (thesis ch. 7 §5.2): (a) symbolic +
//! numeric from scratch, as the first frame pays it, and (b) numeric refactorization with new
//! values on the same pattern and storage, as every later frame pays it.
//!
//! Run: `cargo bench -p squish --bench factorization -- --quick`.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use squish::linalg::{NumericFactor, SparsePattern, SymbolicFactor, SymmetricMatrix, cotangent_stiffness};
use squish::mesh::{Topology, shapes};

/// `K + diag(d)` with a seeded pseudo-random positive diagonal, so every variant is a new set of
/// values with the same pattern (what a new frame or a new diffusion looks like).
fn stiffness_plus_random_diagonal(k: &SymmetricMatrix, seed: u64) -> SymmetricMatrix {
    let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
    let diagonal: Vec<f64> = (0..k.dimension())
        .map(|_| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            0.01 + (state >> 11) as f64 / (1u64 << 53) as f64
        })
        .collect();
    let mut a = k.clone();
    a.add_diagonal(&diagonal, 1.0).expect("diagonal has one entry per vertex");
    a
}

fn factorization(c: &mut Criterion) {
    let mut group = c.benchmark_group("factorization");
    group.sample_size(10).measurement_time(Duration::from_secs(5)).warm_up_time(Duration::from_secs(1));
    for subdivisions in [5u32, 6] {
        let mesh = shapes::icosphere(1.0, subdivisions);
        let topology = Topology::new(&mesh);
        let pattern: Arc<SparsePattern> = SparsePattern::shared(&mesh, &topology).expect("pattern");
        let k = cotangent_stiffness(&mesh, &pattern, None).expect("stiffness");
        let variants = [stiffness_plus_random_diagonal(&k, 1), stiffness_plus_random_diagonal(&k, 2)];
        let label = format!("{}v", mesh.num_vertices());

        group.bench_function(BenchmarkId::new("symbolic+numeric", &label), |b| {
            b.iter(|| {
                let symbolic = SymbolicFactor::analyze(&pattern).expect("analysis");
                let factor = NumericFactor::factorize_new(&symbolic, &variants[0]).expect("factorization");
                black_box(factor.is_factorized())
            })
        });

        let symbolic = SymbolicFactor::analyze(&pattern).expect("analysis");
        let mut factor = NumericFactor::factorize_new(&symbolic, &variants[0]).expect("factorization");
        let mut which = 0;
        group.bench_function(BenchmarkId::new("refactorize", &label), |b| {
            b.iter(|| {
                which ^= 1;
                factor.factorize(black_box(&variants[which])).expect("refactorization");
            })
        });
    }
    group.finish();
}

criterion_group!(benches, factorization);
criterion_main!(benches);
