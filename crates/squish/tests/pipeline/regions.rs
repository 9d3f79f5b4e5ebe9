//! Tests of working regions and many contacts (thesis §4.5, §5.2.2, §7.1.2): hand-like scenes
//! with one contact per finger, regions versus whole objects, automatic regions over an
//! animation, determinism.

use std::time::{Duration, Instant};

use glam::DVec3;
use squish::contact::ContactError;
use squish::mesh::{SubMesh, TriMesh, shapes};
use squish::params::{ObjectParams, PairParams, RegionChoice};
use squish::pipeline::*;
use squish::spatial::{penetration_depths, self_intersections};
use squish::stage::{Stage, StageTimes};
use squish_scenes::procedural::{self as scenes, ProceduralScene};

use crate::common::{self as test_meshes, assert_no_flipped_face, deepest_penetration, deformed, penetrations};

fn bits(positions: &[DVec3]) -> Vec<u64> {
    positions.iter().flat_map(|p| p.to_array().map(f64::to_bits)).collect()
}

/// Figures of a two-object scene checked by [`check_regions`].
struct Checked {
    result: FrameResult,
    contacts: usize,
}

/// Runs a two-object scene and checks: every volume preserved to 1e-9, residual penetration
/// ≤ `max_ratio` of the initial one, no NaN, no flipped face, vertices outside every region and outside
/// 𝒟 ∪ 𝒞 bit-identical, no clamped extent.
fn check_regions(scene: &ProceduralScene, max_ratio: f64) -> Checked {
    let start = Instant::now();
    let result = Deformer::new().deform(&scene.frame()).expect("frame deforms");
    let elapsed = start.elapsed();
    let (before, after_meshes, after) = penetrations(scene, &result);
    let mut worst_volume = 0.0f64;
    for (i, object) in scene.objects.iter().enumerate() {
        let stats = &result.stats.objects[i];
        assert!(stats.deformed, "{}: {} not deformed", scene.name, object.name);
        assert!(!stats.extent_clamped, "{}: {} needed a clamped extent", scene.name, object.name);
        worst_volume = worst_volume.max(stats.relative_volume_change.abs());
        let output = &after_meshes[i];
        assert!(output.positions.iter().all(|p| p.is_finite()), "{}: NaN in {}", scene.name, object.name);
        assert_no_flipped_face(&object.mesh, output, &format!("{} ({})", object.name, scene.name));
        let mut in_region = vec![false; object.mesh.num_vertices()];
        for summary in result.regions.iter().filter(|s| s.object == i) {
            if summary.whole {
                in_region.fill(true);
            }
            for &v in &summary.vertices {
                in_region[v as usize] = true;
            }
        }
        let deformation = result.deformations[i].as_ref().unwrap();
        let mut outside = 0;
        for (v, &inside) in in_region.iter().enumerate() {
            if !inside || (!deformation.deformable[v] && !deformation.contact[v]) {
                outside += usize::from(!inside);
                assert_eq!(
                    bits(&output.positions[v..=v]),
                    bits(&object.mesh.positions[v..=v]),
                    "{}: vertex {v} of {} is outside the regions or 𝒟 ∪ 𝒞 but moved",
                    scene.name,
                    object.name
                );
            }
        }
        let regions: Vec<&RegionStats> = result.stats.regions.iter().filter(|r| r.object == i).collect();
        println!(
            "  {}: {} vertices, {} outside every region; regions (vertices, zones, extent): {:?}",
            object.name,
            object.mesh.num_vertices(),
            outside,
            regions.iter().map(|r| (r.vertices, r.zones, (r.extent * 1e3).round() / 1e3)).collect::<Vec<_>>()
        );
    }
    let contacts = result.stats.pairs.iter().filter(|p| p.in_contact).count();
    let ratio = after / before;
    println!(
        "{}: {} contacts, volume change {worst_volume:.2e}, penetration {before:.4} → {after:.2e} ({ratio:.2e}); \
         {:.1} ms ({})",
        scene.name,
        contacts,
        elapsed.as_secs_f64() * 1e3,
        stage_times(&result.stats.stages),
    );
    assert!(worst_volume <= 1e-9, "{}: relative volume change {worst_volume:.3e}", scene.name);
    assert!(ratio <= max_ratio, "{}: residual penetration {after:.4e} is {ratio:.3e} of {before:.4e}", scene.name);
    Checked { result, contacts }
}

/// The non-zero stage times in ms, in pipeline order.
fn stage_times(stages: &StageTimes) -> String {
    let times: Vec<String> = Stage::ALL
        .into_iter()
        .filter(|&s| stages[s] > Duration::ZERO)
        .map(|s| format!("{s} {:.1}", stages[s].as_secs_f64() * 1e3))
        .collect();
    times.join(", ")
}

/// Prints the wall-clock time of a frame deformed again by a deformer that has seen it (caches
/// built: numeric work only), with its stage breakdown.
fn print_steady_timing(scene: &ProceduralScene) {
    let mut deformer = Deformer::new();
    deformer.deform(&scene.frame()).unwrap();
    let start = Instant::now();
    let result = deformer.deform(&scene.frame()).unwrap();
    println!(
        "{}, reused deformer: {:.1} ms ({}); {} regions in parallel",
        scene.name,
        start.elapsed().as_secs_f64() * 1e3,
        stage_times(&result.stats.stages),
        result.stats.regions.len()
    );
}

/// Number of fingers of a hand scene whose tip intersects the other object.
fn intersecting_fingers(scene: &ProceduralScene) -> usize {
    let hand = &scene.objects[0].mesh;
    let depths = penetration_depths(hand, &scene.objects[1].mesh).unwrap();
    let per_finger = hand.num_vertices() / 5;
    (0..5).filter(|k| depths[k * per_finger..(k + 1) * per_finger].iter().any(|&d| d > 0.0)).count()
}

#[test]
fn each_finger_pressing_a_ball_gets_its_own_contact() {
    let scene = scenes::fingers_on_ball(0.06, 6, 32);
    assert!(self_intersections(&scene.objects[0].mesh).unwrap().faces.is_empty(), "fingers must not touch");
    let fingers = intersecting_fingers(&scene);
    assert_eq!(fingers, 5);
    let checked = check_regions(&scene, 0.02);
    assert_eq!(checked.contacts, fingers, "one contact per intersecting finger");
    let stats = &checked.result.stats;
    assert_eq!(stats.objects[0].regions, 5);
    // Every finger region touches the ball once; the ball's single region holds all the zones,
    // each with its own mapping direction.
    for region in stats.regions.iter().filter(|r| r.object == 0) {
        assert_eq!((region.zones, region.touching.as_slice()), (1, &[[1, 0]][..]), "{region:?}");
    }
    print_steady_timing(&scene);
    let ball: Vec<&RegionStats> = stats.regions.iter().filter(|r| r.object == 1).collect();
    assert_eq!(ball.len(), 1);
    assert_eq!(ball[0].zones, 5);
    let directions: Vec<DVec3> =
        stats.pairs.iter().filter(|p| p.in_contact).map(|p| DVec3::from_array(p.direction)).collect();
    for (k, a) in directions.iter().enumerate() {
        for b in &directions[k + 1..] {
            assert!(a.dot(*b) < 0.999, "each finger has its own mapping direction: {a} vs {b}");
        }
    }
}

#[test]
fn each_finger_pressing_a_slab_gets_its_own_contact() {
    let mut scene = scenes::fingers_on_slab(0.06, 96, 32);
    // A fixed extent: the automatic one (≈ 0.9) makes the slab's band (2·φ_max wide) the whole
    // 2 × 2 slab.
    scene.objects[1].params.extent = Some(0.4);
    let fingers = intersecting_fingers(&scene);
    assert_eq!(fingers, 5);
    let checked = check_regions(&scene, 0.02);
    assert_eq!(checked.contacts, fingers, "one contact per intersecting finger");
    let stats = &checked.result.stats;
    print_steady_timing(&scene);
    let slab: Vec<&RegionStats> = stats.regions.iter().filter(|r| r.object == 1).collect();
    assert_eq!(slab.iter().map(|r| r.zones).sum::<usize>(), 5);
    assert!(slab.iter().all(|r| !r.whole && r.cut_border_vertices > 0), "the slab is processed on a band");
    assert!(slab.iter().map(|r| r.vertices).sum::<usize>() < scene.objects[1].mesh.num_vertices());
}

/// Largest distance between the positions of two results, and the largest displacement of the
/// reference.
fn difference(reference: &FrameResult, other: &FrameResult, input: &ProceduralScene) -> (f64, f64) {
    let mut worst = 0.0f64;
    let mut moved = 0.0f64;
    for (i, object) in input.objects.iter().enumerate() {
        for ((a, b), p) in reference.positions[i].iter().zip(&other.positions[i]).zip(&object.mesh.positions) {
            worst = worst.max((*a - *b).length());
            moved = moved.max((*a - *p).length());
        }
    }
    (worst, moved)
}

#[test]
fn regions_holding_the_deformation_match_the_whole_object() {
    // Fixed extents: the automatic one (2.17 on this slab) makes 𝒫 the whole slab.
    for extent in [Some(0.8), Some(0.5)] {
        let mut scene = scenes::ball_on_ground(0.2, 4, 48);
        scene.objects[1].params.extent = extent;
        let run = |region: &dyn Fn(ObjectParams) -> ObjectParams| {
            let mut scene = scene.clone();
            scene.objects[1].params = region(scene.objects[1].params.clone());
            Deformer::new().deform(&scene.frame()).unwrap()
        };
        let whole = run(&|p| p);
        let ground = &scene.objects[1].mesh;

        // A mask selecting every vertex is the whole object: bit-identical.
        let all = run(&|p| p.with_region_masks(&[vec![true; ground.num_vertices()]]));
        assert!(all.regions.iter().all(|r| r.whole));
        for (a, b) in whole.positions.iter().zip(&all.positions) {
            assert_eq!(bits(a), bits(b));
        }

        // The parametrization domain 𝒫 (within 2 φ_max of ∂𝒞 along edges) as a mask, and the
        // automatic band: 𝒫 does not reach their cut, so they give the whole object's result up
        // to round-off (the heat time and the slope confidence use the object's h, the
        // constraint weights do not depend on the region). A mask of u ≤ 1.25 holds 𝒟 but cuts 𝒫:
        // a small difference, reported.
        let deformation = whole.deformations[1].as_ref().unwrap();
        // 𝒫's vertices and their neighbours (so that no vertex within the radius is on the cut).
        let mut grown = deformation.domain.clone();
        for tri in &ground.triangles {
            if tri.iter().any(|&v| deformation.domain[v as usize]) {
                for &v in tri {
                    grown[v as usize] = true;
                }
            }
        }
        let inner: Vec<bool> = deformation.u.iter().map(|&u| u <= 1.25).collect();
        type Choose<'a> = &'a dyn Fn(ObjectParams) -> ObjectParams;
        let runs: [(&str, Choose, bool); 3] = [
            ("mask of 𝒫 and its neighbours", &|p| p.with_region_masks(std::slice::from_ref(&grown)), false),
            ("distance band", &|p| p.with_region_distance(0.0), false),
            ("mask of u ≤ 1.25", &|p| p.with_region_masks(std::slice::from_ref(&inner)), true),
        ];
        for (name, region, cut) in runs {
            let result = run(region);
            let region = result.stats.regions.iter().find(|r| r.object == 1).unwrap();
            assert!(!region.whole && !region.extent_clamped, "{name}: {region:?}");
            assert_eq!(region.extent, whole.stats.objects[1].extent, "{name}: same extent");
            assert_eq!(region.domain_reaches_cut, cut, "{name}: {region:?}");
            assert_eq!(result.stats.objects[1].domain_reaches_cut, cut, "{name}: the object's figure");
            let (worst, moved) = difference(&whole, &result, &scene);
            println!(
                "extent {extent:?}, {name}: region of {} / {} vertices, 𝒫 {} vertices, reaches the cut: {}; \
                 largest difference with the whole object {worst:.3e} ({:.2e} of the largest displacement \
                 {moved:.3e})",
                region.vertices,
                ground.num_vertices(),
                region.domain_vertices,
                region.domain_reaches_cut,
                worst / moved
            );
            if cut {
                assert!(worst > 1e-9 * moved && worst <= 5e-2 * moved, "{name}: {worst:.3e} vs {moved:.3e}");
            } else {
                assert!(worst <= 1e-12 * moved && worst <= 1e-6, "{name}: {worst:.3e} vs {moved:.3e}");
            }
            assert!(result.stats.objects[1].relative_volume_change.abs() <= 1e-9);
            // The object's figures sum its regions' (a cut region's counts were once dropped).
            let stats = &result.deformations[1].as_ref().unwrap().stats;
            assert_eq!(stats.numeric_factorizations, 3, "{name}: heat, Poisson, guide");
            assert!(stats.factorized_rows > 0 && stats.recomputed_rows <= stats.factorized_rows, "{name}: {stats:?}");
            assert_eq!(
                stats.reduced_analyses > 0,
                stats.timings[Stage::Analysis] > Duration::ZERO,
                "{name}: {stats:?}"
            );
            assert!(stats.timings[Stage::Analysis] <= stats.timings[Stage::Factorization], "{name}: {stats:?}");
        }
    }
}

/// A disk of the ground's top face around the contact, as a vertex mask.
fn top_disk(ground: &TriMesh, radius: f64) -> Vec<bool> {
    ground.positions.iter().map(|p| p.z > -1e-9 && p.x * p.x + p.y * p.y < radius * radius).collect()
}

#[test]
fn a_region_too_small_for_the_extent_clamps_it() {
    let mut scene = scenes::ball_on_ground(0.2, 4, 48);
    let whole = Deformer::new().deform(&scene.frame()).unwrap();
    let mask = top_disk(&scene.objects[1].mesh, 1.6);
    scene.objects[1].params = scene.objects[1].params.clone().with_region_masks(std::slice::from_ref(&mask));
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    let region = &result.stats.regions[1];
    let automatic = whole.stats.objects[1].extent;
    println!("disk of radius 1.6: extent {automatic:.3} clamped to {:.3}", region.extent);
    assert!(region.extent_clamped && region.extent < automatic, "{region:?}");
    assert!(result.stats.objects[1].extent_clamped);
    // Both solves of §5.1–5.3 (before and after the clamp) count in the region's figures.
    let stats = &result.deformations[1].as_ref().unwrap().stats;
    assert_eq!(stats.numeric_factorizations, 6, "heat, Poisson, guide, twice: {stats:?}");
    assert!(stats.work[Stage::Parametrization].rows > 0 && stats.timings[Stage::Guide] > Duration::ZERO);
    // The cut border and everything outside the region stay put, the volume is preserved and the
    // contact stays clean.
    let ground = &scene.objects[1].mesh.clone();
    let summary = &result.regions[1];
    assert!(!summary.cut_border.is_empty());
    let mut inside = vec![false; ground.num_vertices()];
    for &v in &summary.vertices {
        inside[v as usize] = true;
    }
    for &v in &summary.cut_border {
        inside[v as usize] = false;
    }
    for (v, (p, q)) in ground.positions.iter().zip(&result.positions[1]).enumerate() {
        if !inside[v] {
            assert_eq!(bits(&[*p]), bits(&[*q]), "vertex {v} outside the region or on its cut moved");
        }
    }
    assert!(result.stats.objects[1].relative_volume_change.abs() <= 1e-9);
    let before = deepest_penetration(&scene.objects[0].mesh, ground);
    let after = deepest_penetration(&deformed(&scene, &result, 0), &deformed(&scene, &result, 1));
    println!("disk of radius 1.6: penetration {before:.4} → {after:.2e} ({:.2e})", after / before);
    assert!(after <= 0.02 * before, "{after} vs {before}");

    // A region cutting through the intersection, and a region lying wholly inside the ball, are
    // errors naming the object.
    let half: Vec<bool> = top_disk(ground, 1.6).iter().zip(&ground.positions).map(|(&m, p)| m && p.x < 0.0).collect();
    scene.objects[1].params = scene.objects[1].params.clone().with_region_masks(&[half]);
    let err = Deformer::new().deform(&scene.frame()).unwrap_err();
    println!("{err}");
    assert!(matches!(err, PipelineError::Contact { source: ContactError::IntersectionReachesBorder { .. }, .. }));
    assert!(err.to_string().contains("ground (region 0)"), "{err}");
    scene.objects[1].params = scene.objects[1].params.clone().with_region_masks(&[top_disk(ground, 0.3)]);
    let err = Deformer::new().deform(&scene.frame()).unwrap_err();
    println!("{err}");
    assert!(matches!(err, PipelineError::RegionTooSmall { region: 0, .. }), "{err}");
    assert!(err.to_string().contains("\"ground\"") && err.to_string().contains("inside \"ball\""), "{err}");
}

#[test]
fn invalid_regions_are_errors_naming_the_object() {
    let scene = scenes::ball_on_ground(0.1, 2, 4);
    let n = scene.objects[1].mesh.num_vertices();
    let fails = |params: ObjectParams, expected: &str| {
        let mut scene = scene.clone();
        scene.objects[1].params = params;
        let err = Deformer::new().deform(&scene.frame()).unwrap_err().to_string();
        assert!(err.contains("\"ground\"") && err.contains(expected), "{err}");
    };
    let ground = ObjectParams::default();
    fails(ground.clone().with_region_masks(&[vec![true; n - 1]]), "one value per vertex");
    let mut overlapping = ground.clone().with_region_masks(&[vec![true; n]]);
    // Labels give each vertex one mask, so masks cannot overlap; a value that is not a number
    // is an error naming the key, as is a NaN distance.
    overlapping.region_mask = Some(vec![f64::NAN; n]);
    fails(overlapping, "region_mask");
    fails(ground.clone().with_region_distance(f64::NAN), "region_distance = NaN");
    // Self-contact needs explicit regions.
    for region in [ground.clone(), ground.clone().with_region_distance(0.1)] {
        let mut scene = scene.clone();
        scene.objects[1].params = region;
        scene.pairs.push(FramePair { objects: [1, 1], params: PairParams::default() });
        let err = Deformer::new().deform(&scene.frame()).unwrap_err();
        assert!(matches!(err, PipelineError::SelfPair { .. }), "{err}");
    }
}

#[test]
fn regions_are_serde_ready_with_a_whole_default() {
    let params: ObjectParams = serde_json::from_str(r#"{ "stiffness": 2 }"#).unwrap();
    assert_eq!(params.region, RegionChoice::Whole);
    let params: ObjectParams = serde_json::from_str(r#"{ "region": "distance", "region_distance": 0.25 }"#).unwrap();
    assert_eq!((params.region, params.region_distance), (RegionChoice::Distance, 0.25));
    let params: ObjectParams = serde_json::from_str(r#"{ "region": "components" }"#).unwrap();
    assert_eq!(params.region, RegionChoice::Components);
    let masks = ObjectParams::default().with_region_masks(&[vec![true, false], vec![false, true]]);
    let json = serde_json::to_string(&masks).unwrap();
    assert!(json.contains(r#""region":"mask""#) && json.contains(r#""region_mask":[1.0,2.0]"#), "{json}");
    assert_eq!(serde_json::from_str::<ObjectParams>(&json).unwrap(), masks);
}

#[test]
fn automatic_regions_follow_a_sliding_ball_continuously() {
    // A ball pressed 0.15 into the ground slides 0.4 along x in 100 steps; the ground's working
    // region is the automatic band, which follows the ball. Between consecutive frames, no vertex
    // moves by more than 10× the step (after removing the ball's own motion).
    let steps = 100;
    let step = 0.004;
    let mut deformer = Deformer::new();
    let mut previous: Option<Vec<Vec<DVec3>>> = None;
    let (mut worst, mut rebuilds, mut clamps) = (0.0f64, 0, 0);
    let mut sizes = Vec::new();
    let start = Instant::now();
    for k in 0..=steps {
        let mut scene = scenes::ball_on_ground(0.15, 4, 32);
        let shift = DVec3::new(step * k as f64 - 0.2, 0.0, 0.0);
        scene.objects[0].mesh.map_positions(|p| p + shift);
        scene.objects[1].params = scene.objects[1].params.clone().with_region_distance(0.0);
        // A fixed extent: the automatic one (≈ 2.2) makes the band the whole ground.
        scene.objects[1].params.extent = Some(0.8);
        let result = deformer.deform(&scene.frame()).unwrap();
        let ground = result.stats.regions.iter().filter(|r| r.object == 1);
        rebuilds += ground.clone().filter(|r| r.rebuilt).count();
        clamps += ground.clone().filter(|r| r.extent_clamped).count();
        sizes.push(ground.map(|r| r.vertices).sum::<usize>());
        assert!(result.stats.objects[1].relative_volume_change.abs() <= 1e-9);
        if let Some(prev) = &previous {
            for (i, (now, before)) in result.positions.iter().zip(prev).enumerate() {
                let rigid = if i == 0 { DVec3::new(step, 0.0, 0.0) } else { DVec3::ZERO };
                for (p, q) in now.iter().zip(before) {
                    worst = worst.max((*p - *q - rigid).length());
                }
            }
        }
        previous = Some(result.positions);
    }
    let ratio = worst / step;
    let (min, max) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
    println!(
        "sliding ball: largest jump {worst:.3e} = {ratio:.2} × step; {rebuilds} region rebuilds in {} frames, \
         {clamps} clamps, band of {min}..{max} vertices; {:.1} ms per frame",
        steps + 1,
        start.elapsed().as_secs_f64() * 1e3 / (steps + 1) as f64
    );
    assert!(rebuilds > 1, "the band must move with the ball");
    assert!(ratio <= 10.0, "largest jump between frames {worst:.3e} is {ratio:.2} × the step");
}

#[test]
fn reusing_the_deformer_and_the_thread_count_do_not_change_regional_results() {
    let scenes = [scenes::fingers_on_slab(0.04, 48, 24), scenes::fingers_on_slab(0.06, 48, 24)];
    let mut reused = Deformer::new();
    let pools = [1, 2].map(|n| rayon::ThreadPoolBuilder::new().num_threads(n).build().unwrap());
    for scene in &scenes {
        let a = reused.deform(&scene.frame()).unwrap();
        assert_eq!(a.stats.pairs.iter().filter(|p| p.in_contact).count(), 5);
        for pool in &pools {
            let b = pool.install(|| Deformer::new().deform(&scene.frame()).unwrap());
            for (x, y) in a.positions.iter().zip(&b.positions) {
                assert_eq!(bits(x), bits(y));
            }
        }
    }
}

#[test]
fn fingers_pressing_their_own_palm_are_regions_of_one_object() {
    let scene = scenes::fingers_on_own_palm(0.06, 96, 32);
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    let stats = &result.stats;
    let contacts = stats.pairs.iter().filter(|p| p.in_contact).count();
    let palm = &stats.regions[0];
    println!(
        "own palm: {} regions, {} region pairs, {contacts} contacts, palm zones {}, volume change {:.2e}",
        stats.objects[0].regions,
        stats.pairs.len(),
        palm.zones,
        stats.objects[0].relative_volume_change
    );
    assert_eq!(stats.objects[0].regions, 6);
    assert_eq!(contacts, 5);
    assert_eq!(palm.zones, 5);
    assert!(stats.pairs.iter().filter(|p| p.in_contact).all(|p| p.regions.is_some_and(|[a, _]| a == 0)));
    assert!(stats.objects[0].relative_volume_change.abs() <= 1e-9);
    let mesh = &scene.objects[0].mesh;
    let output = deformed(&scene, &result, 0);
    assert_no_flipped_face(mesh, &output, "the hand");
    // The palm (first component) and the fingers as separate meshes: clean contact.
    let split = |m: &TriMesh| {
        let faces = result.regions[0].faces.iter().copied();
        let palm = SubMesh::from_faces(m, faces).mesh;
        let rest: Vec<u32> =
            (0..m.num_triangles() as u32).filter(|f| result.regions[0].faces.binary_search(f).is_err()).collect();
        (palm, SubMesh::from_faces(m, rest).mesh)
    };
    let (palm_before, fingers_before) = split(mesh);
    let (palm_after, fingers_after) = split(&output);
    let before = deepest_penetration(&palm_before, &fingers_before);
    let after = deepest_penetration(&palm_after, &fingers_after);
    println!("own palm: penetration {before:.4} → {after:.2e} ({:.2e})", after / before);
    assert!(after <= 0.02 * before);
}

/// The scanned hand (y up, fingers' pads toward +z) and a soft ball of radius 0.4 in front of
/// its index, middle and ring fingers, pushed toward the hand until the deepest overlap is 0.03
/// (index 0.016, middle 0.03, ring 0.0095). `None` if the mesh is absent.
fn scanned_hand_scene(hand_region: RegionChoice, hand_extent: Option<f64>) -> Option<ProceduralScene> {
    let hand = test_meshes::shared_mesh("hand_7993.obj")?;
    let (radius, depth) = (0.4, 0.03);
    let overlap = |z: f64| {
        let c = DVec3::new(0.0, 0.83, z);
        hand.positions.iter().map(|p| radius - (*p - c).length()).fold(f64::NEG_INFINITY, f64::max)
    };
    let (mut lo, mut hi) = (0.0, 1.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if overlap(mid) > depth { lo = mid } else { hi = mid }
    }
    let mut ball = shapes::icosphere(radius, 6);
    ball.map_positions(|p| p + DVec3::new(0.0, 0.83, lo));
    let mut scene = ProceduralScene { name: "scanned hand and a ball".into(), ..Default::default() };
    let mut params = ObjectParams::default().with_region(hand_region);
    params.extent = hand_extent;
    scene.objects.push(squish::OwnedObject { name: "hand".into(), mesh: hand, params });
    let ball_params = ObjectParams::default().with_region_distance(0.0);
    scene.objects.push(squish::OwnedObject { name: "ball".into(), mesh: ball, params: ball_params });
    scene.pairs.push(FramePair { objects: [0, 1], params: PairParams::default() });
    Some(scene)
}

#[test]
fn a_scanned_hand_with_automatic_regions_pressing_a_ball() {
    // The bands around the three finger tips merge through the fingers' sides (they touch in this
    // scan): one hand region, one contact, one ε_c for three tips of different depths (0.016,
    // 0.03, 0.0095). With τ = 0 the shallow ring-finger tip falls below ε_c = m_𝒮 and stays
    // inside the ball (29% of the depth left, as with whole objects); τ = −1 lowers ε_c to take
    // it in. The residual left (2.3% of the depth, at contact-zone vertices of the finger pads, of
    // radius ≈ 0.04 for edges of 0.011) is the discretization of 𝒮, so the bound here is 3%.
    let Some(mut scene) = scanned_hand_scene(RegionChoice::Distance, None) else { return };
    scene.pairs[0].params.contact_tau = -1.0;
    let checked = check_regions(&scene, 0.03);
    assert_eq!(checked.contacts, 1);
    // The same as processing the whole objects, up to the cut's boundary condition.
    let mut whole = scene.clone();
    for object in &mut whole.objects {
        object.params.region = RegionChoice::Whole;
    }
    let reference = Deformer::new().deform(&whole.frame()).unwrap();
    let (worst, moved) = difference(&reference, &checked.result, &scene);
    println!("scanned hand: automatic regions vs whole objects {worst:.2e} ({:.2e} of {moved:.2e})", worst / moved);
    assert!(worst <= 0.01 * moved);
}

#[test]
fn whole_round_objects_take_the_nested_dissection_and_automatic_regions_keep_amd() {
    // Two icospheres of 10242 vertices: AMD's order needs ~1.8× the dissection's flops on them,
    // so a whole ball keeps the dissection. An automatic region is cut again whenever its faces
    // change, and its analysis stays AMD's alone (its cap here would also prefer the dissection).
    let mut scene = scenes::two_balls(0.1, 5);
    let whole = Deformer::new().deform(&scene.frame()).unwrap();
    assert_eq!(whole.stats.regions.len(), 2);
    for region in &whole.stats.regions {
        assert!(region.deformed && region.whole, "{}", region.name);
        assert!(region.nested_dissection, "whole ball {} should keep the dissection", region.name);
    }
    scene.objects[1].params = scene.objects[1].params.clone().with_region_distance(0.0);
    scene.objects[1].params.extent = Some(1.2);
    let automatic = Deformer::new().deform(&scene.frame()).unwrap();
    let big: Vec<_> = automatic.stats.regions.iter().filter(|r| r.object == 1).collect();
    assert_eq!(big.len(), 1);
    assert!(big[0].deformed && !big[0].whole, "the big ball's region is an automatic cap");
    assert!(!big[0].nested_dissection, "automatic regions use AMD's order");
    let small = automatic.stats.regions.iter().find(|r| r.object == 0).unwrap();
    assert!(small.nested_dissection, "the small ball is still whole");
}
