//! glTF reading on small hand-built documents: containers (.glb, .gltf with a data URI or an
//! external .bin), index types, primitive modes, quantized and sparse accessors, skins and
//! animations with every interpolation, and every kind of bad input.

#![allow(clippy::unwrap_used)]

mod common;

use common::*;
use glam::{DMat4, DQuat, DVec3};
use serde_json::json;
use squish::animation::{ChannelValues, Interpolation, NodeTransform};
use squish_io::*;

fn read(path: &std::path::Path) -> GltfScene {
    read_gltf(path, &GltfReadOptions::default()).unwrap()
}

#[test]
fn containers_index_types_and_modes() {
    let dir = tempfile::tempdir().unwrap();
    for index_type in [U8, U16, U32] {
        for mode in [4u32, 5, 6] {
            let f = square_fixture(index_type, mode);
            let paths = [
                f.write_glb(dir.path(), "sq"),
                f.write_gltf_embedded(dir.path(), "sq_embedded"),
                f.write_gltf_external(dir.path(), "sq_external", "square data.bin"),
            ];
            for path in paths {
                let scene = read(&path);
                let mesh = &scene.meshes[0];
                assert_eq!(mesh.positions.len(), 4);
                let expected: Vec<[u32; 3]> =
                    if mode == 4 { vec![[0, 1, 2], [0, 2, 3]] } else { vec![[1, 2, 0], [2, 3, 0]] };
                assert_eq!(mesh.triangles, expected, "{} type {index_type} mode {mode}", path.display());
                assert_eq!(read_mesh(&path).unwrap().triangles, expected);
                assert_eq!(scene.nodes[0].name, "square");
            }
        }
    }
}

#[test]
fn non_indexed_primitives_and_degenerate_strip_joins() {
    let dir = tempfile::tempdir().unwrap();
    let mut f = Fixture::new();
    let tri = f.accessor(F32, "VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    // Two strips joined by repeating vertices 3 and 4: (0,1,2) (2,1,3) [3,3,4 joins] (4,5,6).
    let strip = f.accessor(F32, "VEC3", &(0..7).flat_map(|i| [i as f64, (i % 2) as f64, 0.0]).collect::<Vec<_>>());
    let strip_idx = f.accessor(U16, "SCALAR", &[0.0, 1.0, 2.0, 3.0, 3.0, 4.0, 4.0, 5.0, 6.0]);
    f.root = json!({
        "nodes": [{ "mesh": 0 }],
        "meshes": [{ "primitives": [
            { "attributes": { "POSITION": tri } },
            { "attributes": { "POSITION": strip }, "indices": strip_idx, "mode": 5 },
        ] }],
    });
    let scene = read(&f.write_glb(dir.path(), "mixed"));
    let mesh = &scene.meshes[0];
    assert_eq!(mesh.positions.len(), 10);
    assert_eq!(mesh.primitive_vertices, vec![0..3, 3..10]);
    // Strip triangles i = 0..6 on indices [0,1,2,3,3,4,4,5,6] (offset 3): (v_i, v_{i+1+i%2},
    // v_{i+2-i%2}); the four that repeat a vertex (the join) are dropped.
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [3, 4, 5], [4, 6, 5], [7, 8, 9]]);
}

#[test]
fn quantized_and_sparse_accessors() {
    let dir = tempfile::tempdir().unwrap();
    let mut f = Fixture::new();
    // Normalized i16 positions (KHR_mesh_quantization): 32767 ↦ 1, −32767 ↦ −1.
    let pos = f.accessor_ex(
        I16,
        "VEC3",
        &[0.0, 0.0, 0.0, 32767.0, 0.0, 0.0, 0.0, -32767.0, 0.0, 16384.0, 16384.0, 0.0],
        true,
    );
    // Sparse override of vertex 3's position through an F32 sparse block.
    let sparse_idx = f.accessor(U8, "SCALAR", &[3.0]);
    let sparse_val = f.accessor(I16, "VEC3", &[0.0, 0.0, 32767.0]);
    let idx = f.accessor(U8, "SCALAR", &[0.0, 1.0, 2.0, 0.0, 1.0, 3.0]);
    let (iv, vv) = (f.accessors[sparse_idx]["bufferView"].clone(), f.accessors[sparse_val]["bufferView"].clone());
    f.accessors[pos]["sparse"] =
        json!({ "count": 1, "indices": { "bufferView": iv, "componentType": U8 }, "values": { "bufferView": vv } });
    f.root = json!({
        "extensionsUsed": ["KHR_mesh_quantization"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "nodes": [{ "mesh": 0, "scale": [2.0, 2.0, 2.0] }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": pos }, "indices": idx }] }],
    });
    let path = f.write_gltf_embedded(dir.path(), "quantized");
    let scene = read(&path);
    let p = &scene.meshes[0].positions;
    assert_eq!(p[1], DVec3::X);
    assert_eq!(p[2], -DVec3::Y);
    assert_eq!(p[3], DVec3::Z, "sparse value replaced the base");
    // The node's scale applies in world space.
    assert_eq!(read_mesh(&path).unwrap().positions[3], DVec3::new(0.0, 0.0, 2.0));
}

/// Two bones under a root with a matrix transform, a strip of 6 vertices skinned with u8
/// joints and normalized u8 weights, and an animation with one channel per interpolation.
fn skinned_fixture(variant: u32) -> Fixture {
    let mut f = Fixture::new();
    // Bind-pose vertices near the bones, which sit at x = 10 (the root's translation).
    let positions: Vec<f64> = [0.0, 1.0, 2.0].iter().flat_map(|&y| [9.5, y, 0.0, 10.5, y, 0.0]).collect();
    let pos = f.accessor(F32, "VEC3", &positions);
    let idx = f.accessor(U16, "SCALAR", &[0.0, 1.0, 3.0, 0.0, 3.0, 2.0, 2.0, 3.0, 5.0, 2.0, 5.0, 4.0]);
    let (joints, weights) = if variant == 0 {
        let j = f.accessor(U8, "VEC4", &[0.0, 1.0, 0.0, 0.0].repeat(6));
        let w: Vec<f64> = [[255.0, 0.0], [255.0, 0.0], [128.0, 127.0], [128.0, 127.0], [0.0, 255.0], [0.0, 255.0]]
            .iter()
            .flat_map(|w| [w[0], w[1], 0.0, 0.0])
            .collect();
        (j, f.accessor_ex(U8, "VEC4", &w, true))
    } else {
        // u16 joints, float weights that do not sum to 1 (normalized on reading).
        let j = f.accessor(U16, "VEC4", &[1.0, 0.0, 0.0, 0.0].repeat(6));
        (j, f.accessor(F32, "VEC4", &[2.0, 2.0, 0.0, 0.0].repeat(6)))
    };
    let mut ibm = Vec::new();
    for m in
        [DMat4::from_translation(DVec3::new(-10.0, 0.0, 0.0)), DMat4::from_translation(DVec3::new(-10.0, -1.0, 0.0))]
    {
        ibm.extend_from_slice(&m.to_cols_array());
    }
    let ibm = f.accessor(F32, "MAT4", &ibm);
    let t_rot = f.accessor(F32, "SCALAR", &[0.0, 1.0]);
    let q = DQuat::from_rotation_z(std::f64::consts::FRAC_PI_2);
    let v_rot = f.accessor(F32, "VEC4", &[0.0, 0.0, 0.0, 1.0, q.x, q.y, q.z, q.w]);
    let t_step = f.accessor(F32, "SCALAR", &[0.0, 0.5]);
    let v_step = f.accessor(F32, "VEC3", &[0.0, 0.0, 0.0, 0.0, 0.0, 5.0]);
    let t_cubic = f.accessor(F32, "SCALAR", &[0.0, 2.0]);
    let v_cubic = f.accessor(
        F32,
        "VEC3",
        &[0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 3.0, 3.0, 3.0, 0.0, 0.0, 0.0],
    );
    let root_matrix = DMat4::from_translation(DVec3::new(10.0, 0.0, 0.0)).to_cols_array();
    let mut skin = json!({ "name": "rig", "joints": [1, 2], "skeleton": 1 });
    if variant == 0 {
        skin["inverseBindMatrices"] = json!(ibm);
    }
    f.root = json!({
        "scene": 0,
        "scenes": [{ "nodes": [0, 3] }],
        "nodes": [
            { "name": "root", "children": [1], "matrix": root_matrix },
            { "name": "bone0", "children": [2] },
            { "name": "bone1", "translation": [0.0, 1.0, 0.0] },
            // glTF ignores the transform of a skinned mesh's node.
            { "name": "body", "mesh": 0, "skin": 0, "translation": [100.0, 0.0, 0.0] },
        ],
        "meshes": [{ "name": "strip", "primitives": [{
            "attributes": { "POSITION": pos, "JOINTS_0": joints, "WEIGHTS_0": weights }, "indices": idx,
        }] }],
        "skins": [skin],
        "animations": [{
            "name": "bend",
            "samplers": [
                { "input": t_rot, "output": v_rot, "interpolation": "LINEAR" },
                { "input": t_step, "output": v_step, "interpolation": "STEP" },
                { "input": t_cubic, "output": v_cubic, "interpolation": "CUBICSPLINE" },
            ],
            "channels": [
                { "sampler": 0, "target": { "node": 2, "path": "rotation" } },
                { "sampler": 1, "target": { "node": 1, "path": "translation" } },
                { "sampler": 2, "target": { "node": 2, "path": "scale" } },
            ],
        }],
    });
    f
}

#[test]
fn skin_hierarchy_and_animation_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let scene = read(&skinned_fixture(0).write_glb(dir.path(), "rig"));
    assert_eq!(scene.nodes.iter().map(|n| n.name.as_str()).collect::<Vec<_>>(), ["root", "bone0", "bone1", "body"]);
    assert_eq!(scene.nodes[2].parent, Some(1));
    assert_eq!(scene.nodes[1].parent, Some(0));
    assert_eq!(scene.roots, vec![0, 3]);
    assert!(matches!(scene.nodes[0].transform, NodeTransform::Matrix(_)));
    assert_eq!(scene.skins[0].skin.joints, vec![1, 2]);
    assert_eq!(scene.skins[0].skeleton_root, Some(1));
    assert_eq!(scene.skins[0].name, "rig");

    let anim = &scene.animations[0];
    assert_eq!(anim.name, "bend");
    assert_eq!(anim.duration(), 2.0);
    let kinds: Vec<Interpolation> = anim
        .clip
        .channels
        .iter()
        .map(|c| match &c.values {
            ChannelValues::Rotation(s) => s.interpolation(),
            ChannelValues::Translation(s) | ChannelValues::Scale(s) => s.interpolation(),
        })
        .collect();
    assert_eq!(kinds, [Interpolation::Linear, Interpolation::Step, Interpolation::CubicSpline]);

    // Rest pose: every joint matrix is the identity, so the mesh stays where it was bound (the
    // body node's translation is ignored, as glTF specifies for skinned meshes).
    let rest = scene.posed_mesh(3, None, 0.0).unwrap();
    for (a, b) in rest.positions.iter().zip(&scene.meshes[0].positions) {
        assert!((*a - *b).length() < 1e-12);
    }

    // At t = 1: bone1 rotated 90° about z and scaled by the cubic spline's midpoint value 2;
    // bone0 translated by (0, 0, 5) since the STEP key at 0.5.
    let posed = scene.posed_mesh(3, Some(0), 1.0).unwrap();
    let p = &posed.positions;
    assert!((p[0] - DVec3::new(9.5, 0.0, 5.0)).length() < 1e-12, "{}", p[0]);
    assert!((p[5] - DVec3::new(8.0, 2.0, 5.0)).length() < 1e-6, "{}", p[5]);
    let (w0, w1) = (128.0 / 255.0, 127.0 / 255.0);
    let mixed = (w0 * DVec3::new(10.5, 1.0, 5.0) + w1 * DVec3::new(10.0, 2.0, 5.0)) / (w0 + w1);
    assert!((p[3] - mixed).length() < 1e-6, "{} vs {mixed}", p[3]);
    // Before the STEP key, no translation.
    let early = scene.posed_mesh(3, Some(0), 0.25).unwrap();
    assert!((early.positions[0] - DVec3::new(9.5, 0.0, 0.0)).length() < 1e-12);
    // Deterministic.
    assert_eq!(scene.posed_mesh(3, Some(0), 0.7).unwrap(), scene.posed_mesh(3, Some(0), 0.7).unwrap());
}

#[test]
fn u16_joints_float_weights_and_default_inverse_binds() {
    let dir = tempfile::tempdir().unwrap();
    let scene = read(&skinned_fixture(1).write_gltf_embedded(dir.path(), "rig16"));
    assert!(scene.skins[0].skin.inverse_bind.iter().all(|m| *m == DMat4::IDENTITY));
    let w = scene.meshes[0].skin_weights.as_ref().unwrap();
    assert_eq!(w.joints()[0], [1, 0, 0, 0]);
    assert_eq!(w.weights()[0], [0.5, 0.5, 0.0, 0.0]);
}

/// Two triangles sharing an edge whose two vertices are duplicated (a UV seam), each copy with
/// different skin weights: welding merges the copies and averages their weights.
#[test]
fn welding_averages_the_weights_of_seam_copies() {
    let dir = tempfile::tempdir().unwrap();
    let mut f = Fixture::new();
    let pos = f.accessor(
        F32,
        "VEC3",
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, /* copies: */ 0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
    );
    let idx = f.accessor(U8, "SCALAR", &[0.0, 1.0, 2.0, 3.0, 4.0, 5.0]);
    let joints = f.accessor(U8, "VEC4", &[0.0, 1.0, 2.0, 0.0].repeat(6));
    let weights = f.accessor(
        F32,
        "VEC4",
        &[[1.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.5, 0.0], [0.0, 1.0, 0.0], [0.5, 0.0, 0.5], [1.0, 0.0, 0.0]]
            .iter()
            .flat_map(|w| [w[0], w[1], w[2], 0.0])
            .collect::<Vec<_>>(),
    );
    f.root = json!({
        "nodes": [{ "mesh": 0, "skin": 0 }, { "name": "j0" }, { "name": "j1" }, { "name": "j2" }],
        "skins": [{ "joints": [1, 2, 3] }],
        "meshes": [{ "primitives": [{ "attributes": { "POSITION": pos, "JOINTS_0": joints, "WEIGHTS_0": weights }, "indices": idx }] }],
    });
    let path = f.write_glb(dir.path(), "seam");
    let scene = read_gltf(&path, &GltfReadOptions::default().with_weld(WeldMode::Exact)).unwrap();
    let mesh = &scene.meshes[0];
    assert_eq!(mesh.positions.len(), 4);
    assert_eq!(mesh.vertex_map.as_ref().unwrap(), &vec![0, 1, 2, 0, 2, 3]);
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    let w = mesh.skin_weights.as_ref().unwrap();
    // Vertex 0 = copies 0 (j0: 1) and 3 (j1: 1) → j0 and j1 at 0.5 each (ties: lower joint first).
    assert_eq!((w.joints()[0], w.weights()[0]), ([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0]));
    // Vertex 2 = copies 2 (j0 .5, j1 .5) and 4 (j0 .5, j2 .5) → j0 .5, j1 .25, j2 .25.
    assert_eq!((w.joints()[2], w.weights()[2]), ([0, 1, 2, 0], [0.5, 0.25, 0.25, 0.0]));
    assert_eq!((w.joints()[3], w.weights()[3]), ([0, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]));
}

fn read_error(path: &std::path::Path) -> String {
    let e = read_gltf(path, &GltfReadOptions::default()).unwrap_err().to_string();
    let name = path.file_name().unwrap().to_string_lossy();
    assert!(e.contains(name.as_ref()), "error does not name the file: {e}");
    e
}

#[test]
fn unsupported_modes_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    for (mode, name) in [(0u32, "POINTS"), (1, "LINES"), (2, "LINE_LOOP"), (3, "LINE_STRIP")] {
        let f = square_fixture(U16, mode);
        let e = read_error(&f.write_glb(dir.path(), &format!("mode{mode}")));
        assert!(e.contains(&format!("mode {name}")) && e.contains("mesh 0 'square' primitive 0"), "{e}");
    }
}

#[test]
fn bad_contents_are_located() {
    let dir = tempfile::tempdir().unwrap();
    // Index out of range.
    let mut f = square_fixture(U16, 4);
    f.buffer[48 + 10] = 9; // last index (u16 at byte 48 + 10) := 9
    let e = read_error(&f.write_glb(dir.path(), "range"));
    assert!(
        e.contains("indices of mesh 0 'square' primitive 0") && e.contains("index 5 is 9") && e.contains("4 vertices"),
        "{e}"
    );
    // Index count not a multiple of 3.
    let mut f = square_fixture(U16, 4);
    f.accessors[1]["count"] = json!(5);
    let e = read_error(&f.write_glb(dir.path(), "count"));
    assert!(e.contains("5 indices"), "{e}");
    // NaN coordinate.
    let mut f = square_fixture(U16, 4);
    f.buffer[16..20].copy_from_slice(&f32::NAN.to_le_bytes());
    f.accessors[0].as_object_mut().unwrap().remove("min");
    f.accessors[0].as_object_mut().unwrap().remove("max");
    let e = read_error(&f.write_glb(dir.path(), "nan"));
    assert!(
        e.contains("accessor 0 (POSITION of mesh 0 'square' primitive 0)")
            && e.contains("vertex 1")
            && e.contains("non-finite"),
        "{e}"
    );
    // Accessor larger than its view.
    let mut f = square_fixture(U16, 4);
    f.accessors[0]["count"] = json!(40);
    let e = read_error(&f.write_glb(dir.path(), "overrun"));
    assert!(e.contains("accessor 0") && e.contains("do not fit in buffer view 0"), "{e}");
    // Invalid JSON and invalid glTF.
    let path = dir.path().join("broken.gltf");
    std::fs::write(&path, b"{ \"asset\": { \"version\": \"2.0\" }, \"nodes\": [ { \"mesh\": 0.5 } ] ").unwrap();
    assert!(read_error(&path).contains("invalid glTF JSON"));
    // Issue 28: a GLB whose magic number is wrong was called "invalid glTF JSON"; the error
    // now says that the magic bytes are wrong and shows them.
    let f = square_fixture(U16, 4);
    let good = f.write_glb(dir.path(), "magic");
    let mut bytes = std::fs::read(&good).unwrap();
    bytes[..4].copy_from_slice(b"glTX");
    std::fs::write(&good, &bytes).unwrap();
    let e = read_error(&good);
    assert!(
        e.contains("magic.glb") && e.contains("not a glTF file") && e.contains("67 6C 54 58") && !e.contains("JSON:"),
        "{e}"
    );
    let path = dir.path().join("empty.glb");
    std::fs::write(&path, b"").unwrap();
    assert!(read_error(&path).contains("the file is empty"));
    let path = dir.path().join("dangling.gltf");
    std::fs::write(&path, br#"{ "asset": { "version": "2.0" }, "nodes": [ { "mesh": 3 } ] }"#).unwrap();
    let e = read_error(&path);
    assert!(e.contains("invalid glTF") && e.contains("nodes[0].mesh"), "{e}");
    // Missing and short external buffers.
    let f = square_fixture(U16, 4);
    let path = f.write_gltf_external(dir.path(), "external", "external.bin");
    std::fs::remove_file(dir.path().join("external.bin")).unwrap();
    let e = read_gltf(&path, &GltfReadOptions::default()).unwrap_err().to_string();
    assert!(e.contains("external.bin") && e.contains("buffer file"), "{e}");
    std::fs::write(dir.path().join("external.bin"), &f.buffer[..20]).unwrap();
    let e = read_error(&path);
    assert!(e.contains("buffer 0") && e.contains("truncated"), "{e}");
    // Compressed geometry.
    let mut f = square_fixture(U16, 4);
    f.root["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    f.root["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    let e = read_error(&f.write_glb(dir.path(), "draco"));
    assert!(e.contains("KHR_draco_mesh_compression") && e.contains("without mesh compression"), "{e}");
    // No mesh at all: reading it as a mesh gives an empty-mesh error.
    let mut f = Fixture::new();
    f.root = json!({ "nodes": [{ "name": "empty" }] });
    let path = f.write_gltf_embedded(dir.path(), "nomesh");
    let e = read_mesh(&path).unwrap_err().to_string();
    assert!(e.contains("nomesh.gltf") && e.contains("empty"), "{e}");
    // A skinned node whose mesh has no skin attributes, and weights naming a missing joint.
    let mut f = skinned_fixture(0);
    f.root["meshes"][0]["primitives"][0]["attributes"] = json!({ "POSITION": 0 });
    let e = read_error(&f.write_glb(dir.path(), "noweights"));
    assert!(e.contains("node 3 'body'") && e.contains("no JOINTS_0/WEIGHTS_0"), "{e}");
    let mut f = skinned_fixture(0);
    f.root["skins"][0]["joints"] = json!([1]);
    f.root["skins"][0].as_object_mut().unwrap().remove("inverseBindMatrices");
    let e = read_error(&f.write_glb(dir.path(), "joints"));
    assert!(e.contains("joint 1") && e.contains("only 1 joints"), "{e}");
    // Animation keys going back in time.
    let mut f = skinned_fixture(0);
    let t = f.root["animations"][0]["samplers"][0]["input"].as_u64().unwrap() as usize;
    let view = f.accessors[t]["bufferView"].as_u64().unwrap() as usize;
    let start = f.views[view]["byteOffset"].as_u64().unwrap() as usize;
    f.buffer[start..start + 4].copy_from_slice(&5.0f32.to_le_bytes());
    f.accessors[t]["min"] = json!([1.0]);
    f.accessors[t]["max"] = json!([5.0]);
    let e = read_error(&f.write_glb(dir.path(), "times"));
    assert!(
        e.contains("animation 0 'bend' channel 0 (node 2 rotation)") && e.contains("key times must increase"),
        "{e}"
    );
    // A node that is the child of two parents.
    let mut f = square_fixture(U16, 4);
    f.root["nodes"] = json!([{ "mesh": 0 }, { "children": [0] }, { "children": [0] }]);
    let e = read_error(&f.write_glb(dir.path(), "parents"));
    assert!(e.contains("child of both node 1 and node 2"), "{e}");
}

#[test]
fn glb_container_errors() {
    let dir = tempfile::tempdir().unwrap();
    let good = square_fixture(U16, 4).glb_bytes();
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let e = read_error(&write("short.glb", &good[..8]));
    assert!(e.contains("12-byte GLB header") && e.contains("truncated"), "{e}");
    let mut v1 = good.clone();
    v1[4] = 1;
    let e = read_error(&write("v1.glb", &v1));
    assert!(e.contains("at byte 4") && e.contains("GLB version 1"), "{e}");
    let e = read_error(&write("cut.glb", &good[..good.len() - 10]));
    assert!(e.contains(&format!("at byte {}", good.len() - 10)) && e.contains("truncated"), "{e}");
    // Header length patched to the cut length: the BIN chunk then overruns.
    let mut cut = good[..good.len() - 10].to_vec();
    let n = cut.len() as u32;
    cut[8..12].copy_from_slice(&n.to_le_bytes());
    let e = read_error(&write("chunk.glb", &cut));
    assert!(e.contains("chunk of") && e.contains("truncated"), "{e}");
}

/// Truncating a GLB anywhere, or corrupting any of its bytes, gives an error or a mesh, never a
/// panic.
#[test]
fn truncated_or_corrupt_glb_never_panics() {
    let dir = tempfile::tempdir().unwrap();
    let good = skinned_fixture(0).glb_bytes();
    let path = dir.path().join("fuzz.glb");
    for len in 0..good.len() {
        std::fs::write(&path, &good[..len]).unwrap();
        let e = read_gltf(&path, &GltfReadOptions::default()).unwrap_err();
        assert!(e.to_string().contains("fuzz.glb"));
    }
    // Deterministic pseudo-random byte corruption (xorshift).
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    for _ in 0..600 {
        let mut bytes = good.clone();
        for _ in 0..3 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let at = (state % bytes.len() as u64) as usize;
            bytes[at] = (state >> 32) as u8;
        }
        std::fs::write(&path, &bytes).unwrap();
        if let Ok(scene) = read_gltf(&path, &GltfReadOptions::default()) {
            for inst in scene.instances() {
                let _ = scene.posed_mesh(inst.node, Some(0), 0.6);
            }
        }
    }
}
