//! The rigged test characters of issue 36 (squish_scenes::characters) and the harness that
//! measures self-contact on them (squish_scenes::shots).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;
use std::sync::Arc;

use glam::{DMat4, DQuat, DVec3};
use squish::mesh::{TriMesh, signed_volume};
use squish::skinning::{RestIntersections, SkinWeights, joint_matrices, linear_blend_skinning};
use squish_scenes::characters::{self, Pose, RiggedCharacter};
use squish_scenes::shots;

fn self_intersecting(mesh: &TriMesh) -> usize {
    squish::spatial::self_intersecting_faces(mesh, 0..mesh.num_triangles() as u32, |_, _| true).unwrap().len()
}

fn assert_weights_normalized(weights: &SkinWeights) {
    for (v, w) in weights.weights().iter().enumerate() {
        let sum: f64 = w.iter().sum();
        assert!((sum - 1.0).abs() < 1e-12, "vertex {v}: weights sum to {sum}");
        assert!(w.iter().all(|&x| x >= 0.0));
    }
}

#[test]
fn the_humanoid_is_one_closed_oriented_manifold_skinned_at_rest_without_self_intersections() {
    let h = characters::humanoid(characters::HUMANOID_CELL);
    let topology = h.rest.check_for_deformation().unwrap();
    assert!(topology.is_closed());
    assert_eq!(topology.vertex_components().1, 1, "one piece");
    assert_eq!(topology.euler_characteristic(), 2, "a sphere's topology");
    // Outward: positive volume, about a person's (≈ 0.07 m³ at 1.78 m).
    let volume = signed_volume(&h.rest);
    assert!((0.04..0.1).contains(&volume), "{volume}");
    let n = h.rest.num_vertices();
    assert!((2_000..8_000).contains(&n), "{n} vertices");
    assert_eq!(h.weights.len(), n);
    assert_weights_normalized(&h.weights);
    assert_eq!(h.skin.joints.len(), 17);
    // Skinning at rest is the rest mesh; the rest mesh crosses nowhere.
    let rest = characters::humanoid_pose(Pose::Squat, 0.0);
    let posed = h.posed(&rest).unwrap();
    for (p, q) in posed.positions.iter().zip(&h.rest.positions) {
        assert!((*p - *q).length() < 1e-12);
    }
    assert_eq!(self_intersecting(&h.rest), 0);
    // `auto` finds the skeleton's articulations and parts on it.
    let auto = h.auto_self_contact();
    assert!(auto.articulations.len() >= 10, "{} articulations", auto.articulations.len());
    assert!(auto.parts.names.len() >= 10, "{} parts", auto.parts.names.len());
}

#[test]
fn the_humanoid_poses_push_the_skin_through_itself_more_and_more() {
    let h = Arc::new(characters::humanoid(characters::HUMANOID_CELL));
    let rest = RestIntersections::new(&h.rest).unwrap();
    for pose in Pose::ALL {
        let shot = characters::humanoid_shot(h.clone(), pose, 24);
        let faces = |frame: f64| rest.faces_beyond(&shot.input(frame).unwrap()).unwrap().len();
        let (start, middle, end) = (faces(0.0), faces(19.0), faces(23.0));
        println!("{}: {start} → {middle} → {end} faces", shot.name);
        assert_eq!(start, 0, "{}", shot.name);
        assert!(end >= 100, "{}: {end} faces at the last frame", shot.name);
        assert!(middle < end, "{}", shot.name);
        // The pose eases in: the first step is small, the feet stay on the ground.
        let (a, b) = (shot.input(0.0).unwrap(), shot.input(1.0).unwrap());
        let step = a.positions.iter().zip(&b.positions).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
        assert!(step < 0.02, "{}: {step}", shot.name);
        let lowest = |m: &TriMesh| m.positions.iter().map(|p| p.z).fold(f64::INFINITY, f64::min);
        let end_mesh = shot.input(23.0).unwrap();
        assert!((lowest(&end_mesh) - lowest(&a)).abs() < 0.05, "{}", shot.name);
    }
}

/// A small closed skinned mesh: an icosphere stretched along z, skinned to three joints along
/// it with smooth weights.
fn skinned_capsule() -> (TriMesh, SkinWeights) {
    let mut mesh = squish::mesh::shapes::icosphere(1.0, 2);
    mesh.map_positions(|p| DVec3::new(0.3 * p.x, 0.3 * p.y, p.z));
    let mut joints = Vec::new();
    let mut weights = Vec::new();
    for p in &mesh.positions {
        let w = [(0.5 - p.z).clamp(0.0, 1.0), 1.0 - (p.z).abs().min(1.0), (p.z + 0.5).clamp(0.0, 1.0) - 0.5];
        joints.push([0, 1, 2, 0]);
        weights.push([w[0].max(0.0), w[1].max(0.0), w[2].max(0.0), 0.0]);
    }
    (mesh, SkinWeights::new(joints, weights).unwrap())
}

fn bend(angle: f64) -> Vec<DMat4> {
    vec![
        DMat4::IDENTITY,
        DMat4::from_rotation_x(0.5 * angle),
        DMat4::from_translation(DVec3::new(0.0, 0.1, 0.0)) * DMat4::from_rotation_y(angle),
    ]
}

/// The position of a subdivided vertex interpolated from its origin's posed corners.
fn interpolated(origin: &characters::Origin, posed: &[DVec3]) -> DVec3 {
    origin.iter().fold(DVec3::ZERO, |s, &(v, l)| s + posed[v as usize] * l)
}

#[test]
fn subdivision_keeps_a_closed_mesh_closed_and_interpolates_positions_and_weights() {
    let (mesh, weights) = skinned_capsule();
    let (sub, sub_weights, origins) = characters::subdivide_skinned(&mesh, &weights);
    let topology = squish::Topology::new(&mesh);
    assert_eq!(sub.num_vertices(), mesh.num_vertices() + 2 * topology.num_edges() + mesh.num_triangles());
    assert_eq!(sub.num_triangles(), 9 * mesh.num_triangles());
    let sub_topology = sub.check_for_deformation().unwrap();
    assert!(sub_topology.is_closed());
    assert!((signed_volume(&sub) - signed_volume(&mesh)).abs() < 1e-12 * signed_volume(&mesh).abs().max(1.0));
    assert_weights_normalized(&sub_weights);
    // Original vertices first, unchanged.
    assert_eq!(&sub.positions[..mesh.num_vertices()], &mesh.positions[..]);
    for (v, o) in origins.iter().enumerate() {
        assert!((interpolated(o, &mesh.positions) - sub.positions[v]).length() < 1e-15);
    }
}

/// Linear blend skinning is linear in the weights and, per joint, affine in the position, but
/// not jointly: posing interpolated weights at an interpolated position gives the interpolation
/// of the posed corners plus `−Σ_a λ_a Σ_j (w_aj − w_j) A_j (p_a − p)` (A_j the linear part of
/// joint j's matrix). That term vanishes where every corner has the vertex's weights, or where
/// every joint moves alike (a rigid motion, the rest pose), and is otherwise bounded by
/// `Σ_a λ_a ‖w_a − w‖₁ · max_j ‖A_j − A_ref‖ · |p_a − p|`: second order in the edge length.
fn check_subdivided_skinning(mesh: &TriMesh, weights: &SkinWeights, matrices: &[DMat4], what: &str) -> usize {
    let (sub, sub_weights, origins) = characters::subdivide_skinned(mesh, weights);
    let posed = linear_blend_skinning(&mesh.positions, weights, matrices).unwrap();
    let sub_posed = linear_blend_skinning(&sub.positions, &sub_weights, matrices).unwrap();
    let scale = posed.iter().map(|p| p.length()).fold(1.0, f64::max);
    let dense = |w: &SkinWeights, v: usize| {
        let mut row = vec![0.0; matrices.len()];
        for (&j, &x) in w.joints()[v].iter().zip(&w.weights()[v]) {
            row[j as usize] += x;
        }
        row
    };
    let mut exact = 0;
    for (v, origin) in origins.iter().enumerate() {
        let difference = (sub_posed[v] - interpolated(origin, &posed)).length();
        let w = dense(&sub_weights, v);
        let corners: Vec<(usize, f64)> = origin.iter().filter(|o| o.1 > 0.0).map(|&(a, l)| (a as usize, l)).collect();
        // Interpolated weights before the cut to four joints.
        let mut interpolated_w = vec![0.0; matrices.len()];
        for &(a, l) in &corners {
            for (x, y) in interpolated_w.iter_mut().zip(dense(weights, a)) {
                *x += l * y;
            }
        }
        if w.iter().zip(&interpolated_w).any(|(x, y)| (x - y).abs() > 1e-12) {
            continue; // cut to four joints: not a linear interpolation any more
        }
        let same = corners.iter().all(|&(a, _)| dense(weights, a).iter().zip(&w).all(|(x, y)| (x - y).abs() < 1e-15));
        if same {
            assert!(difference <= 1e-12 * scale, "{what}: vertex {v} off by {difference:e}");
            exact += 1;
            continue;
        }
        let support: Vec<usize> = (0..matrices.len())
            .filter(|&j| w[j] > 0.0 || corners.iter().any(|&(a, _)| dense(weights, a)[j] > 0.0))
            .collect();
        let linear = |j: usize| glam::DMat3::from_mat4(matrices[j]);
        let reference = linear(support[0]);
        let spread = support.iter().map(|&j| {
            let d = linear(j) - reference;
            (d.x_axis.length_squared() + d.y_axis.length_squared() + d.z_axis.length_squared()).sqrt()
        });
        let spread = spread.fold(0.0, f64::max);
        let bound: f64 = corners
            .iter()
            .map(|&(a, l)| {
                let norm: f64 = dense(weights, a).iter().zip(&w).map(|(x, y)| (x - y).abs()).sum();
                l * norm * spread * (mesh.positions[a] - sub.positions[v]).length()
            })
            .sum();
        assert!(difference <= bound + 1e-12 * scale, "{what}: vertex {v} off by {difference:e}, bound {bound:e}");
    }
    exact
}

#[test]
fn skinning_a_subdivided_mesh_is_the_subdivision_of_the_skinned_mesh_up_to_a_second_order_term() {
    let (mesh, weights) = skinned_capsule();
    let (sub, sub_weights, _) = characters::subdivide_skinned(&mesh, &weights);
    // Rest pose (identities) and a rigid motion of the whole skeleton: equal.
    let rigid = DMat4::from_rotation_translation(DQuat::from_rotation_z(0.7), DVec3::new(1.0, -2.0, 0.5));
    for matrices in [vec![DMat4::IDENTITY; 3], vec![rigid; 3]] {
        let (_, sub_posed) = (
            linear_blend_skinning(&mesh.positions, &weights, &matrices).unwrap(),
            linear_blend_skinning(&sub.positions, &sub_weights, &matrices).unwrap(),
        );
        for (p, q) in sub_posed.iter().zip(&sub.positions) {
            assert!((*p - matrices[0].transform_point3(*q)).length() < 1e-12);
        }
        check_subdivided_skinning(&mesh, &weights, &matrices, "rigid");
    }
    // A bent pose: exact where the corners share their weights, bounded elsewhere.
    let exact = check_subdivided_skinning(&mesh, &weights, &bend(1.2), "bent");
    assert!(exact > 0);
}

#[test]
fn cesium_man_subdivided_has_15k_vertices_and_skins_like_the_original() {
    let glb = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/rigged/CesiumMan.glb");
    if !glb.is_file() {
        eprintln!("skipped: {} is absent", glb.display());
        return;
    }
    let (original, scene) = characters::gltf_character(&glb).unwrap();
    let (sub, _) = characters::cesium_man_subdivided(&glb).unwrap();
    assert!(sub.rest.num_vertices() >= 15_000, "{}", sub.rest.num_vertices());
    let (t0, t1) = (original.rest.check_for_deformation().unwrap(), sub.rest.check_for_deformation().unwrap());
    assert_eq!(t0.is_closed(), t1.is_closed());
    assert_eq!(3 * t0.boundary_edges().len(), t1.boundary_edges().len());
    assert_eq!(t0.vertex_components().1, t1.vertex_components().1);
    assert_weights_normalized(&sub.weights);
    // At the bind pose the skin gives the subdivided rest mesh when the original's does.
    let bind: Vec<DMat4> = original.skin.inverse_bind.iter().map(DMat4::inverse).collect();
    let mut world = scene.skeleton.rest_world_transforms();
    for (&node, m) in original.skin.joints.iter().zip(&bind) {
        world[node] = *m;
    }
    let check_rest = |c: &RiggedCharacter| {
        let posed = c.posed(&world).unwrap();
        posed.positions.iter().zip(&c.rest.positions).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max)
    };
    assert!(check_rest(&original) < 1e-5 && check_rest(&sub) < 1e-5);
    // A walking frame: the subdivision of the posed original, up to the second-order term.
    let walking = scene.world_transforms(Some(0), 0.5).unwrap();
    let matrices = joint_matrices(&original.skin, &walking).unwrap();
    let exact = check_subdivided_skinning(&original.rest, &original.weights, &matrices, "CesiumMan");
    assert!(exact > 1000, "{exact}");
}

#[test]
fn the_harness_measures_plain_skinning_as_its_own_input() {
    let h = Arc::new(characters::humanoid(0.03));
    let shot = characters::humanoid_shot(h, Pose::ArmsCrossed, 8);
    // Without self-contact the output is the input: every step ratio is 1.
    let ratios = shots::step_ratios(&shot, 5.0, 6.0, 4, None).unwrap();
    assert_eq!(ratios.len(), 4);
    assert!(ratios.iter().all(|r| (r - 1.0).abs() < 1e-12), "{ratios:?}");
    // motion_quality.py's figures of identical shots: no excess acceleration, nothing moved.
    let frames: Vec<Vec<DVec3>> = (0..4).map(|k| shot.input(k as f64).unwrap().positions).collect();
    let acc = shots::excess_acceleration(&frames, &frames, 1.0);
    assert_eq!(acc, vec![0.0, 0.0]);
    assert_eq!(shots::moved_share(&frames[1], &frames[1], 1.0), 0.0);
    let mut shifted = frames[2].clone();
    shifted[0] += DVec3::X;
    let acc =
        shots::excess_acceleration(&frames, &[frames[0].clone(), frames[1].clone(), shifted, frames[3].clone()], 0.5);
    assert!(acc[0] > 0.0 && acc[1] > 0.0);
}

/// The continuity check of issue 36 on `self_contact = "auto"`: the crossed arms swept in
/// twentieths of a frame from frame 28 to 29 (0-based), the output's steps bounded by a
/// constant times the input's. Ignored: ≈ 1 min, and it fails on the algorithm of main at
/// b928e78 (frame 29's output blows up, a vertex ≈ 550 mean edges off; over frames 24–25 the
/// ratios stay within 1–4.9). Run with
/// `cargo test --release -p squish-scenes --test characters -- --ignored`.
#[test]
#[ignore = "issue 36: about a minute; fails on the algorithm of main at b928e78"]
fn automatic_self_contact_is_continuous_in_the_pose() {
    let h = Arc::new(characters::humanoid(characters::HUMANOID_CELL));
    let shot = characters::humanoid_shot(h.clone(), Pose::ArmsCrossed, 32);
    let auto = h.auto_self_contact();
    let ratios = shots::step_ratios(&shot, 28.0, 29.0, 20, Some(&auto)).unwrap();
    println!("{ratios:?}");
    let worst = ratios.iter().copied().fold(0.0, f64::max);
    assert!(worst <= 10.0, "largest step ratio {worst}");
}

/// The humanoid crouch (32 frames) at frame `k` (0-based) with `self_contact = "auto"`: its
/// input object and its result on a fresh deformer.
fn crouch_at(k: f64) -> (squish::OwnedObject, squish::FrameResult) {
    let shot = characters::humanoid_shots(characters::HUMANOID_CELL, 32)
        .into_iter()
        .find(|s| s.name == "humanoid-crouch")
        .unwrap();
    let auto = shot.character.auto_self_contact();
    let object = shot.character.object(&shot.world(k), Some(&auto)).unwrap();
    let frame = squish::OwnedFrame { objects: vec![object.clone()], pairs: vec![] };
    let result = squish::pipeline::Deformer::new().deform(&frame.frame()).unwrap();
    (object, result)
}

/// The crouch's frame 29 (0-based, 32 frames): the hips/spine articulation finds no bulge of
/// its region's size that gives the volume back (the smallest root of its volume cubic is 2.6
/// model units over an extent of 0.14; the character is 1.7 tall). Under the rule of
/// docs/decisions.md ("An articulation's bulge taller than its extent") it is left without
/// effect, with its reason; every articulation kept has a bulge within its extent, nothing flies
/// off and the frame is not worse than its input. (The rule was first shown at frame 26's right
/// knee, 41 units; since articulations may take a dent, that knee needs no bulge at all.)
#[test]
fn an_articulation_whose_bulge_would_be_a_spike_is_left_without_effect() {
    let (object, result) = crouch_at(29.0);
    let spine = result.stats.articulations.iter().find(|a| a.name == "hips / spine").unwrap();
    assert!(spine.error.as_deref().is_some_and(|e| e.contains("spike")), "{spine:?}");
    assert_eq!(spine.applied_bulge_height, 0.0);
    for a in result.stats.articulations.iter().filter(|a| a.error.is_none()) {
        assert!(a.applied_bulge_height.abs() <= a.extent, "{}: {} over {}", a.name, a.applied_bulge_height, a.extent);
    }
    let edge = shots::first_edge_mean(&object.mesh);
    let offset = object.mesh.positions.iter().zip(&result.positions[0]).map(|(a, b)| (*a - *b).length());
    let offset = offset.fold(0.0, f64::max) / edge;
    assert!(offset < 5.0, "a vertex {offset:.1} mean edges off");
    let [before, after] = result.stats.objects[0].self_intersecting_faces.unwrap();
    assert!(after <= before, "{before} → {after} faces");
}

/// The crouch's frame 30 (0-based): four articulations (chest against the upper arms, thighs
/// against the shins) push skin that *adds* volume, which no outward bulge (h ≥ 0) takes back:
/// their heights were 0 and not exact, and the frame lost 7.7·10⁻³ of its volume. They now take
/// a dent (h < 0, docs/decisions.md, "An articulation that adds volume") and the volume is kept.
#[test]
fn an_articulation_that_adds_volume_takes_a_dent_and_keeps_it() {
    let (object, result) = crouch_at(30.0);
    let kept: Vec<_> =
        result.stats.articulations.iter().filter(|a| a.error.is_none() && a.applied_bulge_height != 0.0).collect();
    assert!(kept.iter().all(|a| a.volume_exact), "{kept:?}");
    assert!(kept.iter().any(|a| a.applied_bulge_height < 0.0), "{kept:?}");
    let output = TriMesh { positions: result.positions[0].clone(), triangles: object.mesh.triangles.clone() };
    let (before, after) = (signed_volume(&object.mesh), signed_volume(&output));
    assert!(((after - before) / before).abs() <= 1e-9, "ΔV/V = {:e}", (after - before) / before);
}
