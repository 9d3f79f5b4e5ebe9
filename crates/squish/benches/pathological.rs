//! `squish info`'s analysis of meshes whose shape used to make it quadratic (issue 28): the
//! topology (edges, manifoldness, components, boundary loops), degenerate faces and
//! self-intersections, on 100 000 faces of
//! - `fan`: a flat disk fanned around its centre (every face shares one vertex);
//! - `ngon`: one polygon as an OBJ `f` line gives it (fanned from its first corner: long thin
//!   faces that all share it), with 10 000 and 100 000 corners;
//! - `slivers`: a tilted sheet of parallel strips, diagonal to every coordinate axis (the
//!   axis-aligned box of each face overlaps almost every other's);
//! - `coincident`: the fan as a triangle soup, each face with its own three vertices (the centre
//!   100 000 times at the same position);
//! - `spikes`: a hedgehog of thin faces around one vertex, in every direction;
//! - `book`: faces around one edge, like the pages of a book.
//!
//! Run: `cargo bench -p squish --bench pathological -- --quick`; the figures are in
//! `docs/decisions.md` (Speed).

use std::f64::consts::TAU;
use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::DVec3;
use squish::mesh::{Topology, TriMesh, mean_edge_length};
use squish::spatial::self_intersections;

/// What `squish info` computes about a mesh; returns the self-intersecting face count.
fn analyse(mesh: &TriMesh) -> usize {
    let topology = Topology::new(mesh);
    let manifold = topology.check_manifold(mesh).is_ok();
    let components = topology.face_components(mesh).1;
    let loops = topology.boundary_loops(mesh).len();
    let degenerate = (0..mesh.num_triangles()).filter(|&t| mesh.degeneracy(t).is_some()).count();
    let length = mean_edge_length(mesh, &topology);
    black_box((manifold, components, loops, degenerate, length));
    self_intersections(mesh).map_or(usize::MAX, |s| s.faces.len())
}

fn ring(i: usize, n: usize) -> DVec3 {
    let a = TAU * i as f64 / n as f64;
    DVec3::new(a.cos(), a.sin(), 0.0)
}

fn fan(n: usize) -> TriMesh {
    let mut positions = vec![DVec3::ZERO];
    positions.extend((0..n).map(|i| ring(i, n)));
    let triangles = (0..n as u32).map(|i| [0, 1 + i, 1 + (i + 1) % n as u32]).collect();
    TriMesh { positions, triangles }
}

fn ngon(corners: usize) -> TriMesh {
    TriMesh {
        positions: (0..corners).map(|i| ring(i, corners)).collect(),
        triangles: (1..corners as u32 - 1).map(|i| [0, i, i + 1]).collect(),
    }
}

fn slivers(faces: usize) -> TriMesh {
    let strips = faces / 2;
    let along = DVec3::new(1.0, 1.0, 0.3).normalize();
    let across = DVec3::new(-1.0, 1.0, 0.2).normalize();
    let mut positions = Vec::with_capacity(2 * strips + 2);
    for i in 0..=strips {
        let o = across * (i as f64 / strips as f64);
        positions.push(o);
        positions.push(o + along);
    }
    let triangles =
        (0..strips as u32).flat_map(|i| [[2 * i, 2 * i + 2, 2 * i + 1], [2 * i + 1, 2 * i + 2, 2 * i + 3]]).collect();
    TriMesh { positions, triangles }
}

fn coincident(n: usize) -> TriMesh {
    let fan = fan(n);
    let positions = fan.triangles.iter().flat_map(|t| t.map(|v| fan.positions[v as usize])).collect();
    let triangles = (0..n as u32).map(|f| [3 * f, 3 * f + 1, 3 * f + 2]).collect();
    TriMesh { positions, triangles }
}

/// Thin faces from the origin toward points spread over the sphere (a Fibonacci lattice).
fn spikes(n: usize) -> TriMesh {
    let mut positions = vec![DVec3::ZERO];
    for i in 0..n {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / n as f64;
        let a = i as f64 * 2.399_963_229_728_653;
        let r = (1.0 - z * z).sqrt();
        let tip = DVec3::new(r * a.cos(), r * a.sin(), z);
        let side = tip.any_orthonormal_vector() * 1e-3;
        positions.push(tip);
        positions.push(tip + side);
    }
    let triangles = (0..n as u32).map(|i| [0, 1 + 2 * i, 2 + 2 * i]).collect();
    TriMesh { positions, triangles }
}

fn book(n: usize) -> TriMesh {
    let mut positions = vec![DVec3::ZERO, DVec3::Z];
    positions.extend((0..n).map(|i| ring(i, n) + DVec3::Z * 0.5));
    let triangles = (0..n as u32).map(|i| [0, 1, 2 + i]).collect();
    TriMesh { positions, triangles }
}

fn pathological(c: &mut Criterion) {
    let mut group = c.benchmark_group("info-analysis");
    group.sample_size(10).measurement_time(Duration::from_secs(10));
    let cases = [
        ("fan-100k", fan(100_000), 0),
        ("ngon-10k", ngon(10_000), 0),
        ("ngon-100k", ngon(100_000), 0),
        ("slivers-100k", slivers(100_000), 0),
        ("coincident-100k", coincident(100_000), 0),
        ("spikes-100k", spikes(100_000), 0),
        ("book-100k", book(100_000), 0),
    ];
    for (name, mesh, intersecting) in &cases {
        // The answer is checked once, so that a fast wrong answer cannot pass unnoticed.
        assert_eq!(analyse(mesh), *intersecting, "{name}");
        group.bench_function(*name, |b| b.iter(|| analyse(black_box(mesh))));
    }
    group.finish();
}

criterion_group!(benches, pathological);
criterion_main!(benches);
