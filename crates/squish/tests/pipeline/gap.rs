//! The contact gap (`pair.contact_gap`, issue 29): at the default, no triangle of one output
//! intersects a triangle of the other (exact test), the volume stays preserved, and 0 gives the
//! thesis' coincident surfaces back.

use squish::params::{ObjectParams, PairParams};
use squish::pipeline::{Deformer, FrameResult};
use squish::spatial::mesh_intersections;
use squish_scenes::procedural::{self as scenes, ProceduralScene};

use crate::common::deformed;

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
    scene.objects.push(scenes::SceneObject { name: "bunny".into(), mesh: bunny, params: Default::default() });
    scene.objects.push(scenes::SceneObject { name: "box".into(), mesh: slab, params: Default::default() });
    scene.pairs.push(squish::pipeline::FramePair { objects: [0, 1], params: PairParams::default() });
    scene
}
