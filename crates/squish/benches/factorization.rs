//! Cost of the sparse Cholesky factorizations of a region (thesis ch. 7 §5.2): (a) symbolic +
//! numeric from scratch, as the first frame pays it, (b) numeric refactorization with new
//! values on the same pattern and storage, as every later frame pays it, and (c) the same when
//! only a cap of the sphere is coupled (the rows outside the parametrization domain are
//! decoupled and left out), with the same cap (the submatrix analysis reused), with a cap that
//! alternates between two positions (both analyses stay cached: a whole numeric factorization of
//! the submatrix each time) and with a cap that moves through four positions (one new submatrix
//! analysis per factorization, as a moving contact pays it), (d) a partial
//! refactorization: only the values around one point change (a contact moving on a static
//! object: the supernodes there and their ancestors are recomputed), (e) solves of one and of
//! three right-hand sides, and (f) a heat system and a guide system on a smaller cap inside it,
//! the guide system on its own rows and on the heat system's (`factorize_within`: no analysis),
//! and (g) the symbolic analysis alone in AMD's order and in the cheaper of AMD's and the nested
//! dissection's (what a region's first frame pays for the choice; an icosphere keeps the
//! dissection).
//!
//! Run: `cargo bench -p squish --bench factorization -- --quick`.

use std::hint::black_box;
use std::sync::Arc;
use std::time::Duration;

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use squish::linalg::{FillOrder, NumericFactor, SparsePattern, SymbolicFactor, SymmetricMatrix, cotangent_stiffness};
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

/// `a` with every off-diagonal value that touches a vertex with `z < z_min` set to 0: only the
/// cap `z ≥ z_min` stays coupled (its diagonal keeps the removed couplings, so it stays definite).
fn decouple_below(a: &SymmetricMatrix, mesh: &squish::mesh::TriMesh, z_min: f64) -> SymmetricMatrix {
    let mut local = a.clone();
    let pattern = Arc::clone(a.pattern());
    let (col_ptr, row_idx) = (pattern.col_ptr(), pattern.row_idx());
    let values = local.values_mut();
    for j in 0..pattern.num_vertices() {
        for slot in col_ptr[j]..col_ptr[j + 1] {
            let i = row_idx[slot];
            if i != j && (mesh.positions[i].z < z_min || mesh.positions[j].z < z_min) {
                values[slot] = 0.0;
            }
        }
    }
    local
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

        for (name, fill_order) in [("symbolic-amd", FillOrder::Amd), ("symbolic-fewer-flops", FillOrder::FewerFlops)] {
            group.bench_function(BenchmarkId::new(name, &label), |b| {
                b.iter(|| black_box(SymbolicFactor::analyze_in(&pattern, fill_order).expect("analysis").factor_len()))
            });
        }

        let symbolic = SymbolicFactor::analyze(&pattern).expect("analysis");
        let mut factor = NumericFactor::factorize_new(&symbolic, &variants[0]).expect("factorization");
        let mut which = 0;
        group.bench_function(BenchmarkId::new("refactorize", &label), |b| {
            b.iter(|| {
                which ^= 1;
                factor.factorize(black_box(&variants[which])).expect("refactorization");
            })
        });

        // Values that change only within 0.2 of the north pole, alternately.
        let local = [stiffness_plus_random_diagonal(&k, 1), {
            let mut a = stiffness_plus_random_diagonal(&k, 1);
            let pattern = Arc::clone(a.pattern());
            for (v, p) in mesh.positions.iter().enumerate() {
                if (*p - glam::DVec3::Z).length() < 0.2 {
                    a.values_mut()[pattern.diag_slot(v as u32)] *= 1.5;
                }
            }
            a
        }];
        let mut factor = NumericFactor::factorize_new(&symbolic, &local[0]).expect("factorization");
        group.bench_function(BenchmarkId::new("refactorize-local-change", &label), |b| {
            b.iter(|| {
                which ^= 1;
                factor.factorize(black_box(&local[which])).expect("refactorization");
            })
        });
        let n = mesh.num_vertices();
        let rhs: Vec<f64> = (0..3 * n).map(|i| ((i * 7919) % 1000) as f64 / 500.0 - 1.0).collect();
        for columns in [1, 3] {
            let mut x = rhs[..columns * n].to_vec();
            group.bench_function(BenchmarkId::new(format!("solve-{columns}-columns"), &label), |b| {
                b.iter(|| {
                    x.copy_from_slice(&rhs[..columns * n]);
                    factor.solve_columns_in_place(black_box(&mut x), columns).expect("solve");
                })
            });
        }

        // A cap of about a quarter of the sphere coupled: the same cap twice, then two caps.
        let same_cap = [decouple_below(&variants[0], &mesh, 0.5), decouple_below(&variants[1], &mesh, 0.5)];
        let moving_cap = [decouple_below(&variants[0], &mesh, 0.5), decouple_below(&variants[1], &mesh, 0.45)];
        for (name, caps) in [("refactorize-cap", &same_cap[..]), ("refactorize-moving-cap", &moving_cap[..])] {
            let mut factor = NumericFactor::factorize_new(&symbolic, &caps[0]).expect("factorization");
            let mut which = 0;
            group.bench_function(BenchmarkId::new(name, &label), |b| {
                b.iter(|| {
                    which ^= 1;
                    factor.factorize(black_box(&caps[which])).expect("refactorization");
                })
            });
        }
        // More positions than a symbolic factor keeps analyses of: each factorization analyzes.
        let travelling_cap: Vec<SymmetricMatrix> =
            [0.5, 0.48, 0.46, 0.44].iter().map(|&z| decouple_below(&variants[0], &mesh, z)).collect();
        let mut factor = NumericFactor::factorize_new(&symbolic, &travelling_cap[0]).expect("factorization");
        let before = factor.reduced_analyses();
        for position in [1, 2, 3, 0] {
            factor.factorize(&travelling_cap[position]).expect("refactorization");
        }
        assert_eq!(factor.reduced_analyses() - before, 4, "each position of the cap is analyzed anew");
        let mut position = 0;
        group.bench_function(BenchmarkId::new("analyze-and-factorize-travelling-cap", &label), |b| {
            b.iter(|| {
                position = (position + 1) % travelling_cap.len();
                factor.factorize(black_box(&travelling_cap[position])).expect("refactorization");
            })
        });

        // A guide system coupling a smaller cap inside each travelling cap (𝒟 inside 𝒫): on its
        // own rows (a second analysis per position) and on the heat system's rows (none).
        let inner_cap: Vec<SymmetricMatrix> =
            [0.55, 0.53, 0.51, 0.49].iter().map(|&z| decouple_below(&variants[1], &mesh, z)).collect();
        let mut heat = NumericFactor::factorize_new(&symbolic, &travelling_cap[0]).expect("factorization");
        let mut guide = NumericFactor::factorize_new(&symbolic, &inner_cap[0]).expect("factorization");
        for within in [false, true] {
            let name = if within { "heat-and-guide-within-travelling-cap" } else { "heat-and-guide-travelling-cap" };
            let mut position = 0;
            group.bench_function(BenchmarkId::new(name, &label), |b| {
                b.iter(|| {
                    position = (position + 1) % travelling_cap.len();
                    heat.factorize(black_box(&travelling_cap[position])).expect("refactorization");
                    let other = within.then_some(&heat);
                    guide.factorize_within(black_box(&inner_cap[position]), other).expect("refactorization");
                })
            });
        }
        let analyses = guide.reduced_analyses();
        for position in [1, 2, 3, 0] {
            heat.factorize(&travelling_cap[position]).expect("refactorization");
            guide.factorize_within(&inner_cap[position], Some(&heat)).expect("refactorization");
        }
        assert_eq!(guide.reduced_analyses(), analyses, "the guide system reuses the heat system's analyses");
        assert_eq!(guide.factorized_rows(), heat.factorized_rows());
    }
    group.finish();
}

criterion_group!(benches, factorization);
criterion_main!(benches);
