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
//!   four largest influences are kept), morph-target position displacements, normals and
//!   tangents (for writing back, [`crate::GltfDocument`]), the first texture coordinates
//!   (`TEXCOORD_0`, for writing OBJ and PLY files). Other UV sets and colours are left in the
//!   file (checked to hold one element per vertex, like every attribute);
//! - nodes (names, hierarchy, TRS or matrix), skins (joints as node ids, inverse bind matrices,
//!   identity when absent, skeleton root), animations (translation / rotation / scale channels
//!   as [`AnimationClip`]s, morph-target weight channels as [`MorphWeightsTrack`]s).
//!
//! Optionally ([`GltfReadOptions::weld`]) each mesh's vertices are welded by position, because
//! glTF duplicates vertices along UV seams and hard edges, which opens a closed surface.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DQuat, DVec2, DVec3};
use gltf::json::validation::Checked;
use squish::animation::{
    AnimationClip, Channel, ChannelValues, Interpolation, NodeTransform, Sampler, Skeleton, SkeletonNode, Trs,
};
use squish::skinning::{Skin, SkinWeights};

use crate::IoError;
use crate::gltf_binary::{BufferData, load_buffers, split_glb};
use crate::gltf_scene::{GltfAnimation, GltfMesh, GltfNode, GltfScene, GltfSkin, MorphWeightsTrack};
use crate::weld::{WeldMode, weld_positions};

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

// ---------------------------------------------------------------------------------------------
// Reading

/// Reads a `.gltf` or `.glb` file (recognized by content: GLB starts with `glTF`).
pub fn read_gltf(path: &Path, options: &GltfReadOptions) -> Result<GltfScene, IoError> {
    Ok(read_gltf_file(path, options)?.scene)
}

/// A glTF file as read: the document model, and the raw JSON and buffers it came from (what
/// [`crate::GltfDocument`] writes back).
pub(crate) struct GltfFile {
    pub(crate) scene: GltfScene,
    pub(crate) json: Vec<u8>,
    pub(crate) buffers: Vec<Vec<u8>>,
}

pub(crate) fn read_gltf_file(path: &Path, options: &GltfReadOptions) -> Result<GltfFile, IoError> {
    let bytes = std::fs::read(path).map_err(|e| IoError::io(path, "open", e))?;
    let (json, bin) = if bytes.starts_with(b"glTF") {
        split_glb(path, &bytes)?
    } else if starts_like_json(&bytes) {
        (&bytes[..], None)
    } else {
        return Err(not_gltf(path, &bytes));
    };
    let document = parse_document(path, json)?;
    let buffers = load_buffers(path, &document, bin)?;
    let reader =
        Reader { path, document: &document, data: BufferData { path, document: &document, buffers: &buffers } };
    let scene = reader.scene(options)?;
    Ok(GltfFile { scene, json: json.to_vec(), buffers })
}

/// True if the first byte other than white space (after an optional UTF-8 byte order mark) is
/// `{`, as in every JSON glTF.
fn starts_like_json(bytes: &[u8]) -> bool {
    let bytes = bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes);
    bytes.iter().find(|b| !b.is_ascii_whitespace()) == Some(&b'{')
}

/// The error for a file that is neither GLB (magic `glTF`) nor JSON: it names the bytes found.
fn not_gltf(path: &Path, bytes: &[u8]) -> IoError {
    let head: Vec<String> = bytes.iter().take(4).map(|b| format!("{b:02X}")).collect();
    let found =
        if head.is_empty() { "the file is empty".to_string() } else { format!("it starts with {}", head.join(" ")) };
    IoError::offset(
        path,
        0,
        format!(
            "not a glTF file: a .glb starts with the magic bytes 'glTF' (67 6C 54 46) and a .gltf with '{{', but {found}; the file is corrupt or in another format (export it again)"
        ),
    )
}

/// Extensions that change how geometry is stored, which this reader cannot decode.
const GEOMETRY_EXTENSIONS: &[&str] =
    &["KHR_draco_mesh_compression", "EXT_meshopt_compression", "KHR_meshopt_compression"];

fn parse_document(path: &Path, json: &[u8]) -> Result<gltf::Document, IoError> {
    let mut root = gltf::json::Root::from_slice(json)
        .map_err(|e| IoError::format(path, format!("invalid glTF JSON: {e}; the file is corrupt or not glTF 2.0")))?;
    // A glTF 1.0 file parses (most of its keys are optional in 2.0) but its meshes are laid out
    // differently: it would read as an empty mesh without this.
    let major = root.asset.version.split('.').next().unwrap_or_default();
    if major != "2" {
        return Err(IoError::format(
            path,
            format!("asset.version is \"{}\"; only glTF 2.0 is supported (re-export as glTF 2.0)", root.asset.version),
        ));
    }
    // Required extensions that only concern appearance (materials, textures, lights) do not
    // matter to geometry; quantized attributes are decoded by our accessor reader. Compressed
    // geometry cannot be read: say which export option to turn off.
    let mut unsupported = Vec::new();
    root.extensions_required.retain(|ext| {
        if GEOMETRY_EXTENSIONS.contains(&ext.as_str()) {
            unsupported.push(format!("{ext} (compressed geometry: export without mesh compression)"));
            true
        } else if ext == "KHR_mesh_quantization"
            || ["KHR_materials_", "KHR_texture_", "EXT_texture_", "KHR_lights_", "EXT_lights_"]
                .iter()
                .any(|p| ext.starts_with(p))
        {
            false
        } else {
            unsupported.push(ext.clone());
            true
        }
    });
    if !unsupported.is_empty() {
        return Err(IoError::format(
            path,
            format!("the file requires unsupported glTF extensions: {}", unsupported.join(", ")),
        ));
    }
    // The `gltf` crate's validation indexes the accessor of every POSITION attribute without a
    // bounds check (gltf-json 1.4.1, mesh.rs): an index past the accessors must be an error here.
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = primitive.attributes.get(&Checked::Valid(gltf::json::mesh::Semantic::Positions));
            if let Some(index) = position
                && index.value() >= root.accessors.len()
            {
                return Err(IoError::element(
                    path,
                    format!("mesh {m} primitive {p}"),
                    format!(
                        "its POSITION attribute refers to accessor {}, but the file has {} accessors; the file is corrupt (export it again)",
                        index.value(),
                        root.accessors.len()
                    ),
                ));
            }
        }
    }
    // Animation channels are not bounds-checked by the validation either: `Target::node` (gltf
    // 1.4.1, animation/mod.rs) unwraps the node of a channel whose index is past the nodes.
    for (a, animation) in root.animations.iter().enumerate() {
        for (c, channel) in animation.channels.iter().enumerate() {
            let (node, sampler) = (channel.target.node.value(), channel.sampler.value());
            let problem = if node >= root.nodes.len() {
                Some(format!("targets node {node}, but the file has {} nodes", root.nodes.len()))
            } else if sampler >= animation.samplers.len() {
                Some(format!("uses sampler {sampler}, but the animation has {} samplers", animation.samplers.len()))
            } else {
                None
            };
            if let Some(problem) = problem {
                return Err(IoError::element(
                    path,
                    format!("animation {a} channel {c}"),
                    format!("{problem}; the file is corrupt (export it again)"),
                ));
            }
        }
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

/// Converts a validated document into the document model.
struct Reader<'a> {
    path: &'a Path,
    document: &'a gltf::Document,
    data: BufferData<'a>,
}

impl<'a> Reader<'a> {
    fn err(&self, element: impl Into<String>, message: impl Into<String>) -> IoError {
        IoError::element(self.path, element, message)
    }

    fn scene(&self, options: &GltfReadOptions) -> Result<GltfScene, IoError> {
        let nodes = self.nodes()?;
        let skeleton_nodes =
            nodes.iter().map(|n| SkeletonNode { name: n.name.clone(), parent: n.parent, rest: n.transform }).collect();
        let skeleton = Skeleton::new(skeleton_nodes).map_err(|source| IoError::Animation {
            path: self.path.to_path_buf(),
            element: "node hierarchy".into(),
            source,
        })?;
        let roots = match self.document.default_scene().or_else(|| self.document.scenes().next()) {
            Some(scene) => scene.nodes().map(|n| n.index()).collect(),
            None => (0..nodes.len()).filter(|&i| nodes[i].parent.is_none()).collect(),
        };
        let meshes = self.document.meshes().map(|m| self.mesh(&m, options.weld)).collect::<Result<Vec<_>, _>>()?;
        let skins = self.document.skins().map(|s| self.skin(&s)).collect::<Result<Vec<_>, _>>()?;
        let animations =
            self.document.animations().map(|a| self.animation(&a, &nodes, &meshes)).collect::<Result<Vec<_>, _>>()?;
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
                        return Err(
                            self.err(element, "has a zero rotation quaternion; rotations must be unit quaternions")
                        );
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
        let mut normals: Vec<DVec3> = Vec::new();
        let mut tangents: Vec<[f64; 4]> = Vec::new();
        let mut texcoords: Vec<[f64; 2]> = Vec::new();
        // The per-corner UVs of the shared parametrization need TEXCOORD_0 on every primitive.
        let mut every_primitive_has_uvs = true;
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
            // Every attribute holds one element per vertex; a mismatch means a broken export
            // (and would misalign UVs, normals or weights when the file is written back).
            for (semantic, accessor) in primitive.attributes() {
                if accessor.count() != pos_acc.count() {
                    return Err(self.err(
                        format!("accessor {} ({} of {element})", accessor.index(), semantic.to_string()),
                        format!(
                            "has {} elements but POSITION (accessor {}) has {}; every attribute of a primitive needs one element per vertex (export the mesh again)",
                            accessor.count(),
                            pos_acc.index(),
                            pos_acc.count()
                        ),
                    ));
                }
            }
            let data = self.data.accessor_with(pos_acc.index(), &what, 3, "VEC3")?;
            let offset = positions.len();
            for (v, p) in data.rows::<3>().enumerate() {
                if !p.iter().all(|c| c.is_finite()) {
                    return Err(self.err(
                        format!("accessor {} ({what})", pos_acc.index()),
                        format!("vertex {v} has a non-finite coordinate {p:?}"),
                    ));
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
                    let data = self.data.accessor_with(acc.index(), &what, 1, "SCALAR")?;
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
                            format!(
                                "has {} indices, not a multiple of 3 as TRIANGLES requires; the file is corrupt",
                                indices.len()
                            ),
                        ));
                    }
                    triangles.extend(indices.chunks_exact(3).map(|c| [c[0] + o, c[1] + o, c[2] + o]));
                }
            }

            // Normals and tangents: kept so that writing back can recompute them per the file's
            // splits (zeros for a primitive without them, which then gets none written).
            if let Some(acc) = primitive.get(&gltf::Semantic::Normals) {
                let what = format!("NORMAL of {element}");
                let d = self.data.accessor_with(acc.index(), &what, 3, "VEC3")?;
                normals.resize(offset, DVec3::ZERO);
                normals.extend(d.rows::<3>().map(DVec3::from_array));
            }
            if let Some(acc) = primitive.get(&gltf::Semantic::Tangents) {
                let what = format!("TANGENT of {element}");
                let d = self.data.accessor_with(acc.index(), &what, 4, "VEC4")?;
                tangents.resize(offset, [0.0; 4]);
                tangents.extend(d.rows::<4>());
            }
            // The first UV set, for writing into formats that hold one (OBJ `vt`, PLY `u, v`).
            if let Some(acc) = primitive.get(&gltf::Semantic::TexCoords(0)) {
                let what = format!("TEXCOORD_0 of {element}");
                let d = self.data.accessor_with(acc.index(), &what, 2, "VEC2")?;
                if d.values.iter().any(|x| !x.is_finite()) {
                    return Err(self.err(format!("accessor {} ({what})", acc.index()), "has a non-finite UV"));
                }
                texcoords.resize(offset, [0.0; 2]);
                texcoords.extend(d.rows::<2>());
            } else {
                every_primitive_has_uvs = false;
            }

            // Skin attributes: every set JOINTS_k/WEIGHTS_k, the four largest influences kept.
            let mut influences: Vec<Vec<(u32, f64)>> = Vec::new();
            let mut set = 0;
            while let (Some(j_acc), Some(w_acc)) =
                (primitive.get(&gltf::Semantic::Joints(set)), primitive.get(&gltf::Semantic::Weights(set)))
            {
                let jw = format!("JOINTS_{set} of {element}");
                let ww = format!("WEIGHTS_{set} of {element}");
                let j = self.data.accessor_with(j_acc.index(), &jw, 4, "VEC4")?;
                let w = self.data.accessor_with(w_acc.index(), &ww, 4, "VEC4")?;
                if j.count() != n || w.count() != n {
                    return Err(self.err(
                        element,
                        format!("{jw} has {} and {ww} {} elements for {n} vertices", j.count(), w.count()),
                    ));
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
                    format!(
                        "has {} morph targets but primitive 0 has {}; every primitive needs the same targets",
                        targets.len(),
                        morph_targets.len()
                    ),
                ));
            }
            for (t, target) in targets.iter().enumerate() {
                match target.positions() {
                    Some(acc) => {
                        let what = format!("POSITION of morph target {t} of {element}");
                        let d = self.data.accessor_with(acc.index(), &what, 3, "VEC3")?;
                        if d.count() != n {
                            return Err(self.err(
                                format!("accessor {} ({what})", acc.index()),
                                format!("has {} elements for {n} vertices", d.count()),
                            ));
                        }
                        if d.values.iter().any(|x| !x.is_finite()) {
                            return Err(
                                self.err(format!("accessor {} ({what})", acc.index()), "has a non-finite displacement")
                            );
                        }
                        morph_targets[t].extend(d.rows::<3>().map(DVec3::from_array));
                    }
                    None => morph_targets[t].extend(std::iter::repeat_n(DVec3::ZERO, n)),
                }
            }
        }
        let element = format!("mesh {} '{name}'", mesh.index());
        let skin_weights = if skinned == Some(true) {
            Some(SkinWeights::new(joints, weights).map_err(|source| IoError::Skin {
                path: self.path.to_path_buf(),
                element: element.clone(),
                source,
            })?)
        } else {
            None
        };
        let default_weights: Vec<f64> =
            mesh.weights().map(|w| w.iter().map(|&x| x as f64).collect()).unwrap_or_default();
        let target_names = target_names(mesh);
        let file_vertex_count = positions.len();
        let normals = (!normals.is_empty()).then(|| {
            normals.resize(file_vertex_count, DVec3::ZERO);
            normals
        });
        let tangents = (!tangents.is_empty()).then(|| {
            tangents.resize(file_vertex_count, [0.0; 4]);
            tangents
        });
        let corner_uvs = (every_primitive_has_uvs && !texcoords.is_empty())
            .then(|| triangles.iter().map(|t| t.map(|v| DVec2::from_array(texcoords[v as usize]))).collect());
        let texcoords = (!texcoords.is_empty()).then(|| {
            texcoords.resize(file_vertex_count, [0.0; 2]);
            texcoords
        });
        let mut out = GltfMesh {
            corner_uvs,
            normals,
            tangents,
            texcoords,
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
            let kept = welded.positions.len();
            if let Some(w) = &out.skin_weights {
                let weights = average_skin_weights(w, &welded.vertex_map, kept).map_err(|source| IoError::Skin {
                    path: self.path.to_path_buf(),
                    element: element.clone(),
                    source,
                })?;
                out.skin_weights = Some(weights);
            }
            for target in &mut out.morph_targets {
                *target = average_rows(target, &welded.vertex_map, kept);
            }
            if let Some(normals) = &mut out.normals {
                *normals =
                    average_rows(normals, &welded.vertex_map, kept).iter().map(|n| n.normalize_or_zero()).collect();
            }
            // Tangents and UVs follow the UV layout, which welding across seams does not keep.
            out.tangents = None;
            out.texcoords = None;
            // The corners' UVs stay those of their triangles; collapsed triangles are dropped.
            if let Some(corners) = &mut out.corner_uvs {
                let mut kept = corners.iter();
                *corners = out
                    .triangles
                    .iter()
                    .filter_map(|t| {
                        let corner = kept.next().copied();
                        let w = t.map(|v| welded.vertex_map[v as usize]);
                        (w[0] != w[1] && w[1] != w[2] && w[0] != w[2]).then_some(corner).flatten()
                    })
                    .collect();
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
                let data = self.data.accessor_with(acc.index(), &what, 16, "MAT4")?;
                if data.count() < joints.len() {
                    return Err(self.err(
                        format!("accessor {} ({what})", acc.index()),
                        format!("has {} matrices for {} joints; give one per joint", data.count(), joints.len()),
                    ));
                }
                let matrices: Vec<DMat4> =
                    data.rows::<16>().take(joints.len()).map(|m| DMat4::from_cols_array(&m)).collect();
                if let Some(j) = matrices.iter().position(|m| !m.is_finite()) {
                    return Err(
                        self.err(format!("accessor {} ({what})", acc.index()), format!("matrix {j} is not finite"))
                    );
                }
                Some(matrices)
            }
            None => None,
        };
        let skin_data = Skin::new(joints, inverse_bind).map_err(|source| IoError::Skin {
            path: self.path.to_path_buf(),
            element: element.clone(),
            source,
        })?;
        Ok(GltfSkin { name, skin: skin_data, skeleton_root: skin.skeleton().map(|n| n.index()) })
    }

    fn animation(
        &self,
        animation: &gltf::Animation,
        nodes: &[GltfNode],
        meshes: &[GltfMesh],
    ) -> Result<GltfAnimation, IoError> {
        use gltf::animation::{Interpolation as I, Property};
        let name = animation.name().unwrap_or("").to_string();
        let mut clip = AnimationClip { name: name.clone(), channels: Vec::new() };
        let mut morph_weights = Vec::new();
        for channel in animation.channels() {
            let node = channel.target().node().index();
            let property = channel.target().property();
            let element = format!(
                "animation {} '{name}' channel {} (node {node} {})",
                animation.index(),
                channel.index(),
                property_name(&property)
            );
            let sampler = channel.sampler();
            let interpolation = match sampler.interpolation() {
                I::Linear => Interpolation::Linear,
                I::Step => Interpolation::Step,
                I::CubicSpline => Interpolation::CubicSpline,
            };
            let times = self
                .data
                .accessor_with(sampler.input().index(), &format!("key times of {element}"), 1, "SCALAR")?
                .values;
            let out_index = sampler.output().index();
            let out_what = format!("key values of {element}");
            let anim_error =
                |source| IoError::Animation { path: self.path.to_path_buf(), element: element.clone(), source };
            let values = match property {
                Property::Translation | Property::Scale => {
                    let v: Vec<DVec3> = self
                        .data
                        .accessor_with(out_index, &out_what, 3, "VEC3")?
                        .rows::<3>()
                        .map(DVec3::from_array)
                        .collect();
                    let s = Sampler::new(times, v, interpolation).map_err(anim_error)?;
                    if property == Property::Translation {
                        ChannelValues::Translation(s)
                    } else {
                        ChannelValues::Scale(s)
                    }
                }
                Property::Rotation => {
                    let v: Vec<DQuat> = self
                        .data
                        .accessor_with(out_index, &out_what, 4, "VEC4")?
                        .rows::<4>()
                        .map(DQuat::from_array)
                        .collect();
                    ChannelValues::Rotation(Sampler::new_rotation(times, v, interpolation).map_err(anim_error)?)
                }
                Property::MorphTargetWeights => {
                    let v = self.data.accessor_with(out_index, &out_what, 1, "SCALAR")?.values;
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
                            format!(
                                "has {} weight values for {} keys and {targets} morph targets",
                                v.len(),
                                times.len()
                            ),
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

/// Skin weights of welded vertices: the average over the file vertices merged into each one
/// (as joint → weight sums), keeping the four largest influences (ties: lower joint first).
/// Exporters may give seam copies slightly different weights (RiggedCylinder4's differ by up to
/// 0.06), so that the file's own surface cracks along seams when animated; averaging is the
/// closed surface closest to both sides.
fn average_skin_weights(
    weights: &SkinWeights,
    vertex_map: &[u32],
    kept: usize,
) -> Result<SkinWeights, squish::skinning::SkinError> {
    let mut sums: Vec<Vec<(u32, f64)>> = vec![Vec::new(); kept];
    for (v, &w) in vertex_map.iter().enumerate() {
        let slot = &mut sums[w as usize];
        for (&j, &x) in weights.joints()[v].iter().zip(&weights.weights()[v]) {
            if x == 0.0 {
                continue;
            }
            match slot.iter_mut().find(|(jj, _)| *jj == j) {
                Some((_, sum)) => *sum += x,
                None => slot.push((j, x)),
            }
        }
    }
    let mut joints = Vec::with_capacity(kept);
    let mut rows = Vec::with_capacity(kept);
    for mut slot in sums {
        slot.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        let mut jr = [0u32; 4];
        let mut wr = [0.0f64; 4];
        for (k, (j, x)) in slot.into_iter().take(4).enumerate() {
            jr[k] = j;
            wr[k] = x;
        }
        joints.push(jr);
        rows.push(wr);
    }
    // Dividing by the number of copies is left to the normalization in `SkinWeights::new`.
    SkinWeights::new(joints, rows)
}

/// Per-vertex vectors of welded vertices: the average over the merged file vertices.
fn average_rows(rows: &[DVec3], vertex_map: &[u32], kept: usize) -> Vec<DVec3> {
    let mut sum = vec![DVec3::ZERO; kept];
    let mut count = vec![0u32; kept];
    for (v, &w) in vertex_map.iter().enumerate() {
        sum[w as usize] += rows[v];
        count[w as usize] += 1;
    }
    sum.iter().zip(&count).map(|(s, &c)| *s / c.max(1) as f64).collect()
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
