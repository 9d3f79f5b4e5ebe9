//! Acceptance tests of the contact definition (the "Must show" list): each asserts a
//! property that a wrong implementation would break, and prints the figures it measured.

use glam::{DMat3, DVec3};

use super::export::{LABEL_CONTACT, LABEL_INTERSECTION, LABEL_MAPPING, LABEL_OUTSIDE};
use super::test_support::*;
use super::*;
use crate::linalg::test_support::Lcg;
use crate::mesh::{mean_edge_length, shapes};
use crate::params::PairParams;
use crate::stage::Stage;
use std::time::Duration;

fn run(a: &Owned, b: &Owned, params: &PairParams) -> PairContact {
    // The thesis' 𝒮 is checked here: the contact gap (tested with the pipeline, in
    // tests/pipeline/gap.rs) is 0 unless a test asks for one.
    let params = PairParams { contact_gap: params.contact_gap.or(Some(0.0)), ..*params };
    contact_pair(&a.side(), &b.side(), &params).unwrap()
}

/// Boundary points of a region as (inside, outside, α).
fn edge_points(region: &EdgeRegion) -> Vec<(u32, u32, f64)> {
    region.points().iter().map(|p| (p.inside, p.outside, p.alpha)).collect()
}

fn assert_same_points(x: &EdgeRegion, y: &EdgeRegion, tolerance: f64, what: &str) {
    let (px, py) = (edge_points(x), edge_points(y));
    assert_eq!(px.len(), py.len(), "{what}: point counts");
    for (p, q) in px.iter().zip(&py) {
        assert_eq!((p.0, p.1), (q.0, q.1), "{what}: point edges");
        assert!((p.2 - q.2).abs() <= tolerance, "{what}: α {} vs {}", p.2, q.2);
    }
}

/// Sphere (a, unit icosphere level 4) dipped h = 0.2 into a flat grid (b).
#[test]
fn sphere_dipped_into_a_plane() {
    let h = 0.2;
    let (sphere, grid) = sphere_in_grid(h, 4, 60);
    let center = sphere_center(h);
    let result = run(&sphere, &grid, &PairParams::default());

    // Intersection points: on the plane, reconstructed exactly from their edge, and within the
    // chord error of the analytic circle of radius √(2h − h²).
    let longest = sphere
        .topology
        .edges()
        .iter()
        .map(|&[i, j]| (sphere.mesh.positions[i as usize] - sphere.mesh.positions[j as usize]).length())
        .fold(0.0, f64::max);
    // Every point of a face of the inscribed polyhedron is at least R − e²/(2R) from the centre.
    let inner = 1.0 - longest * longest / 2.0;
    let zc = center.z;
    let (r_min, r_max) = ((inner * inner - zc * zc).sqrt(), (1.0 - zc * zc).sqrt());
    let analytic = (2.0 * h - h * h).sqrt();
    assert!(r_min < analytic && analytic <= r_max + 1e-12);
    assert!(result.intersection_points.len() > 100);
    let mut worst: f64 = 0.0;
    for p in &result.intersection_points {
        assert!(p.position.z.abs() <= 1e-9, "{p:?}");
        let owner = if p.edge_side == 0 { &sphere } else { &grid };
        let [i, j] = owner.topology.edge(p.edge);
        let on_edge = owner.mesh.positions[i as usize].lerp(owner.mesh.positions[j as usize], p.t);
        assert!((on_edge - p.position).length() < 1e-12, "{p:?} vs {on_edge}");
        let r = (p.position - center).truncate().length();
        assert!(r >= r_min - 1e-12 && r <= r_max + 1e-12, "radius {r} outside [{r_min}, {r_max}]");
        worst = worst.max((r - analytic).abs());
    }
    println!("intersection points: {}, worst |r − √(2h − h²)| = {worst:.2e}", result.intersection_points.len());

    // d̂ is the plane's normal: the plane is flat (zero variation).
    assert!((result.direction - DVec3::Z).length() < 1e-9, "{}", result.direction);
    assert_eq!(result.direction_source, DirectionSource::Automatic);
    assert_eq!(result.stats.fallbacks.numerical(), 0, "{:?}", result.stats.fallbacks);

    // Elastic–elastic: both zones exist. Signs (THESIS-NOTES item 8): penetration is positive,
    // every zone point penetrates at least ε_c > 0, the sphere's n′ points down (outward of the
    // sphere, against d̂) and the plane's up; the sphere moves up, the plane down, to meet on 𝒮.
    let [za, zb] = result.zones();
    assert!(!za.is_empty() && !zb.is_empty());
    assert!(result.criterion.mean > 0.0 && result.threshold() > 0.0);
    for (l, zone) in [za, zb].into_iter().enumerate() {
        let (side, surface) = (&result.sides[l], &result.sides[l].surface);
        for (&v, s) in side.mapping.vertices.iter().zip(&surface.vertex_samples) {
            if zone.region.contains(v) {
                assert!(s.depth >= result.threshold());
                let up = zone.normals[v as usize].z;
                assert!(if l == 0 { up < 0.0 } else { up > 0.0 });
                let lift = zone.targets[v as usize].z - s.position.z;
                assert!(if l == 0 { lift > 0.0 } else { lift < 0.0 });
            }
        }
    }

    // Rigid sphere: 𝒮 is the sphere. Every target of the plane's zone lies on the sphere mesh,
    // and the zone lies within the sphere's shadow (inside the intersection disk).
    let rigid = sphere.clone_with(Stiffness::Rigid);
    let result = run(&rigid, &grid, &PairParams::default());
    let zone = &result.sides[1].zone;
    assert!(zone.region.num_inside() > 50, "{}", zone.region.num_inside());
    let mut on_sphere: f64 = 0.0;
    for v in 0..grid.mesh.num_vertices() as u32 {
        if zone.region.contains(v) {
            on_sphere = on_sphere.max(distance_to(&sphere, zone.targets[v as usize]));
            let p = grid.mesh.positions[v as usize];
            assert!((p - center).truncate().length() < r_max, "zone vertex {v} outside the shadow");
            // The plane is pushed down (along −d̂ = b's d̄ reversed): targets below it.
            assert!(zone.targets[v as usize].z < 0.0);
            assert!(zone.normals[v as usize].dot(DVec3::Z) > 0.5);
        }
    }
    for (k, t) in zone.boundary_targets.iter().enumerate() {
        on_sphere = on_sphere.max(distance_to(&sphere, *t));
        assert!((zone.boundary_positions[k] - center).truncate().length() < r_max);
    }
    assert!(on_sphere <= 1e-9, "targets off the sphere by {on_sphere:e}");
    // The rigid sphere's own zone does not move.
    let za = &result.sides[0].zone;
    for v in 0..sphere.mesh.num_vertices() as u32 {
        if za.region.contains(v) {
            assert!((za.targets[v as usize] - sphere.mesh.positions[v as usize]).length() < 1e-15);
        }
    }
    assert_eq!(zone.direction, DVec3::Z);
    assert_eq!(za.direction, -DVec3::Z);
    println!(
        "rigid sphere: ε_c = {:.4}, m = {:.4}, σ = {:.4}, contact area on 𝒮 = {:.4} (plane side {:.4}), targets on the sphere to {on_sphere:.1e}",
        result.criterion.threshold,
        result.criterion.mean,
        result.criterion.std_dev,
        result.contact_area,
        result.sides[1].zone_area_on_surface
    );
}

/// An elastic sphere pressed into a rigid tilted plane: d̂ is the plane's normal, 𝒮 is the plane,
/// and n′ is the plane's normal on the plane's side and its opposite on the sphere's side.
#[test]
fn a_rigid_tilted_plane_is_the_contact_surface() {
    let tilt = DMat3::from_axis_angle(DVec3::new(1.0, 0.3, 0.0).normalize(), 0.4);
    let normal = tilt * DVec3::Z;
    let mut plane = shapes::grid(3.0, 3.0, 50, 50);
    plane.map_positions(|p| tilt * p);
    let plane = Owned::new(plane, DVec3::ZERO).with_stiffness(Stiffness::Rigid);
    let sphere = Owned::new(shapes::icosphere(1.0, 4), normal * 0.8 + DVec3::new(0.01, 0.02, 0.0));
    let result = run(&sphere, &plane, &PairParams::default());
    assert!((result.direction - normal).length() < 1e-9);
    let [za, zb] = result.zones();
    assert!(za.region.num_inside() > 20 && zb.region.num_inside() > 20);
    for v in 0..za.targets.len() {
        if za.region.contains(v as u32) {
            assert!((za.normals[v] + normal).length() < 1e-9, "{}", za.normals[v]);
            assert!(za.targets[v].dot(normal).abs() < 1e-9);
        }
    }
    for (t, n) in za.boundary_targets.iter().zip(&za.boundary_normals) {
        assert!((*n + normal).length() < 1e-9 && t.dot(normal).abs() < 1e-9);
    }
    for v in 0..zb.targets.len() {
        if zb.region.contains(v as u32) {
            assert!((zb.normals[v] - normal).length() < 1e-9);
            assert_eq!(zb.targets[v], plane.mesh.positions[v]);
        }
    }
}

/// Checks that the result on b is the image of the result on a under `map` (vertex i ↔ i).
fn assert_symmetric(result: &PairContact, map: DMat3, what: &str) {
    let [sa, sb] = &result.sides;
    assert_eq!(sa.intersection.inside(), sb.intersection.inside(), "{what}: ℐ");
    assert_eq!(sa.mapping.region.inside(), sb.mapping.region.inside(), "{what}: ℳ");
    assert_eq!(sa.zone.region.inside(), sb.zone.region.inside(), "{what}: 𝒞");
    assert_same_points(&sa.mapping.region, &sb.mapping.region, 1e-9, what);
    assert_same_points(&sa.zone.region, &sb.zone.region, 1e-9, what);
    let rel = (sa.zone_area_on_surface - sb.zone_area_on_surface).abs() / sa.zone_area_on_surface;
    assert!(rel < 1e-6, "{what}: contact areas {} vs {}", sa.zone_area_on_surface, sb.zone_area_on_surface);
    for v in 0..sa.zone.targets.len() {
        if sa.zone.region.contains(v as u32) {
            assert!((map * sa.zone.targets[v] - sb.zone.targets[v]).length() < 1e-9, "{what}: target {v}");
            assert!((map * sa.zone.normals[v] - sb.zone.normals[v]).length() < 1e-9, "{what}: normal {v}");
        }
    }
    for k in 0..sa.zone.boundary_targets.len() {
        assert!((map * sa.zone.boundary_targets[k] - sb.zone.boundary_targets[k]).length() < 1e-9);
        assert!((map * sa.zone.boundary_normals[k] - sb.zone.boundary_normals[k]).length() < 1e-9);
    }
    assert!((map * result.direction + result.direction).length() < 1e-9, "{what}: d̂ must be reversed by the map");
}

/// Two identical icospheres mirrored through the plane z = 0, equal stiffness: everything is
/// mirror-symmetric, 𝒮 is the mid-plane and its normals are ∓d̂.
#[test]
fn mirrored_spheres_are_symmetric() {
    let a = Owned::new(shapes::icosphere(1.0, 4), DVec3::new(0.05, -0.03, 0.85));
    let mirror = DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0));
    let b = a.image(mirror);
    let result = run(&a, &b, &PairParams::default());
    assert!((result.direction - DVec3::Z).length() < 1e-9);
    assert!(result.sides[0].zone.region.num_inside() > 20);
    assert_symmetric(&result, mirror, "spheres");
    let [sa, sb] = &result.sides;
    for v in 0..sa.zone.targets.len() {
        if sa.zone.region.contains(v as u32) {
            assert!(sa.zone.targets[v].z.abs() < 1e-9);
            assert!((sa.zone.normals[v] + sb.zone.normals[v]).length() < 1e-9);
            assert!((sa.zone.normals[v] + DVec3::Z).length() < 1e-9);
        }
    }
    println!(
        "mirrored spheres: zone {} vertices, contact area {:.6} / {:.6}",
        sa.zone.region.num_inside(),
        sa.zone_area_on_surface,
        sb.zone_area_on_surface
    );
}

/// Two crossed capsules exchanged by the half-turn about (1, 1, 0) — the product of the mirrors
/// z ↦ −z and x ↔ y, a proper rotation, so no triangle needs flipping.
#[test]
fn crossed_capsules_are_symmetric() {
    let capsule = shapes::capsule(0.5, 2.0, 40, 12, 24);
    // Along x, lifted so that the two capsules overlap by 0.2.
    let along_x = DMat3::from_cols(DVec3::new(0.0, 0.0, -1.0), DVec3::Y, DVec3::X);
    let mut mesh = capsule.clone();
    mesh.map_positions(|p| along_x * p);
    let a = Owned::new(mesh, DVec3::new(0.07, 0.0, 0.4));
    let swap = DMat3::from_cols(DVec3::Y, DVec3::X, DVec3::new(0.0, 0.0, -1.0));
    assert!(swap.determinant() > 0.0);
    let b = a.image(swap);
    let result = run(&a, &b, &PairParams::default());
    assert!(result.sides[0].zone.region.num_inside() > 10);
    assert_symmetric(&result, swap, "capsules");
    println!(
        "crossed capsules: d̂ = {:.6}, zone {} vertices, contact area {:.6} / {:.6}",
        result.direction,
        result.sides[0].zone.region.num_inside(),
        result.sides[0].zone_area_on_surface,
        result.sides[1].zone_area_on_surface
    );
}

/// Two spheres of different radii: a (radius 1) above b (radius 1.5), tilted contact.
fn two_spheres(level: u32) -> (Owned, Owned) {
    let axis = DVec3::new(0.3, 0.2, 1.0).normalize();
    let a = Owned::new(shapes::icosphere(1.0, level), axis * (2.5 - 0.15));
    let b = Owned::new(shapes::icosphere(1.5, level), DVec3::ZERO);
    (a, b)
}

/// 𝒮 moves monotonically from b's surface to a's as k̄_a goes 0 → 1 (Fig. 4.5), and larger τ
/// gives smaller zones (Fig. 4.11).
#[test]
fn stiffness_moves_the_surface_and_tau_shrinks_the_zone() {
    let (a, b) = two_spheres(3);
    let ks: [(Stiffness, Stiffness); 7] = [
        (Stiffness::Elastic(1.0), Stiffness::Rigid),
        (Stiffness::Elastic(0.1), Stiffness::Elastic(0.9)),
        (Stiffness::Elastic(0.3), Stiffness::Elastic(0.7)),
        (Stiffness::Elastic(0.5), Stiffness::Elastic(0.5)),
        (Stiffness::Elastic(0.7), Stiffness::Elastic(0.3)),
        (Stiffness::Elastic(0.9), Stiffness::Elastic(0.1)),
        (Stiffness::Rigid, Stiffness::Elastic(1.0)),
    ];
    let mut heights = Vec::new();
    for (k, (sa, sb)) in ks.iter().enumerate() {
        let (a, b) = (a.clone_with(*sa), b.clone_with(*sb));
        let result = run(&a, &b, &PairParams::default());
        let d = result.direction;
        // Mean height along d̂ of 𝒮 over the vertices of ℳ_a (a set independent of stiffness).
        let samples = &result.sides[0].surface.vertex_samples;
        let mean = samples.iter().map(|s| s.target.dot(d)).sum::<f64>() / samples.len() as f64;
        heights.push(mean);
        let own = samples.iter().map(|s| s.position.dot(d)).sum::<f64>() / samples.len() as f64;
        let matched = samples.iter().map(|s| s.matched.dot(d)).sum::<f64>() / samples.len() as f64;
        if k == 0 {
            // b rigid: 𝒮 is b; a's zone targets lie on b.
            assert!((mean - matched).abs() < 1e-12);
            let zone = &result.sides[0].zone;
            for v in 0..zone.targets.len() {
                if zone.region.contains(v as u32) {
                    assert!(distance_to(&b, zone.targets[v]) < 1e-9);
                }
            }
            assert!(zone.boundary_targets.iter().all(|t| distance_to(&b, *t) < 1e-9));
        }
        if k == ks.len() - 1 {
            // a rigid: 𝒮 is a; b's zone targets lie on a.
            assert!((mean - own).abs() < 1e-12);
            let zone = &result.sides[1].zone;
            assert!(zone.region.num_inside() > 0);
            for v in 0..zone.targets.len() {
                if zone.region.contains(v as u32) {
                    assert!(distance_to(&a, zone.targets[v]) < 1e-9);
                }
            }
            assert!(zone.boundary_targets.iter().all(|t| distance_to(&a, *t) < 1e-9));
        }
    }
    println!("mean height of 𝒮 along d̂ over ℳ_a for k̄_a = 0, .1, .3, .5, .7, .9, 1: {heights:.5?}");
    for w in heights.windows(2) {
        assert!(w[1] < w[0], "not monotonic: {heights:?}");
    }

    let mut areas = Vec::new();
    let mut thresholds = Vec::new();
    for tau in [-1.0, -0.5, 0.0, 0.5, 1.0] {
        let result = run(&a, &b, &PairParams::default().with_contact_tau(tau));
        areas.push(result.contact_area);
        thresholds.push(result.threshold());
    }
    println!("τ = −1, −½, 0, ½, 1: contact areas {areas:.5?}, ε_c {thresholds:.5?}");
    for w in areas.windows(2) {
        assert!(w[1] < w[0], "area not decreasing with τ: {areas:?}");
    }
    for w in thresholds.windows(2) {
        assert!(w[1] > w[0]);
    }
}

/// The object moves by steps of 1e-4 of its size over 200 positions: the contact area, ε_c and d̂
/// change by at most a constant times the step, also when the zone boundary crosses vertices.
#[test]
fn results_are_continuous_when_an_object_moves() {
    // Level 5 (10242 vertices each): the boundary crosses tens of vertices over the motion.
    let (mut a, b) = two_spheres(5);
    let size = 2.0; // diameter of a
    let step = 1e-4 * size;
    let motion = DVec3::new(1.0, 0.5, -0.7).normalize() * step;
    // (contact area, ε_c, d̂, zone flags of a and b) at the previous position.
    type State = (f64, f64, DVec3, Vec<bool>, Vec<bool>);
    let mut previous: Option<State> = None;
    let (mut max_area, mut max_eps, mut max_dir): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let mut crossings = 0;
    for k in 0..200 {
        let result = run(&a, &b, &PairParams::default());
        assert_eq!(result.stats.fallbacks.numerical(), 0, "step {k}: {:?}", result.stats.fallbacks);
        let zones = [result.sides[0].zone.region.inside().to_vec(), result.sides[1].zone.region.inside().to_vec()];
        if std::env::var("SQUISH_DEBUG").is_ok() {
            println!(
                "{k}: zone {:?} M {:?} area {:.6} eps {:.6} d {:.6}",
                [result.sides[0].zone.region.num_inside(), result.sides[1].zone.region.num_inside()],
                [result.sides[0].mapping.region.num_inside(), result.sides[1].mapping.region.num_inside()],
                result.contact_area,
                result.threshold(),
                result.direction
            );
        }
        if let Some((area, eps, dir, za, zb)) = &previous {
            max_area = max_area.max((result.contact_area - area).abs() / step);
            max_eps = max_eps.max((result.threshold() - eps).abs() / step);
            max_dir = max_dir.max((result.direction - *dir).length() / step);
            let changed = za != &zones[0] || zb != &zones[1];
            crossings += usize::from(changed);
        }
        previous =
            Some((result.contact_area, result.threshold(), result.direction, zones[0].clone(), zones[1].clone()));
        a.translate(motion);
    }
    // Bounds from the geometry: the contact radius ρ ≈ 0.5, perimeter ≈ 3; the zone boundary
    // moves at most ~ a few times the step, so |Δarea| ≲ perimeter × that; ε_c follows the depth.
    let perimeter = 3.0;
    println!(
        "continuity over 200 steps of {step:e}: max |Δarea|/step = {max_area:.3}, max |Δε_c|/step = {max_eps:.3}, \
         max |Δd̂|/step = {max_dir:.3}; zone vertex sets changed at {crossings} steps"
    );
    assert!(crossings >= 10, "the motion must make the zone boundary cross vertices ({crossings})");
    assert!(max_area <= 50.0 * perimeter, "area jumped: {max_area}");
    assert!(max_eps <= 50.0, "ε_c jumped: {max_eps}");
    assert!(max_dir <= 50.0, "d̂ jumped: {max_dir}");
}

/// A rigid motion of both inputs moves every output rigidly.
#[test]
fn rigid_motion_moves_the_result_rigidly() {
    let (a, b) = two_spheres(3);
    let rotation = DMat3::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let translation = DVec3::new(0.3, -1.2, 2.5);
    let (a2, b2) = (a.transformed(rotation, translation), b.transformed(rotation, translation));
    let r1 = run(&a, &b, &PairParams::default());
    let r2 = run(&a2, &b2, &PairParams::default());
    let tol = 1e-9;
    assert!((rotation * r1.direction - r2.direction).length() < tol);
    assert!((r1.threshold() - r2.threshold()).abs() < tol);
    assert!((r1.criterion.mean - r2.criterion.mean).abs() < tol);
    assert!((r1.criterion.std_dev - r2.criterion.std_dev).abs() < tol);
    assert!((r1.contact_area - r2.contact_area).abs() < tol);
    assert_eq!(r1.intersection_points.len(), r2.intersection_points.len());
    for l in 0..2 {
        let (s1, s2) = (&r1.sides[l], &r2.sides[l]);
        assert!((s1.zone_area_on_surface - s2.zone_area_on_surface).abs() < tol);
        assert_eq!(s1.intersection.inside(), s2.intersection.inside());
        assert_eq!(s1.mapping.region.inside(), s2.mapping.region.inside());
        assert_eq!(s1.zone.region.inside(), s2.zone.region.inside());
        assert_same_points(&s1.intersection, &s2.intersection, tol, "ℐ");
        assert_same_points(&s1.mapping.region, &s2.mapping.region, tol, "ℳ");
        assert_same_points(&s1.zone.region, &s2.zone.region, tol, "𝒞");
        let (z1, z2) = (&s1.zone, &s2.zone);
        for v in 0..z1.targets.len() {
            assert!((rotation * z1.targets[v] + translation - z2.targets[v]).length() < tol);
            assert!((rotation * z1.normals[v] - z2.normals[v]).length() < tol);
        }
        for k in 0..z1.boundary_targets.len() {
            assert!((rotation * z1.boundary_positions[k] + translation - z2.boundary_positions[k]).length() < tol);
            assert!((rotation * z1.boundary_targets[k] + translation - z2.boundary_targets[k]).length() < tol);
            assert!((rotation * z1.boundary_normals[k] - z2.boundary_normals[k]).length() < tol);
        }
        assert!((rotation * z1.direction - z2.direction).length() < tol);
    }
    assert!(r1.sides[0].zone.region.num_inside() > 0);
}

/// A small sphere poking through a coarse plane between its vertices: ℐ on the plane is empty
/// (the crossings are not representable there), so d̂ comes from the sphere alone (−n̄_a), and the
/// pipeline still gives a zone on the sphere.
#[test]
fn a_tip_between_vertices_uses_the_other_side_for_the_direction() {
    let grid = Owned::new(shapes::grid(1.0, 1.0, 10, 10), DVec3::ZERO);
    let center = DVec3::new(0.013, -0.021, 0.01);
    let sphere = Owned::new(shapes::icosphere(0.02, 3), center);
    let result = run(&sphere, &grid, &PairParams::default());
    assert_eq!(result.direction_source, DirectionSource::OnlyFirst);
    assert!(result.sides[1].intersection.is_empty());
    assert!((result.direction - DVec3::Z).length() < 0.02, "{}", result.direction);
    assert!((result.direction + result.sides[0].normal_stats.mean).length() < 1e-15);
    assert!(!result.sides[0].zone.is_empty());
    assert!(result.sides[1].zone.is_empty());
}

#[test]
fn no_intersection_gives_an_empty_result() {
    let (mut sphere, grid) = sphere_in_grid(0.2, 3, 20);
    sphere.translate(DVec3::new(0.0, 0.0, 0.5));
    let result = run(&sphere, &grid, &PairParams::default());
    assert!(result.is_empty());
    assert!(result.intersection_points.is_empty());
    assert_eq!(result.direction, DVec3::ZERO);
    assert_eq!(result.direction_source, DirectionSource::None);
    assert_eq!(result.contact_area, 0.0);
    // Zones are sized for the meshes, so that consumers can index them.
    assert_eq!(result.sides[1].zone.targets.len(), grid.mesh.num_vertices());
    assert_eq!(result.sides[0].zone.region.inside().len(), sphere.mesh.num_vertices());
    let user = PairParams::default().with_direction(Some(DVec3::new(0.0, 0.0, 3.0)));
    let result = run(&sphere, &grid, &user);
    assert_eq!((result.direction, result.direction_source), (DVec3::Z, DirectionSource::User));
}

#[test]
fn a_user_direction_overrides_the_automatic_one() {
    let (sphere, grid) = sphere_in_grid(0.2, 3, 40);
    let d = DVec3::new(0.2, -0.1, 1.0);
    let result = run(&sphere, &grid, &PairParams::default().with_direction(Some(d)));
    assert_eq!(result.direction_source, DirectionSource::User);
    assert!(!result.direction_source.is_automatic());
    assert!((result.direction - d.normalize()).length() < 1e-15);
    assert!(!result.is_empty());
    // Matches of the plane's mapping vertices lie on lines along d̂.
    let side = &result.sides[1];
    for s in &side.surface.vertex_samples {
        assert!(s.displacement().cross(result.direction).length() < 1e-9);
    }
    let err = contact_pair(&sphere.side(), &grid.side(), &PairParams::default().with_direction(Some(DVec3::ZERO)));
    let err = err.unwrap_err();
    assert!(matches!(err, ContactError::Parameter(_)), "{err}");
    assert!(err.to_string().starts_with("pair parameter direction = [0, 0, 0]: must be a non-zero vector"), "{err}");
}

#[test]
fn errors_name_their_cause() {
    let (sphere, grid) = sphere_in_grid(0.2, 3, 20);
    let both_rigid = contact_pair(
        &sphere.side().with_stiffness(Stiffness::Rigid),
        &grid.side().with_stiffness(Stiffness::Rigid),
        &PairParams::default(),
    );
    assert!(matches!(both_rigid, Err(ContactError::BothRigid)));
    let short = vec![DVec3::Z; 3];
    let mut side = grid.side().with_name("floor");
    side.normals = &short;
    let err = contact_pair(&sphere.side(), &side, &PairParams::default()).unwrap_err();
    assert!(err.to_string().contains("floor") && err.to_string().contains("normals"), "{err}");
    // A cut working region that the intersection reaches.
    let small = Owned::new(shapes::grid(1.0, 1.0, 10, 10), DVec3::ZERO);
    let border = small.topology.boundary_vertices();
    let err =
        contact_pair(&sphere.side(), &small.side().with_border(Some(&border)), &PairParams::default()).unwrap_err();
    assert!(matches!(err, ContactError::IntersectionReachesBorder { ref object, .. } if object == "b"), "{err}");
}

#[test]
fn results_are_deterministic_whatever_the_thread_count() {
    let (a, b) = two_spheres(3);
    let single = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let r1 = single.install(|| run(&a, &b, &PairParams::default()));
    let r2 = run(&a, &b, &PairParams::default());
    assert_eq!(r1.direction.to_array().map(f64::to_bits), r2.direction.to_array().map(f64::to_bits));
    assert_eq!(r1.threshold().to_bits(), r2.threshold().to_bits());
    assert_eq!(r1.intersection_points, r2.intersection_points);
    for l in 0..2 {
        assert_eq!(r1.sides[l].zone.region, r2.sides[l].zone.region);
        assert_eq!(r1.sides[l].zone.targets, r2.sides[l].zone.targets);
        assert_eq!(r1.sides[l].zone.boundary_targets, r2.sides[l].zone.boundary_targets);
        assert_eq!(r1.sides[l].mapping, r2.sides[l].mapping);
    }
}

#[test]
fn debug_export_labels_and_points() {
    let (a, b) = two_spheres(3);
    let result = run(&a, &b, &PairParams::default());
    let export = debug_export(&result, [&a.mesh, &b.mesh]);
    for (l, side) in export.iter().enumerate() {
        let s = &result.sides[l];
        assert_eq!(side.labels.len(), [&a, &b][l].mesh.num_vertices());
        for (v, &label) in side.labels.iter().enumerate() {
            let v = v as u32;
            let expected = if s.zone.region.contains(v) {
                LABEL_CONTACT
            } else if s.mapping.region.contains(v) {
                LABEL_MAPPING
            } else if s.intersection.contains(v) {
                LABEL_INTERSECTION
            } else {
                LABEL_OUTSIDE
            };
            assert_eq!(label, expected);
        }
        let count = |kind| side.points.iter().filter(|p| p.kind == kind).count();
        assert_eq!(count(BoundaryKind::Intersection), s.intersection.points().len());
        assert_eq!(count(BoundaryKind::Mapping), s.mapping.region.points().len());
        assert_eq!(count(BoundaryKind::Contact), s.zone.region.points().len());
        assert!(side.labels.contains(&LABEL_CONTACT));
    }
    let json = serde_json::to_string(&export[0]).unwrap();
    assert!(json.contains("Contact"));
}

/// Timings for a pair of ~10k-vertex working regions (the thesis' C++ took 5–170 ms per frame on
/// 1–12k-vertex regions).
#[test]
fn timings_for_a_ten_thousand_vertex_pair() {
    let a = Owned::new(shapes::icosphere(1.0, 5), DVec3::new(0.013, -0.021, 0.75));
    let b = Owned::new(shapes::grid(3.0, 3.0, 100, 100), DVec3::ZERO);
    let (c, d) = (
        Owned::new(shapes::icosphere(1.0, 5), DVec3::new(0.2, 0.1, 0.9)),
        Owned::new(shapes::icosphere(1.0, 5), DVec3::new(0.0, 0.0, -0.9)),
    );
    for (name, a, b) in [("sphere–plane", &a, &b), ("sphere–sphere", &c, &d)] {
        let mut best = None::<ContactStats>;
        let mut result = None;
        for _ in 0..5 {
            let r = run(a, b, &PairParams::default());
            if best.is_none_or(|t| r.stats.time < t.time) {
                best = Some(r.stats);
            }
            result = Some(r);
        }
        let (s, r) = (best.unwrap(), result.unwrap());
        let stages: Vec<String> = Stage::spans()
            .filter(|&st| s.timings[st] > Duration::ZERO)
            .map(|st| format!("{st} {:?}", s.timings[st]))
            .collect();
        println!(
            "{name} ({} + {} vertices, h ≈ {:.3}): total {:?} = {}; counts {:?}",
            a.mesh.num_vertices(),
            b.mesh.num_vertices(),
            mean_edge_length(&a.mesh, &a.topology),
            s.time,
            stages.join(" + "),
            r.stats.counts
        );
        assert!(!r.is_empty());
        assert!(s.time.as_secs_f64() < 2.0);
    }
}

/// Random placements of various shapes, plus degenerate ones (coincident surfaces, a sphere
/// touching a cube's edges and corners): never a panic, and every output finite.
#[test]
fn random_and_degenerate_configurations_give_finite_results() {
    let mut lcg = Lcg::from_state(0x5eed);
    let mut rand = move || lcg.next_unit();
    let shapes_a = [shapes::icosphere(0.6, 3), shapes::cube(1.0, 4), shapes::capsule(0.3, 1.0, 16, 6, 8)];
    let shapes_b = [shapes::grid(3.0, 3.0, 30, 30), shapes::icosphere(1.0, 3), shapes::cube(1.2, 6)];
    let mut non_empty = 0;
    let mut cases: Vec<(Owned, Owned)> = Vec::new();
    for k in 0..36 {
        let axis = DVec3::new(rand() - 0.5, rand() - 0.5, rand() - 0.5);
        let rotation = DMat3::from_axis_angle(axis.try_normalize().unwrap_or(DVec3::Z), 6.0 * rand());
        let offset = DVec3::new(rand() - 0.5, rand() - 0.5, rand() - 0.5) * 1.2;
        let a = Owned::new(shapes_a[k % 3].clone(), DVec3::ZERO).transformed(rotation, offset);
        let b = Owned::new(shapes_b[(k / 3) % 3].clone(), DVec3::ZERO);
        cases.push((a, b));
    }
    // Coincident surfaces, and a sphere through the corners and edges of a cube exactly.
    cases
        .push((Owned::new(shapes::icosphere(1.0, 3), DVec3::ZERO), Owned::new(shapes::icosphere(1.0, 3), DVec3::ZERO)));
    cases.push((
        Owned::new(shapes::cube(1.0, 2), DVec3::ZERO),
        Owned::new(shapes::cube(1.0, 2), DVec3::new(0.5, 0.5, 0.5)),
    ));
    cases.push((
        Owned::new(shapes::icosphere(3f64.sqrt() / 2.0, 2), DVec3::ZERO),
        Owned::new(shapes::cube(1.0, 1), DVec3::ZERO),
    ));
    for (k, (a, b)) in cases.iter().enumerate() {
        let result = match contact_pair(&a.side(), &b.side(), &PairParams::default()) {
            Ok(r) => r,
            Err(ContactError::DirectionUndefined) => continue,
            Err(e) => panic!("case {k}: {e}"),
        };
        non_empty += usize::from(!result.is_empty());
        if std::env::var("SQUISH_DEBUG").is_ok() {
            println!(
                "case {k}: {:?} {:?} {:?}",
                result.direction_source, result.stats.counts.zone_vertices, result.stats.fallbacks
            );
        }
        assert!(result.direction.is_finite() && result.threshold().is_finite(), "case {k}");
        assert!(result.contact_area.is_finite() && result.contact_area >= 0.0, "case {k}");
        for side in &result.sides {
            let z = &side.zone;
            assert!(z.targets.iter().chain(&z.normals).chain(&z.boundary_targets).all(|p| p.is_finite()), "case {k}");
            assert!(z.boundary_normals.iter().all(|n| (n.length() - 1.0).abs() < 1e-9), "case {k}");
        }
    }
    println!("{non_empty} of {} configurations have a contact zone", cases.len());
    assert!(non_empty >= 10);
}

/// The threshold's floor and cap (self-contact's settings): ε_c = min(max(m + τσ, −P), max).
#[test]
fn the_threshold_floor_and_cap_bound_the_criterion() {
    let (a, b) = two_spheres(3);
    let free = run(&a, &b, &PairParams { contact_tau: -3.0, ..PairParams::default() });
    assert_eq!(free.criterion.penetration, 0.0, "computed only with a floor");
    let floored =
        run(&a, &b, &PairParams { contact_tau: -3.0, contact_threshold_floor: Some(0.25), ..PairParams::default() });
    let depth = floored.criterion.penetration;
    println!(
        "τ = −3: ε_c {:.5}; typical penetration P {depth:.5}; floored ε_c {:.5}",
        free.threshold(),
        floored.threshold()
    );
    assert!(depth > 0.0);
    assert!(free.threshold() < -0.25 * depth, "the test needs a threshold below −P/4");
    assert_eq!(floored.threshold(), -0.25 * depth);
    println!("contact areas: τ = −3 {:.5}, floored {:.5}", free.contact_area, floored.contact_area);
    assert!(floored.contact_area <= free.contact_area);
    let tighter =
        run(&a, &b, &PairParams { contact_tau: -3.0, contact_threshold_floor: Some(0.1), ..PairParams::default() });
    assert_eq!(tighter.threshold(), -0.1 * tighter.criterion.penetration);
    assert!(tighter.contact_area <= floored.contact_area);
    let capped =
        run(&a, &b, &PairParams { contact_tau: 2.0, max_contact_threshold: Some(0.0), ..PairParams::default() });
    let uncapped = run(&a, &b, &PairParams { contact_tau: 2.0, ..PairParams::default() });
    assert!(uncapped.threshold() > 0.0, "the test needs a positive threshold");
    assert_eq!(capped.threshold(), 0.0);
    assert!(capped.contact_area > uncapped.contact_area);
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let params = PairParams { contact_threshold_floor: Some(bad), ..PairParams::default() };
        assert!(contact_pair(&a.side(), &b.side(), &params).is_err(), "floor {bad}");
    }
}
