//! Acceptance tests of the whole pipeline (chapters 4 and 5 together) on procedural scenes and
//! on the shared meshes: volume, clean contact, no flips, untouched vertices, symmetry,
//! continuity, γ, bulge maps, determinism.

use glam::DVec3;
use squish::mesh::{TriMesh, shapes};
use squish::params::{DirectionFieldMethod, MappingMethod, ObjectParams, PairParams};
use squish::pipeline::*;
use squish_scenes::bench::{self, BenchSize};
use squish_scenes::procedural::{self as scenes, ProceduralScene};

use crate::common::{self as test_meshes, assert_no_flipped_face, deformed, penetrations};

fn run(scene: &ProceduralScene) -> FrameResult {
    Deformer::new().deform(&scene.frame()).expect("frame deforms")
}

/// Checks volume, clean contact, orientation, NaN and untouched vertices; returns the largest
/// relative volume change and the residual penetration ratio.
fn check_scene(scene: &ProceduralScene) -> (f64, f64) {
    let result = run(scene);
    let (before, after_meshes, after) = penetrations(scene, &result);
    let mut worst_volume = 0.0f64;
    for (i, object) in scene.objects.iter().enumerate() {
        let stats = &result.stats.objects[i];
        if object.params.rigid {
            assert_eq!(result.positions[i], object.mesh.positions, "{}: rigid {} moved", scene.name, object.name);
            continue;
        }
        assert!(stats.deformed, "{}: {} not deformed", scene.name, object.name);
        worst_volume = worst_volume.max(stats.relative_volume_change.abs());
        let output = &after_meshes[i];
        assert!(output.positions.iter().all(|p| p.is_finite()), "{}: NaN in {}", scene.name, object.name);
        assert_no_flipped_face(&object.mesh, output, &format!("{} ({})", object.name, scene.name));
        let deformation = result.deformations[i].as_ref().unwrap();
        for v in 0..output.num_vertices() {
            if !deformation.deformable[v] && !deformation.contact[v] {
                assert_eq!(
                    output.positions[v].to_array().map(f64::to_bits),
                    object.mesh.positions[v].to_array().map(f64::to_bits),
                    "{}: vertex {v} of {} is outside 𝒟 ∪ 𝒞 but moved",
                    scene.name,
                    object.name
                );
            }
        }
    }
    let ratio = after / before;
    println!("{}: volume change {worst_volume:.2e}, penetration {before:.4} → {after:.2e} ({ratio:.2e})", scene.name);
    assert!(worst_volume <= 1e-9, "{}: relative volume change {worst_volume:.3e}", scene.name);
    assert!(ratio <= 0.02, "{}: residual penetration {after:.4e} is {ratio:.3e} of {before:.4e}", scene.name);
    (worst_volume, ratio)
}

#[test]
fn ball_pressed_into_ground() {
    check_scene(&scenes::ball_on_ground(0.2, 4, 48));
}

#[test]
fn two_balls_of_different_sizes() {
    check_scene(&scenes::two_balls(0.15, 4));
}

#[test]
fn crossed_capsules() {
    check_scene(&scenes::crossed_capsules(0.2, 48));
}

/// The bunny (y up, looking toward −x) with a rigid box pressed 0.1 into its tail and rump from
/// +x. (With a soft box the residual is 2.9% of the depth: the potential contact surface then
/// inherits half of the coarse bunny's crease angles, which the box's vertices sample between the
/// bunny's vertices; a rigid box makes 𝒮 the box itself.)
fn bunny_scene() -> Option<ProceduralScene> {
    let bunny = test_meshes::bunny()?;
    let extreme = bunny.positions.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p.x));
    let mut slab = shapes::cuboid(DVec3::new(0.4, 2.0, 2.0), 64);
    slab.map_positions(|p| p + DVec3::new(extreme - 0.1 + 0.2, 0.0, 0.0));
    let mut scene = ProceduralScene { name: "bunny against a rigid box".into(), ..Default::default() };
    scene.objects.push(squish::OwnedObject { name: "bunny".into(), mesh: bunny, params: ObjectParams::default() });
    scene.objects.push(squish::OwnedObject { name: "box".into(), mesh: slab, params: ObjectParams::rigid() });
    scene.pairs.push(FramePair { objects: [0, 1], params: PairParams::default() });
    Some(scene)
}

#[test]
fn bunny_against_a_box() {
    let Some(scene) = bunny_scene() else { return };
    check_scene(&scene);
}

fn spot_scene() -> Option<ProceduralScene> {
    let spot = test_meshes::shared_mesh("spot_11533.obj")?;
    // Spot (about 1.3 long, y up) with a sphere pressed into its back.
    // Press a ball into the cow's flank (y is up, the head is toward −z, the body spans
    // z ∈ [0.2, 0.8]): the outermost vertex (largest x) in the middle of the body.
    let side = spot
        .positions
        .iter()
        .filter(|p| (p.y + 0.05).abs() < 0.1 && (p.z - 0.45).abs() < 0.1)
        .fold(DVec3::splat(f64::NEG_INFINITY), |m, p| if p.x > m.x { *p } else { m });
    let mut ball = shapes::icosphere(0.3, 4);
    ball.map_positions(|p| p + side + DVec3::new(0.3 - 0.08, 0.0, 0.0));
    let mut scene = ProceduralScene { name: "spot and a sphere".into(), ..Default::default() };
    scene.objects.push(squish::OwnedObject { name: "ball".into(), mesh: ball, params: ObjectParams::default() });
    scene.objects.push(squish::OwnedObject { name: "spot".into(), mesh: spot, params: ObjectParams::default() });
    scene.pairs.push(FramePair { objects: [0, 1], params: PairParams::default() });
    Some(scene)
}

#[test]
fn spot_against_a_sphere() {
    let Some(scene) = spot_scene() else { return };
    check_scene(&scene);
}

#[test]
fn identical_balls_give_mirror_symmetric_results() {
    let scene = scenes::mirrored_balls(0.3, 4);
    let result = run(&scene);
    let (top, bottom) = (&result.positions[0], &result.positions[1]);
    let worst = top.iter().zip(bottom).map(|(t, b)| (DVec3::new(t.x, t.y, -t.z) - *b).length()).fold(0.0f64, f64::max);
    println!("mirror asymmetry {worst:.2e}");
    assert!(worst < 1e-9, "mirror asymmetry {worst}");
    assert!(result.stats.objects[0].max_displacement > 0.05);
}

#[test]
fn pressing_a_ball_is_continuous_from_first_contact() {
    // 120 steps from a gap of 0.02 to a depth of 0.25: the largest displacement of any vertex
    // between consecutive frames stays below 10× the step, and each object's automatic extent
    // grows with the contact without a jump: by at most 7·√(ΔA/π) a frame (the rule's slope in
    // the contact radius √(A/π)) while the area A grows by at most twice the rate of a unit
    // sphere's cap, 2π·R·Δdepth.
    let steps = 120;
    let (from, to) = (-0.02, 0.25);
    let step = (to - from) / steps as f64;
    let mut deformer = Deformer::new();
    let mut previous: Option<Vec<Vec<DVec3>>> = None;
    let mut worst: f64 = 0.0;
    let mut first_contact = None;
    let mut extents: Vec<[f64; 2]> = Vec::new();
    let mut areas: Vec<f64> = Vec::new();
    for k in 0..=steps {
        let depth = from + step * k as f64;
        let scene = scenes::ball_on_ground(depth, 4, 24);
        let result = deformer.deform(&scene.frame()).unwrap();
        if first_contact.is_none() && result.stats.pairs[0].in_contact {
            first_contact = Some(k);
        }
        if result.stats.pairs[0].in_contact {
            extents.push([0, 1].map(|i| result.stats.objects[i].extent));
            areas.push(result.contacts[0].as_ref().map_or(0.0, |c| c.contact_area));
        }
        // Compare in the frame of each object's rigid motion: the ball moves down by `step`.
        let ball_motion = DVec3::new(0.0, 0.0, -step);
        if let Some(prev) = &previous {
            for (i, (now, before)) in result.positions.iter().zip(prev).enumerate() {
                let rigid = if i == 0 { ball_motion } else { DVec3::ZERO };
                for (p, q) in now.iter().zip(before) {
                    worst = worst.max((*p - *q - rigid).length());
                }
            }
        }
        previous = Some(result.positions);
    }
    let ratio = worst / step;
    println!("first contact at step {first_contact:?}; largest jump {worst:.3e} = {ratio:.2} × step");
    assert!(first_contact.is_some_and(|k| k > 0), "the sweep must start before the first contact");
    assert!(ratio < 10.0, "largest jump between frames {worst:.3e} is {ratio:.2} × the step");
    let area_rate = areas.windows(2).map(|w| (w[1] - w[0]).abs() / step).fold(0.0, f64::max);
    println!("contact area: largest growth {area_rate:.3} × the step (a unit sphere's cap: 2π)");
    assert!(area_rate < 4.0 * std::f64::consts::PI, "the contact area jumped: {area_rate:.3} × the step");
    for i in 0..2 {
        let last = extents.last().map_or(0.0, |e| e[i]);
        println!("object {i}: extent {:.4} at first contact, {last:.4} at the end", extents[0][i]);
        for (k, (e, a)) in extents.windows(2).zip(areas.windows(2)).enumerate() {
            let bound = squish::deform::EXTENT_CONTACT_FACTOR * ((a[1] - a[0]).abs() / std::f64::consts::PI).sqrt();
            assert!(
                (e[1][i] - e[0][i]).abs() <= bound * (1.0 + 1e-9) + 1e-12,
                "object {i}'s extent changed by {:.4} at contact frame {k}, more than its area allows ({bound:.4})",
                e[1][i] - e[0][i]
            );
            assert!(e[1][i] >= e[0][i] - 1e-12 * last, "object {i}'s extent shrank as the contact grew");
        }
    }
}

#[test]
fn bulge_factor_controls_the_injected_volume() {
    let mut volumes = Vec::new();
    for gamma in [0.0, 0.5, 1.0, 1.5, 2.0] {
        let mut scene = scenes::ball_on_ground(0.2, 4, 24);
        for object in &mut scene.objects {
            object.params.bulge = gamma;
        }
        let result = run(&scene);
        let ball = &result.stats.objects[0];
        volumes.push(ball.volume_after - ball.volume_before);
    }
    println!("volume change for γ = 0, 0.5, 1, 1.5, 2: {volumes:?}");
    assert!(volumes[0] < -1e-3, "γ = 0 cancels the bulge: the dent's volume is lost");
    assert!(volumes[2].abs() < 1e-9 * 4.2, "γ = 1 preserves the volume");
    for w in volumes.windows(2) {
        assert!(w[1] > w[0], "injected volume grows with γ: {volumes:?}");
    }
    assert!(volumes[4] > 1e-3, "γ > 1 exaggerates");
}

#[test]
fn a_half_bulge_map_moves_the_bulge_and_keeps_the_volume() {
    let mut scene = scenes::ball_on_ground(0.2, 4, 24);
    let uniform = run(&scene);
    let ground = 1;
    let mesh = scene.objects[ground].mesh.clone();
    let map: Vec<f64> = mesh.positions.iter().map(|p| if p.x < 0.0 { 0.0 } else { 1.0 }).collect();
    scene.objects[ground].params.bulge_map = Some(map);
    let half = run(&scene);
    let stats = &half.stats.objects[ground];
    assert!(stats.relative_volume_change.abs() < 1e-9, "{}", stats.relative_volume_change);
    // On the top face outside the contact, the x < 0 half no longer rises; the x > 0 half rises
    // more than with a uniform map.
    let rise = |positions: &[DVec3], side: f64| {
        mesh.positions
            .iter()
            .zip(positions)
            .filter(|(p, _)| p.z > -1e-9 && p.x * side > 0.3)
            .map(|(p, q)| q.z - p.z)
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let (left, right) = (rise(&half.positions[ground], -1.0), rise(&half.positions[ground], 1.0));
    let right_uniform = rise(&uniform.positions[ground], 1.0);
    println!("rise left {left:.3e}, right {right:.3e} (uniform {right_uniform:.3e})");
    assert!(left <= 1e-12, "no bulge where η = 0: {left}");
    assert!(right > 1.5 * right_uniform, "{right} vs {right_uniform}");
}

#[test]
fn reusing_the_deformer_and_the_thread_count_do_not_change_the_result() {
    let scenes = [scenes::ball_on_ground(0.1, 3, 16), scenes::ball_on_ground(0.2, 3, 16)];
    let mut reused = Deformer::new();
    for scene in &scenes {
        let a = reused.deform(&scene.frame()).unwrap();
        let b = Deformer::new().deform(&scene.frame()).unwrap();
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        let c = pool.install(|| Deformer::new().deform(&scene.frame()).unwrap());
        for (x, (y, z)) in a.positions.iter().zip(b.positions.iter().zip(&c.positions)) {
            let bits = |v: &Vec<DVec3>| v.iter().flat_map(|p| p.to_array().map(f64::to_bits)).collect::<Vec<_>>();
            assert_eq!(bits(x), bits(y));
            assert_eq!(bits(x), bits(z));
        }
    }
}

#[test]
fn frames_keep_no_trace_of_the_frames_before_them() {
    // A static ball pressed by fingers that move: the ball's systems change only around the
    // contacts, so a reused deformer recomputes part of their factors. Whatever came before — the
    // previous frame, the frames in reverse order, nothing — every frame is the same bit for bit.
    let scene = bench::fingers_ball(BenchSize::Quick);
    let times = [0.0, 0.2, 0.4, 0.7, 1.0];
    let bits = |r: &FrameResult| -> Vec<u64> {
        r.positions.iter().flatten().flat_map(|p| p.to_array().map(f64::to_bits)).collect()
    };
    let fresh: Vec<Vec<u64>> = times.iter().map(|&t| bits(&run(&scene.pose(t)))).collect();
    let mut forward = Deformer::new();
    let (mut factorized, mut recomputed) = (0, 0);
    for (k, &t) in times.iter().enumerate() {
        let result = forward.deform(&scene.pose(t).frame()).unwrap();
        assert_eq!(bits(&result), fresh[k], "frame {k} after the frames before it");
        if k > 0 {
            let deformations = || result.deformations.iter().flatten();
            factorized += deformations().map(|d| d.stats.factorized_rows).sum::<usize>();
            recomputed += deformations().map(|d| d.stats.recomputed_rows).sum::<usize>();
        }
    }
    println!("rows factorized {factorized}, recomputed {recomputed}");
    assert!(recomputed < factorized, "the static ball keeps part of its factors");
    let mut backward = Deformer::new();
    for (k, &t) in times.iter().enumerate().rev() {
        assert_eq!(bits(&backward.deform(&scene.pose(t).frame()).unwrap()), fresh[k], "frame {k} in reverse order");
    }
}

#[test]
fn objects_apart_are_returned_unchanged() {
    let scene = scenes::ball_on_ground(-0.3, 3, 8);
    let result = run(&scene);
    for (object, positions) in scene.objects.iter().zip(&result.positions) {
        assert_eq!(&object.mesh.positions, positions);
    }
    assert!(!result.stats.pairs[0].in_contact);
}

#[test]
fn a_rigid_ground_keeps_its_shape_and_the_ball_lies_on_it() {
    let mut scene = scenes::ball_on_ground(0.2, 4, 24);
    scene.objects[1].params = ObjectParams::rigid();
    let result = run(&scene);
    assert_eq!(result.positions[1], scene.objects[1].mesh.positions);
    // The rigid ground's top is z = 0: the ball may not sink into it by more than 2% of the
    // initial depth (0.2); its contact zone lies exactly the contact gap above it (the rigid side
    // keeps its surface, the ball leaves the whole gap).
    let lowest = result.positions[0].iter().fold(f64::INFINITY, |m, p| m.min(p.z));
    assert!(lowest > -0.004, "ball vertex below the rigid ground: {lowest}");
    let zone = result.deformations[0].as_ref().unwrap();
    let gap = result.contacts[0].as_ref().unwrap().gap;
    assert!(gap > 0.0);
    for (v, p) in result.positions[0].iter().enumerate() {
        if zone.contact[v] {
            assert!((p.z - gap).abs() < 1e-12, "contact vertex {v} off the rigid surface by the gap {gap}: {p}");
        }
    }
    assert!(result.stats.objects[0].relative_volume_change.abs() < 1e-9);
}

#[test]
fn bad_inputs_are_errors_naming_the_object() {
    let mut scene = scenes::ball_on_ground(0.1, 2, 4);
    scene.objects[0].mesh.positions[3].x = f64::NAN;
    let err = Deformer::new().deform(&scene.frame()).unwrap_err();
    assert!(err.to_string().contains("\"ball\""), "{err}");
    let mut scene = scenes::ball_on_ground(0.1, 2, 4);
    scene.objects[1].params.stiffness = -1.0;
    let err = Deformer::new().deform(&scene.frame()).unwrap_err();
    assert!(err.to_string().contains("ground") && err.to_string().contains("stiffness"), "{err}");
    let mut scene = scenes::ball_on_ground(0.1, 2, 4);
    scene.objects[0].mesh.triangles[0] = [0, 1, 1];
    let err = Deformer::new().deform(&scene.frame()).unwrap_err();
    assert!(err.to_string().contains("degenerate"), "{err}");
}

/// Regression: deep presses (a third of the ball's radius) used to jump by up to 12× the input's
/// step between frames, from slope estimates spiking at vertices about to enter 𝒞 (see
/// `deform::guide`, "Slope confidence").
#[test]
fn a_deep_press_stays_continuous() {
    let mut deformer = Deformer::new();
    let mut previous: Option<(f64, Vec<Vec<DVec3>>)> = None;
    let (steps, from, to) = (100, -0.05, 0.45);
    let mut worst_ratio: f64 = 0.0;
    for k in 0..=steps {
        let depth = from + (to - from) * k as f64 / steps as f64;
        let mut scene = scenes::ball_on_ground(depth, 4, 32);
        scene.objects[1].params = ObjectParams::default().with_stiffness(2.0);
        let result = deformer.deform(&scene.frame()).unwrap();
        if let Some((d0, prev)) = &previous {
            let step = depth - d0;
            for (i, (now, before)) in result.positions.iter().zip(prev).enumerate() {
                let rigid = if i == 0 { DVec3::new(0.0, 0.0, -step) } else { DVec3::ZERO };
                for (p, q) in now.iter().zip(before) {
                    worst_ratio = worst_ratio.max((*p - *q - rigid).length() / step);
                }
            }
        }
        previous = Some((depth, result.positions));
    }
    println!("largest jump over a press to 0.45: {worst_ratio:.2} × the step");
    assert!(worst_ratio < 5.0, "{worst_ratio}");
}

/// Method A end to end through the deformer: ball testing (§4.4.1), the shared-parametrization
/// mapping (§4.2.1, UVs = (x, y) on both objects) and the parallel-transport direction field. The
/// elastic ground keeps its volume, the rigid ball's penetration is resolved, and the result stays
/// close to method B's on this configuration where both apply (thesis Fig. 7.14).
#[test]
fn method_a_runs_through_the_deformer() {
    let depth = 0.2;
    let method_b = {
        let mut scene = scenes::ball_on_ground(depth, 4, 48);
        scene.objects[0].params = ObjectParams::rigid();
        scene
    };
    let mut method_a = method_b.clone();
    for object in &mut method_a.objects {
        object.params.uvs =
            Some(squish::params::Uvs::PerVertex(object.mesh.positions.iter().map(|p| p.truncate()).collect()));
    }
    method_a.objects[1].params.direction_field = DirectionFieldMethod::ParallelTransport;
    method_a.pairs[0].params =
        method_a.pairs[0].params.with_mapping(MappingMethod::SharedParametrization).with_ball(0.15);
    let (volume, penetration) = check_scene(&method_a);
    println!("method A: volume change {volume:.2e}, residual penetration {:.2}%", 100.0 * penetration);
    assert!(volume < 1e-9, "volume change {volume}");
    assert!(penetration < 0.05, "residual penetration {penetration}");
    let (a, b) = (run(&method_a), run(&method_b));
    let largest_gap = a.positions[1].iter().zip(&b.positions[1]).map(|(p, q)| p.distance(*q)).fold(0.0, f64::max);
    println!("largest vertex distance between methods A and B: {largest_gap:.4} (depth {depth})");
    assert!(largest_gap < 0.5 * depth, "methods A and B disagree by {largest_gap}");
    assert!(a.deformations[1].as_ref().is_some_and(|d| d.contact.iter().any(|&c| c)));

    let mut bad = method_a.clone();
    if let Some(squish::params::Uvs::PerVertex(uvs)) = bad.objects[1].params.uvs.as_mut() {
        uvs.pop();
    }
    let err = Deformer::new().deform(&bad.frame()).unwrap_err().to_string();
    assert!(err.contains("\"ground\"") && err.contains("UVs"), "{err}");
}

/// Ball testing is a per-pair parameter, so the [`Deformer`] already runs it
/// (the direction field is not selectable there yet): a rigid ball in the procedural ground.
#[test]
fn the_deformer_runs_ball_testing_from_the_pair_parameters() {
    let mut scene = scenes::ball_on_ground(0.15, 4, 48);
    scene.objects[0].params = ObjectParams::rigid();
    // The ground slab is 0.5 thick: the ball (r_s = 0.1) must fit inside it (§4.4.1).
    scene.pairs[0].params = PairParams::default().with_ball(0.1);
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    let ground = &scene.objects[1];
    let stats = &result.stats.objects[1];
    let contact = result.contacts[0].as_ref().unwrap();
    println!(
        "Deformer with ball testing: zone vertices {:?}, contact area {:.4}, ground volume change {:.2e}",
        result.stats.pairs[0].zone_vertices, contact.contact_area, stats.relative_volume_change
    );
    assert!(stats.deformed && !result.stats.objects[0].deformed);
    assert!(result.stats.pairs[0].zone_vertices[1] > 0 && result.stats.pairs[0].zone_vertices[0] == 0);
    assert!(stats.relative_volume_change.abs() < 1e-9);
    assert_no_flipped_face(&ground.mesh, &deformed(&scene, &result, 1), "the ground");
    // The zone is pressed onto the ball, the contact gap away from it.
    let zone = &contact.sides[1].zone;
    let centre = DVec3::new(0.0, 0.0, 1.0 - 0.15);
    for v in 0..ground.mesh.num_vertices() {
        if zone.region.contains(v as u32) {
            let d = (result.positions[1][v] - centre).length();
            assert!(
                (d - 1.0 - contact.gap).abs() < 5e-3,
                "vertex {v} at {d} from the ball's centre (gap {})",
                contact.gap
            );
        }
    }
}

/// The zones lent to chapter 5 come back to the pair and side they were found on: four fingers
/// pressed to unequal depths into one ball give four zones on the ball's one region, and each
/// pair's zones are the ones its statistics counted, carry its mapping direction and lie under
/// its own finger.
#[test]
fn each_pair_gets_its_own_zones_back_after_the_deformation() {
    let scene = bench::fingers_ball(BenchSize::Quick);
    let pose = scene.pose(1.0);
    let frame = pose.frame();
    let result = Deformer::new().deform(&frame).unwrap();
    assert_eq!(result.stats.regions[0].zones, 4, "the ball's one region has the four zones");
    assert_eq!(result.contacts.len(), result.stats.pairs.len());
    let center = |mesh: &TriMesh| mesh.positions.iter().sum::<DVec3>() / mesh.num_vertices() as f64;
    let fingers: Vec<DVec3> = frame.pairs.iter().map(|p| center(frame.objects[p.objects[0]].mesh)).collect();
    for (contact, stats) in result.contacts.iter().zip(&result.stats.pairs) {
        let contact = contact.as_ref().expect("every finger touches the ball");
        assert!(stats.in_contact);
        for side in 0..2 {
            let zone = &contact.sides[side].zone;
            let what = format!("pair {} side {side}", stats.pair);
            assert_eq!(zone.region.num_inside(), stats.zone_vertices[side], "{what}");
            let mesh = frame.objects[frame.pairs[stats.pair].objects[side]].mesh;
            assert_eq!(zone.targets.len(), mesh.num_vertices(), "{what}");
            assert_eq!(zone.mapping_direction.to_array(), contact.direction.to_array(), "{what}");
            // The zone's nearest finger is the pair's own.
            let inside: Vec<DVec3> = (0..mesh.num_vertices())
                .filter(|&v| zone.region.contains(v as u32))
                .map(|v| mesh.positions[v])
                .collect();
            let mean = inside.iter().sum::<DVec3>() / inside.len() as f64;
            let nearest =
                (0..fingers.len()).min_by(|&a, &b| mean.distance(fingers[a]).total_cmp(&mean.distance(fingers[b])));
            assert_eq!(nearest, Some(stats.pair), "{what}");
        }
    }
}
