//! What the pipeline's tests share: the shared sample meshes, deformed meshes, penetration depths.

use std::path::Path;

use squish::mesh::{TriMesh, face_normal_unnormalized};
use squish::pipeline::FrameResult;
use squish::spatial::penetration_depths;
use squish_scenes::procedural::ProceduralScene;

/// A mesh of the shared data by file name (e.g. `"spot_11533.obj"`), or `None` (with a message)
/// if absent.
pub fn shared_mesh(name: &str) -> Option<TriMesh> {
    let path = format!("{}/../../../shared/data/meshes/{name}", env!("CARGO_MANIFEST_DIR"));
    let mesh = squish_io::read_obj(Path::new(&path)).ok();
    if mesh.is_none() {
        eprintln!("skipping: {path} not found");
    }
    mesh
}

/// The 3301-vertex Stanford bunny of the shared data, or `None` (with a message) if absent.
pub fn bunny() -> Option<TriMesh> {
    shared_mesh("bunny_3301.obj")
}

/// Object `i` of `scene` with its positions of `result`.
pub fn deformed(scene: &ProceduralScene, result: &FrameResult, i: usize) -> TriMesh {
    TriMesh { positions: result.positions[i].clone(), triangles: scene.objects[i].mesh.triangles.clone() }
}

/// The deepest penetration between a two-object scene's inputs (which must intersect), the
/// deformed meshes of `result`, and their deepest penetration.
pub fn penetrations(scene: &ProceduralScene, result: &FrameResult) -> (f64, Vec<TriMesh>, f64) {
    let before = deepest_penetration(&scene.objects[0].mesh, &scene.objects[1].mesh);
    assert!(before > 0.0, "{}: the inputs must intersect", scene.name);
    let after_meshes: Vec<TriMesh> = (0..2).map(|i| deformed(scene, result, i)).collect();
    let after = deepest_penetration(&after_meshes[0], &after_meshes[1]);
    (before, after_meshes, after)
}

/// Deepest vertex of either mesh inside the other.
pub fn deepest_penetration(a: &TriMesh, b: &TriMesh) -> f64 {
    let ab = penetration_depths(a, b).unwrap();
    let ba = penetration_depths(b, a).unwrap();
    ab.iter().chain(&ba).fold(0.0f64, |m, &d| m.max(d))
}

/// Asserts that no face of `output` turned over from `input` (their normals more than 90° apart);
/// `what` names the mesh in the message.
pub fn assert_no_flipped_face(input: &TriMesh, output: &TriMesh, what: &str) {
    for t in 0..output.num_triangles() {
        let [a, b, c] = input.corners(t);
        let [a2, b2, c2] = output.corners(t);
        let (n0, n1) = (face_normal_unnormalized(a, b, c), face_normal_unnormalized(a2, b2, c2));
        assert!(n0.dot(n1) > 0.0, "{what}: face {t} flipped");
    }
}

/// Largest distance between object `object`'s output for `scene` moved by (`rotation`, `shift`)
/// and its output for the moved scene: 0 up to round-off for a rigid-motion invariant pipeline.
pub fn rigid_motion_difference(
    scene: &ProceduralScene,
    object: usize,
    rotation: glam::DQuat,
    shift: glam::DVec3,
) -> f64 {
    let mut moved = scene.clone();
    for o in &mut moved.objects {
        o.mesh.map_positions(|p| rotation * p + shift);
    }
    let a = squish::pipeline::Deformer::new().deform(&scene.frame()).unwrap();
    let b = squish::pipeline::Deformer::new().deform(&moved.frame()).unwrap();
    a.positions[object]
        .iter()
        .zip(&b.positions[object])
        .map(|(p, q)| (rotation * *p + shift - *q).length())
        .fold(0.0, f64::max)
}
