//! glTF writing: static meshes (.glb and .gltf, single and several named meshes) and the
//! animated .glb, each read back with our reader.

#![allow(clippy::unwrap_used)]

use glam::{DMat4, DQuat, DVec3};
use squish::TriMesh;
use squish::mesh::shapes;
use squish_io::*;

fn f32_rounded(p: &[DVec3]) -> Vec<DVec3> {
    p.iter().map(|p| p.as_vec3().as_dvec3()).collect()
}

fn json_of(path: &std::path::Path) -> serde_json::Value {
    let bytes = std::fs::read(path).unwrap();
    if bytes.starts_with(b"glTF") {
        let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
        serde_json::from_slice(&bytes[20..20 + len]).unwrap()
    } else {
        serde_json::from_slice(&bytes).unwrap()
    }
}

#[test]
fn meshes_round_trip_to_f32() {
    let dir = tempfile::tempdir().unwrap();
    let sphere = shapes::icosphere(1.0 / 3.0, 2);
    let mut moved = shapes::cube(0.7, 2);
    moved.map_positions(|p| p + DVec3::new(1e3 / 7.0, -0.1, 0.0));
    for ext in ["glb", "gltf"] {
        let path = dir.path().join(format!("two.{ext}"));
        let meshes = [NamedMesh { name: "sphere", mesh: &sphere }, NamedMesh { name: "box", mesh: &moved }];
        write_gltf_meshes(&path, &meshes, &GltfWriteOptions::default()).unwrap();
        let scene = read_gltf(&path, &GltfReadOptions::default()).unwrap();
        assert_eq!(scene.meshes.len(), 2);
        for (m, original) in scene.meshes.iter().zip([&sphere, &moved]) {
            assert_eq!(m.triangles, original.triangles);
            assert_eq!(m.positions, f32_rounded(&original.positions));
        }
        assert_eq!(scene.meshes[1].name, "box");
        assert_eq!(scene.nodes.iter().map(|n| n.name.as_str()).collect::<Vec<_>>(), ["sphere", "box"]);
        let json = json_of(&path);
        assert!(json["meshes"][0]["primitives"][0]["attributes"]["NORMAL"].is_number());
        if ext == "gltf" {
            assert!(json["buffers"][0]["uri"].as_str().unwrap().starts_with("data:application/octet-stream;base64,"));
        }
        // The merged mesh of both instances.
        assert_eq!(read_mesh(&path).unwrap().num_vertices(), sphere.num_vertices() + moved.num_vertices());
    }
    let path = dir.path().join("plain.glb");
    write_gltf(&path, &sphere, &GltfWriteOptions { normals: false }).unwrap();
    assert!(json_of(&path)["meshes"][0]["primitives"][0]["attributes"]["NORMAL"].is_null());
    let e = write_gltf(&dir.path().join("x.gltf2"), &sphere, &GltfWriteOptions::default()).unwrap_err();
    assert!(e.to_string().contains(".glb (binary) or .gltf"), "{e}");
}

/// Frames of a capsule bending about its middle, as the deformer would produce.
fn bending_frames(n: usize) -> (TriMesh, Vec<Vec<DVec3>>) {
    let mesh = shapes::capsule(0.25, 1.5, 12, 3, 6);
    let frames = (0..n)
        .map(|k| {
            let angle = 1.2 * k as f64 / (n - 1).max(1) as f64;
            let bend = DMat4::from_quat(DQuat::from_rotation_x(angle));
            mesh.positions.iter().map(|p| if p.z > 0.0 { bend.transform_point3(*p) } else { *p }).collect()
        })
        .collect();
    (mesh, frames)
}

/// Frames of the mesh as displacements from its base positions, keyed at `k / fps`.
fn morph_frames(base: &[DVec3], frames: &[Vec<DVec3>], fps: f64) -> Vec<MorphFrame> {
    frames
        .iter()
        .enumerate()
        .map(|(k, frame)| {
            let delta: Vec<DVec3> = frame.iter().zip(base).map(|(p, q)| *p - *q).collect();
            MorphFrame {
                name: format!("frame_{k:04}"),
                time: k as f64 / fps,
                displacement: SparseDisplacement::from_dense(&delta).unwrap(),
            }
        })
        .collect()
}

#[test]
fn animated_glb_reproduces_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, frames) = bending_frames(7);
    let fps = 24.0;
    let path = dir.path().join("anim.glb");
    let morphs = morph_frames(&mesh.positions, &frames, fps);
    write_animated_glb(&path, "bend", &mesh.triangles, &mesh.positions, &morphs, MorphKeys::default()).unwrap();
    let scene = read_gltf(&path, &GltfReadOptions::default()).unwrap();
    assert_eq!(scene.meshes[0].morph_targets.len(), 7);
    assert_eq!(scene.meshes[0].target_names[1], "frame_0001");
    assert_eq!(scene.animations.len(), 1);
    let anim = &scene.animations[0];
    assert!((anim.duration() - 6.0 / fps).abs() < 1e-6);
    assert_eq!(anim.morph_weights[0].samplers[0].interpolation(), squish::animation::Interpolation::Step);
    for (k, frame) in frames.iter().enumerate() {
        // Sample in the middle of frame k's display interval: STEP holds it until k + 1.
        let posed = scene.posed_mesh(0, Some(0), (k as f64 + 0.5) / fps).unwrap();
        assert_eq!(posed.triangles, mesh.triangles);
        for (a, b) in posed.positions.iter().zip(frame) {
            assert!((*a - *b).length() < 1e-6, "frame {k}: {a} vs {b}");
        }
    }
    // The rest pose (no animation) is the base mesh.
    let rest = scene.posed_mesh(0, None, 0.0).unwrap();
    assert_eq!(rest.positions, f32_rounded(&mesh.positions));
    let json = json_of(&path);
    assert_eq!(json["animations"][0]["samplers"][0]["interpolation"], "STEP");
    assert_eq!(json["animations"][0]["channels"][0]["target"]["path"], "weights");
    let target = |k: usize| {
        let accessor = json["meshes"][0]["primitives"][0]["targets"][k]["POSITION"].as_u64().unwrap() as usize;
        json["accessors"][accessor].clone()
    };
    // Frame 0 does not bend: a target of one zero entry. The others store only the bending half,
    // as sparse accessors, with bounds.
    assert_eq!(
        (&target(0)["sparse"]["count"], &target(0)["max"]),
        (&serde_json::json!(1), &serde_json::json!([0.0, 0.0, 0.0]))
    );
    assert!(morphs[0].displacement.is_empty());
    let moving = morphs[3].displacement.indices.len();
    assert!(moving > 0 && moving < mesh.positions.len() * 2 / 3, "{moving} of {}", mesh.positions.len());
    assert_eq!(target(3)["sparse"]["count"], moving);
    assert!(target(3)["min"].is_array() && target(3).get("bufferView").is_none());
    // Read back, every frame's displacement is the one written, bit for bit.
    let back = read_animated_glb(&path).unwrap();
    assert_eq!(back.triangles, mesh.triangles);
    assert_eq!(back.base, f32_rounded(&mesh.positions));
    for (written, (name, read)) in morphs.iter().zip(&back.frames) {
        assert_eq!((&written.name, &written.displacement), (name, read));
    }

    // A part: every target off before its first frame and after its last.
    let keys = MorphKeys { off_before: Some(1.0 / fps), off_after: Some(6.0 / fps) };
    write_animated_glb(&path, "part", &mesh.triangles, &mesh.positions, &morphs[2..6], keys).unwrap();
    let scene = read_gltf(&path, &GltfReadOptions::default()).unwrap();
    for (time, expected) in [
        (0.0, &mesh.positions),
        (1.5 / fps, &mesh.positions),
        (4.5 / fps, &frames[4]),
        (6.5 / fps, &mesh.positions),
        (9.0 / fps, &mesh.positions),
    ] {
        let posed = scene.posed_mesh(0, Some(0), time).unwrap();
        for (a, b) in posed.positions.iter().zip(expected) {
            assert!((*a - *b).length() < 1e-6, "time {time}: {a} vs {b}");
        }
    }

    // Bad input leaves the previous file.
    let before = std::fs::read(&path).unwrap();
    let mut bad = morphs.clone();
    bad[3].displacement.count -= 1;
    let e = write_animated_glb(&path, "bad", &mesh.triangles, &mesh.positions, &bad, MorphKeys::default()).unwrap_err();
    assert!(e.to_string().contains("frame 3"), "{e}");
    let mut far = mesh.positions.clone();
    far[5].x = f64::INFINITY;
    assert!(write_animated_glb(&path, "bad", &mesh.triangles, &far, &morphs, MorphKeys::default()).is_err());
    let late = MorphKeys { off_before: Some(1.0), off_after: None };
    let e = write_animated_glb(&path, "bad", &mesh.triangles, &mesh.positions, &morphs, late).unwrap_err();
    assert!(e.to_string().contains("increasing"), "{e}");
    assert!(
        write_animated_glb(
            &dir.path().join("a.txt"),
            "bad",
            &mesh.triangles,
            &mesh.positions,
            &morphs,
            MorphKeys::default()
        )
        .is_err()
    );
    assert_eq!(std::fs::read(&path).unwrap(), before);
    // The same animation as a .gltf JSON file.
    let json = dir.path().join("a.gltf");
    write_animated_glb(&json, "json", &mesh.triangles, &mesh.positions, &morphs, MorphKeys::default()).unwrap();
    assert_eq!(read_animated_glb(&json).unwrap().frames, back.frames);
}
