//! Issue 28: a frame that leaves a requested treatment undone says so ([`FrameStats::warnings`]),
//! and the contact zone is never empty while the meshes penetrate.

use glam::DVec3;

use squish::mesh::shapes;
use squish::params::{ObjectParams, PairParams};
use squish::pipeline::*;
use squish_scenes::procedural::ProceduralScene;

use crate::common::{deepest_penetration, deformed};

/// A ball of radius `radius` pressed `depth` into the top of a 3 × 3 × `thickness` slab.
fn ball_in_slab(radius: f64, depth: f64, thickness: f64, pair: PairParams, ball: ObjectParams) -> ProceduralScene {
    let mut slab = shapes::cuboid(DVec3::new(3.0, 3.0, thickness), 24);
    slab.map_positions(|p| p - DVec3::Z * (0.5 * thickness));
    let mut sphere = shapes::icosphere(radius, 4);
    sphere.map_positions(|p| p + DVec3::Z * (radius - depth));
    let mut scene = ProceduralScene { name: "ball in slab".into(), ..Default::default() };
    scene.objects.push(squish::OwnedObject { name: "ball".into(), mesh: sphere, params: ball });
    scene.objects.push(squish::OwnedObject { name: "slab".into(), mesh: slab, params: ObjectParams::default() });
    scene.pairs.push(FramePair { objects: [0, 1], params: pair });
    scene
}

fn kinds(result: &FrameResult) -> Vec<WarningKind> {
    result.stats.warnings.iter().map(|w| w.kind).collect()
}

/// τ = 2 on a sphere 0.25 deep in a slab gave ε_c above every depth: an empty zone, "do not
/// intersect" and the whole penetration left. ε_c is now clamped to the typical penetration P,
/// the zone holds the deepest part, most of the penetration is resolved, and the clamp is
/// reported. τ ≤ 0 is never clamped.
#[test]
fn large_tau_is_clamped_so_that_the_zone_is_not_empty() {
    let scene = ball_in_slab(0.5, 0.25, 1.0, PairParams::default().with_contact_tau(2.0), ObjectParams::default());
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    let contact = result.contacts[0].as_ref().unwrap();
    let crit = &contact.criterion;
    let unclamped = crit.unclamped_threshold.expect("m + 2σ is above P here");
    assert!(unclamped > crit.penetration && crit.threshold == crit.penetration && crit.penetration > 0.0);
    assert!(result.stats.pairs[0].in_contact && result.stats.pairs[0].zone_vertices.iter().all(|&n| n > 0));
    let before = deepest_penetration(&scene.objects[0].mesh, &scene.objects[1].mesh);
    let after = deepest_penetration(&deformed(&scene, &result, 0), &deformed(&scene, &result, 1));
    assert!(after < 0.15 * before, "{before} → {after}");
    assert_eq!(kinds(&result), vec![WarningKind::ContactSpreadClamped]);
    for tau in [0.0, -1.0] {
        let scene = ball_in_slab(0.5, 0.25, 1.0, PairParams::default().with_contact_tau(tau), ObjectParams::default());
        let result = Deformer::new().deform(&scene.frame()).unwrap();
        assert!(result.contacts[0].as_ref().unwrap().criterion.unclamped_threshold.is_none());
        assert!(result.stats.warnings.is_empty(), "{:?}", result.stats.warnings);
    }
}

/// Method A with a ball radius beyond the elastic slab's half thickness left the whole
/// penetration (every ball touched the slab's bottom). The radius is halved until balls fit,
/// the contact is resolved, and the radius used is reported.
#[test]
fn a_ball_radius_too_large_for_the_elastic_object_is_reduced() {
    let pair = PairParams::default().with_ball(0.6);
    let scene = ball_in_slab(0.6, 0.2, 1.0, pair, ObjectParams::rigid());
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    let used = result.contacts[0].as_ref().unwrap().ball_radius.expect("0.6 does not fit in a 1.0-thick slab");
    assert!(used < 0.5, "{used}");
    assert!(result.stats.pairs[0].in_contact);
    assert!(kinds(&result).contains(&WarningKind::BallRadiusReduced), "{:?}", result.stats.warnings);
    let before = deepest_penetration(&scene.objects[0].mesh, &scene.objects[1].mesh);
    let after = deepest_penetration(&deformed(&scene, &result, 0), &deformed(&scene, &result, 1));
    assert!(after < 0.5 * before, "{before} → {after}");
}

/// A sphere wholly inside a closed slab was "do not intersect"; it is now named as a
/// containment (nothing is resolved: there is no intersection curve to bound a zone), and the
/// quality pass finds its whole penetration left.
#[test]
fn a_mesh_inside_another_is_named_as_such() {
    let scene = ball_in_slab(0.2, 0.6, 1.0, PairParams::default(), ObjectParams::default());
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    assert!(!result.stats.pairs[0].in_contact);
    assert_eq!(kinds(&result), vec![WarningKind::Containment, WarningKind::ResidualPenetration]);
    assert!(result.stats.warnings[0].message.contains("\"ball\" lies wholly inside \"slab\""));
    // Apart: no warning.
    let scene = ball_in_slab(0.2, -0.5, 1.0, PairParams::default(), ObjectParams::default());
    assert!(Deformer::new().deform(&scene.frame()).unwrap().stats.warnings.is_empty());
}

/// An open mesh bulges by default (its swept volume is preserved): no warning. With volume
/// preservation off and no bulge height it loses volume: reported; with a bulge height it is not.
#[test]
fn an_open_mesh_without_bulge_is_reported() {
    let mut scene = ball_in_slab(0.5, 0.2, 1.0, PairParams::default(), ObjectParams::rigid());
    scene.objects[1].mesh = shapes::grid(3.0, 3.0, 48, 48);
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    assert!(result.stats.objects[1].deformed && result.stats.objects[1].preserve_volume);
    assert!(result.stats.warnings.is_empty(), "{:?}", result.stats.warnings);
    scene.objects[1].params.preserve_volume = Some(false);
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    assert!(result.stats.objects[1].deformed);
    assert_eq!(kinds(&result), vec![WarningKind::NoBulge]);
    assert_eq!(result.stats.warnings[0].object, Some(1));
    scene.objects[1].params.bulge_height = 0.05;
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    assert!(result.stats.warnings.is_empty(), "{:?}", result.stats.warnings);
}

/// The quality pass: a ball pressed into a slab penetrates before, far less after, with no
/// faces crossing at the default gap; left out on request.
#[test]
fn the_quality_pass_measures_the_penetration_before_and_after() {
    let scene = ball_in_slab(0.5, 0.2, 1.0, PairParams::default(), ObjectParams::default());
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    let quality = &result.stats.quality;
    assert_eq!(quality.len(), 1);
    let q = &quality[0];
    let (before, after) = (q.penetration_before.unwrap(), q.penetration_after.unwrap());
    assert!(before > 0.15 && before < 0.25, "{before}");
    assert!(after <= RESIDUAL_PENETRATION_TOLERANCE * before, "{after} of {before}");
    assert!(q.intersecting_faces_before[0] > 0 && q.intersecting_faces_after == [0, 0], "{q:?}");
    assert!(!kinds(&result).contains(&WarningKind::ResidualPenetration));
    // A default deformer (a shot's worker) runs it too.
    let default = Deformer::default().deform(&scene.frame()).unwrap();
    assert_eq!(default.stats.quality, result.stats.quality);
    let without = Deformer::new().without_quality().deform(&scene.frame()).unwrap();
    assert!(without.stats.quality.is_empty());
    assert_eq!(without.positions, result.positions);
}
