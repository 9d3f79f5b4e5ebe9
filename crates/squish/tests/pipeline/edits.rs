//! Edits of the parameters of §5.4–5.5 (`Deformer::keep_for_edits`): an edited frame reuses the
//! last frame's contact stage and region fields, and must equal, bit for bit, a fresh deformer's
//! computation of the same frame — for each downstream parameter, on a scene of whole objects and
//! on one with a cut (and clamped) working region. A change of any other parameter or of a
//! position is a full frame.

use squish::params::{ObjectParams, ParamValue, Params};
use squish::pipeline::*;
use squish_scenes::procedural::{self as scenes, ProceduralScene};

/// Everything of a result that does not measure work: positions, deformations, figures of
/// objects, pairs and regions (times, work counters and the edit flag left out), as text whose
/// numbers are written to round-trip (so equal text is equal bits).
fn figures(result: &FrameResult) -> String {
    let mut text = format!("{:?}\n", result.positions);
    for d in result.deformations.iter().flatten() {
        let s = &d.stats;
        text += &format!(
            "{:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?}\n",
            d.positions,
            d.u,
            d.domain,
            d.deformable,
            d.contact,
            d.directions,
            d.heights,
            d.amplitude,
            d.slope,
            d.bulge_map
        );
        text += &format!(
            "h {:?} {:?} exact {} residual {:?} volumes {:?} {:?} counts {} {} {} moved {} fallbacks {:?}\n",
            s.bulge_height,
            s.applied_bulge_height,
            s.volume_exact,
            s.volume_residual,
            s.volume_before,
            s.volume_after,
            s.num_deformable,
            s.num_contact,
            s.num_boundary_points,
            s.outer_boundary_moved,
            s.fallbacks
        );
    }
    text += &format!("{:?}\n{:?}\n{:?}\n", result.stats.objects, result.stats.pairs, result.regions);
    for r in &result.stats.regions {
        let r = RegionStats { time: Default::default(), rebuilt: false, ..r.clone() };
        text += &format!("{r:?}\n");
    }
    text
}

/// Panics naming the first line where `a` and `b` differ (whole texts are megabytes).
fn assert_same(a: &str, b: &str, what: &str) {
    if let Some((k, (x, y))) = a.lines().zip(b.lines()).enumerate().find(|(_, (x, y))| x != y) {
        let at = x.bytes().zip(y.bytes()).take_while(|(p, q)| p == q).count().saturating_sub(40);
        let shown = |line: &str| line.get(at..).unwrap_or("").chars().take(240).collect::<String>();
        panic!("{what}: line {k} differs at byte {at}:\n  {}\n  {}", shown(x), shown(y));
    }
    assert_eq!(a.lines().count(), b.lines().count(), "{what}: line counts");
}

/// The values a downstream key is edited to on the ball's parameters.
fn edited_value(key: &str) -> ParamValue {
    match key {
        "bulge" => ParamValue::Number(1.2),
        "bulge_height" => ParamValue::Number(0.05),
        "preserve_volume" => ParamValue::Bool(false),
        "profile_v2" => ParamValue::Number(0.45),
        "profile_v3" => ParamValue::Number(0.7),
        "profile_v4" => ParamValue::Number(0.97),
        "wrinkle_amplitude" => ParamValue::Number(0.01),
        "wrinkle_frequency" => ParamValue::Number(3.0),
        "anisotropy" => ParamValue::Bool(true),
        "anisotropy_exponent" => ParamValue::Number(3.0),
        "anisotropy_offset" => ParamValue::Number(0.2),
        other => panic!("no edit for {other}"),
    }
}

/// A painted map: more bulge on one side (x > 0).
fn half_map(scene: &ProceduralScene, object: usize) -> Vec<f64> {
    scene.objects[object].mesh.positions.iter().map(|p| if p.x > 0.0 { 2.0 } else { 0.5 }).collect()
}

/// Sets `key` on object `object` of `scene` to its edited value; the anisotropic map's own keys
/// are edited with the map on (and the kept frame has it on too: see `prepare`).
fn edit(scene: &mut ProceduralScene, object: usize, key: &str) {
    if key == "bulge_map" {
        let map = half_map(scene, object);
        scene.objects[object].params.bulge_map = Some(map);
        return;
    }
    scene.objects[object].params.set(key, &edited_value(key)).unwrap();
}

/// The kept frame's parameters for editing `key`: the anisotropic map on for its exponent and
/// offset, so that the edit changes the result.
fn prepare(params: &mut ObjectParams, key: &str) {
    if matches!(key, "anisotropy_exponent" | "anisotropy_offset") {
        params.anisotropy = true;
    }
    // Wrinkles need both an amplitude and a frequency: the other one is set for each.
    if key == "wrinkle_frequency" {
        params.wrinkle_amplitude = 0.01;
    }
    if key == "wrinkle_amplitude" {
        params.wrinkle_frequency = 3.0;
    }
    if key == "bulge_height" {
        params.preserve_volume = Some(false);
    }
}

/// For every downstream key: a kept frame, then the frame with that key edited on `object`,
/// compared with a fresh deformer's.
fn check_every_downstream_key(base: &ProceduralScene, object: usize) {
    for key in DOWNSTREAM_KEYS {
        let mut scene = base.clone();
        prepare(&mut scene.objects[object].params, key);
        let mut deformer = Deformer::new().keep_for_edits();
        let before = deformer.deform(&scene.frame()).unwrap();
        assert!(!before.stats.edit);
        edit(&mut scene, object, key);
        let edited = deformer.deform(&scene.frame()).unwrap();
        assert!(edited.stats.edit, "{}: {key} must be an edit", base.name);
        let fresh = Deformer::new().deform(&scene.frame()).unwrap();
        assert_same(&figures(&edited), &figures(&fresh), &format!("{}: {key}", base.name));
        assert_ne!(figures(&before), figures(&edited), "{}: editing {key} changes nothing", base.name);
        let s = &edited.deformations[object].as_ref().unwrap().stats;
        assert_eq!((s.numeric_factorizations, s.factorized_rows), (0, 0), "{key}: an edit factorizes nothing");
        // The edit is kept's successor: editing again from it works as well.
        let again = deformer.deform(&base.frame()).unwrap();
        let fresh = Deformer::new().deform(&base.frame()).unwrap();
        assert_same(&figures(&again), &figures(&fresh), &format!("{}: {key} back", base.name));
    }
}

#[test]
fn an_edit_of_each_downstream_parameter_equals_a_full_computation() {
    check_every_downstream_key(&scenes::ball_on_ground(0.25, 3, 24), 0);
}

#[test]
fn an_edit_on_a_clamped_cut_region_equals_a_full_computation() {
    let mut scene = scenes::ball_on_ground(0.2, 3, 32);
    let ground = &scene.objects[1].mesh;
    let mask: Vec<bool> = ground.positions.iter().map(|p| p.z > -1e-9 && p.x * p.x + p.y * p.y < 1.6 * 1.6).collect();
    scene.objects[1].params = scene.objects[1].params.clone().with_region_masks(std::slice::from_ref(&mask));
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    assert!(result.stats.objects[1].extent_clamped, "the mask must clamp the ground's extent");
    check_every_downstream_key(&scene, 1);
}

#[test]
fn any_other_change_is_a_full_frame() {
    let scene = scenes::ball_on_ground(0.25, 3, 24);
    let mut deformer = Deformer::new().keep_for_edits();
    deformer.deform(&scene.frame()).unwrap();
    let same = deformer.deform(&scene.frame()).unwrap();
    assert!(same.stats.edit, "the same frame again reuses everything");

    let mut stiffer = scene.clone();
    stiffer.objects[0].params.stiffness = 2.0;
    let result = deformer.deform(&stiffer.frame()).unwrap();
    assert!(!result.stats.edit, "the stiffness changes the contact surface");
    assert_eq!(figures(&result), figures(&Deformer::new().deform(&stiffer.frame()).unwrap()));

    let mut extent = stiffer.clone();
    extent.objects[0].params.extent = Some(0.7);
    assert!(!deformer.deform(&extent.frame()).unwrap().stats.edit, "the extent changes u");

    let mut moved = extent.clone();
    moved.objects[0].mesh.positions[0].x += 1e-12;
    assert!(!deformer.deform(&moved.frame()).unwrap().stats.edit, "a moved vertex changes the contact");

    let mut tau = moved.clone();
    tau.pairs[0].params.contact_tau = 0.5;
    assert!(!deformer.deform(&tau.frame()).unwrap().stats.edit, "τ changes the zones");

    // Without keep_for_edits nothing is kept.
    let mut plain = Deformer::new();
    plain.deform(&scene.frame()).unwrap();
    assert!(!plain.deform(&scene.frame()).unwrap().stats.edit);
}

#[test]
fn an_invalid_edit_is_an_error_and_the_next_valid_one_still_edits() {
    let scene = scenes::ball_on_ground(0.25, 3, 24);
    let mut deformer = Deformer::new().keep_for_edits();
    deformer.deform(&scene.frame()).unwrap();
    let mut wrong = scene.clone();
    wrong.objects[0].params.bulge_map = Some(vec![1.0; 3]);
    let err = deformer.deform(&wrong.frame()).unwrap_err();
    assert!(err.to_string().contains("ball"), "{err}");
    let mut fine = scene.clone();
    fine.objects[0].params.bulge = 0.5;
    let result = deformer.deform(&fine.frame()).unwrap();
    assert!(result.stats.edit);
    assert_eq!(figures(&result), figures(&Deformer::new().deform(&fine.frame()).unwrap()));
}

/// An edit's separation pass starts from the kept frame's distance bounds, lowered by how far
/// every vertex moved since (`separation::SeparationSeed`): it asks fewer distance queries than a
/// full frame's pass and gives the same bits, for a small edit, a large one (the bulge tripled:
/// the bounds must be lowered by the whole move) and the kept frame itself again.
#[test]
fn an_edits_separation_pass_starts_from_the_kept_frames_bounds() {
    use squish::stage::Stage;
    let scene = scenes::ball_on_ground(0.25, 3, 24);
    let mut deformer = Deformer::new().keep_for_edits();
    let kept = deformer.deform(&scene.frame()).unwrap();
    let full = kept.stats.work[Stage::Separation];
    assert!(full.rounds > 0 && full.queries > 0, "the pass must work on this scene: {full:?}");
    for bulge in [1.0, 1.2, 3.0] {
        let mut edited = scene.clone();
        edited.objects[0].params.bulge = bulge;
        edited.objects[1].params.bulge = bulge;
        let result = deformer.deform(&edited.frame()).unwrap();
        assert!(result.stats.edit);
        let fresh = Deformer::new().deform(&edited.frame()).unwrap();
        assert_same(&figures(&result), &figures(&fresh), &format!("bulge {bulge}"));
        let (edit, from_scratch) = (result.stats.work[Stage::Separation], fresh.stats.work[Stage::Separation]);
        assert_eq!(edit.rounds, from_scratch.rounds, "bulge {bulge}: the same rounds");
        assert!(
            edit.queries < from_scratch.queries,
            "bulge {bulge}: the edit's pass asks {} queries, a full frame's {}",
            edit.queries,
            from_scratch.queries
        );
    }
}
