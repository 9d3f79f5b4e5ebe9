//! The contact gap (`pair.contact_gap`, issue 29): at the default, no triangle of one output
//! intersects a triangle of the other (exact test), the volume stays preserved, and 0 gives the
//! thesis' coincident surfaces back.

use squish::params::{ObjectParams, PairParams};
use squish::pipeline::{Deformer, FrameResult};
use squish::spatial::mesh_intersections;
use squish_scenes::procedural::{self as scenes, ProceduralScene};

use crate::common::{deformed, rigid_motion_difference};

/// Distinct faces of each mesh that intersect the other.
fn intersecting_faces(a: &squish::TriMesh, b: &squish::TriMesh) -> [usize; 2] {
    let pairs = mesh_intersections(a, b).unwrap();
    let mut fa: Vec<u32> = pairs.iter().map(|p| p[0]).collect();
    let mut fb: Vec<u32> = pairs.iter().map(|p| p[1]).collect();
    for f in [&mut fa, &mut fb] {
        f.sort_unstable();
        f.dedup();
    }
    [fa.len(), fb.len()]
}

struct Measured {
    before: [usize; 2],
    after: [usize; 2],
    volume: f64,
    gap: f64,
}

fn measure(scene: &ProceduralScene) -> (FrameResult, Measured) {
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    let before = intersecting_faces(&scene.objects[0].mesh, &scene.objects[1].mesh);
    let after = intersecting_faces(&deformed(scene, &result, 0), &deformed(scene, &result, 1));
    let volume = result.stats.objects.iter().map(|o| o.relative_volume_change.abs()).fold(0.0, f64::max);
    let gap = result.contacts.iter().flatten().map(|c| c.gap).fold(0.0, f64::max);
    (result, Measured { before, after, volume, gap })
}

fn with_gap(mut scene: ProceduralScene, gap: Option<f64>) -> ProceduralScene {
    for p in &mut scene.pairs {
        p.params = PairParams { contact_gap: gap, ..p.params };
    }
    scene
}

/// Asserts that `scene`'s outputs at the default gap have no intersecting faces (and that those
/// of the thesis' coincident surfaces have some), with the volume preserved.
fn check_no_intersecting_faces(scene: &ProceduralScene) -> Measured {
    let (_, coincident) = measure(&with_gap(scene.clone(), Some(0.0)));
    let (_, m) = measure(scene);
    println!(
        "{}: intersecting faces {:?} before, {:?} after with the thesis' coincident surfaces, {:?} after with the \
         default gap {:.4}; volume change {:.1e}",
        scene.name, m.before, coincident.after, m.after, m.gap, m.volume
    );
    assert!(m.before.iter().all(|&n| n > 20), "{}: the inputs must intersect widely", scene.name);
    assert!(coincident.after.iter().all(|&n| n > 0), "{}: coincident surfaces interleave", scene.name);
    assert_eq!(m.after, [0, 0], "{}: faces still intersect at the default gap {}", scene.name, m.gap);
    assert!(m.gap > 0.0);
    assert!(m.volume <= 1e-9, "{}: relative volume change {:.3e}", scene.name, m.volume);
    m
}

#[test]
fn the_default_gap_separates_a_ball_and_a_soft_slab() {
    check_no_intersecting_faces(&scenes::ball_on_ground(0.2, 4, 48));
}

#[test]
fn the_default_gap_separates_two_balls_and_crossed_capsules() {
    check_no_intersecting_faces(&scenes::two_balls(0.15, 4));
    check_no_intersecting_faces(&scenes::crossed_capsules(0.2, 48));
}

#[test]
fn the_default_gap_separates_the_bunny_and_a_soft_box() {
    let Some(bunny) = crate::common::bunny() else { return };
    check_no_intersecting_faces(&bunny_in_box(bunny));
}

#[test]
fn the_gap_grows_from_zero_with_the_penetration() {
    // From the first touch to a deep press: never an intersecting face, and the gap used is at
    // most the typical penetration (about 2/3 of the depth for a ball on a plane), so it starts at 0.
    for depth in [0.001, 0.003, 0.01, 0.03, 0.1, 0.3] {
        let (_, m) = measure(&scenes::ball_on_ground(depth, 4, 48));
        assert_eq!(m.after, [0, 0], "depth {depth}: {:?} faces before, gap {}", m.before, m.gap);
        assert!(m.gap > 0.0 && m.gap <= depth, "depth {depth}: gap {}", m.gap);
    }
}

#[test]
fn a_rigid_side_keeps_its_surface_and_the_other_leaves_the_whole_gap() {
    let mut scene = scenes::ball_on_ground(0.2, 4, 48);
    scene.objects[1].params = ObjectParams::rigid();
    let gap = 0.02;
    let scene = with_gap(scene, Some(gap));
    let (result, m) = measure(&scene);
    assert_eq!(result.positions[1], scene.objects[1].mesh.positions);
    let contact = &result.deformations[0].as_ref().unwrap().contact;
    let lowest =
        (0..contact.len()).filter(|&v| contact[v]).map(|v| result.positions[0][v].z).fold(f64::INFINITY, f64::min);
    let highest =
        (0..contact.len()).filter(|&v| contact[v]).map(|v| result.positions[0][v].z).fold(f64::NEG_INFINITY, f64::max);
    // The ground's top is the plane z = 0: the ball's contact vertices lie on z = gap.
    assert!((lowest - gap).abs() < 1e-12 && (highest - gap).abs() < 1e-12, "{lowest} {highest}");
    assert_eq!(m.gap, gap);
    assert_eq!(m.after, [0, 0]);
}

#[test]
fn two_identical_soft_sides_share_the_gap_equally() {
    let scene = with_gap(scenes::mirrored_balls(0.3, 4), Some(0.02));
    let (result, m) = measure(&scene);
    assert_eq!(m.after, [0, 0]);
    // The balls meet along the plane of symmetry: each stops half the gap from it.
    let contact: Vec<&Vec<bool>> = (0..2).map(|i| &result.deformations[i].as_ref().unwrap().contact).collect();
    let centre = 0.5
        * (squish::mesh::vertex_centroid(&scene.objects[0].mesh.positions)
            + squish::mesh::vertex_centroid(&scene.objects[1].mesh.positions));
    let axis = (squish::mesh::vertex_centroid(&scene.objects[1].mesh.positions) - centre).normalize();
    for (i, (contact, positions)) in contact.iter().zip(&result.positions).enumerate() {
        for v in (0..contact.len()).filter(|&v| contact[v]) {
            let distance = (positions[v] - centre).dot(axis).abs();
            assert!((distance - 0.01).abs() < 1e-9, "ball {i} vertex {v}: {distance}");
        }
    }
}

/// The bunny (y up) with its tail and rump pressed 0.1 into a soft box from +x.
fn bunny_in_box(bunny: squish::TriMesh) -> ProceduralScene {
    let extreme = bunny.positions.iter().fold(f64::NEG_INFINITY, |m, p| m.max(p.x));
    let mut slab = squish::mesh::shapes::cuboid(glam::DVec3::new(0.4, 2.0, 2.0), 64);
    slab.map_positions(|p| p + glam::DVec3::new(extreme - 0.1 + 0.2, 0.0, 0.0));
    let mut scene = ProceduralScene { name: "bunny in a box".into(), ..Default::default() };
    scene.objects.push(squish::OwnedObject { name: "bunny".into(), mesh: bunny, params: Default::default() });
    scene.objects.push(squish::OwnedObject { name: "box".into(), mesh: slab, params: Default::default() });
    scene.pairs.push(squish::pipeline::FramePair { objects: [0, 1], params: PairParams::default() });
    scene
}

// The separation pass (`pipeline::separation`): what the targets' gap alone leaves intersecting —
// a fine partner poking through coarse triangles, bulges growing into each other — is pushed
// apart after chapter 5, with the volume kept.

/// A rigid ball of radius 0.5 with bumps of 0.04 (fine: 2562 vertices) pressed `depth` into a
/// coarse soft slab (cells of 0.25, top at z = 0), shifted by `shift` along x.
fn bumpy_ball_on_coarse_slab(depth: f64, shift: f64) -> ProceduralScene {
    let mut ball = squish::mesh::shapes::icosphere(0.5, 4);
    ball.map_positions(|p| {
        let bump = 1.0 + 0.08 * (9.0 * p.x).sin() * (9.0 * p.y).sin() * (9.0 * p.z).cos();
        p * bump + glam::DVec3::new(shift, 0.0, 0.5 - depth)
    });
    let mut slab = squish::mesh::shapes::cuboid(glam::DVec3::new(3.0, 3.0, 0.5), 12);
    slab.map_positions(|p| p - glam::DVec3::new(0.0, 0.0, 0.25));
    let mut scene = ProceduralScene { name: "bumpy ball on a coarse slab".into(), ..Default::default() };
    scene.objects.push(squish::OwnedObject { name: "bumpy ball".into(), mesh: ball, params: ObjectParams::rigid() });
    scene.objects.push(squish::OwnedObject { name: "slab".into(), mesh: slab, params: Default::default() });
    scene.pairs.push(squish::pipeline::FramePair { objects: [0, 1], params: PairParams::default() });
    scene
}

#[test]
fn a_fine_rigid_bumpy_ball_does_not_poke_through_a_coarse_soft_slab() {
    let scene = bumpy_ball_on_coarse_slab(0.12, 0.0);
    let (result, m) = measure(&scene);
    let (_, coincident) = measure(&with_gap(scene.clone(), Some(0.0)));
    println!(
        "bumpy ball: faces {:?} before, {:?} without gap, {:?} after; volume {:.1e}",
        m.before, coincident.after, m.after, m.volume
    );
    assert!(m.before.iter().all(|&n| n > 10), "{:?}", m.before);
    assert_eq!(m.after, [0, 0], "gap {}", m.gap);
    assert!(m.volume <= 1e-9, "{:.3e}", m.volume);
    assert_eq!(result.positions[0], scene.objects[0].mesh.positions, "the rigid side keeps its surface");
    assert!(result.stats.warnings.is_empty(), "{:?}", result.stats.warnings);
}

#[test]
fn two_soft_balls_bulging_into_each_other_are_separated() {
    // Deep enough that the bulges around the contact meet beyond the zones.
    for (depth, subdivisions) in [(0.3, 3), (0.4, 4)] {
        let scene = scenes::two_balls(depth, subdivisions);
        let (result, m) = measure(&scene);
        println!(
            "two balls {depth} / {subdivisions}: faces {:?} before, {:?} after; volume {:.1e}",
            m.before, m.after, m.volume
        );
        assert_eq!(m.after, [0, 0], "depth {depth}");
        assert!(m.volume <= 1e-9, "depth {depth}: {:.3e}", m.volume);
        assert!(result.stats.warnings.is_empty(), "{:?}", result.stats.warnings);
    }
}

#[test]
fn the_separation_pass_is_invariant_under_rigid_motions() {
    let scene = bumpy_ball_on_coarse_slab(0.12, 0.03);
    let (rotation, shift) =
        (glam::DQuat::from_euler(glam::EulerRot::XYZ, 0.4, -0.9, 1.3), glam::DVec3::new(-3.0, 7.0, 2.0));
    let worst = rigid_motion_difference(&scene, 1, rotation, shift);
    println!("bumpy ball, rotated and moved: largest difference {worst:.2e}");
    assert!(worst < 1e-9, "{worst:e}");
}

#[test]
fn the_separation_pass_keeps_the_motion_continuous() {
    // The bumpy ball slides along x while pressing 0.1 deep: the separation pass corrects a
    // changing set of vertices. The largest move of a vertex between frames, with the pass, stays
    // within 1.2× of the largest without it (its input: chapter 5 with the gap's targets).
    let steps = 40;
    let largest_step = |separate: bool| {
        let mut previous: Option<Vec<glam::DVec3>> = None;
        let mut worst = 0.0f64;
        for k in 0..=steps {
            let scene = bumpy_ball_on_coarse_slab(0.1, 0.1 * k as f64 / steps as f64);
            let mut deformer = if separate { Deformer::new() } else { Deformer::new().without_separation() };
            let result = deformer.deform(&scene.frame()).unwrap();
            if let Some(previous) = &previous {
                let step =
                    previous.iter().zip(&result.positions[1]).map(|(p, q)| (*p - *q).length()).fold(0.0, f64::max);
                worst = worst.max(step);
            }
            previous = Some(result.positions[1].clone());
        }
        worst
    };
    let (with_pass, without) = (largest_step(true), largest_step(false));
    println!(
        "sliding bumpy ball: largest step {with_pass:.3e} with the pass, {without:.3e} without ({:.2}×)",
        with_pass / without
    );
    assert!(with_pass <= 1.2 * without, "{with_pass:.3e} vs {without:.3e}");
}

/// The separation pass starts from the last pass's distance bounds, lowered by how far every
/// vertex moved since (`separation::SeparationSeed`): a ball pressed deeper in small steps, then a
/// jump, another mesh, a cut ground region and the whole ground again (the seed then does not
/// fit: a distance to a cut region bounds none to the whole) give on one deformer a fresh
/// deformer's bits at every frame, and the small steps ask fewer queries.
#[test]
fn each_pass_starts_from_the_last_ones_bounds_with_a_fresh_frames_bits() {
    use squish::stage::Stage;
    let bits = |r: &FrameResult| -> Vec<u64> {
        r.positions.iter().flatten().flat_map(|p| p.to_array().map(f64::to_bits)).collect()
    };
    let mut frames: Vec<ProceduralScene> =
        (0..6).map(|k| scenes::ball_on_ground(0.2 + 0.002 * k as f64, 3, 24)).collect();
    frames.push(scenes::ball_on_ground(0.3, 3, 24));
    let whole = scenes::ball_on_ground(0.3, 2, 24);
    let mut cut = whole.clone();
    let mask: Vec<bool> = cut.objects[1].mesh.positions.iter().map(|p| p.x * p.x + p.y * p.y < 0.9 * 0.9).collect();
    cut.objects[1].params = cut.objects[1].params.clone().with_region_masks(std::slice::from_ref(&mask));
    frames.extend([whole.clone(), cut.clone(), cut, whole]);
    let mut deformer = Deformer::new();
    let (mut reused, mut fresh) = (0, 0);
    for (k, scene) in frames.iter().enumerate() {
        let result = deformer.deform(&scene.frame()).unwrap();
        let alone = Deformer::new().deform(&scene.frame()).unwrap();
        assert!(bits(&result) == bits(&alone), "frame {k}: the positions differ from a fresh deformer's");
        assert_eq!(format!("{:?}", result.stats.objects), format!("{:?}", alone.stats.objects), "frame {k}");
        let (a, b) = (result.stats.work[Stage::Separation], alone.stats.work[Stage::Separation]);
        assert!(b.rounds > 0, "frame {k}: the pass must work");
        assert_eq!(a.rounds, b.rounds, "frame {k}: the same rounds");
        if (1..6).contains(&k) {
            reused += a.queries;
            fresh += b.queries;
        }
    }
    assert!(reused * 10 < fresh * 9, "small steps: {reused} queries from the last bounds, {fresh} from none");
}

#[test]
fn the_pass_stops_with_every_vertex_within_its_tolerance_of_the_gap() {
    // When the pass stops, no vertex is asked to move by more than `STOP_FRACTION`·g: each
    // output vertex near the other object is about (1 − `STOP_FRACTION`)·g or more out of it; a
    // side's share of the gap, the blend of a vertex's asks and the spread of its neighbours'
    // moves allow twice that. Two bench scenes whose pass takes at least two rounds, so that a
    // pass stopped early fails (the figures are in docs/speed.md, "The separation pass stops at
    // 5% of the gap").
    use squish::pipeline::STOP_FRACTION;
    use squish_scenes::bench::{BenchSize, fingers_ball, hat_egg};
    for scene in [fingers_ball(BenchSize::Full), hat_egg(BenchSize::Full)] {
        let scene = scene.pose(0.5);
        let (result, m) = measure(&scene);
        let outputs = [deformed(&scene, &result, 0), deformed(&scene, &result, 1)];
        let (mut nearest, mut count) = (f64::INFINITY, 0);
        for l in 0..2 {
            let tree = squish::spatial::TriangleBvh::new(&outputs[1 - l]).unwrap();
            for &p in &outputs[l].positions {
                let Some(cp) = tree.closest_point_within(p, 2.0 * m.gap) else { continue };
                let inside = tree.winding_number(p) != 0;
                nearest = nearest.min(if inside { -cp.distance } else { cp.distance });
                count += 1;
            }
        }
        let rounds = result.stats.work[squish::stage::Stage::Separation].rounds;
        println!(
            "{}: {count} vertices within 2g of the other object, the nearest at {:.4} g after {rounds} rounds",
            scene.name,
            nearest / m.gap
        );
        assert!(count > 20 && rounds >= 2, "{}: {count} vertices, {rounds} rounds", scene.name);
        assert!(nearest >= (1.0 - 2.0 * STOP_FRACTION) * m.gap, "{}: nearest {:.4} g", scene.name, nearest / m.gap);
    }
}
