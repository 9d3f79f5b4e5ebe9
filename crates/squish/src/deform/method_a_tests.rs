//! Tests of method A's alternatives through both stages (contact definition, then deformation):
//! methods A and B agree where both apply (thesis Fig. 7.14), both direction fields are fold-free
//! on deep collisions, and the parallel-transport field's cost on a ~10k-vertex region.
//!
//! These tests call [`contact_pair`] and [`deform_region`] directly, to look at each stage; the
//! same choices through the pipeline's `Deformer` (`ObjectParams::direction_field`,
//! `ObjectParams::uvs`, `PairParams::{contact_method, mapping}`) are tested in the pipeline's
//! tests (`crates/squish/tests/pipeline`).

#![allow(clippy::unwrap_used)]

use std::time::Instant;

use glam::{DQuat, DVec3};

use super::direction_field::blend_weight;
use super::parametrize::{ParametrizeParams, parametrize};
use super::transport::transport_field;
use super::{ContactSet, DeformParams, RegionDeformation, RegionSolver, automatic_extent, deform_region, object_size};
use crate::contact::{ContactSide, ContactZone, PairContact, Stiffness, contact_pair};
use crate::mesh::{Topology, TriMesh, face_normal_unnormalized, shapes, vertex_normals};
use crate::params::{DirectionFieldMethod, PairParams};
use crate::spatial::TriangleBvh;
use crate::stage::Stage;

/// A working region with what the contact stage borrows.
struct Object {
    mesh: TriMesh,
    topology: Topology,
    normals: Vec<DVec3>,
    bvh: TriangleBvh,
    stiffness: Stiffness,
}

impl Object {
    fn new(mesh: TriMesh, stiffness: Stiffness) -> Self {
        let topology = Topology::new(&mesh);
        let normals = vertex_normals(&mesh);
        let bvh = TriangleBvh::new(&mesh).unwrap();
        Self { mesh, topology, normals, bvh, stiffness }
    }

    fn side(&self) -> ContactSide<'_> {
        ContactSide::new(&self.mesh, &self.topology, &self.normals, &self.bvh).with_stiffness(self.stiffness)
    }
}

/// The mean edge length of a mesh (the automatic extent's floor).
fn mean_edge(mesh: &TriMesh) -> f64 {
    crate::mesh::mean_edge_length(mesh, &Topology::new(mesh))
}

fn translated(mut mesh: TriMesh, offset: DVec3) -> TriMesh {
    mesh.map_positions(|p| p + offset);
    mesh
}

/// A closed elastic block `width` × `width` × 4 with its top face at z = 0 and `cells` cells along
/// every axis. The balls of §4.4.1 must roll inside it without reaching its other faces.
fn block(width: f64, cells: u32) -> Object {
    Object::new(
        translated(shapes::cuboid(DVec3::new(width, width, 4.0), cells), DVec3::new(0.0, 0.0, -2.0)),
        Stiffness::default(),
    )
}

/// A rigid unit sphere whose bottom is `depth` below z = 0 (off the symmetry axes).
fn rigid_sphere(depth: f64, level: u32) -> Object {
    Object::new(translated(shapes::icosphere(1.0, level), DVec3::new(0.013, -0.021, 1.0 - depth)), Stiffness::Rigid)
}

fn contact(a: &Object, b: &Object, params: &PairParams) -> PairContact {
    contact_pair(&a.side(), &b.side(), params).unwrap()
}

fn deform(object: &Object, zones: &[&ContactZone], extent: f64, method: DirectionFieldMethod) -> RegionDeformation {
    let mut solver = RegionSolver::new(&object.mesh, &object.topology).unwrap();
    let params = DeformParams::new(extent).with_direction_field(method);
    deform_region(&object.mesh, &object.topology, &mut solver, zones, &params).unwrap()
}

/// Symmetric Hausdorff distance between two meshes, vertex to mesh both ways.
fn hausdorff(a: &TriMesh, b: &TriMesh) -> f64 {
    let one_way = |x: &TriMesh, y: &TriMesh| {
        let tree = TriangleBvh::new(y).unwrap();
        x.positions.iter().map(|&p| tree.closest_point(p).unwrap().distance).fold(0.0, f64::max)
    };
    one_way(a, b).max(one_way(b, a))
}

/// Faces whose orientation flipped (normals before and after at more than 90°).
fn flipped_faces(mesh: &TriMesh, positions: &[DVec3]) -> usize {
    mesh.triangles
        .iter()
        .filter(|t| {
            let [a, b, c] = t.map(|v| mesh.positions[v as usize]);
            let [a2, b2, c2] = t.map(|v| positions[v as usize]);
            face_normal_unnormalized(a, b, c).dot(face_normal_unnormalized(a2, b2, c2)) <= 0.0
        })
        .count()
}

fn with_positions(mesh: &TriMesh, positions: &[DVec3]) -> TriMesh {
    TriMesh { positions: positions.to_vec(), triangles: mesh.triangles.clone() }
}

/// Thesis Fig. 7.14: a rigid sphere pressed 0.3 into an elastic slab, contact by the geometric
/// criterion (τ = 0, method B) and by ball testing (method A) with the radius whose zone has the
/// same area on 𝒮 — "a comparable radius" — deformed with the same parameters. The deformed
/// slabs nearly coincide.
#[test]
fn methods_a_and_b_agree_where_both_apply() {
    let depth = 0.3;
    let (sphere, slab) = (rigid_sphere(depth, 4), block(6.0, 72));
    let b = contact(&sphere, &slab, &PairParams::default());
    let target_area = b.contact_area;
    // Ball-rolling area 2πh/(1 + r) (see the ball tests) gives the first guess; a few secant
    // steps match the measured areas.
    let area_of = |r: f64| contact(&sphere, &slab, &PairParams::default().with_ball(r)).contact_area;
    // Fig. 4.10 on the closed slab: larger balls, smaller zones, as the ball-rolling area
    // 2πh/(1 + r_s) (the block is wide and deep enough for these balls).
    let radii = [0.05, 0.2, 0.4, 0.8, 1.2];
    let areas: Vec<f64> = radii.iter().map(|&r| area_of(r)).collect();
    for (&r, &area) in radii.iter().zip(&areas) {
        let analytic = 2.0 * std::f64::consts::PI * depth / (1.0 + r);
        assert!((area / analytic - 1.0).abs() < 0.06, "r_s = {r}: {area} vs {analytic}");
    }
    println!(
        "closed slab, sphere 0.3 deep: ball-tested areas {:?} for r_s = {radii:?}",
        areas.iter().map(|a| (a * 1e4).round() / 1e4).collect::<Vec<_>>()
    );
    assert!(areas.windows(2).all(|w| w[1] < w[0]), "{areas:?}");
    let mut r = (2.0 * std::f64::consts::PI * depth / target_area - 1.0).max(0.01);
    let mut previous = (r * 1.1, area_of(r * 1.1));
    for _ in 0..8 {
        let area = area_of(r);
        if (area - target_area).abs() < 1e-4 * target_area {
            break;
        }
        let slope = (area - previous.1) / (r - previous.0);
        previous = (r, area);
        r = (r - (area - target_area) / slope).clamp(0.01, 1.5);
    }
    let params_a = PairParams::default().with_ball(r);
    let a = contact(&sphere, &slab, &params_a);
    let extent = automatic_extent(object_size(&slab.mesh), target_area, mean_edge(&slab.mesh));
    fn zones(c: &PairContact) -> Vec<&ContactZone> {
        vec![&c.sides[1].zone]
    }
    let method_b = deform(&slab, &zones(&b), extent, DirectionFieldMethod::Blended);
    let method_a = deform(&slab, &zones(&a), extent, DirectionFieldMethod::ParallelTransport);
    let ball_blended = deform(&slab, &zones(&a), extent, DirectionFieldMethod::Blended);
    let mesh_of = |d: &RegionDeformation| with_positions(&slab.mesh, &d.positions);
    let full = hausdorff(&mesh_of(&method_a), &mesh_of(&method_b));
    let zones_only = hausdorff(&mesh_of(&ball_blended), &mesh_of(&method_b));
    let fields_only = hausdorff(&mesh_of(&method_a), &mesh_of(&ball_blended));
    let largest =
        method_b.positions.iter().zip(&slab.mesh.positions).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
    println!(
        "Fig. 7.14, sphere 0.3 deep in a slab: geometric zone area {target_area:.4}, ball radius r_s = {r:.4} (area {:.4}); \
         extent {extent:.3}; largest displacement {largest:.3}. Hausdorff distances: A (ball + transport) vs B (geometric + \
         blended) {full:.4} = {:.1}% of the depth; ball + blended vs B {zones_only:.4}; transport vs blended on the ball zone \
         {fields_only:.4}",
        a.contact_area,
        100.0 * full / depth,
    );
    assert!((a.contact_area / target_area - 1.0).abs() < 1e-2, "the radius was not calibrated");
    // The two zones are the same disc up to the discretization of their boundaries (an edge is
    // 0.083 here); the displacements differ by where ∂𝒞 falls times the slope there and by how the
    // two direction fields turn towards the normals. A wrong zone, side or sign moves the surface
    // by about the whole depth; 10% of it is far below that and twice what we measure.
    assert!(full < 0.1 * depth, "methods A and B disagree by {full}");
    assert!(zones_only < 0.1 * depth, "ball testing and the geometric criterion disagree by {zones_only}");
    for d in [&method_a, &method_b, &ball_blended] {
        assert!(d.stats.volume_exact && d.stats.fallbacks.volume_without_root == 0);
        assert_eq!(flipped_faces(&slab.mesh, &d.positions), 0);
    }
}

/// The parallel-transport field's constraints on a deformation: the largest angle between the
/// field (interpolated at the boundary points) and its targets at ∂𝒞, and the normal at ∂𝒟.
fn transport_constraint_angles(object: &Object, zones: &[&ContactZone], extent: f64) -> (f64, f64) {
    let mut solver = RegionSolver::new(&object.mesh, &object.topology).unwrap();
    let contact = ContactSet::new(&object.mesh, &object.topology, zones).unwrap();
    let params = ParametrizeParams::new(extent);
    let p = parametrize(&object.mesh, &object.topology, &mut solver, &contact, &params).unwrap();
    let normals = vertex_normals(&object.mesh);
    let field = transport_field(&object.mesh, &mut solver, &contact, &p, &normals).unwrap();
    let at_c = contact
        .boundary
        .iter()
        .zip(&field.boundary)
        .map(|(b, t)| field.direction_at(&normals, b.point.inside, b.point.outside, b.point.alpha).angle_between(*t))
        .fold(0.0, f64::max);
    let at_d = field
        .outer_points
        .iter()
        .map(|&(i, j, alpha)| {
            let n = normals[i as usize].lerp(normals[j as usize], alpha).normalize();
            field.direction_at(&normals, i, j, alpha).angle_between(n)
        })
        .fold(0.0, f64::max);
    (at_c.to_degrees(), at_d.to_degrees())
}

/// Deep collisions — a rigid sphere pressed 0.6 (60% of its radius) into the slab, the same along
/// a user mapping direction tilted by 20° (so that the slab's targets at ∂𝒞 leave its normal), and
/// a rigid capsule pressed 0.4 into an elastic sphere of radius 1 — deformed with both direction
/// fields: no face flips, and the transport field meets its constraints.
#[test]
fn both_direction_fields_are_fold_free_on_deep_collisions() {
    let capsule = {
        let mut mesh = shapes::capsule(0.5, 2.0, 48, 12, 24);
        let along_x = DQuat::from_rotation_y(std::f64::consts::FRAC_PI_2);
        mesh.map_positions(|p| along_x * p + DVec3::new(0.017, 0.011, 1.5 - 0.4));
        Object::new(mesh, Stiffness::Rigid)
    };
    let tilted = PairParams::default().with_direction(Some(DVec3::new(20f64.to_radians().tan(), 0.0, 1.0)));
    let scenes = [
        ("sphere 0.6 deep in a slab", rigid_sphere(0.6, 4), block(4.0, 48), PairParams::default()),
        ("sphere 0.6 deep in a slab, d̂ tilted 20°", rigid_sphere(0.6, 4), block(4.0, 48), tilted),
        (
            "capsule 0.4 deep in a sphere",
            capsule,
            Object::new(shapes::icosphere(1.0, 5), Stiffness::default()),
            PairParams::default(),
        ),
    ];
    for (name, rigid, elastic, pair_params) in &scenes {
        let c = contact(rigid, elastic, pair_params);
        let zones = [&c.sides[1].zone];
        assert!(!zones[0].is_empty());
        let extent = automatic_extent(object_size(&elastic.mesh), c.contact_area, mean_edge(&elastic.mesh));
        for method in [DirectionFieldMethod::Blended, DirectionFieldMethod::ParallelTransport] {
            let d = deform(elastic, &zones, extent, method);
            let flips = flipped_faces(&elastic.mesh, &d.positions);
            // How far the field turns from the normal inside 𝒟 (the deep case is the hard one).
            let normals = vertex_normals(&elastic.mesh);
            let turn = (0..normals.len())
                .filter(|&v| d.deformable[v])
                .map(|v| d.directions[v].angle_between(normals[v]).to_degrees())
                .fold(0.0, f64::max);
            println!(
                "{name}, {method:?}: |𝒞| = {}, |𝒟| = {}, extent {extent:.3}, flipped faces {flips}, largest angle d/n in 𝒟 {turn:.1}°, volume exact {}",
                d.stats.num_contact, d.stats.num_deformable, d.stats.volume_exact
            );
            assert_eq!(flips, 0, "{name}, {method:?}: faces flipped");
            assert!(d.positions.iter().all(|p| p.is_finite()));
        }
        let (at_c, at_d) = transport_constraint_angles(elastic, &zones, extent);
        println!("{name}: transport field vs its targets at ∂𝒞 ≤ {at_c:.2}°, vs the normal at ∂𝒟 ≤ {at_d:.2}°");
        assert!(at_c < 3.0, "{name}: ∂𝒞 constraint off by {at_c}°");
        assert!(at_d < 3.0, "{name}: ∂𝒟 constraint off by {at_d}°");
    }
    // The blended field's weight is what the transport field's u/u′ correction replaces.
    assert_eq!(blend_weight(1.0), 0.0);
}

/// Cost of the two direction fields on a ~10k-vertex deformable region.
#[test]
fn direction_field_timings_on_a_ten_thousand_vertex_region() {
    let elastic = Object::new(shapes::icosphere(1.0, 5), Stiffness::default());
    let rigid = Object::new(translated(shapes::icosphere(1.0, 4), DVec3::new(0.02, -0.01, 1.7)), Stiffness::Rigid);
    let c = contact(&rigid, &elastic, &PairParams::default());
    let zones = [&c.sides[1].zone];
    let extent = 1.5;
    for method in [DirectionFieldMethod::Blended, DirectionFieldMethod::ParallelTransport] {
        let mut solver = RegionSolver::new(&elastic.mesh, &elastic.topology).unwrap();
        let params = DeformParams::new(extent).with_direction_field(method);
        let mut best = (f64::INFINITY, f64::INFINITY, f64::INFINITY);
        let mut last = None;
        for _ in 0..4 {
            let start = Instant::now();
            let d = deform_region(&elastic.mesh, &elastic.topology, &mut solver, &zones, &params).unwrap();
            let total = start.elapsed().as_secs_f64();
            if total < best.0 {
                best = (
                    total,
                    d.stats.timings[Stage::Directions].as_secs_f64(),
                    d.stats.timings[Stage::Factorization].as_secs_f64(),
                );
            }
            last = Some(d);
        }
        let d = last.unwrap();
        println!(
            "{method:?}: {} vertices, |𝒟| = {}: deform_region {:.1} ms, of which direction field {:.1} ms; factorizations {} ({:.1} ms)",
            elastic.mesh.num_vertices(),
            d.stats.num_deformable,
            best.0 * 1e3,
            best.1 * 1e3,
            d.stats.numeric_factorizations,
            best.2 * 1e3
        );
        assert!(d.stats.num_deformable > 3000);
        assert!(best.0 < 5.0);
    }
}
