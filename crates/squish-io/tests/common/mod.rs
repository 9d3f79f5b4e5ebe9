//! Helpers shared by the integration tests: small glTF documents built by hand (so that every
//! component type, primitive mode and container can be exercised without binary fixtures), and
//! the location of the shared test data.

#![allow(dead_code, clippy::unwrap_used)]

use std::path::{Path, PathBuf};

use base64::Engine as _;
use serde_json::{Value, json};

/// `../shared/data/<relative>` if the shared data directory exists; otherwise prints a note and
/// returns `None` so that the test can skip.
pub fn shared_data(relative: &str) -> Option<PathBuf> {
    let root = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data"));
    let path = root.join(relative);
    if path.exists() {
        Some(path)
    } else {
        eprintln!("note: {} not found; skipping this test", path.display());
        None
    }
}

/// Builds a glTF document: a binary buffer, views and accessors of any component type.
#[derive(Default)]
pub struct Fixture {
    pub buffer: Vec<u8>,
    pub views: Vec<Value>,
    pub accessors: Vec<Value>,
    /// Everything else (meshes, nodes, skins, animations, scenes).
    pub root: Value,
}

/// glTF component type codes.
pub const I8: u32 = 5120;
pub const U8: u32 = 5121;
pub const I16: u32 = 5122;
pub const U16: u32 = 5123;
pub const U32: u32 = 5125;
pub const F32: u32 = 5126;

impl Fixture {
    pub fn new() -> Self {
        Self { root: json!({}), ..Self::default() }
    }

    /// Appends an accessor of `ty` ("SCALAR", "VEC3", …) with components of `component` type
    /// (values converted with `as`), tightly packed. Returns its index.
    pub fn accessor(&mut self, component: u32, ty: &str, values: &[f64]) -> usize {
        self.accessor_ex(component, ty, values, false)
    }

    pub fn accessor_ex(&mut self, component: u32, ty: &str, values: &[f64], normalized: bool) -> usize {
        while !self.buffer.len().is_multiple_of(4) {
            self.buffer.push(0);
        }
        let start = self.buffer.len();
        for &v in values {
            match component {
                I8 => self.buffer.push(v as i8 as u8),
                U8 => self.buffer.push(v as u8),
                I16 => self.buffer.extend_from_slice(&(v as i16).to_le_bytes()),
                U16 => self.buffer.extend_from_slice(&(v as u16).to_le_bytes()),
                U32 => self.buffer.extend_from_slice(&(v as u32).to_le_bytes()),
                F32 => self.buffer.extend_from_slice(&(v as f32).to_le_bytes()),
                _ => panic!("bad component type"),
            }
        }
        let components = match ty {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            _ => panic!("unsupported type in fixture"),
        };
        self.views.push(json!({ "buffer": 0, "byteOffset": start, "byteLength": self.buffer.len() - start }));
        let mut acc = json!({
            "bufferView": self.views.len() - 1, "componentType": component,
            "count": values.len() / components, "type": ty,
        });
        if normalized {
            acc["normalized"] = json!(true);
        }
        if ty == "VEC3" && component == F32 && !values.is_empty() {
            let mut min = [f64::INFINITY; 3];
            let mut max = [f64::NEG_INFINITY; 3];
            for c in values.chunks(3) {
                for k in 0..3 {
                    min[k] = min[k].min(c[k] as f32 as f64);
                    max[k] = max[k].max(c[k] as f32 as f64);
                }
            }
            if min.iter().chain(&max).all(|x| x.is_finite()) {
                acc["min"] = json!(min);
                acc["max"] = json!(max);
            }
        }
        if ty == "SCALAR" && component == F32 && !values.is_empty() {
            let min = values.iter().cloned().fold(f64::INFINITY, f64::min);
            let max = values.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            acc["min"] = json!([min]);
            acc["max"] = json!([max]);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    fn json_with(&self, uri: Option<String>) -> Value {
        let mut root = self.root.clone();
        root["asset"] = json!({ "version": "2.0" });
        let mut buffer = json!({ "byteLength": self.buffer.len() });
        if let Some(uri) = uri {
            buffer["uri"] = json!(uri);
        }
        if !self.buffer.is_empty() {
            root["buffers"] = json!([buffer]);
            root["bufferViews"] = json!(self.views);
            root["accessors"] = json!(self.accessors);
        }
        root
    }

    /// Writes `<dir>/<name>.gltf` with the buffer embedded as a base64 data URI.
    pub fn write_gltf_embedded(&self, dir: &Path, name: &str) -> PathBuf {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&self.buffer)
        );
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_vec_pretty(&self.json_with(Some(uri))).unwrap()).unwrap();
        path
    }

    /// Writes `<dir>/<name>.gltf` and its buffer as `<dir>/<bin_name>` (percent-encoded in the URI).
    pub fn write_gltf_external(&self, dir: &Path, name: &str, bin_name: &str) -> PathBuf {
        std::fs::write(dir.join(bin_name), &self.buffer).unwrap();
        let uri = bin_name.replace(' ', "%20");
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_vec_pretty(&self.json_with(Some(uri))).unwrap()).unwrap();
        path
    }

    /// The GLB bytes.
    pub fn glb_bytes(&self) -> Vec<u8> {
        let mut json = serde_json::to_vec(&self.json_with(None)).unwrap();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = self.buffer.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
        let mut out = Vec::new();
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        if !bin.is_empty() {
            out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
            out.extend_from_slice(b"BIN\0");
            out.extend_from_slice(&bin);
        }
        out
    }

    pub fn write_glb(&self, dir: &Path, name: &str) -> PathBuf {
        let path = dir.join(format!("{name}.glb"));
        std::fs::write(&path, self.glb_bytes()).unwrap();
        path
    }
}

/// A unit square in the xy plane as two triangles, with the given index component type.
pub fn square_fixture(index_type: u32, mode: u32) -> Fixture {
    let mut f = Fixture::new();
    let pos = f.accessor(F32, "VEC3", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0]);
    let indices: Vec<f64> = match mode {
        4 => vec![0.0, 1.0, 2.0, 0.0, 2.0, 3.0],
        5 => vec![1.0, 2.0, 0.0, 3.0], // strip: (1,2,0), (2,3,0) after the odd-triangle swap
        6 => vec![0.0, 1.0, 2.0, 3.0], // fan around 0
        _ => vec![0.0, 1.0, 2.0, 3.0],
    };
    let idx = f.accessor(index_type, "SCALAR", &indices);
    f.root = json!({
        "scene": 0,
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "name": "square", "mesh": 0 }],
        "meshes": [{ "name": "square", "primitives": [{ "attributes": { "POSITION": pos }, "indices": idx, "mode": mode }] }],
    });
    f
}

/// A closed cylinder along x from −1 to 1 (radius 0.25, `rings` rings of `segments` vertices and
/// two cap centres), skinned to three joints in a chain: "root" at x = −1, "elbow" at x = 0 and
/// "tip" at x = 1 (a leaf). `weight(x)` gives the two joints (indices into the chain) and their
/// weights of a vertex at x. The animation "bend" turns the elbow about z from 0 at t = 0 to 150°
/// at t = 1 s, so that the inner side of the bend passes through itself.
pub fn bending_cylinder(rings: usize, segments: usize, weight: impl Fn(f64) -> ([f64; 2], [f64; 2])) -> Fixture {
    use glam::{DMat4, DQuat, DVec3};
    use std::f64::consts::PI;
    let mut positions = Vec::new();
    let mut weights = Vec::new();
    for r in 0..rings {
        let x = -1.0 + 2.0 * r as f64 / (rings - 1) as f64;
        for s in 0..segments {
            let a = 2.0 * PI * s as f64 / segments as f64;
            positions.extend_from_slice(&[x, 0.25 * a.cos(), 0.25 * a.sin()]);
            weights.push(weight(x));
        }
    }
    positions.extend_from_slice(&[-1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
    weights.push(weight(-1.0));
    weights.push(weight(1.0));
    let mut indices = Vec::new();
    let v = |r: usize, s: usize| (r * segments + s % segments) as f64;
    for r in 0..rings - 1 {
        for s in 0..segments {
            indices.extend_from_slice(&[v(r, s), v(r + 1, s + 1), v(r + 1, s), v(r, s), v(r, s + 1), v(r + 1, s + 1)]);
        }
    }
    let (c0, c1) = ((rings * segments) as f64, (rings * segments + 1) as f64);
    for s in 0..segments {
        indices.extend_from_slice(&[c0, v(0, s + 1), v(0, s)]);
        indices.extend_from_slice(&[c1, v(rings - 1, s), v(rings - 1, s + 1)]);
    }
    let mut f = Fixture::new();
    let pos = f.accessor(F32, "VEC3", &positions);
    let idx = f.accessor(U32, "SCALAR", &indices);
    let j: Vec<f64> = weights.iter().flat_map(|(j, _)| [j[0], j[1], 0.0, 0.0]).collect();
    let joints = f.accessor(U8, "VEC4", &j);
    let w: Vec<f64> = weights.iter().flat_map(|(_, w)| [w[0], w[1], 0.0, 0.0]).collect();
    let w = f.accessor(F32, "VEC4", &w);
    let mut ibm = Vec::new();
    for x in [-1.0, 0.0, 1.0] {
        ibm.extend_from_slice(&DMat4::from_translation(DVec3::new(-x, 0.0, 0.0)).to_cols_array());
    }
    let ibm = f.accessor(F32, "MAT4", &ibm);
    let times = f.accessor(F32, "SCALAR", &[0.0, 1.0]);
    let q = DQuat::from_rotation_z(150f64.to_radians());
    let rotations = f.accessor(F32, "VEC4", &[0.0, 0.0, 0.0, 1.0, q.x, q.y, q.z, q.w]);
    f.root = json!({
        "scene": 0,
        "scenes": [{ "nodes": [0, 1] }],
        "nodes": [
            { "name": "body", "mesh": 0, "skin": 0 },
            { "name": "root", "translation": [-1.0, 0.0, 0.0], "children": [2] },
            { "name": "elbow", "translation": [1.0, 0.0, 0.0], "children": [3] },
            { "name": "tip", "translation": [1.0, 0.0, 0.0] },
        ],
        "meshes": [{ "name": "cylinder", "primitives": [{
            "attributes": { "POSITION": pos, "JOINTS_0": joints, "WEIGHTS_0": w }, "indices": idx,
        }] }],
        "skins": [{ "name": "arm", "joints": [1, 2, 3], "inverseBindMatrices": ibm }],
        "animations": [{
            "name": "bend",
            "samplers": [{ "input": times, "output": rotations, "interpolation": "LINEAR" }],
            "channels": [{ "sampler": 0, "target": { "node": 2, "path": "rotation" } }],
        }],
    });
    f
}
