//! glTF 2.0 writing: meshes as `.glb` (binary) or `.gltf` (JSON with the buffer embedded as a
//! base64 `data:` URI, a single self-contained file), and an animated `.glb` holding one mesh's
//! positions over many frames.
//!
//! Precision: glTF stores positions as 32-bit floats, so coordinates are rounded from `f64` to
//! the nearest `f32` (a relative error below 6e-8, i.e. ~0.06 mm on a 1 km scene, ~0.1 µm on a
//! 2 m character). Reading back gives those `f32` values exactly; use OBJ or PLY (doubles) when
//! bit-exact round trips matter. Coordinates beyond the `f32` range are an error.
//!
//! Animated meshes are written as morph targets (see [`write_animated_glb`] for why).

use std::io::Write;
use std::path::Path;

use base64::Engine as _;
use glam::DVec3;
use serde_json::{Value, json};
use squish::TriMesh;
use squish::mesh::vertex_normals;

use crate::gltf_read::{GltfReadOptions, read_gltf};
use crate::morph::{MorphFrame, MorphKeys, SparseDisplacement};
use crate::{IoError, write_atomically};

/// Options of the glTF writers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GltfWriteOptions {
    /// Write area-weighted vertex normals (`NORMAL`). Default: true, so that viewers shade the
    /// mesh smoothly instead of computing flat normals.
    pub normals: bool,
}

impl Default for GltfWriteOptions {
    fn default() -> Self {
        Self { normals: true }
    }
}

/// A mesh with a name (becomes the glTF mesh and node name, which DCC tools show).
#[derive(Clone, Copy, Debug)]
pub struct NamedMesh<'a> {
    pub name: &'a str,
    pub mesh: &'a TriMesh,
}

const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;
const FLOAT: u32 = 5126;
const UNSIGNED_INT: u32 = 5125;

/// Accumulates the binary buffer, buffer views and accessors of a document.
#[derive(Default)]
struct Builder {
    buffer: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Builder {
    fn view(&mut self, bytes: &[u8], target: Option<u32>) -> usize {
        // Every view starts on a 4-byte boundary, as float and u32 accessors require.
        while !self.buffer.len().is_multiple_of(4) {
            self.buffer.push(0);
        }
        let mut view = json!({ "buffer": 0, "byteOffset": self.buffer.len(), "byteLength": bytes.len() });
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.buffer.extend_from_slice(bytes);
        self.views.push(view);
        self.views.len() - 1
    }

    /// A VEC3 float accessor with min/max (required for POSITION, useful everywhere).
    fn vec3(&mut self, values: &[[f32; 3]], target: Option<u32>) -> usize {
        let bytes: Vec<u8> = values.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, target);
        let mut min = [f32::INFINITY; 3];
        let mut max = [f32::NEG_INFINITY; 3];
        for v in values {
            for c in 0..3 {
                min[c] = min[c].min(v[c]);
                max[c] = max[c].max(v[c]);
            }
        }
        if values.is_empty() {
            min = [0.0; 3];
            max = [0.0; 3];
        }
        self.accessors.push(json!({
            "bufferView": view, "componentType": FLOAT, "count": values.len(), "type": "VEC3",
            "min": min, "max": max,
        }));
        self.accessors.len() - 1
    }

    fn indices(&mut self, triangles: &[[u32; 3]]) -> usize {
        let bytes: Vec<u8> = triangles.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(ELEMENT_ARRAY_BUFFER));
        self.accessors.push(json!({
            "bufferView": view, "componentType": UNSIGNED_INT, "count": 3 * triangles.len(), "type": "SCALAR",
        }));
        self.accessors.len() - 1
    }

    fn scalars(&mut self, values: &[f32], with_bounds: bool) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let view = self.view(&bytes, None);
        let mut acc = json!({ "bufferView": view, "componentType": FLOAT, "count": values.len(), "type": "SCALAR" });
        if with_bounds {
            let min = values.iter().copied().fold(f32::INFINITY, f32::min);
            let max = values.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            acc["min"] = json!([min]);
            acc["max"] = json!([max]);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// The document around `extra` (meshes, nodes, animations …), with this builder's buffer
    /// either referenced by the GLB binary chunk (`uri: None`) or embedded as `uri`.
    fn document(&self, mut extra: Value, uri: Option<String>) -> Value {
        let mut buffer = json!({ "byteLength": self.buffer.len() });
        if let Some(uri) = uri {
            buffer["uri"] = json!(uri);
        }
        extra["asset"] = json!({ "version": "2.0", "generator": concat!("Squish ", env!("CARGO_PKG_VERSION")) });
        extra["scene"] = json!(0);
        extra["buffers"] = json!([buffer]);
        extra["bufferViews"] = json!(self.views);
        extra["accessors"] = json!(self.accessors);
        extra
    }
}

/// Rounds positions to `f32`, failing on values beyond the `f32` range.
fn to_f32(path: &Path, positions: &[DVec3], what: &str) -> Result<Vec<[f32; 3]>, IoError> {
    positions
        .iter()
        .enumerate()
        .map(|(v, p)| {
            let q = p.as_vec3().to_array();
            if q.iter().all(|c| c.is_finite()) {
                Ok(q)
            } else {
                Err(IoError::invalid_input(
                    path,
                    format!("{what} vertex {v} ({p}) is not finite in 32-bit floats, which glTF uses"),
                ))
            }
        })
        .collect()
}

/// Writes one mesh as `.glb` or `.gltf` (chosen by the extension).
pub fn write_gltf(path: &Path, mesh: &TriMesh, options: &GltfWriteOptions) -> Result<(), IoError> {
    write_gltf_meshes(path, &[NamedMesh { name: "mesh", mesh }], options)
}

/// Writes several named meshes, one node each, as `.glb` or `.gltf` (chosen by the extension;
/// `.gltf` embeds the buffer as base64 so the file stands alone).
pub fn write_gltf_meshes(path: &Path, meshes: &[NamedMesh], options: &GltfWriteOptions) -> Result<(), IoError> {
    let binary = is_glb(path)?;
    if meshes.is_empty() {
        return Err(IoError::invalid_input(path, "no mesh to write"));
    }
    let mut builder = Builder::default();
    let mut json_meshes = Vec::new();
    let mut nodes = Vec::new();
    for (i, named) in meshes.iter().enumerate() {
        named.mesh.check_structure().map_err(|e| IoError::mesh(path, e))?;
        let positions = to_f32(path, &named.mesh.positions, named.name)?;
        let position = builder.vec3(&positions, Some(ARRAY_BUFFER));
        let mut attributes = json!({ "POSITION": position });
        if options.normals {
            let normals: Vec<[f32; 3]> = vertex_normals(named.mesh)
                .iter()
                .map(|n| if *n == DVec3::ZERO { [0.0, 0.0, 1.0] } else { n.as_vec3().to_array() })
                .collect();
            attributes["NORMAL"] = json!(builder.vec3(&normals, Some(ARRAY_BUFFER)));
        }
        let indices = builder.indices(&named.mesh.triangles);
        json_meshes.push(json!({
            "name": named.name,
            "primitives": [{ "attributes": attributes, "indices": indices, "mode": 4 }],
        }));
        nodes.push(json!({ "name": named.name, "mesh": i }));
    }
    let extra = json!({
        "scenes": [{ "nodes": (0..meshes.len()).collect::<Vec<_>>() }],
        "nodes": nodes,
        "meshes": json_meshes,
    });
    finish(path, builder, extra, binary)
}

/// Writes an animated mesh as `.glb` or `.gltf`: `base` is the mesh's base positions (a shot's
/// input at its first frame), on the topology of `triangles` (the same for every frame, as the
/// deformer never changes connectivity), and `frames` each frame's displacement from `base`.
/// For a glTF source, [`crate::GltfDocument::write_animated`] keeps the asset instead.
///
/// Encoding: one mesh, one morph target per frame holding its displacement as a sparse accessor
/// of the vertices that move (dense when that is smaller; see [`crate::morph`]), and a STEP
/// animation of the morph weights that sets the frame's weight to one and all others to zero
/// from its time on (and every weight to zero at `keys`' times). Why morph targets rather than
/// one node per frame shown or hidden by a STEP scale animation:
/// - the result is one object with one topology: Blender imports the targets as shape keys
///   (named after their frame, from `extras.targetNames`) driven by an action with constant
///   interpolation, so the user gets a single mesh that plays back, can be modified or
///   re-exported, instead of hundreds of objects in the outliner;
/// - scale-0 hiding needs degenerate node matrices, which some importers reject or turn into
///   NaN normals, and a viewer interpolating (not stepping) the scale would show two frames at
///   once;
/// - the index buffer is stored once, and the base positions.
///
/// No normals are written: importers keep custom normals fixed while shape keys move the
/// vertices (wrong shading on every frame but the first), whereas without normals they are
/// recomputed from each frame's geometry. Set the importing scene's frame rate to the shot's so
/// keys fall on whole frames. The weights output grows as frames² (4 bytes each; 1000 frames ≈
/// 4 MB).
pub fn write_animated_glb(
    path: &Path,
    name: &str,
    triangles: &[[u32; 3]],
    base: &[DVec3],
    frames: &[MorphFrame],
    keys: MorphKeys,
) -> Result<(), IoError> {
    let binary = is_glb(path)?;
    if frames.is_empty() {
        return Err(IoError::invalid_input(path, "no frame to write"));
    }
    TriMesh::new(base.to_vec(), triangles.to_vec()).map_err(|e| IoError::mesh(path, e))?;
    if let Some(k) = frames.iter().position(|f| f.displacement.count != base.len()) {
        return Err(IoError::invalid_input(
            path,
            format!("frame {k} displaces {} vertices but the mesh has {}", frames[k].displacement.count, base.len()),
        ));
    }
    let times = keys.times(frames).map_err(|m| IoError::invalid_input(path, m))?;
    let mut builder = Builder::default();
    let base = to_f32(path, base, "the base mesh's")?;
    let position = builder.vec3(&base, Some(ARRAY_BUFFER));
    let indices = builder.indices(triangles);
    let targets: Vec<Value> = frames
        .iter()
        .map(|frame| {
            let accessor = crate::morph::sparse_accessor(&frame.displacement, true, |bytes| builder.view(bytes, None));
            builder.accessors.push(accessor);
            json!({ "POSITION": builder.accessors.len() - 1 })
        })
        .collect();
    let names: Vec<&str> = frames.iter().map(|f| f.name.as_str()).collect();
    let n_targets = targets.len();
    let primitive =
        json!({ "attributes": { "POSITION": position }, "indices": indices, "mode": 4, "targets": targets });
    let mesh = json!({
        "name": name,
        "primitives": [primitive],
        "weights": vec![0.0f32; n_targets],
        "extras": { "targetNames": names },
    });
    let key_times: Vec<f32> = times.iter().map(|&t| t as f32).collect();
    let mut weights = vec![0.0f32; times.len() * n_targets];
    for (k, on) in keys.frame_on(n_targets).into_iter().enumerate() {
        if let Some(frame) = on {
            weights[k * n_targets + frame] = 1.0;
        }
    }
    let input = builder.scalars(&key_times, true);
    let output = builder.scalars(&weights, false);
    let extra = json!({
        "scenes": [{ "nodes": [0] }],
        "nodes": [{ "name": name, "mesh": 0 }],
        "meshes": [mesh],
        "animations": [{
            "name": name,
            "samplers": [{ "input": input, "output": output, "interpolation": "STEP" }],
            "channels": [{ "sampler": 0, "target": { "node": 0, "path": "weights" } }],
        }],
    });
    finish(path, builder, extra, binary)
}

/// A file [`write_animated_glb`] wrote, read back: the base positions, the triangles, and each
/// frame's target name and displacement, as written (bit for bit), so that the parts of a split
/// shot merge into what one run writes.
pub fn read_animated_glb(path: &Path) -> Result<AnimatedMesh, IoError> {
    let scene = read_gltf(path, &GltfReadOptions::default())?;
    let [mesh] = scene.meshes.as_slice() else {
        return Err(IoError::invalid_input(
            path,
            format!("{} meshes: a shot's file of positions over time holds one", scene.meshes.len()),
        ));
    };
    let frames = mesh
        .morph_targets
        .iter()
        .enumerate()
        .map(|(k, target)| {
            let name = mesh.target_names.get(k).cloned().unwrap_or_default();
            let displacement = SparseDisplacement::from_dense(target)
                .map_err(|v| IoError::invalid_input(path, format!("target {name}: vertex {v} is not finite")))?;
            Ok((name, displacement))
        })
        .collect::<Result<_, IoError>>()?;
    Ok(AnimatedMesh { base: mesh.positions.clone(), triangles: mesh.triangles.clone(), frames })
}

/// What [`read_animated_glb`] reads.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimatedMesh {
    pub base: Vec<DVec3>,
    pub triangles: Vec<[u32; 3]>,
    /// Per target: its name and displacement.
    pub frames: Vec<(String, SparseDisplacement)>,
}

fn is_glb(path: &Path) -> Result<bool, IoError> {
    match path.extension().map(|e| e.to_ascii_lowercase()) {
        Some(e) if e == "glb" => Ok(true),
        Some(e) if e == "gltf" => Ok(false),
        _ => Err(IoError::invalid_input(path, "a glTF file name must end in .glb (binary) or .gltf (JSON)")),
    }
}

fn finish(path: &Path, builder: Builder, extra: Value, binary: bool) -> Result<(), IoError> {
    if binary {
        let doc = builder.document(extra, None);
        let json_bytes =
            serde_json::to_vec(&doc).map_err(|e| IoError::invalid_input(path, format!("JSON encoding failed: {e}")))?;
        write_atomically(path, |w| write_glb_container(w, &json_bytes, &builder.buffer))
    } else {
        let uri = format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(&builder.buffer)
        );
        let doc = builder.document(extra, Some(uri));
        let json_bytes = serde_json::to_vec_pretty(&doc)
            .map_err(|e| IoError::invalid_input(path, format!("JSON encoding failed: {e}")))?;
        write_atomically(path, |w| w.write_all(&json_bytes))
    }
}

/// GLB: 12-byte header, JSON chunk padded with spaces, BIN chunk padded with zeros (glTF 2.0
/// §4.4: chunks are 4-byte aligned).
pub(crate) fn write_glb_container(w: &mut dyn Write, json: &[u8], bin: &[u8]) -> std::io::Result<()> {
    let json_padded = json.len().div_ceil(4) * 4;
    let bin_padded = bin.len().div_ceil(4) * 4;
    let total = 12 + 8 + json_padded + if bin.is_empty() { 0 } else { 8 + bin_padded };
    let too_big = || std::io::Error::other("the file would exceed the 4 GiB limit of GLB");
    let total = u32::try_from(total).map_err(|_| too_big())?;
    w.write_all(b"glTF")?;
    w.write_all(&2u32.to_le_bytes())?;
    w.write_all(&total.to_le_bytes())?;
    w.write_all(&(json_padded as u32).to_le_bytes())?;
    w.write_all(b"JSON")?;
    w.write_all(json)?;
    w.write_all(&vec![b' '; json_padded - json.len()])?;
    if !bin.is_empty() {
        w.write_all(&(bin_padded as u32).to_le_bytes())?;
        w.write_all(b"BIN\0")?;
        w.write_all(bin)?;
        w.write_all(&vec![0u8; bin_padded - bin.len()])?;
    }
    Ok(())
}
