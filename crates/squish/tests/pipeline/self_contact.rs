//! The self-contact stage inside the whole pipeline: a skinned arm folded at its elbow and pressed
//! by a ball at its hand, in one frame.

use glam::DVec3;
use squish::mesh::{TriMesh, shapes, signed_volume};
use squish::params::{ObjectParams, PairParams};
use squish::pipeline::*;
use squish_scenes::procedural;

use crate::common::deepest_penetration;

/// The arm of [`procedural::bent_arm`] at `degrees`.
fn bent_arm(degrees: f64) -> (TriMesh, ObjectParams) {
    let mut scene = procedural::bent_arm(degrees, 32);
    let arm = scene.objects.remove(0);
    (arm.mesh, arm.params)
}

/// The ball against the tip of the bent forearm, 0.15 deep.
fn ball_at_the_hand(arm: &TriMesh) -> TriMesh {
    // The forearm's tip: the vertex farthest from the elbow.
    let tip = arm.positions.iter().copied().fold(DVec3::ZERO, |a, p| if p.length() > a.length() { p } else { a });
    let center = tip + tip.normalize() * (0.8 - 0.15);
    let mut ball = shapes::icosphere(0.8, 4);
    for p in &mut ball.positions {
        *p += center;
    }
    ball
}

#[test]
fn a_folded_arm_pressed_by_a_ball_is_clean_at_the_elbow_and_at_the_hand_with_its_volume() {
    let (arm, arm_params) = bent_arm(130.0);
    let ball = ball_at_the_hand(&arm);
    let ball_params = ObjectParams::default();
    let frame = Frame {
        objects: vec![
            FrameObject { name: "arm", mesh: &arm, params: &arm_params },
            FrameObject { name: "ball", mesh: &ball, params: &ball_params },
        ],
        pairs: vec![FramePair { objects: [0, 1], params: PairParams::default() }],
    };
    let before = deepest_penetration(&arm, &ball);
    assert!(before > 0.1);
    let result = Deformer::new().deform(&frame).unwrap();

    // The elbow: its self-intersections are gone.
    let [elbow] = result.stats.articulations.as_slice() else { panic!("one articulation") };
    assert!(elbow.in_contact);
    assert!(elbow.self_intersecting_faces_before > 50, "{elbow:?}");
    assert_eq!(elbow.self_intersecting_faces_after, 0, "{elbow:?}");
    // At the elbow every intersecting pair joins the two sides.
    assert_eq!(elbow.self_intersecting_faces_across_before, elbow.self_intersecting_faces_before, "{elbow:?}");
    assert_eq!(elbow.self_intersecting_faces_across_after, 0);
    let own = result.self_contact[0].as_ref().unwrap();
    assert!(own.contact.iter().any(|&c| c));

    // The hand: the ball's contact is resolved on the arm that came out of the self-contact.
    let arm_out = TriMesh { positions: result.positions[0].clone(), triangles: arm.triangles.clone() };
    let ball_out = TriMesh { positions: result.positions[1].clone(), triangles: ball.triangles.clone() };
    let after = deepest_penetration(&arm_out, &ball_out);
    assert!(after <= 0.02 * before, "residual penetration {after} of {before}");

    // Volume: both stages preserve it, so the frame does, relative to the skinned input.
    for (i, object) in result.stats.objects.iter().enumerate() {
        assert!(object.relative_volume_change.abs() < 1e-9, "object {i}: {}", object.relative_volume_change);
    }
    let relative = (signed_volume(&arm_out) - signed_volume(&arm)) / signed_volume(&arm);
    assert!(relative.abs() < 1e-9, "{relative}");

    // Deterministic whatever the thread count.
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let single = pool.install(|| Deformer::new().deform(&frame).unwrap());
    let bits = |v: &Vec<DVec3>| v.iter().flat_map(|p| p.to_array().map(f64::to_bits)).collect::<Vec<_>>();
    for (x, y) in result.positions.iter().zip(&single.positions) {
        assert_eq!(bits(x), bits(y));
    }
}
