//! Tests of the radial brush (§5.5.1) on an open grid: a synthetic radial parametrization (u the
//! normalized distance from a disc) where the profiles are exact radial lines, and the deformer's
//! own u of a grid pressed by a rigid sphere.

#![allow(clippy::unwrap_used)]

use glam::DVec3;

use super::*;
use crate::deform::test_support::{nearest_vertex, sphere_zone};
use crate::deform::{DeformParams, RegionSolver, deform_region};
use crate::linalg::{SparsePattern, cotangent_stiffness};
use crate::mesh::shapes;

/// Cells per side of the test grids (even: the grid is symmetric about x = 0 and y = 0).
const CELLS: u32 = 60;

/// 𝒞 = {ρ < inner}, 𝒟 = {inner ≤ ρ < outer}, u = (ρ − inner)/(outer − inner) outside 𝒞, with
/// ρ the distance to the nearest of `centres`.
struct Synthetic {
    u: Vec<f64>,
    contact: Vec<bool>,
    deformable: Vec<bool>,
}

impl Synthetic {
    fn new(mesh: &TriMesh, centres: &[DVec3], inner: f64, outer: f64) -> Self {
        let rho: Vec<f64> = mesh
            .positions
            .iter()
            .map(|p| centres.iter().map(|c| p.distance(*c)).fold(f64::INFINITY, f64::min))
            .collect();
        let contact: Vec<bool> = rho.iter().map(|&r| r < inner).collect();
        let u = rho.iter().map(|&r| ((r - inner) / (outer - inner)).max(0.0)).collect::<Vec<_>>();
        let deformable = rho.iter().zip(&u).map(|(&r, &u)| r >= inner && u < 1.0).collect();
        Self { u, contact, deformable }
    }

    fn fields(&self) -> BrushFields<'_> {
        BrushFields { u: &self.u, contact: &self.contact, deformable: &self.deformable }
    }
}

/// The vertex mirrored about y = 0 on the grid of [`CELLS`] cells.
fn mirrored(v: usize) -> usize {
    let row = CELLS as usize + 1;
    (CELLS as usize - v / row) * row + v % row
}

fn ring() -> (TriMesh, Topology, Synthetic) {
    let mesh = shapes::grid(3.0, 3.0, CELLS, CELLS);
    let topology = Topology::new(&mesh);
    let fields = Synthetic::new(&mesh, &[DVec3::ZERO], 0.4, 1.2);
    (mesh, topology, fields)
}

#[test]
fn the_selection_spans_the_profiles_and_nu_is_harmonic_with_its_boundary_values() {
    let (mesh, topology, synthetic) = ring();
    let (rho, radius) = (0.8, 0.25);
    let s = radial_brush(&mesh, &topology, &synthetic.fields(), DVec3::new(rho, 0.0, 0.0), radius).unwrap();
    let selected: Vec<usize> = (0..mesh.num_vertices()).filter(|&v| s.selected[v]).collect();
    assert!(selected.iter().all(|&v| synthetic.deformable[v]), "𝒵 is part of 𝒟");
    // From ∂𝒞 to ∂𝒟.
    let (lowest, highest) =
        selected.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &v| (lo.min(synthetic.u[v]), hi.max(synthetic.u[v])));
    println!("|𝒵| = {}, u from {lowest:.3} to {highest:.3}", selected.len());
    assert!(lowest < 0.06 && highest > 0.94, "{lowest} {highest}");
    // The magnitude: in [0, 1] on 𝒵, 0 elsewhere.
    for v in 0..mesh.num_vertices() {
        assert!((0.0..=1.0).contains(&s.weights[v]));
        if !s.selected[v] {
            assert_eq!(s.weights[v], 0.0, "vertex {v} outside 𝒵");
        }
    }
    // ν in [0, 1] (up to the least-squares slack), 0 and 1 on the lateral boundaries, ½ under the centre.
    let (nu_min, nu_max) =
        selected.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &v| (lo.min(s.nu[v]), hi.max(s.nu[v])));
    assert!(nu_min > -0.02 && nu_max < 1.02, "{nu_min} {nu_max}");
    for (value, boundary) in [0.0, 1.0].iter().zip(&s.lateral) {
        assert!(boundary.len() >= 10, "{} points", boundary.len());
        let mut worst = 0.0f64;
        for p in boundary {
            let (a, b) = (s.nu[p.i as usize], s.nu[p.j as usize]);
            if a.is_finite() && b.is_finite() {
                worst = worst.max(((1.0 - p.alpha) * a + p.alpha * b - value).abs());
            }
        }
        println!("ν = {value} boundary: {} points, largest deviation {worst:.2e}", boundary.len());
        assert!(worst < 0.03, "{worst}");
    }
    let under = nearest_vertex(&mesh, DVec3::new(rho, 0.0, 0.0));
    assert!((s.nu[under] - 0.5).abs() < 0.02, "ν = {} under the centre", s.nu[under]);
    assert!(s.weights[under] > 0.99);
    // Harmonic: the cotangent Laplacian vanishes at the vertices whose whole ring is in 𝒵 and
    // that no constraint touches.
    let constrained: Vec<u32> = s.lateral.iter().flatten().flat_map(|p| [p.i, p.j]).collect();
    let pattern = SparsePattern::shared(&mesh, &topology).unwrap();
    let k = cotangent_stiffness(&mesh, &pattern, None).unwrap();
    let mut interior = 0;
    let mut worst = 0.0f64;
    for &v in &selected {
        let v = v as u32;
        if constrained.contains(&v) || !topology.vertex_neighbors(v).all(|w| s.selected[w as usize]) {
            continue;
        }
        let residual = k.diagonal(v) * s.nu[v as usize]
            + topology.vertex_neighbors(v).map(|w| k.get(v, w) * s.nu[w as usize]).sum::<f64>();
        worst = worst.max(residual.abs() / k.diagonal(v));
        interior += 1;
    }
    println!("Laplacian residual at {interior} interior vertices ≤ {worst:.1e}");
    assert!(interior > 50);
    assert!(worst < 1e-9, "{worst}");
}

#[test]
fn the_width_along_the_isoline_is_twice_the_radius() {
    let (mesh, topology, synthetic) = ring();
    let (rho, radius) = (0.8, 0.25);
    let s = radial_brush(&mesh, &topology, &synthetic.fields(), DVec3::new(rho, 0.0, 0.0), radius).unwrap();
    // The ends: at arc length `radius` along the (polygonal) circle ρ = 0.8, so at angles ±r/ρ.
    let half_angle = radius / rho;
    for (end, sign) in s.ends.iter().zip([-1.0, 1.0]) {
        let angle = end.y.atan2(end.x);
        assert!((angle - sign * half_angle).abs() < 0.01 * half_angle, "{angle} vs {}", sign * half_angle);
        assert!((end.length() - rho).abs() < 2e-3, "on the isoline: ρ = {}", end.length());
    }
    // The selected vertices near the isoline reach the profiles through the ends, no further.
    let h = 3.0 / CELLS as f64;
    let near: Vec<f64> = (0..mesh.num_vertices())
        .filter(|&v| s.selected[v] && (synthetic.u[v] - s.level).abs() < 0.05)
        .map(|v| mesh.positions[v].y.atan2(mesh.positions[v].x))
        .collect();
    let (lo, hi) = near.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &t| (a.min(t), b.max(t)));
    println!("isoline width: selected angles {lo:.3} … {hi:.3}, brush ±{half_angle:.3}");
    assert!(hi <= half_angle + 1e-9 && hi > half_angle - 1.5 * h / rho, "{hi}");
    assert!(lo >= -half_angle - 1e-9 && lo < -half_angle + 1.5 * h / rho, "{lo}");
}

#[test]
fn errors_name_the_fix() {
    let (mesh, topology, synthetic) = ring();
    let fields = synthetic.fields();
    let brush = |centre: DVec3, radius: f64| radial_brush(&mesh, &topology, &fields, centre, radius).unwrap_err();
    assert!(matches!(brush(DVec3::ZERO, 0.2), RadialBrushError::CentreOutside { .. }));
    assert!(matches!(brush(DVec3::new(1.4, 0.0, 0.0), 0.2), RadialBrushError::CentreOutside { .. }));
    assert!(matches!(brush(DVec3::new(0.8, 0.0, 0.0), 0.01), RadialBrushError::RadiusBelowEdges { .. }));
    let around = brush(DVec3::new(0.8, 0.0, 0.0), 2.6);
    assert!(matches!(around, RadialBrushError::RadiusAroundContact { .. }), "{around}");
    assert!(around.to_string().contains("local brush"));
    assert!(matches!(brush(DVec3::new(0.8, 0.0, 0.0), f64::NAN), RadialBrushError::InvalidBrush { .. }));
    let nothing = Synthetic::new(&mesh, &[DVec3::new(9.0, 0.0, 0.0)], 0.1, 0.2);
    let e = radial_brush(&mesh, &topology, &nothing.fields(), DVec3::ZERO, 0.2).unwrap_err();
    assert_eq!(e, RadialBrushError::NoDeformableRegion);
    let short = BrushFields { u: &synthetic.u[1..], ..fields };
    assert!(matches!(
        radial_brush(&mesh, &topology, &short, DVec3::ZERO, 0.2),
        Err(RadialBrushError::LengthMismatch { .. })
    ));
}

#[test]
fn several_zones_are_refused_unless_their_deformed_regions_are_apart() {
    let mesh = shapes::grid(3.0, 3.0, CELLS, CELLS);
    let topology = Topology::new(&mesh);
    // Two zones sharing one deformable region.
    let joined = Synthetic::new(&mesh, &[DVec3::new(-0.5, 0.0, 0.0), DVec3::new(0.5, 0.0, 0.0)], 0.2, 0.8);
    let e = radial_brush(&mesh, &topology, &joined.fields(), DVec3::new(0.0, 0.6, 0.0), 0.2).unwrap_err();
    assert_eq!(e, RadialBrushError::SeveralZones { zones: 2 });
    assert!(e.to_string().contains("use the local brush"));
    // Two zones whose deformable regions are apart: each is painted on its own.
    let apart = Synthetic::new(&mesh, &[DVec3::new(-0.8, 0.0, 0.0), DVec3::new(0.8, 0.0, 0.0)], 0.15, 0.6);
    let s = radial_brush(&mesh, &topology, &apart.fields(), DVec3::new(0.8, 0.45, 0.0), 0.2).unwrap();
    assert!((0..mesh.num_vertices()).any(|v| s.selected[v]));
    assert!(
        (0..mesh.num_vertices()).all(|v| !s.selected[v] || mesh.positions[v].x > 0.0),
        "only the zone under the brush"
    );
}

/// A grid pressed by a rigid sphere on its symmetry axis; no volume preservation, a fixed bulge
/// height (so that η changes each vertex's own displacement only).
fn pressed_grid() -> (TriMesh, Topology, RegionSolver, crate::contact::ContactZone, DeformParams<'static>) {
    let mesh = shapes::grid(3.0, 3.0, CELLS, CELLS);
    let topology = Topology::new(&mesh);
    let solver = RegionSolver::new(&mesh, &topology).unwrap();
    let (radius, depth) = (0.6, 0.12);
    let zone = sphere_zone(&mesh, &topology, DVec3::new(0.0, 0.0, radius - depth), radius);
    let params = DeformParams::new(0.6).with_preserve_volume(false).with_bulge_height(0.03);
    (mesh, topology, solver, zone, params)
}

#[test]
fn on_the_deformers_u_the_selection_is_symmetric_and_the_painted_map_moves_only_the_selection() {
    let (mesh, topology, mut solver, zone, params) = pressed_grid();
    let before = deform_region(&mesh, &topology, &mut solver, &[&zone], &params).unwrap();
    let fields = BrushFields { u: &before.u, contact: &before.contact, deformable: &before.deformable };
    let s = radial_brush(&mesh, &topology, &fields, DVec3::new(0.62, 0.0, 0.0), 0.25).unwrap();
    let count = s.selected.iter().filter(|&&x| x).count();
    // Symmetric about the plane y = 0 through the contact axis and the brush centre.
    let mut asymmetric = 0;
    let mut worst = 0.0f64;
    for v in 0..mesh.num_vertices() {
        asymmetric += usize::from(s.selected[v] != s.selected[mirrored(v)]);
        worst = worst.max((s.weights[v] - s.weights[mirrored(v)]).abs());
    }
    println!("deformer's u: |𝒵| = {count}, {asymmetric} vertices without a mirror, largest w difference {worst:.1e}");
    assert!(count > 100);
    assert_eq!(asymmetric, 0);
    assert!(worst < 1e-6, "{worst}");
    let (lowest, highest) = (0..mesh.num_vertices())
        .filter(|&v| s.selected[v])
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(before.u[v]), hi.max(before.u[v])));
    assert!(lowest < 0.1 && highest > 0.9, "from ∂𝒞 to ∂𝒟: {lowest} … {highest}");

    // An `add` stroke of strength 1: η = 1 + w.
    let map: Vec<f64> = s.weights.iter().map(|w| 1.0 + w).collect();
    let painted = params.clone().with_bulge_map(map);
    let after = deform_region(&mesh, &topology, &mut solver, &[&zone], &painted).unwrap();
    let mut moved_inside = 0;
    for v in 0..mesh.num_vertices() {
        if before.positions[v] != after.positions[v] {
            assert!(s.selected[v], "vertex {v} outside 𝒵 moved");
            moved_inside += 1;
        }
    }
    let rise =
        (0..mesh.num_vertices()).map(|v| (after.positions[v] - before.positions[v]).length()).fold(0.0, f64::max);
    println!("the painted map moved {moved_inside} vertices of 𝒵, at most {rise:.2e}");
    assert!(moved_inside > count / 2);
}

/// Every centre a vertex (the isoline through a vertex, paths through vertices of the
/// icosphere's great circles): the selection closes and spans the profiles.
#[test]
fn on_a_sphere_pressed_by_a_plane_the_selection_closes() {
    let mesh = shapes::icosphere(1.0, 4);
    let topology = Topology::new(&mesh);
    let mut solver = RegionSolver::new(&mesh, &topology).unwrap();
    let zone = crate::deform::test_support::plane_zone(&mesh, &topology, DVec3::Z, -0.75);
    let result = deform_region(&mesh, &topology, &mut solver, &[&zone], &DeformParams::new(0.8)).unwrap();
    let fields = BrushFields { u: &result.u, contact: &result.contact, deformable: &result.deformable };
    let mut failures = Vec::new();
    let mut tried = 0;
    for v in 0..mesh.num_vertices() {
        if !result.deformable[v] || (result.u[v] - 0.5).abs() > 0.1 {
            continue;
        }
        tried += 1;
        match radial_brush(&mesh, &topology, &fields, mesh.positions[v], 0.3) {
            Ok(s) => {
                let us: Vec<f64> = (0..mesh.num_vertices()).filter(|&w| s.selected[w]).map(|w| result.u[w]).collect();
                let (lo, hi) = us.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &u| (a.min(u), b.max(u)));
                assert!(us.len() > 20 && lo < 0.15 && hi > 0.85, "centre {v}: {} vertices, u {lo} … {hi}", us.len());
                assert!(s.weights[v] > 0.9, "centre {v}: w = {}", s.weights[v]);
            }
            Err(e) => failures.push((v, e)),
        }
    }
    println!("{tried} centres, {} failures: {:?}", failures.len(), failures.iter().take(3).collect::<Vec<_>>());
    assert!(tried > 20);
    assert!(failures.is_empty());
}
