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

#[test]
fn animated_glb_reproduces_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let (mesh, frames) = bending_frames(7);
    let fps = 24.0;
    let path = dir.path().join("anim.glb");
    write_animated_glb(&path, "bend", &mesh.triangles, &frames, fps).unwrap();
    let scene = read_gltf(&path, &GltfReadOptions::default()).unwrap();
    assert_eq!(scene.meshes[0].morph_targets.len(), 6);
    assert_eq!(scene.meshes[0].target_names[0], "frame_0001");
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
    // The rest pose (no animation) is frame 0.
    let rest = scene.posed_mesh(0, None, 0.0).unwrap();
    assert_eq!(rest.positions, f32_rounded(&frames[0]));
    let json = json_of(&path);
    assert_eq!(json["animations"][0]["samplers"][0]["interpolation"], "STEP");
    assert_eq!(json["animations"][0]["channels"][0]["target"]["path"], "weights");
    assert!(json["accessors"][json["meshes"][0]["primitives"][0]["targets"][0]["POSITION"].as_u64().unwrap() as usize]["min"].is_array());

    // A single frame is a static mesh.
    write_animated_glb(&path, "still", &mesh.triangles, &frames[..1], fps).unwrap();
    let scene = read_gltf(&path, &GltfReadOptions::default()).unwrap();
    assert!(scene.animations.is_empty() && scene.meshes[0].morph_targets.is_empty());

    // Bad input leaves the previous file.
    let before = std::fs::read(&path).unwrap();
    let mut bad = frames.clone();
    bad[3].pop();
    let e = write_animated_glb(&path, "bad", &mesh.triangles, &bad, fps).unwrap_err();
    assert!(e.to_string().contains("frame 3"), "{e}");
    bad = frames.clone();
    bad[2][5].x = f64::INFINITY;
    assert!(write_animated_glb(&path, "bad", &mesh.triangles, &bad, fps).is_err());
    assert!(write_animated_glb(&path, "bad", &mesh.triangles, &frames, 0.0).is_err());
    assert!(write_animated_glb(&dir.path().join("a.txt"), "bad", &mesh.triangles, &frames, fps).is_err());
    assert_eq!(std::fs::read(&path).unwrap(), before);
    // The same animation as a .gltf JSON file.
    let json = dir.path().join("a.gltf");
    write_animated_glb(&json, "json", &mesh.triangles, &frames, fps).unwrap();
    assert_eq!(read_gltf(&json, &GltfReadOptions::default()).unwrap().meshes[0].morph_targets.len(), frames.len() - 1);
}
