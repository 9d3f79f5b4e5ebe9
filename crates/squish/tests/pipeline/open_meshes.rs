//! Open meshes bulge by default (issue 29; docs/decisions.md, "Open meshes bulge"): the volume
//! swept by the surface's displacement is compensated within the deformable region, as a closed
//! mesh's enclosed volume is. Measured here independently of the library's cubic: the signed
//! volume of the closed surface made of the output, the input reversed and the strips swept by
//! the boundary edges.

use glam::{DQuat, DVec3};
use squish::mesh::{TriMesh, shapes};
use squish::params::{ObjectParams, PairParams};
use squish::pipeline::{Deformer, FramePair, FrameResult};
use squish::{SubMesh, Topology};
use squish_scenes::procedural::ProceduralScene;

use crate::common::rigid_motion_difference;

/// Signed volume swept from `before` to `after` (same triangles), about the origin.
fn swept_volume(mesh: &TriMesh, after: &[DVec3]) -> f64 {
    let before = &mesh.positions;
    let cone = |a: DVec3, b: DVec3, c: DVec3| a.dot(b.cross(c)) / 6.0;
    let mut volume = 0.0;
    for t in &mesh.triangles {
        let [i, j, k] = t.map(|v| v as usize);
        volume += cone(after[i], after[j], after[k]) - cone(before[i], before[j], before[k]);
    }
    let topology = Topology::new(mesh);
    for e in topology.boundary_edges() {
        let [a, b] = topology.edge(e);
        let face = mesh.triangles[topology.edge_faces(e)[0] as usize];
        let k = face.iter().position(|&v| v == a).unwrap();
        let [i, j] = if face[(k + 1) % 3] == b { [a, b] } else { [b, a] }.map(|v| v as usize);
        volume += cone(before[i], before[j], after[j]) + cone(before[i], after[j], after[i]);
    }
    volume
}

/// A rigid ball of radius `radius` pressed `depth` into `sheet` (an open mesh whose top, at the
/// origin's vertical, is at height `top`), from above.
fn ball_on_sheet(sheet: TriMesh, top: f64, radius: f64, depth: f64) -> ProceduralScene {
    let mut ball = shapes::icosphere(radius, 4);
    ball.map_positions(|p| p + DVec3::Z * (top + radius - depth));
    let mut scene = ProceduralScene { name: "ball on an open sheet".into(), ..Default::default() };
    scene.objects.push(squish::OwnedObject { name: "ball".into(), mesh: ball, params: ObjectParams::rigid() });
    scene.objects.push(squish::OwnedObject { name: "sheet".into(), mesh: sheet, params: ObjectParams::default() });
    scene.pairs.push(FramePair { objects: [0, 1], params: PairParams::default() });
    scene
}

/// The upper half (z ≥ 0) of a unit icosphere: an open dome.
fn dome() -> TriMesh {
    let sphere = shapes::icosphere(1.0, 4);
    let mask: Vec<bool> = sphere.positions.iter().map(|p| p.z >= -1e-9).collect();
    SubMesh::from_vertex_mask(&sphere, &mask).mesh
}

/// Runs `scene` and returns the result, the sheet's swept volume at the default, the one with
/// the volume preservation off (the dent alone), and the sheet's largest rise above its input.
fn check(scene: &ProceduralScene) -> (FrameResult, f64, f64, f64) {
    let result = Deformer::new().deform(&scene.frame()).unwrap();
    let sheet = &scene.objects[1];
    assert!(result.stats.objects[1].deformed && result.stats.objects[1].preserve_volume);
    assert!(result.stats.warnings.is_empty(), "{:?}", result.stats.warnings);
    let swept = swept_volume(&sheet.mesh, &result.positions[1]);
    let mut without = scene.clone();
    without.objects[1].params.preserve_volume = Some(false);
    let dent = swept_volume(&sheet.mesh, &Deformer::new().deform(&without.frame()).unwrap().positions[1]);
    let rise = sheet.mesh.positions.iter().zip(&result.positions[1]).map(|(p, q)| q.z - p.z).fold(0.0, f64::max);
    (result, swept, dent, rise)
}

#[test]
fn an_open_grid_pressed_by_a_ball_bulges_and_keeps_its_swept_volume() {
    let scene = ball_on_sheet(shapes::grid(3.0, 3.0, 48, 48), 0.0, 0.5, 0.15);
    let (_, swept, dent, rise) = check(&scene);
    println!(
        "open grid: dent {dent:.4e}, swept at the default {swept:.2e} ({:.1e} of the dent), bulge {rise:.4}",
        swept / dent
    );
    assert!(dent < -1e-3, "the dent pushes volume in: {dent}");
    assert!((swept / dent).abs() <= 1e-9, "swept volume {swept:e} against the dent's {dent:e}");
    assert!(rise > 1e-3, "no bulge: {rise}");
}

#[test]
fn an_open_dome_pressed_by_a_ball_bulges_and_keeps_its_swept_volume() {
    let scene = ball_on_sheet(dome(), 1.0, 0.5, 0.15);
    let (_, swept, dent, _) = check(&scene);
    println!("open dome: dent {dent:.4e}, swept at the default {swept:.2e} ({:.1e} of the dent)", swept / dent);
    assert!(dent < -1e-3);
    assert!((swept / dent).abs() <= 1e-9, "swept volume {swept:e} against the dent's {dent:e}");
}

#[test]
fn the_open_bulge_is_invariant_under_rigid_motions() {
    let scene = ball_on_sheet(shapes::grid(3.0, 3.0, 32, 32), 0.0, 0.5, 0.15);
    let (rotation, shift) = (DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1), DVec3::new(5.0, -2.0, 3.0));
    let worst = rigid_motion_difference(&scene, 1, rotation, shift);
    assert!(worst < 1e-9, "{worst:e}");
}
