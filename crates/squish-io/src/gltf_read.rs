//! glTF 2.0 reading (`.gltf` with external `.bin` files or `data:` URIs, and `.glb`) into a
//! document model, [`GltfScene`], that converts into the core types: [`TriMesh`], [`Skeleton`],
//! [`Skin`], [`SkinWeights`] and [`AnimationClip`].
//!
//! The `gltf` crate parses and validates the JSON; the binary side (GLB container, buffers,
//! accessors) is decoded here, with every offset and length checked, so that a truncated or
//! corrupt file gives an error naming the accessor or byte offset instead of a panic.
//!
//! What is read:
//! - every mesh primitive of mode TRIANGLES, TRIANGLE_STRIP or TRIANGLE_FAN (strips and fans are
//!   converted to triangles; strip triangles that repeat a vertex, the usual way of joining
//!   strips, are dropped). POINTS and LINES primitives are an error: they have no surface.
//!   A mesh's primitives are concatenated in order, so its vertex order and count are the file's;
//! - positions (float or quantized), indices (u8/u16/u32, or none), skin attributes
//!   (`JOINTS_n` u8/u16, `WEIGHTS_n` float or normalized u8/u16; with more than one set, the
//!   four largest influences are kept), morph-target position displacements. Normals,
//!   tangents, texture coordinates and colours are ignored;
//! - nodes (names, hierarchy, TRS or matrix), skins (joints as node ids, inverse bind matrices,
//!   identity when absent, skeleton root), animations (translation / rotation / scale channels
//!   as [`AnimationClip`]s, morph-target weight channels as [`MorphWeightsTrack`]s).
//!
//! Optionally ([`GltfReadOptions::weld`]) each mesh's vertices are welded by position, because
//! glTF duplicates vertices along UV seams and hard edges, which opens a closed surface.

use std::collections::HashMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use base64::Engine as _;
use glam::{DMat4, DQuat, DVec3};
use gltf::json::validation::Checked;
use squish::animation::{
    AnimationClip, Channel, ChannelValues, Interpolation, NodeTransform, Sampler, Skeleton, SkeletonNode, Trs,
};
use squish::skinning::{joint_matrices, linear_blend_skinning, Skin, SkinWeights};
use squish::TriMesh;

use crate::weld::{weld_positions, WeldMode};
use crate::IoError;

/// Options of [`read_gltf`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GltfReadOptions {
    /// Welding of each mesh's vertices. Default: off (the file's vertices, in order).
    pub weld: WeldMode,
}

impl GltfReadOptions {
    /// Sets the welding mode.
    pub fn with_weld(mut self, weld: WeldMode) -> Self {
        self.weld = weld;
        self
    }
}

/// A glTF file as read.
#[derive(Clone, Debug)]
pub struct GltfScene {
    /// The file read (errors of later conversions name it).
    pub path: PathBuf,
    /// All nodes, indexed as in the file.
    pub nodes: Vec<GltfNode>,
    /// The node hierarchy as a skeleton whose node ids are the file's node indices, so that
    /// skin joints and animation channels index it directly.
    pub skeleton: Skeleton,
    /// Root nodes of the default scene (or of the first scene, or every parentless node when
    /// the file has no scene).
    pub roots: Vec<usize>,
    pub meshes: Vec<GltfMesh>,
    pub skins: Vec<GltfSkin>,
    pub animations: Vec<GltfAnimation>,
}

/// A node.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfNode {
    /// Name (empty if the file has none).
    pub name: String,
    pub parent: Option<usize>,
    pub children: Vec<usize>,
    /// Local transform.
    pub transform: NodeTransform,
    /// Mesh instanced at this node.
    pub mesh: Option<usize>,
    /// Skin deforming that mesh.
    pub skin: Option<usize>,
    /// Morph-target weights of this instance (overrides the mesh's defaults).
    pub weights: Option<Vec<f64>>,
}

/// A mesh: all its primitives concatenated (welded if asked).
#[derive(Clone, Debug, PartialEq)]
pub struct GltfMesh {
    pub name: String,
    /// Positions in the mesh's own space.
    pub positions: Vec<DVec3>,
    /// Counter-clockwise triangles.
    pub triangles: Vec<[u32; 3]>,
    /// Skin weights, when the primitives have `JOINTS_0` / `WEIGHTS_0`.
    pub skin_weights: Option<SkinWeights>,
    /// Position displacements of each morph target (one per vertex).
    pub morph_targets: Vec<Vec<DVec3>>,
    /// Default morph-target weights.
    pub default_weights: Vec<f64>,
    /// Names of the morph targets (`extras.targetNames`, as Blender writes them), if present.
    pub target_names: Vec<String>,
    /// The file vertices of each primitive, in file numbering (before welding).
    pub primitive_vertices: Vec<Range<usize>>,
    /// Number of vertices in the file (before welding).
    pub file_vertex_count: usize,
    /// With welding: for each file vertex, its welded vertex.
    pub vertex_map: Option<Vec<u32>>,
    /// With welding: triangles dropped because two of their corners were merged.
    pub collapsed_triangles: usize,
}

impl GltfMesh {
    /// The mesh as a [`TriMesh`] in its own space (checked by [`TriMesh::new`]).
    pub fn to_tri_mesh(&self) -> Result<TriMesh, squish::MeshError> {
        TriMesh::new(self.positions.clone(), self.triangles.clone())
    }

    /// Positions with morph targets applied with `weights` (missing weights count as zero).
    pub fn morphed_positions(&self, weights: &[f64]) -> Vec<DVec3> {
        let mut positions = self.positions.clone();
        for (target, &w) in self.morph_targets.iter().zip(weights) {
            if w != 0.0 {
                for (p, d) in positions.iter_mut().zip(target) {
                    *p += w * *d;
                }
            }
        }
        positions
    }
}

/// A skin.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfSkin {
    pub name: String,
    /// Joints (node ids) and inverse bind matrices.
    pub skin: Skin,
    /// The `skeleton` property: the common root of the joints, if the file names it.
    pub skeleton_root: Option<usize>,
}

/// An animation.
#[derive(Clone, Debug, PartialEq)]
pub struct GltfAnimation {
    pub name: String,
    /// Translation, rotation and scale channels.
    pub clip: AnimationClip,
    /// Morph-target weight channels.
    pub morph_weights: Vec<MorphWeightsTrack>,
}

impl GltfAnimation {
    /// Latest key time over all channels, morph weights included (the animation plays from 0).
    pub fn duration(&self) -> f64 {
        self.morph_weights
            .iter()
            .flat_map(|t| t.samplers.iter().map(|s| s.end_time()))
            .fold(self.clip.duration(), f64::max)
    }
}

/// Morph-target weights of one node over time: one sampler per target.
#[derive(Clone, Debug, PartialEq)]
pub struct MorphWeightsTrack {
    pub node: usize,
    pub samplers: Vec<Sampler<f64>>,
}

impl MorphWeightsTrack {
    /// The weights at `time`.
    pub fn weights_at(&self, time: f64) -> Vec<f64> {
        self.samplers.iter().map(|s| s.sample(time)).collect()
    }
}

/// A node that instances a mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshInstance {
    pub node: usize,
    pub mesh: usize,
    pub skin: Option<usize>,
}

impl GltfScene {
    /// Nodes that instance a mesh, in node order.
    pub fn instances(&self) -> Vec<MeshInstance> {
        self.nodes
            .iter()
            .enumerate()
            .filter_map(|(node, n)| n.mesh.map(|mesh| MeshInstance { node, mesh, skin: n.skin }))
            .collect()
    }

    /// The animation with this name.
    pub fn find_animation(&self, name: &str) -> Option<usize> {
        self.animations.iter().position(|a| a.name == name)
    }

    /// Local node transforms: the rest pose, or `animation` evaluated at `time`.
    pub fn local_transforms(&self, animation: Option<usize>, time: f64) -> Result<Vec<NodeTransform>, IoError> {
        match animation {
            None => Ok(self.skeleton.rest_pose()),
            Some(a) => {
                let anim = self.animation(a)?;
                anim.clip.evaluate(&self.skeleton, time).map_err(|source| IoError::Animation {
                    path: self.path.clone(),
                    element: format!("animation {a} '{}'", anim.name),
                    source,
                })
            }
        }
    }

    /// World transforms of every node: the rest pose, or `animation` evaluated at `time`.
    pub fn world_transforms(&self, animation: Option<usize>, time: f64) -> Result<Vec<DMat4>, IoError> {
        Ok(self.skeleton.world_transforms(&self.local_transforms(animation, time)?))
    }

    fn animation(&self, a: usize) -> Result<&GltfAnimation, IoError> {
        self.animations.get(a).ok_or_else(|| {
            IoError::element(&self.path, format!("animation {a}"), format!("no such animation; the file has {}", self.animations.len()))
        })
    }

    /// The mesh of `node` in world space, posed: morph weights (animated, else the node's,
    /// else the mesh's defaults), then skinning by the node's skin if any (glTF ignores the
    /// transform of a skinned mesh's node: the joints place it) or else the node's world
    /// transform. `animation: None` gives the rest pose.
    pub fn posed_mesh(&self, node: usize, animation: Option<usize>, time: f64) -> Result<TriMesh, IoError> {
        let world = self.world_transforms(animation, time)?;
        self.posed_mesh_with(node, animation, time, &world)
    }

    /// Every instance posed as in [`GltfScene::posed_mesh`], in node order.
    pub fn posed_meshes(&self, animation: Option<usize>, time: f64) -> Result<Vec<(usize, TriMesh)>, IoError> {
        let world = self.world_transforms(animation, time)?;
        self.instances()
            .iter()
            .map(|inst| Ok((inst.node, self.posed_mesh_with(inst.node, animation, time, &world)?)))
            .collect()
    }

    /// The mesh of `node` transformed by the node's rest world transform, without skinning or
    /// morphing (the "world-transformed" mesh of a static scene).
    pub fn world_mesh(&self, node: usize) -> Result<TriMesh, IoError> {
        let (mesh, _) = self.node_mesh(node)?;
        let world = self.skeleton.rest_world_transforms();
        let m = world[node];
        let positions = mesh.positions.iter().map(|p| m.transform_point3(*p)).collect();
        TriMesh::new(positions, mesh.triangles.clone()).map_err(|e| IoError::mesh(&self.path, e))
    }

    fn node_mesh(&self, node: usize) -> Result<(&GltfMesh, &GltfNode), IoError> {
        let n = self.nodes.get(node).ok_or_else(|| {
            IoError::element(&self.path, format!("node {node}"), format!("no such node; the file has {}", self.nodes.len()))
        })?;
        let mesh = n
            .mesh
            .and_then(|m| self.meshes.get(m))
            .ok_or_else(|| IoError::element(&self.path, format!("node {node} '{}'", n.name), "the node has no mesh"))?;
        Ok((mesh, n))
    }

    fn posed_mesh_with(&self, node: usize, animation: Option<usize>, time: f64, world: &[DMat4]) -> Result<TriMesh, IoError> {
        let (mesh, n) = self.node_mesh(node)?;
        let animated_weights = match animation {
            Some(a) => self.animation(a)?.morph_weights.iter().rev().find(|t| t.node == node).map(|t| t.weights_at(time)),
            None => None,
        };
        let weights = animated_weights.or_else(|| n.weights.clone()).unwrap_or_else(|| mesh.default_weights.clone());
        let positions = mesh.morphed_positions(&weights);
        let element = || format!("node {node} '{}'", n.name);
        let positions = match (n.skin, &mesh.skin_weights) {
            (Some(s), Some(skin_weights)) => {
                let skin = &self.skins.get(s).ok_or_else(|| IoError::element(&self.path, element(), format!("skin {s} does not exist")))?.skin;
                let skin_error = |source| IoError::Skin { path: self.path.clone(), element: element(), source };
                let matrices = joint_matrices(skin, world).map_err(skin_error)?;
                linear_blend_skinning(&positions, skin_weights, &matrices).map_err(skin_error)?
            }
            _ => positions.iter().map(|p| world[node].transform_point3(*p)).collect(),
        };
        TriMesh::new(positions, mesh.triangles.clone()).map_err(|e| IoError::mesh(&self.path, e))
    }

    /// All instances posed at rest and concatenated in node order; a file with meshes but no
    /// node instancing them gives its meshes in their own space. This is what
    /// [`crate::read_mesh`] returns for glTF.
    pub fn merged_mesh(&self) -> Result<TriMesh, IoError> {
        let mut merged = TriMesh::default();
        let instances = self.instances();
        if instances.is_empty() {
            for m in &self.meshes {
                merged.append(&TriMesh { positions: m.positions.clone(), triangles: m.triangles.clone() });
            }
        } else {
            for (_, mesh) in self.posed_meshes(None, 0.0)? {
                merged.append(&mesh);
            }
        }
        merged.check_structure().map_err(|e| IoError::mesh(&self.path, e))?;
        Ok(merged)
    }
}

// ---------------------------------------------------------------------------------------------
// Reading

/// Reads a `.gltf` or `.glb` file (recognized by content: GLB starts with `glTF`).
pub fn read_gltf(path: &Path, options: &GltfReadOptions) -> Result<GltfScene, IoError> {
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, "open", e))?;
    let (json, bin) = if bytes.starts_with(b"glTF") { split_glb(path, &bytes)? } else { (&bytes[..], None) };
    let document = parse_document(path, json)?;
    let buffers = load_buffers(path, &document, bin)?;
    let reader = Reader { path, document: &document, buffers: &buffers };
    reader.scene(options)
}

const GLB_JSON: u32 = 0x4E4F_534A;
const GLB_BIN: u32 = 0x004E_4942;

fn u32_at(bytes: &[u8], offset: usize) -> Option<u32> {
    let b = bytes.get(offset..offset + 4)?;
    Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

/// Splits a GLB container into its JSON chunk and optional BIN chunk.
fn split_glb<'a>(path: &Path, bytes: &'a [u8]) -> Result<(&'a [u8], Option<&'a [u8]>), IoError> {
    let truncated = |offset: usize, what: &str| {
        IoError::offset(path, offset as u64, format!("the file ends inside {what}; it is truncated (export it again)"))
    };
    let (Some(version), Some(length)) = (u32_at(bytes, 4), u32_at(bytes, 8)) else {
        return Err(truncated(bytes.len(), "the 12-byte GLB header"));
    };
    if version != 2 {
        return Err(IoError::offset(path, 4, format!("GLB version {version}; only glTF 2.0 is supported (re-export as glTF 2.0)")));
    }
    let length = length as usize;
    if length > bytes.len() {
        return Err(IoError::offset(
            path,
            bytes.len() as u64,
            format!("the GLB header declares {length} bytes but the file has {}; it is truncated (export it again)", bytes.len()),
        ));
    }
    let bytes = &bytes[..length];
    let mut offset = 12usize;
    let mut json = None;
    let mut bin = None;
    while offset < bytes.len() {
        let (Some(chunk_length), Some(chunk_type)) = (u32_at(bytes, offset), u32_at(bytes, offset + 4)) else {
            return Err(truncated(offset, "a chunk header"));
        };
        let start = offset + 8;
        let end = start.checked_add(chunk_length as usize).filter(|&e| e <= bytes.len());
        let Some(end) = end else {
            return Err(IoError::offset(
                path,
                offset as u64,
                format!("chunk of {chunk_length} bytes runs past the end of the file ({} bytes); it is truncated", bytes.len()),
            ));
        };
        match chunk_type {
            GLB_JSON if json.is_none() => json = Some(&bytes[start..end]),
            GLB_BIN if bin.is_none() && json.is_some() => bin = Some(&bytes[start..end]),
            // Unknown chunks must be ignored (glTF 2.0 §4.4.3.3).
            _ => {}
        }
        offset = end;
        if json.is_none() {
            return Err(IoError::offset(path, 12, "the first GLB chunk is not JSON; the file is corrupt"));
        }
    }
    match json {
        Some(json) => Ok((json, bin)),
        None => Err(truncated(12, "the GLB header (no JSON chunk)")),
    }
}

/// Extensions that change how geometry is stored, which this reader cannot decode.
const GEOMETRY_EXTENSIONS: &[&str] = &["KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_meshopt_compression"];

fn parse_document(path: &Path, json: &[u8]) -> Result<gltf::Document, IoError> {
    let mut root = gltf::json::Root::from_slice(json)
        .map_err(|e| IoError::format(path, format!("invalid glTF JSON: {e}; the file is corrupt or not glTF 2.0")))?;
    // Required extensions that only concern appearance (materials, textures, lights) do not
    // matter to geometry; quantized attributes are decoded by our accessor reader. Compressed
    // geometry cannot be read: say which export option to turn off.
    let mut unsupported = Vec::new();
    root.extensions_required.retain(|ext| {
        if GEOMETRY_EXTENSIONS.contains(&ext.as_str()) {
            unsupported.push(format!("{ext} (compressed geometry: export without mesh compression)"));
            true
        } else if ext == "KHR_mesh_quantization"
            || ["KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_lights_", "EXT_lights_"].iter().any(|p| ext.starts_with(p))
        {
            false
        } else {
            unsupported.push(ext.clone());
            true
        }
    });
    root.extensions_used.retain(|ext| root.extensions_required.contains(ext));
    if !unsupported.is_empty() {
        return Err(IoError::format(path, format!("the file requires unsupported glTF extensions: {}", unsupported.join(", "))));
    }
    // glTF requires min/max on POSITION accessors, and the validator rejects files without
    // them; several exporters omit them. They are metadata this reader never uses (bounds are
    // recomputed from the data), so fill placeholders rather than refuse the file.
    for accessor in &mut root.accessors {
        if matches!(accessor.type_, Checked::Valid(gltf::json::accessor::Type::Vec3)) {
            accessor.min.get_or_insert_with(|| gltf::json::Value::from(vec![0.0; 3]));
            accessor.max.get_or_insert_with(|| gltf::json::Value::from(vec![0.0; 3]));
        }
    }
    gltf::Document::from_json(root).map_err(|e| {
        let detail = match e {
            gltf::Error::Validation(errors) => {
                let shown: Vec<String> = errors.iter().take(5).map(|(p, err)| format!("{p}: {err}")).collect();
                let more = if errors.len() > 5 { format!(" (and {} more)", errors.len() - 5) } else { String::new() };
                format!("{}{more}", shown.join("; "))
            }
            other => other.to_string(),
        };
        IoError::format(path, format!("invalid glTF: {detail}"))
    })
}

fn load_buffers(path: &Path, document: &gltf::Document, bin: Option<&[u8]>) -> Result<Vec<Vec<u8>>, IoError> {
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let element = format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => match bin {
                Some(b) => b.to_vec(),
                None => {
                    return Err(IoError::element(path, element, "refers to the GLB binary chunk, but the file has none (a .gltf buffer needs a 'uri')"));
                }
            },
            gltf::buffer::Source::Uri(uri) => load_uri(path, &element, uri)?,
        };
        if data.len() < buffer.length() {
            return Err(IoError::element(
                path,
                element,
                format!("has {} bytes but the file declares {}; the data is truncated (export it again)", data.len(), buffer.length()),
            ));
        }
        buffers.push(data);
    }
    Ok(buffers)
}

fn load_uri(path: &Path, element: &str, uri: &str) -> Result<Vec<u8>, IoError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((header, payload)) = rest.split_once(',') else {
            return Err(IoError::element(path, element, "malformed data URI (no ',')"));
        };
        if !header.ends_with(";base64") {
            return Err(IoError::element(path, element, "data URI is not base64-encoded; re-export with embedded (base64) buffers"));
        }
        return base64::engine::general_purpose::STANDARD
            .decode(payload.trim())
            .map_err(|e| IoError::element(path, element, format!("invalid base64 in the data URI: {e}")));
    }
    if let Some((scheme, _)) = uri.split_once(':')
        && scheme.len() > 1
        && scheme.chars().all(|c| c.is_ascii_alphanumeric() || "+-.".contains(c))
    {
        return Err(IoError::element(
            path,
            element,
            format!("URI '{uri}' has scheme '{scheme}:'; only files next to the .gltf and data: URIs are read"),
        ));
    }
    let relative = percent_decode(uri);
    let full = path.parent().unwrap_or(Path::new(".")).join(relative);
    std::fs::read(&full).map_err(|e| IoError::io(&full, "open the buffer file referenced by the glTF", e))
}

/// Decodes `%XX` escapes (URIs in glTF are percent-encoded, e.g. spaces as `%20`).
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && let Some(v) = bytes.get(i + 1..i + 3).and_then(|h| std::str::from_utf8(h).ok()).and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Decoded accessor values: `count × components` numbers, with normalized integers mapped to
/// [0, 1] or [−1, 1] as glTF specifies.
struct AccessorData {
    components: usize,
    values: Vec<f64>,
}

impl AccessorData {
    fn count(&self) -> usize {
        self.values.len() / self.components.max(1)
    }
    fn rows<const N: usize>(&self) -> impl Iterator<Item = [f64; N]> + '_ {
        self.values.chunks_exact(N).map(|c| {
            let mut a = [0.0; N];
            a.copy_from_slice(c);
            a
        })
    }
}

struct Reader<'a> {
    path: &'a Path,
    document: &'a gltf::Document,
    buffers: &'a [Vec<u8>],
}

fn component_size(ct: gltf::json::accessor::ComponentType) -> usize {
    use gltf::json::accessor::ComponentType as C;
    match ct {
        C::I8 | C::U8 => 1,
        C::I16 | C::U16 => 2,
        C::U32 | C::F32 => 4,
    }
}

fn decode_component(bytes: &[u8], ct: gltf::json::accessor::ComponentType, normalized: bool) -> f64 {
    use gltf::json::accessor::ComponentType as C;
    let v = match ct {
        C::I8 => bytes[0] as i8 as f64,
        C::U8 => bytes[0] as f64,
        C::I16 => i16::from_le_bytes([bytes[0], bytes[1]]) as f64,
        C::U16 => u16::from_le_bytes([bytes[0], bytes[1]]) as f64,
        C::U32 => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
        C::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
    };
    if !normalized {
        return v;
    }
    match ct {
        C::I8 => (v / 127.0).max(-1.0),
        C::U8 => v / 255.0,
        C::I16 => (v / 32767.0).max(-1.0),
        C::U16 => v / 65535.0,
        C::U32 => v / u32::MAX as f64,
        C::F32 => v,
    }
}

impl<'a> Reader<'a> {
    fn err(&self, element: impl Into<String>, message: impl Into<String>) -> IoError {
        IoError::element(self.path, element, message)
    }

    /// The bytes of buffer view `view`, checked against its buffer.
    fn view_bytes(&self, view: usize, element: &str) -> Result<(&'a [u8], Option<usize>), IoError> {
        let json = self.document.as_json();
        let Some(v) = json.buffer_views.get(view) else {
            return Err(self.err(element, format!("refers to buffer view {view}, which does not exist")));
        };
        let buffer = v.buffer.value();
        let Some(data) = self.buffers.get(buffer) else {
            return Err(self.err(element, format!("buffer view {view} refers to buffer {buffer}, which does not exist")));
        };
        let start = v.byte_offset.map_or(0, |o| o.0);
        let end = start.checked_add(v.byte_length.0);
        match end.filter(|&e| e <= data.len() as u64) {
            Some(end) => Ok((&data[start as usize..end as usize], v.byte_stride.map(|s| s.0))),
            None => Err(self.err(
                element,
                format!(
                    "buffer view {view} (bytes {start}..{}) runs past the end of buffer {buffer} ({} bytes); the file is truncated or corrupt",
                    start.saturating_add(v.byte_length.0),
                    data.len()
                ),
            )),
        }
    }

    /// Reads accessor `index`; `what` says what it is for (in errors).
    fn accessor(&self, index: usize, what: &str) -> Result<AccessorData, IoError> {
        use gltf::json::accessor::Type as T;
        let element = format!("accessor {index} ({what})");
        let Some(acc) = self.document.as_json().accessors.get(index) else {
            return Err(self.err(element, "does not exist"));
        };
        let (Checked::Valid(ct), Checked::Valid(ty)) = (&acc.component_type, &acc.type_) else {
            return Err(self.err(element, "has an invalid componentType or type"));
        };
        let ct = ct.0;
        let ty = *ty;
        let size = component_size(ct);
        let (columns, rows) = match ty {
            T::Scalar => (1, 1),
            T::Vec2 => (1, 2),
            T::Vec3 => (1, 3),
            T::Vec4 => (1, 4),
            T::Mat2 => (2, 2),
            T::Mat3 => (3, 3),
            T::Mat4 => (4, 4),
        };
        let components = columns * rows;
        // Matrix columns start on 4-byte boundaries (glTF §3.6.2.4), which pads small types.
        let column_stride = if columns > 1 { (rows * size).div_ceil(4) * 4 } else { rows * size };
        let element_size = columns * column_stride;
        let count = acc.count.0;
        // Where the elements are, checked before anything is allocated: a corrupt count must not
        // allocate gigabytes.
        let count = usize::try_from(count).unwrap_or(usize::MAX);
        let dense = match acc.buffer_view {
            Some(view) => {
                let (bytes, stride) = self.view_bytes(view.value(), &element)?;
                let stride = stride.unwrap_or(element_size);
                if stride < element_size {
                    return Err(self.err(element, format!("byteStride {stride} is smaller than an element ({element_size} bytes)")));
                }
                let offset = acc.byte_offset.map_or(0, |o| o.0) as usize;
                let needed = match count {
                    0 => Some(0),
                    _ => (count - 1).checked_mul(stride).and_then(|x| x.checked_add(offset)).and_then(|x| x.checked_add(element_size)),
                };
                if !needed.is_some_and(|n| n <= bytes.len()) {
                    return Err(self.err(
                        element,
                        format!(
                            "{count} elements of {element_size} bytes (stride {stride}, offset {offset}) do not fit in buffer view {} ({} bytes); the file is truncated or corrupt",
                            view.value(),
                            bytes.len()
                        ),
                    ));
                }
                Some((&bytes[offset.min(bytes.len())..], stride))
            }
            None => {
                // Only sparse data (or nothing): zeros. Bound the size, since no data backs it.
                if count.saturating_mul(components) > (1 << 24) {
                    return Err(self.err(element, format!("count {count} is implausibly large for an accessor without data; the file is corrupt")));
                }
                None
            }
        };
        let mut values = vec![0.0f64; count * components];
        let decode_into = |values: &mut [f64], bytes: &[u8], stride: usize, n: usize, dest: &mut dyn FnMut(usize) -> usize| {
            for i in 0..n {
                let base = i * stride;
                let d = dest(i);
                for c in 0..columns {
                    for r in 0..rows {
                        let at = base + c * column_stride + r * size;
                        values[d * components + c * rows + r] = decode_component(&bytes[at..at + size], ct, acc.normalized);
                    }
                }
            }
        };
        if let Some((bytes, stride)) = dense {
            decode_into(&mut values, bytes, stride, count, &mut |i| i);
        }
        if let Some(sparse) = &acc.sparse {
            let n = sparse.count.0 as usize;
            let index_ct = match &sparse.indices.component_type {
                Checked::Valid(c) => c.0,
                Checked::Invalid => return Err(self.err(element, "sparse indices have an invalid componentType")),
            };
            let index_size = component_size(index_ct);
            let (index_bytes, _) = self.view_bytes(sparse.indices.buffer_view.value(), &element)?;
            let index_offset = sparse.indices.byte_offset.0 as usize;
            let (value_bytes, _) = self.view_bytes(sparse.values.buffer_view.value(), &element)?;
            let value_offset = sparse.values.byte_offset.0 as usize;
            let fits = |bytes: &[u8], offset: usize, each: usize| n.checked_mul(each).and_then(|x| x.checked_add(offset)).is_some_and(|e| e <= bytes.len());
            if !fits(index_bytes, index_offset, index_size) || !fits(value_bytes, value_offset, element_size) {
                return Err(self.err(element, format!("sparse data ({n} entries) runs past its buffer view; the file is truncated or corrupt")));
            }
            let mut targets = Vec::with_capacity(n);
            for i in 0..n {
                let at = index_offset + i * index_size;
                let t = decode_component(&index_bytes[at..at + index_size], index_ct, false) as usize;
                if t >= count {
                    return Err(self.err(element, format!("sparse index {t} is out of range (count {count})")));
                }
                targets.push(t);
            }
            decode_into(&mut values, &value_bytes[value_offset..], element_size, n, &mut |i| targets[i]);
        }
        Ok(AccessorData { components, values })
    }

    /// Reads an accessor and checks its number of components.
    fn accessor_with(&self, index: usize, what: &str, components: usize, type_name: &str) -> Result<AccessorData, IoError> {
        let data = self.accessor(index, what)?;
        if data.components != components {
            return Err(self.err(
                format!("accessor {index} ({what})"),
                format!("has {} components per element; {what} must be {type_name}", data.components),
            ));
        }
        Ok(data)
    }

    fn scene(&self, options: &GltfReadOptions) -> Result<GltfScene, IoError> {
        let nodes = self.nodes()?;
        let skeleton_nodes = nodes
            .iter()
            .map(|n| SkeletonNode { name: n.name.clone(), parent: n.parent, rest: n.transform })
            .collect();
        let skeleton = Skeleton::new(skeleton_nodes).map_err(|source| IoError::Animation {
            path: self.path.to_path_buf(),
            element: "node hierarchy".into(),
            source,
        })?;
        let roots = match self.document.default_scene().or_else(|| self.document.scenes().next()) {
            Some(scene) => scene.nodes().map(|n| n.index()).collect(),
            None => (0..nodes.len()).filter(|&i| nodes[i].parent.is_none()).collect(),
        };
        let meshes = self
            .document
            .meshes()
            .map(|m| self.mesh(&m, options.weld))
            .collect::<Result<Vec<_>, _>>()?;
        let skins = self.document.skins().map(|s| self.skin(&s)).collect::<Result<Vec<_>, _>>()?;
        let animations = self
            .document
            .animations()
            .map(|a| self.animation(&a, &nodes, &meshes))
            .collect::<Result<Vec<_>, _>>()?;
        for (i, node) in nodes.iter().enumerate() {
            if let (Some(s), Some(m)) = (node.skin, node.mesh) {
                let mesh = &meshes[m];
                match &mesh.skin_weights {
                    None => {
                        return Err(self.err(
                            format!("node {i} '{}'", node.name),
                            format!("has skin {s} but mesh {m} '{}' has no JOINTS_0/WEIGHTS_0; re-export with skinning data", mesh.name),
                        ));
                    }
                    Some(w) => {
                        let joints = skins[s].skin.joints.len();
                        let bad = w.joints().iter().zip(w.weights()).enumerate().find_map(|(v, (j, ws))| {
                            j.iter().zip(ws).find(|(j, w)| **w != 0.0 && **j as usize >= joints).map(|(j, _)| (v, *j))
                        });
                        if let Some((v, j)) = bad {
                            return Err(self.err(
                                format!("mesh {m} '{}'", mesh.name),
                                format!("vertex {v} is weighted to joint {j}, but skin {s} has only {joints} joints"),
                            ));
                        }
                    }
                }
            }
        }
        Ok(GltfScene { path: self.path.to_path_buf(), nodes, skeleton, roots, meshes, skins, animations })
    }

    fn nodes(&self) -> Result<Vec<GltfNode>, IoError> {
        let mut nodes: Vec<GltfNode> = Vec::new();
        for node in self.document.nodes() {
            let element = format!("node {} '{}'", node.index(), node.name().unwrap_or(""));
            let transform = match node.transform() {
                gltf::scene::Transform::Matrix { matrix } => {
                    let m = DMat4::from_cols_array_2d(&matrix.map(|c| c.map(f64::from)));
                    if !m.is_finite() {
                        return Err(self.err(element, "has a non-finite matrix"));
                    }
                    NodeTransform::Matrix(m)
                }
                gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                    let t = DVec3::from_array(translation.map(f64::from));
                    let r = DQuat::from_array(rotation.map(f64::from));
                    let s = DVec3::from_array(scale.map(f64::from));
                    if !t.is_finite() || !r.is_finite() || !s.is_finite() {
                        return Err(self.err(element, "has a non-finite translation, rotation or scale"));
                    }
                    if r.length() == 0.0 {
                        return Err(self.err(element, "has a zero rotation quaternion; rotations must be unit quaternions"));
                    }
                    NodeTransform::Trs(Trs { translation: t, rotation: r.normalize(), scale: s })
                }
            };
            nodes.push(GltfNode {
                name: node.name().unwrap_or("").to_string(),
                parent: None,
                children: node.children().map(|c| c.index()).collect(),
                transform,
                mesh: node.mesh().map(|m| m.index()),
                skin: node.skin().map(|s| s.index()),
                weights: node.weights().map(|w| w.iter().map(|&x| x as f64).collect()),
            });
        }
        for i in 0..nodes.len() {
            for c in nodes[i].children.clone() {
                if let Some(p) = nodes[c].parent {
                    return Err(self.err(
                        format!("node {c} '{}'", nodes[c].name),
                        format!("is a child of both node {p} and node {i}; a node may have only one parent"),
                    ));
                }
                nodes[c].parent = Some(i);
            }
        }
        Ok(nodes)
    }

    fn mesh(&self, mesh: &gltf::Mesh, weld: WeldMode) -> Result<GltfMesh, IoError> {
        use gltf::mesh::Mode;
        let name = mesh.name().unwrap_or("").to_string();
        let mut positions: Vec<DVec3> = Vec::new();
        let mut triangles: Vec<[u32; 3]> = Vec::new();
        let mut joints: Vec<[u32; 4]> = Vec::new();
        let mut weights: Vec<[f64; 4]> = Vec::new();
        let mut skinned: Option<bool> = None;
        let mut morph_targets: Vec<Vec<DVec3>> = Vec::new();
        let mut primitive_vertices = Vec::new();
        for primitive in mesh.primitives() {
            let element = format!("mesh {} '{name}' primitive {}", mesh.index(), primitive.index());
            let mode = primitive.mode();
            if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
                return Err(self.err(
                    element,
                    format!(
                        "has mode {}; only TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN describe a surface (export the object as a mesh with faces, not points or lines)",
                        mode_name(mode)
                    ),
                ));
            }
            let Some(pos_acc) = primitive.get(&gltf::Semantic::Positions) else {
                return Err(self.err(element, "has no POSITION attribute"));
            };
            let what = format!("POSITION of {element}");
            let data = self.accessor_with(pos_acc.index(), &what, 3, "VEC3")?;
            let offset = positions.len();
            for (v, p) in data.rows::<3>().enumerate() {
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(self.err(format!("accessor {} ({what})", pos_acc.index()), format!("vertex {v} has a non-finite coordinate {p:?}")));
                }
                positions.push(DVec3::from_array(p));
            }
            let n = data.count();
            if positions.len() > u32::MAX as usize {
                return Err(self.err(element, "more than 2^32 − 1 vertices"));
            }
            primitive_vertices.push(offset..offset + n);

            let indices: Vec<u32> = match primitive.indices() {
                Some(acc) => {
                    let what = format!("indices of {element}");
                    let data = self.accessor_with(acc.index(), &what, 1, "SCALAR")?;
                    let mut out = Vec::with_capacity(data.values.len());
                    for (k, &i) in data.values.iter().enumerate() {
                        if i < 0.0 || i.fract() != 0.0 || i >= n as f64 {
                            return Err(self.err(
                                format!("accessor {} ({what})", acc.index()),
                                format!("index {k} is {i}, but the primitive has {n} vertices"),
                            ));
                        }
                        out.push(i as u32);
                    }
                    out
                }
                None => (0..n as u32).collect(),
            };
            let o = offset as u32;
            match mode {
                Mode::TriangleStrip => {
                    for i in 0..indices.len().saturating_sub(2) {
                        // glTF: triangle i is (v_i, v_{i+1+i%2}, v_{i+2-i%2}), which alternates the
                        // winding so that all triangles face the same way.
                        let t = [indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]];
                        if t[0] != t[1] && t[1] != t[2] && t[0] != t[2] {
                            triangles.push(t.map(|x| x + o));
                        }
                    }
                }
                Mode::TriangleFan => {
                    for i in 1..indices.len().saturating_sub(1) {
                        triangles.push([indices[i], indices[i + 1], indices[0]].map(|x| x + o));
                    }
                }
                _ => {
                    if !indices.len().is_multiple_of(3) {
                        return Err(self.err(
                            element,
                            format!("has {} indices, not a multiple of 3 as TRIANGLES requires; the file is corrupt", indices.len()),
                        ));
                    }
                    triangles.extend(indices.chunks_exact(3).map(|c| [c[0] + o, c[1] + o, c[2] + o]));
                }
            }

            // Skin attributes: every set JOINTS_k/WEIGHTS_k, the four largest influences kept.
            let mut influences: Vec<Vec<(u32, f64)>> = Vec::new();
            let mut set = 0;
            while let (Some(j_acc), Some(w_acc)) =
                (primitive.get(&gltf::Semantic::Joints(set)), primitive.get(&gltf::Semantic::Weights(set)))
            {
                let jw = format!("JOINTS_{set} of {element}");
                let ww = format!("WEIGHTS_{set} of {element}");
                let j = self.accessor_with(j_acc.index(), &jw, 4, "VEC4")?;
                let w = self.accessor_with(w_acc.index(), &ww, 4, "VEC4")?;
                if j.count() != n || w.count() != n {
                    return Err(self.err(element, format!("{jw} has {} and {ww} {} elements for {n} vertices", j.count(), w.count())));
                }
                influences.resize(n, Vec::new());
                for (v, (jr, wr)) in j.rows::<4>().zip(w.rows::<4>()).enumerate() {
                    for (jj, ww) in jr.into_iter().zip(wr) {
                        influences[v].push((jj as u32, ww));
                    }
                }
                set += 1;
            }
            let has_skin = !influences.is_empty();
            if *skinned.get_or_insert(has_skin) != has_skin {
                return Err(self.err(element, "has skin attributes (JOINTS_0/WEIGHTS_0) where another primitive of the mesh has none, or the reverse; skin every primitive"));
            }
            for mut inf in influences {
                if inf.len() > 4 {
                    // Stable sort: equal weights keep their set order, so the result is deterministic.
                    inf.sort_by(|a, b| b.1.total_cmp(&a.1));
                }
                let mut jr = [0u32; 4];
                let mut wr = [0.0f64; 4];
                for (k, (j, w)) in inf.into_iter().take(4).enumerate() {
                    jr[k] = j;
                    wr[k] = w;
                }
                joints.push(jr);
                weights.push(wr);
            }

            // Morph targets (position displacements only).
            let targets: Vec<_> = primitive.morph_targets().collect();
            if primitive.index() == 0 {
                morph_targets = vec![Vec::new(); targets.len()];
            } else if targets.len() != morph_targets.len() {
                return Err(self.err(
                    element,
                    format!("has {} morph targets but primitive 0 has {}; every primitive needs the same targets", targets.len(), morph_targets.len()),
                ));
            }
            for (t, target) in targets.iter().enumerate() {
                match target.positions() {
                    Some(acc) => {
                        let what = format!("POSITION of morph target {t} of {element}");
                        let d = self.accessor_with(acc.index(), &what, 3, "VEC3")?;
                        if d.count() != n {
                            return Err(self.err(format!("accessor {} ({what})", acc.index()), format!("has {} elements for {n} vertices", d.count())));
                        }
                        if d.values.iter().any(|x| !x.is_finite()) {
                            return Err(self.err(format!("accessor {} ({what})", acc.index()), "has a non-finite displacement"));
                        }
                        morph_targets[t].extend(d.rows::<3>().map(DVec3::from_array));
                    }
                    None => morph_targets[t].extend(std::iter::repeat_n(DVec3::ZERO, n)),
                }
            }
        }
        let element = format!("mesh {} '{name}'", mesh.index());
        let skin_weights = if skinned == Some(true) {
            Some(SkinWeights::new(joints, weights).map_err(|source| IoError::Skin { path: self.path.to_path_buf(), element: element.clone(), source })?)
        } else {
            None
        };
        let default_weights: Vec<f64> = mesh.weights().map(|w| w.iter().map(|&x| x as f64).collect()).unwrap_or_default();
        let target_names = target_names(mesh);
        let file_vertex_count = positions.len();
        let mut out = GltfMesh {
            name,
            positions,
            triangles,
            skin_weights,
            morph_targets,
            default_weights,
            target_names,
            primitive_vertices,
            file_vertex_count,
            vertex_map: None,
            collapsed_triangles: 0,
        };
        if weld != WeldMode::Off {
            let welded = weld_positions(&out.positions, &out.triangles, weld);
            out.skin_weights = out.skin_weights.as_ref().and_then(|w| w.select(&welded.representatives));
            for target in &mut out.morph_targets {
                *target = welded.representatives.iter().map(|&i| target[i as usize]).collect();
            }
            out.positions = welded.positions;
            out.triangles = welded.triangles;
            out.vertex_map = Some(welded.vertex_map);
            out.collapsed_triangles = welded.collapsed_triangles;
        }
        Ok(out)
    }

    fn skin(&self, skin: &gltf::Skin) -> Result<GltfSkin, IoError> {
        let name = skin.name().unwrap_or("").to_string();
        let element = format!("skin {} '{name}'", skin.index());
        let joints: Vec<usize> = skin.joints().map(|n| n.index()).collect();
        let inverse_bind = match skin.inverse_bind_matrices() {
            Some(acc) => {
                let what = format!("inverse bind matrices of {element}");
                let data = self.accessor_with(acc.index(), &what, 16, "MAT4")?;
                if data.count() < joints.len() {
                    return Err(self.err(
                        format!("accessor {} ({what})", acc.index()),
                        format!("has {} matrices for {} joints; give one per joint", data.count(), joints.len()),
                    ));
                }
                let matrices: Vec<DMat4> = data.rows::<16>().take(joints.len()).map(|m| DMat4::from_cols_array(&m)).collect();
                if let Some(j) = matrices.iter().position(|m| !m.is_finite()) {
                    return Err(self.err(format!("accessor {} ({what})", acc.index()), format!("matrix {j} is not finite")));
                }
                Some(matrices)
            }
            None => None,
        };
        let skin_data = Skin::new(joints, inverse_bind)
            .map_err(|source| IoError::Skin { path: self.path.to_path_buf(), element: element.clone(), source })?;
        Ok(GltfSkin { name, skin: skin_data, skeleton_root: skin.skeleton().map(|n| n.index()) })
    }

    fn animation(&self, animation: &gltf::Animation, nodes: &[GltfNode], meshes: &[GltfMesh]) -> Result<GltfAnimation, IoError> {
        use gltf::animation::{Interpolation as I, Property};
        let name = animation.name().unwrap_or("").to_string();
        let mut clip = AnimationClip { name: name.clone(), channels: Vec::new() };
        let mut morph_weights = Vec::new();
        for channel in animation.channels() {
            let node = channel.target().node().index();
            let property = channel.target().property();
            let element = format!("animation {} '{name}' channel {} (node {node} {})", animation.index(), channel.index(), property_name(&property));
            let sampler = channel.sampler();
            let interpolation = match sampler.interpolation() {
                I::Linear => Interpolation::Linear,
                I::Step => Interpolation::Step,
                I::CubicSpline => Interpolation::CubicSpline,
            };
            let times = self.accessor_with(sampler.input().index(), &format!("key times of {element}"), 1, "SCALAR")?.values;
            let out_index = sampler.output().index();
            let out_what = format!("key values of {element}");
            let anim_error = |source| IoError::Animation { path: self.path.to_path_buf(), element: element.clone(), source };
            let values = match property {
                Property::Translation | Property::Scale => {
                    let v: Vec<DVec3> = self.accessor_with(out_index, &out_what, 3, "VEC3")?.rows::<3>().map(DVec3::from_array).collect();
                    let s = Sampler::new(times, v, interpolation).map_err(anim_error)?;
                    if property == Property::Translation { ChannelValues::Translation(s) } else { ChannelValues::Scale(s) }
                }
                Property::Rotation => {
                    let v: Vec<DQuat> = self.accessor_with(out_index, &out_what, 4, "VEC4")?.rows::<4>().map(DQuat::from_array).collect();
                    ChannelValues::Rotation(Sampler::new_rotation(times, v, interpolation).map_err(anim_error)?)
                }
                Property::MorphTargetWeights => {
                    let v = self.accessor_with(out_index, &out_what, 1, "SCALAR")?.values;
                    let per_key = if interpolation == Interpolation::CubicSpline { 3 } else { 1 };
                    let keys = times.len() * per_key;
                    let targets = nodes[node].mesh.and_then(|m| meshes.get(m)).map(|m| m.morph_targets.len());
                    let targets = match targets {
                        Some(t) if t > 0 => t,
                        _ if keys > 0 => v.len() / keys,
                        _ => 0,
                    };
                    if keys == 0 || targets == 0 || v.len() != keys * targets {
                        return Err(self.err(
                            element,
                            format!("has {} weight values for {} keys and {targets} morph targets", v.len(), times.len()),
                        ));
                    }
                    let mut samplers = Vec::with_capacity(targets);
                    for t in 0..targets {
                        let values: Vec<f64> = (0..keys).map(|k| v[k * targets + t]).collect();
                        samplers.push(Sampler::new(times.clone(), values, interpolation).map_err(anim_error)?);
                    }
                    morph_weights.push(MorphWeightsTrack { node, samplers });
                    continue;
                }
            };
            clip.channels.push(Channel { node, values });
        }
        Ok(GltfAnimation { name, clip, morph_weights })
    }
}

fn target_names(mesh: &gltf::Mesh) -> Vec<String> {
    let Some(raw) = mesh.extras() else { return Vec::new() };
    let parsed: Result<HashMap<String, serde_json::Value>, _> = serde_json::from_str(raw.get());
    parsed
        .ok()
        .and_then(|m| m.get("targetNames").cloned())
        .and_then(|v| serde_json::from_value::<Vec<String>>(v).ok())
        .unwrap_or_default()
}

fn mode_name(mode: gltf::mesh::Mode) -> &'static str {
    use gltf::mesh::Mode;
    match mode {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles => "TRIANGLES",
        Mode::TriangleStrip => "TRIANGLE_STRIP",
        Mode::TriangleFan => "TRIANGLE_FAN",
    }
}

fn property_name(p: &gltf::animation::Property) -> &'static str {
    use gltf::animation::Property;
    match p {
        Property::Translation => "translation",
        Property::Rotation => "rotation",
        Property::Scale => "scale",
        Property::MorphTargetWeights => "weights",
    }
}
