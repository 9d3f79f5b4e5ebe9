//! glTF pass-through: a `.gltf` / `.glb` file kept whole — its JSON as written (nodes, skins,
//! materials, textures, images, samplers, cameras, animations, extras and extensions, known to
//! this crate or not) and its buffers — so that results go back into the asset they came from.
//!
//! Contract: [`GltfDocument::write_with_positions`] writes a copy of the input in which only the
//! deformed meshes' `POSITION`, `NORMAL` and `TANGENT` values changed; every other byte of
//! every buffer view and every other JSON value is the input's. [`GltfDocument::write_animated`]
//! adds the deformation of a shot as morph targets, one per frame, keyed by a STEP animation of
//! the node's morph weights, next to the file's own animation (which keeps posing the skin).
//!
//! Conventions:
//! - positions handed in are the posed ones that [`GltfScene::merged_mesh`] and
//!   [`GltfScene::posed_mesh`] give (world space; skinned meshes by their skin). They are taken
//!   back into each mesh's own space by inverting the pose vertex by vertex
//!   ([`crate::InstancePose::unpose`]), so re-posing the output reproduces them (to `f32`);
//! - normals are recomputed per the file's splits: vertices at one position whose input
//!   normals agree (UV-seam copies) get one normal, the area-weighted average of the deformed
//!   faces around all of them; where the input normals differ (a hard edge) each side keeps its
//!   own faces' average. Tangents are turned with their normal (the smallest rotation), keeping
//!   their handedness;
//! - values are written in place when their accessor is dense `FLOAT` data that nothing else
//!   uses; otherwise (quantized, sparse, shared with other data) a new accessor is appended and
//!   the attribute points to it. Accessor `min`/`max` are updated;
//! - a mesh instanced by several nodes is duplicated for each further instance, since each
//!   instance deforms differently;
//! - buffers are written as one: the GLB binary chunk for `.glb`; for `.gltf`, an external
//!   `<name>.bin` next to it when the input had external buffers, else a base64 `data:` URI.
//!   Images given as files follow the container: embedded in the binary chunk for `.glb`,
//!   copied next to a `.gltf` output (a path leaving the input's folder is embedded as a
//!   `data:` URI instead); images already embedded stay as they are.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use base64::Engine as _;
use glam::{DQuat, DVec3};
use serde_json::{Value, json};
use squish::TriMesh;

use crate::gltf_read::{GltfReadOptions, read_gltf, read_gltf_file};
use crate::gltf_scene::{GltfMesh, GltfScene};
use crate::gltf_write::write_glb_container;
use crate::morph::{MorphFrame, MorphKeys, SparseDisplacement, sparse_accessor};
use crate::{IoError, write_atomically};

const FLOAT: u64 = 5126;
const ARRAY_BUFFER: u64 = 34962;
/// Two unit normals closer than this are "the same" when deciding where the input had a hard
/// edge (exporters write bit-identical normals on UV-seam copies; hard edges differ by degrees).
const SAME_NORMAL: f64 = 1e-3;

/// A glTF file kept whole for writing back (see the module documentation).
#[derive(Clone, Debug)]
pub struct GltfDocument {
    path: PathBuf,
    json: Value,
    buffers: Vec<Vec<u8>>,
    scene: GltfScene,
}

/// What a glTF file holds besides positions: the figures `squish info` reports.
#[derive(Clone, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct GltfAttributeCounts {
    /// Mesh primitives.
    pub primitives: usize,
    /// Largest number of texture-coordinate sets (`TEXCOORD_n`) of a primitive.
    pub uv_sets: usize,
    /// Primitives with `NORMAL` / `TANGENT`.
    pub primitives_with_normals: usize,
    pub primitives_with_tangents: usize,
    /// Largest number of colour sets (`COLOR_n`) of a primitive.
    pub color_sets: usize,
    pub skins: usize,
    /// Morph targets over all meshes.
    pub morph_targets: usize,
    pub materials: usize,
    pub textures: usize,
    pub images: usize,
    pub animations: usize,
    pub nodes: usize,
}

/// A shot's deformation of one glTF node, to be written as morph targets
/// ([`GltfDocument::write_animated`]).
#[derive(Clone, Copy, Debug)]
pub struct MorphAnimation<'a> {
    /// The node whose mesh deforms.
    pub node: usize,
    /// The file's animation that poses the node (its skin) at the frames' times; `None`: the
    /// rest pose. The morph-weight channel is added to it, so that both play together.
    pub animation: Option<usize>,
    /// Per frame, in increasing time: the displacement of the node's mesh in its own (bind)
    /// space, from [`GltfDocument::morph_displacement`].
    pub frames: &'a [MorphFrame],
    /// The keys that turn every frame's target off around the frames (a part of a shot).
    pub keys: MorphKeys,
}

impl GltfDocument {
    /// Reads a `.gltf` or `.glb` file (no welding: the file's vertices).
    pub fn read(path: &Path) -> Result<Self, IoError> {
        let file = read_gltf_file(path, &GltfReadOptions::default())?;
        let json: Value =
            serde_json::from_slice(&file.json).map_err(|e| IoError::format(path, format!("invalid glTF JSON: {e}")))?;
        Ok(Self { path: path.to_path_buf(), json, buffers: file.buffers, scene: file.scene })
    }

    /// The file read.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The document model (nodes, meshes, skins, animations).
    pub fn scene(&self) -> &GltfScene {
        &self.scene
    }

    /// Every instance posed at rest, concatenated in node order ([`GltfScene::merged_mesh`]):
    /// the mesh whose positions [`Self::write_with_positions`] takes.
    pub fn mesh(&self) -> Result<TriMesh, IoError> {
        self.scene.merged_mesh()
    }

    /// What the file holds besides positions.
    pub fn attribute_counts(&self) -> GltfAttributeCounts {
        let len = |key: &str| self.json.get(key).and_then(Value::as_array).map_or(0, Vec::len);
        let mut counts = GltfAttributeCounts {
            skins: len("skins"),
            materials: len("materials"),
            textures: len("textures"),
            images: len("images"),
            animations: len("animations"),
            nodes: len("nodes"),
            ..GltfAttributeCounts::default()
        };
        for mesh in self.json.get("meshes").and_then(Value::as_array).into_iter().flatten() {
            let primitives = mesh.get("primitives").and_then(Value::as_array).map(Vec::as_slice).unwrap_or(&[]);
            if let Some(first) = primitives.first() {
                counts.morph_targets += first.get("targets").and_then(Value::as_array).map_or(0, Vec::len);
            }
            for primitive in primitives {
                counts.primitives += 1;
                let Some(attributes) = primitive.get("attributes").and_then(Value::as_object) else { continue };
                let sets = |prefix: &str| attributes.keys().filter(|k| k.starts_with(prefix)).count();
                counts.uv_sets = counts.uv_sets.max(sets("TEXCOORD_"));
                counts.color_sets = counts.color_sets.max(sets("COLOR_"));
                counts.primitives_with_normals += usize::from(attributes.contains_key("NORMAL"));
                counts.primitives_with_tangents += usize::from(attributes.contains_key("TANGENT"));
            }
        }
        counts
    }

    /// Writes a copy of the file to `path` (`.glb` or `.gltf`, atomically) with `positions` —
    /// one per vertex of [`Self::mesh`], in its order — as the deformed meshes (see the module
    /// documentation for what changes and what does not).
    pub fn write_with_positions(&self, path: &Path, positions: &[DVec3]) -> Result<(), IoError> {
        let binary = is_glb(path)?;
        let expected = self.mesh()?.num_vertices();
        if positions.len() != expected {
            return Err(IoError::invalid_input(
                path,
                format!("{} positions for the {expected} vertices of {}", positions.len(), self.path.display()),
            ));
        }
        if let Some(v) = positions.iter().position(|p| !p.is_finite()) {
            return Err(IoError::invalid_input(path, format!("vertex {v} has a non-finite coordinate")));
        }
        let mut edit = Edit::new(self);
        let instances = self.scene.instances();
        let mut start = 0usize;
        if instances.is_empty() {
            // Meshes without a node are in their own space already.
            for (m, mesh) in self.scene.meshes.iter().enumerate() {
                let end = start + mesh.positions.len();
                edit.set_mesh_geometry(m, mesh, &positions[start..end])?;
                start = end;
            }
        } else {
            let mut used = vec![false; self.scene.meshes.len()];
            for instance in instances {
                let mesh = &self.scene.meshes[instance.mesh];
                let end = start + mesh.positions.len();
                let pose = self.scene.instance_pose(instance.node, None, 0.0)?;
                let local = pose.unpose(&self.scene, &positions[start..end])?;
                let json_mesh = if std::mem::replace(&mut used[instance.mesh], true) {
                    edit.duplicate_mesh(instance.node, instance.mesh)?
                } else {
                    instance.mesh
                };
                edit.set_mesh_geometry(json_mesh, mesh, &local)?;
                start = end;
            }
        }
        edit.apply_writes(path)?;
        edit.finish(path, binary)
    }

    /// Writes `positions` — one per vertex of [`Self::mesh`] (`node: None`) or of node `node`'s
    /// mesh, in any space — as an OBJ or PLY file (by `path`'s extension), atomically, with what
    /// those formats hold of the glTF file: the first UV set (`TEXCOORD_0`, turned to their
    /// convention: `v` = 1 − glTF's `v`) and normals recomputed for `positions` per the file's
    /// splits (seam copies share theirs; a hard edge keeps one per side), when the file has
    /// them. Faces are the file's triangles.
    pub fn write_converted(&self, path: &Path, node: Option<usize>, positions: &[DVec3]) -> Result<(), IoError> {
        let meshes: Vec<&GltfMesh> = match node {
            Some(node) => vec![self.node_mesh(node)?],
            None => {
                let instances = self.scene.instances();
                if instances.is_empty() {
                    self.scene.meshes.iter().collect()
                } else {
                    instances.iter().map(|i| &self.scene.meshes[i.mesh]).collect()
                }
            }
        };
        let count: usize = meshes.iter().map(|m| m.positions.len()).sum();
        if positions.len() != count {
            return Err(IoError::invalid_input(
                path,
                format!("{} positions for the {count} vertices of {}", positions.len(), self.path.display()),
            ));
        }
        let mut rest = Vec::with_capacity(count);
        let mut triangles = Vec::new();
        for mesh in &meshes {
            let offset = rest.len() as u32;
            triangles.extend(mesh.triangles.iter().map(|t| t.map(|v| v + offset)));
            rest.extend_from_slice(&mesh.positions);
        }
        let normals: Option<Vec<DVec3>> = meshes
            .iter()
            .map(|m| m.normals.as_deref())
            .collect::<Option<Vec<_>>>()
            .map(|all| all.concat())
            .map(|old| split_normals(&rest, &old, &triangles, positions));
        let texcoords: Option<Vec<[f64; 2]>> = meshes.iter().any(|m| m.texcoords.is_some()).then(|| {
            meshes
                .iter()
                .flat_map(|m| match &m.texcoords {
                    Some(uv) => uv.clone(),
                    None => vec![[0.0, 0.0]; m.positions.len()],
                })
                .map(|[u, v]| [u, 1.0 - v])
                .collect()
        });
        let mesh = TriMesh { positions: positions.to_vec(), triangles };
        match crate::MeshFormat::from_path(path)? {
            crate::MeshFormat::Obj => crate::write_obj_with(path, &mesh, texcoords.as_deref(), normals.as_deref()),
            crate::MeshFormat::Ply => {
                use crate::{ScalarType, VertexProperty};
                let mut properties = Vec::new();
                if let Some(normals) = &normals {
                    for (c, name) in ["nx", "ny", "nz"].into_iter().enumerate() {
                        properties.push(VertexProperty::new(
                            name,
                            ScalarType::F32,
                            normals.iter().map(|n| n[c]).collect(),
                        ));
                    }
                }
                if let Some(uv) = &texcoords {
                    for (c, name) in ["u", "v"].into_iter().enumerate() {
                        properties.push(VertexProperty::new(name, ScalarType::F32, uv.iter().map(|t| t[c]).collect()));
                    }
                }
                mesh.check_structure().map_err(|e| IoError::mesh(path, e))?;
                crate::write_ply_with(path, &mesh.positions, Some(&mesh.triangles), &properties, &Default::default())
            }
            crate::MeshFormat::Gltf | crate::MeshFormat::Glb => self.write_with_positions(path, positions),
        }
    }

    /// The displacement, in the mesh's own (bind) space, of node `node`'s mesh posed by
    /// `animation` at `time` into `posed` (its file vertices, world space): the posed positions
    /// un-posed and taken from the mesh's base positions, for the vertices `moved` marks (the
    /// others do not move: they get none, rather than the round-off of un-posing).
    pub fn morph_displacement(
        &self,
        node: usize,
        animation: Option<usize>,
        time: f64,
        posed: &[DVec3],
        moved: &[bool],
    ) -> Result<SparseDisplacement, IoError> {
        let mesh = self.node_mesh(node)?;
        if posed.len() != mesh.positions.len() || moved.len() != posed.len() {
            return Err(IoError::invalid_input(
                &self.path,
                format!(
                    "{} positions and {} flags for the {} vertices of node {node}'s mesh",
                    posed.len(),
                    moved.len(),
                    mesh.positions.len()
                ),
            ));
        }
        let pose = self.scene.instance_pose(node, animation, time)?;
        let local = pose.unpose(&self.scene, posed)?;
        let delta: Vec<DVec3> = local
            .iter()
            .zip(&mesh.positions)
            .zip(moved)
            .map(|((a, b), &m)| if m { *a - *b } else { DVec3::ZERO })
            .collect();
        SparseDisplacement::from_dense(&delta).map_err(|v| {
            IoError::invalid_input(&self.path, format!("vertex {v} of node {node}'s mesh moves by a non-finite amount"))
        })
    }

    /// The mesh of node `node`.
    fn node_mesh(&self, node: usize) -> Result<&GltfMesh, IoError> {
        self.scene.nodes.get(node).and_then(|n| n.mesh).and_then(|m| self.scene.meshes.get(m)).ok_or_else(|| {
            IoError::invalid_input(&self.path, format!("node {node} of {} has no mesh", self.path.display()))
        })
    }

    /// Writes a copy of the file to `path` with a shot's deformation of one node as morph
    /// targets (see [`MorphAnimation`]): target `k` holds frame `k`'s displacement from the
    /// mesh's base positions in the mesh's own (bind) space, as a sparse accessor of the vertices
    /// that move (a dense one when that is smaller), and the change of the normals it makes when
    /// the mesh has normals — the difference of the area-weighted normals of the displaced and
    /// the base positions, added to the file's own, so zero wherever no face around a vertex
    /// moved; an added STEP channel of the node's morph weights switches target `k` on from the
    /// frame's time until the next key. The file's own animation keeps posing the skin, so the
    /// result plays in any glTF viewer: re-posing frame `k` gives its deformed positions (to
    /// `f32`). The file's own morph targets and their weights are kept.
    pub fn write_animated(&self, path: &Path, animation: &MorphAnimation) -> Result<(), IoError> {
        let binary = is_glb(path)?;
        let MorphAnimation { node, frames, keys, .. } = *animation;
        let scene = &self.scene;
        let Some(mesh_index) = scene.nodes.get(node).and_then(|n| n.mesh) else {
            return Err(IoError::invalid_input(path, format!("node {node} of {} has no mesh", self.path.display())));
        };
        let mesh = &scene.meshes[mesh_index];
        if frames.is_empty() {
            return Err(IoError::invalid_input(path, "no frame to write: give at least one"));
        }
        if let Some(k) = frames.iter().position(|f| f.displacement.count != mesh.positions.len()) {
            return Err(IoError::invalid_input(
                path,
                format!(
                    "frame {k} displaces {} vertices, node {node}'s mesh has {}",
                    frames[k].displacement.count,
                    mesh.positions.len()
                ),
            ));
        }
        let times = keys.times(frames).map_err(|m| IoError::invalid_input(path, m))?;
        if let Some((a, anim)) =
            scene.animations.iter().enumerate().find(|(_, a)| a.morph_weights.iter().any(|t| t.node == node))
        {
            return Err(IoError::invalid_input(
                path,
                format!(
                    "animation {a} '{}' of {} already animates the morph weights of node {node}; the deformation cannot be added as morph targets (write per-frame files or a point cache instead)",
                    anim.name,
                    self.path.display()
                ),
            ));
        }
        let mut edit = Edit::new(self);
        let shared = scene.instances().iter().any(|i| i.mesh == mesh_index && i.node != node);
        let json_mesh = if shared { edit.duplicate_mesh(node, mesh_index)? } else { mesh_index };
        let base_weights = scene.morph_weights(node, None, 0.0)?;
        let existing = mesh.morph_targets.len();
        let base_normals =
            mesh.normals.as_ref().map(|n| split_normals(&mesh.positions, n, &mesh.triangles, &mesh.positions));
        for (k, frame) in frames.iter().enumerate() {
            let normal_change = match (&mesh.normals, &base_normals) {
                (Some(normals), Some(base)) => {
                    let local: Vec<DVec3> =
                        mesh.positions.iter().zip(frame.displacement.dense()).map(|(p, d)| *p + d).collect();
                    let moved = split_normals(&mesh.positions, normals, &mesh.triangles, &local);
                    let change: Vec<DVec3> = moved.iter().zip(base).map(|(a, b)| *a - *b).collect();
                    Some(SparseDisplacement::from_dense(&change).map_err(|v| {
                        IoError::invalid_input(path, format!("frame {k}: the normal of vertex {v} is not finite"))
                    })?)
                }
                _ => None,
            };
            for (p, range) in mesh.primitive_vertices.iter().enumerate() {
                let has_normal = edit.primitive(json_mesh, p)?.pointer("/attributes/NORMAL").is_some();
                let mut target =
                    json!({ "POSITION": edit.append_displacement(&frame.displacement.slice(range.clone()), true) });
                if let (true, Some(change)) = (has_normal, &normal_change) {
                    target["NORMAL"] = json!(edit.append_displacement(&change.slice(range.clone()), false));
                }
                let primitive = edit.primitive_mut(json_mesh, p)?;
                match primitive.get_mut("targets").and_then(Value::as_array_mut) {
                    Some(targets) => targets.push(target),
                    None => primitive["targets"] = json!([target]),
                }
            }
        }
        // Default weights: the file's for its own targets, zero for the frames'.
        let total = existing + frames.len();
        let mut weights: Vec<f64> = base_weights.clone();
        weights.resize(total, 0.0);
        let json_mesh_value = &mut edit.json["meshes"][json_mesh];
        json_mesh_value["weights"] = json!(weights.iter().map(|&w| w as f32).collect::<Vec<_>>());
        let mut target_names: Vec<String> = mesh.target_names.clone();
        target_names.resize_with(existing, String::new);
        for (t, name) in target_names.iter_mut().enumerate() {
            if name.is_empty() {
                *name = format!("target_{t}");
            }
        }
        target_names.extend(frames.iter().map(|f| f.name.clone()));
        match json_mesh_value.get_mut("extras") {
            Some(Value::Object(extras)) => {
                extras.insert("targetNames".into(), json!(target_names));
            }
            None => json_mesh_value["extras"] = json!({ "targetNames": target_names }),
            // Extras of another shape are the file's own business: leave them.
            Some(_) => {}
        }
        if let Some(node_weights) = edit.json["nodes"][node].get_mut("weights") {
            *node_weights = json!(weights.iter().map(|&w| w as f32).collect::<Vec<_>>());
        }
        // The weights channel: at each key, the file's weights for its targets and the key's
        // frame on (none at the keys that turn the frames off).
        let key_times: Vec<f32> = times.iter().map(|&t| t as f32).collect();
        let mut values = Vec::with_capacity(times.len() * total);
        for on in keys.frame_on(frames.len()) {
            for (t, &w) in weights.iter().enumerate() {
                values.push(if Some(t) == on.map(|k| existing + k) {
                    1.0
                } else if t < existing {
                    w as f32
                } else {
                    0.0
                });
            }
        }
        let input = edit.append_scalars(&key_times, true);
        let output = edit.append_scalars(&values, false);
        let sampler = json!({ "input": input, "output": output, "interpolation": "STEP" });
        let channel = |s: usize| json!({ "sampler": s, "target": { "node": node, "path": "weights" } });
        match animation.animation {
            Some(a) => {
                let anim = edit.json.pointer_mut(&format!("/animations/{a}")).ok_or_else(|| {
                    IoError::invalid_input(path, format!("animation {a} does not exist in {}", self.path.display()))
                })?;
                let samplers = anim["samplers"].as_array_mut().ok_or_else(|| {
                    IoError::invalid_input(path, format!("animation {a} of {} has no samplers", self.path.display()))
                })?;
                samplers.push(sampler);
                let s = samplers.len() - 1;
                match anim["channels"].as_array_mut() {
                    Some(channels) => channels.push(channel(s)),
                    None => anim["channels"] = json!([channel(s)]),
                }
            }
            None => {
                let new = json!({ "name": "squish deformation", "samplers": [sampler], "channels": [channel(0)] });
                match edit.json.get_mut("animations").and_then(Value::as_array_mut) {
                    Some(list) => list.push(new),
                    None => edit.json["animations"] = json!([new]),
                }
            }
        }
        edit.finish(path, binary)
    }

    /// The frames of a shot that [`Self::write_animated`] wrote into `part` (a copy of this
    /// document) for node `node`: each added target's name and displacement, in order, as
    /// written (bit for bit), so that the parts of a split shot merge into what one run writes.
    pub fn shot_frames(&self, part: &Path, node: usize) -> Result<Vec<(String, SparseDisplacement)>, IoError> {
        let source = self.node_mesh(node)?;
        let written = read_gltf(part, &GltfReadOptions::default())?;
        let mesh = written
            .nodes
            .get(node)
            .and_then(|n| n.mesh)
            .and_then(|m| written.meshes.get(m))
            .filter(|m| m.positions.len() == source.positions.len() && m.morph_targets.len() >= source.morph_targets.len())
            .ok_or_else(|| {
                IoError::invalid_input(
                    part,
                    format!(
                        "node {node} does not hold the {} vertices of {} with the shot's morph targets: not a part of this shot",
                        source.positions.len(),
                        self.path.display()
                    ),
                )
            })?;
        let existing = source.morph_targets.len();
        mesh.morph_targets[existing..]
            .iter()
            .enumerate()
            .map(|(k, target)| {
                let name = mesh.target_names.get(existing + k).cloned().unwrap_or_default();
                let displacement = SparseDisplacement::from_dense(target)
                    .map_err(|v| IoError::invalid_input(part, format!("target {name}: vertex {v} is not finite")))?;
                Ok((name, displacement))
            })
            .collect()
    }
}

/// New unit normals of a mesh moved from `old` to `new` positions, per the input's splits
/// (see the module documentation): vertices at one old position with the same old normal form
/// a group whose normal is the normalized sum of the area vectors of the triangles touching the
/// group (each once). A vertex whose group gets no area keeps its old normal.
pub(crate) fn split_normals(old: &[DVec3], old_normals: &[DVec3], triangles: &[[u32; 3]], new: &[DVec3]) -> Vec<DVec3> {
    let mut clusters: HashMap<[u64; 3], Vec<(usize, DVec3)>> = HashMap::new();
    let mut group_of = Vec::with_capacity(old.len());
    let mut groups = 0usize;
    for (p, n) in old.iter().zip(old_normals) {
        let key = [(p.x + 0.0).to_bits(), (p.y + 0.0).to_bits(), (p.z + 0.0).to_bits()];
        let list = clusters.entry(key).or_default();
        let group = match list.iter().find(|(_, seed)| (*seed - *n).length() <= SAME_NORMAL) {
            Some(&(g, _)) => g,
            None => {
                list.push((groups, *n));
                groups += 1;
                groups - 1
            }
        };
        group_of.push(group);
    }
    let mut sums = vec![DVec3::ZERO; groups];
    for tri in triangles {
        let [a, b, c] = tri.map(|v| new[v as usize]);
        let area = (b - a).cross(c - a);
        let g = tri.map(|v| group_of[v as usize]);
        sums[g[0]] += area;
        if g[1] != g[0] {
            sums[g[1]] += area;
        }
        if g[2] != g[0] && g[2] != g[1] {
            sums[g[2]] += area;
        }
    }
    group_of
        .iter()
        .zip(old_normals)
        .map(|(&g, &n)| {
            let s = sums[g].normalize_or_zero();
            if s == DVec3::ZERO { n } else { s }
        })
        .collect()
}

/// A tangent turned by the smallest rotation taking `old_normal` to `new_normal`, made
/// orthogonal to the new normal; the handedness `w` is kept.
fn turned_tangent(tangent: [f64; 4], old_normal: DVec3, new_normal: DVec3) -> [f64; 4] {
    let t = DVec3::new(tangent[0], tangent[1], tangent[2]);
    let (a, b) = (old_normal.normalize_or_zero(), new_normal.normalize_or_zero());
    if a == DVec3::ZERO || b == DVec3::ZERO || t == DVec3::ZERO {
        return tangent;
    }
    let turned = DQuat::from_rotation_arc(a, b) * t;
    let orthogonal = (turned - b * b.dot(turned)).normalize_or_zero();
    let out = if orthogonal == DVec3::ZERO { turned } else { orthogonal };
    [out.x, out.y, out.z, tangent[3]]
}

/// New values of one attribute of one primitive.
struct AttributeWrite {
    mesh: usize,
    primitive: usize,
    semantic: &'static str,
    components: usize,
    values: Vec<f32>,
}

/// A copy of a document being edited: the JSON, the buffers (written in place) and the data
/// appended for new accessors (a buffer of its own until the buffers are merged at the end).
struct Edit<'a> {
    doc: &'a GltfDocument,
    json: Value,
    buffers: Vec<Vec<u8>>,
    appended: Vec<u8>,
    writes: Vec<AttributeWrite>,
}

impl<'a> Edit<'a> {
    fn new(doc: &'a GltfDocument) -> Self {
        Self { doc, json: doc.json.clone(), buffers: doc.buffers.clone(), appended: Vec::new(), writes: Vec::new() }
    }

    fn new_buffer(&self) -> usize {
        self.buffers.len()
    }

    fn err(&self, element: impl Into<String>, message: impl Into<String>) -> IoError {
        IoError::element(&self.doc.path, element, message)
    }

    fn primitive(&self, mesh: usize, p: usize) -> Result<&Value, IoError> {
        self.json
            .pointer(&format!("/meshes/{mesh}/primitives/{p}"))
            .ok_or_else(|| self.err(format!("mesh {mesh} primitive {p}"), "does not exist"))
    }

    fn primitive_mut(&mut self, mesh: usize, p: usize) -> Result<&mut Value, IoError> {
        let element = format!("mesh {mesh} primitive {p}");
        let path = self.doc.path.clone();
        self.json
            .pointer_mut(&format!("/meshes/{mesh}/primitives/{p}"))
            .ok_or_else(|| IoError::element(&path, element, "does not exist"))
    }

    /// A copy of mesh `mesh` for node `node` (which then instances the copy); returns its index.
    fn duplicate_mesh(&mut self, node: usize, mesh: usize) -> Result<usize, IoError> {
        let copy = self
            .json
            .pointer(&format!("/meshes/{mesh}"))
            .cloned()
            .ok_or_else(|| self.err(format!("mesh {mesh}"), "does not exist"))?;
        let meshes = self.json["meshes"].as_array_mut().ok_or_else(|| IoError::format(&self.doc.path, "no meshes"))?;
        meshes.push(copy);
        let index = meshes.len() - 1;
        self.json["nodes"][node]["mesh"] = json!(index);
        Ok(index)
    }

    /// Queues the new positions (mesh space, the mesh's vertex order), and the normals and
    /// tangents recomputed from them, of every primitive of JSON mesh `json_mesh`, read as `mesh`.
    fn set_mesh_geometry(&mut self, json_mesh: usize, mesh: &GltfMesh, local: &[DVec3]) -> Result<(), IoError> {
        let normals = mesh.normals.as_ref().map(|n| split_normals(&mesh.positions, n, &mesh.triangles, local));
        for (p, range) in mesh.primitive_vertices.iter().enumerate() {
            let attributes = self.primitive(json_mesh, p)?.get("attributes").cloned().unwrap_or(Value::Null);
            let flat =
                |rows: &mut dyn Iterator<Item = Vec<f64>>| -> Vec<f32> { rows.flatten().map(|x| x as f32).collect() };
            let positions = flat(&mut local[range.clone()].iter().map(|p| p.to_array().to_vec()));
            self.writes.push(AttributeWrite {
                mesh: json_mesh,
                primitive: p,
                semantic: "POSITION",
                components: 3,
                values: positions,
            });
            if let (Some(new), Some(old)) = (&normals, &mesh.normals)
                && attributes.get("NORMAL").is_some()
            {
                let values = flat(&mut new[range.clone()].iter().map(|n| n.to_array().to_vec()));
                self.writes.push(AttributeWrite {
                    mesh: json_mesh,
                    primitive: p,
                    semantic: "NORMAL",
                    components: 3,
                    values,
                });
                if let (Some(tangents), Some(_)) = (&mesh.tangents, attributes.get("TANGENT")) {
                    let values = flat(&mut range.clone().map(|v| turned_tangent(tangents[v], old[v], new[v]).to_vec()));
                    self.writes.push(AttributeWrite {
                        mesh: json_mesh,
                        primitive: p,
                        semantic: "TANGENT",
                        components: 4,
                        values,
                    });
                }
            }
        }
        Ok(())
    }

    /// How many times each accessor is referenced by the document (attributes, indices, morph
    /// targets, skins, animation samplers, GPU instancing).
    fn accessor_references(&self) -> HashMap<u64, usize> {
        let mut refs: HashMap<u64, usize> = HashMap::new();
        let mut add = |v: Option<&Value>| {
            if let Some(i) = v.and_then(Value::as_u64) {
                *refs.entry(i).or_default() += 1;
            }
        };
        let list = |v: Option<&Value>| v.and_then(Value::as_array).cloned().unwrap_or_default();
        for mesh in list(self.json.get("meshes")) {
            for primitive in list(mesh.get("primitives")) {
                for value in primitive.get("attributes").and_then(Value::as_object).into_iter().flat_map(|o| o.values())
                {
                    add(Some(value));
                }
                add(primitive.get("indices"));
                for target in list(primitive.get("targets")) {
                    for value in target.as_object().into_iter().flat_map(|o| o.values()) {
                        add(Some(value));
                    }
                }
            }
        }
        for skin in list(self.json.get("skins")) {
            add(skin.get("inverseBindMatrices"));
        }
        for animation in list(self.json.get("animations")) {
            for sampler in list(animation.get("samplers")) {
                add(sampler.get("input"));
                add(sampler.get("output"));
            }
        }
        for node in list(self.json.get("nodes")) {
            if let Some(attributes) =
                node.pointer("/extensions/EXT_mesh_gpu_instancing/attributes").and_then(Value::as_object)
            {
                for value in attributes.values() {
                    add(Some(value));
                }
            }
        }
        refs
    }

    /// Performs the queued attribute writes: in place where the accessor is dense float data
    /// used only by the writes that agree on its values, else into new accessors.
    fn apply_writes(&mut self, path: &Path) -> Result<(), IoError> {
        let references = self.accessor_references();
        let writes = std::mem::take(&mut self.writes);
        let mut by_accessor: BTreeMap<u64, Vec<&AttributeWrite>> = BTreeMap::new();
        for w in &writes {
            let pointer = format!("/meshes/{}/primitives/{}/attributes/{}", w.mesh, w.primitive, w.semantic);
            let accessor = self.json.pointer(&pointer).and_then(Value::as_u64).ok_or_else(|| {
                self.err(
                    format!("mesh {} primitive {}", w.mesh, w.primitive),
                    format!("has no {} accessor", w.semantic),
                )
            })?;
            by_accessor.entry(accessor).or_default().push(w);
        }
        for (accessor, group) in by_accessor {
            let in_place = references.get(&accessor).copied().unwrap_or(0) == group.len()
                && self.dense_float(accessor, group[0].components);
            let first = group[0];
            for (k, w) in group.iter().enumerate() {
                if in_place && (k == 0 || w.values == first.values) {
                    if k == 0 {
                        self.write_in_place(accessor, w)?;
                    }
                    continue;
                }
                let new = self.append_accessor(&w.values, w.components, Some(ARRAY_BUFFER), w.semantic == "POSITION");
                let pointer = format!("/meshes/{}/primitives/{}/attributes/{}", w.mesh, w.primitive, w.semantic);
                if let Some(slot) = self.json.pointer_mut(&pointer) {
                    *slot = json!(new);
                } else {
                    return Err(IoError::invalid_input(path, format!("cannot repoint {pointer}")));
                }
            }
        }
        Ok(())
    }

    /// True if `accessor` is dense, non-normalized `FLOAT` data with `components` per element.
    fn dense_float(&self, accessor: u64, components: usize) -> bool {
        let Some(acc) = self.json.pointer(&format!("/accessors/{accessor}")) else { return false };
        let ty = match components {
            3 => "VEC3",
            4 => "VEC4",
            _ => return false,
        };
        acc.get("componentType").and_then(Value::as_u64) == Some(FLOAT)
            && acc.get("type").and_then(Value::as_str) == Some(ty)
            && acc.get("bufferView").is_some()
            && acc.get("sparse").is_none()
            && !acc.get("normalized").and_then(Value::as_bool).unwrap_or(false)
    }

    fn write_in_place(&mut self, accessor: u64, w: &AttributeWrite) -> Result<(), IoError> {
        let element = format!("accessor {accessor} ({} of mesh {} primitive {})", w.semantic, w.mesh, w.primitive);
        let acc = self.json.pointer(&format!("/accessors/{accessor}")).cloned().unwrap_or(Value::Null);
        let view_index = acc.get("bufferView").and_then(Value::as_u64).unwrap_or(0);
        let view = self.json.pointer(&format!("/bufferViews/{view_index}")).cloned().unwrap_or(Value::Null);
        let buffer = view.get("buffer").and_then(Value::as_u64).unwrap_or(0) as usize;
        let element_size = 4 * w.components;
        let stride = view.get("byteStride").and_then(Value::as_u64).map_or(element_size, |s| s as usize);
        let start = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize
            + acc.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
        let count = w.values.len() / w.components;
        let fits =
            count == 0 || start + (count - 1) * stride + element_size <= self.buffers.get(buffer).map_or(0, Vec::len);
        if !fits || acc.get("count").and_then(Value::as_u64) != Some(count as u64) {
            return Err(self.err(element, "does not hold the primitive's vertices; the file is corrupt"));
        }
        let data = &mut self.buffers[buffer];
        for (i, row) in w.values.chunks_exact(w.components).enumerate() {
            for (c, v) in row.iter().enumerate() {
                let at = start + i * stride + 4 * c;
                data[at..at + 4].copy_from_slice(&v.to_le_bytes());
            }
        }
        if w.semantic == "POSITION" || acc.get("min").is_some() {
            let (min, max) = bounds(&w.values, w.components);
            self.json["accessors"][accessor as usize]["min"] = json!(min);
            self.json["accessors"][accessor as usize]["max"] = json!(max);
        }
        Ok(())
    }

    /// Appends `bytes` as a new buffer view (4-byte aligned); returns its index.
    fn append_view(&mut self, bytes: &[u8], target: Option<u64>) -> usize {
        while !self.appended.len().is_multiple_of(4) {
            self.appended.push(0);
        }
        let offset = self.appended.len();
        self.appended.extend_from_slice(bytes);
        let mut view = json!({ "buffer": self.new_buffer(), "byteOffset": offset, "byteLength": bytes.len() });
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        push(&mut self.json, "bufferViews", view)
    }

    /// Appends a displacement as a `VEC3` float accessor (see [`sparse_accessor`]); returns its
    /// index.
    fn append_displacement(&mut self, displacement: &SparseDisplacement, with_bounds: bool) -> usize {
        let accessor = sparse_accessor(displacement, with_bounds, |bytes| self.append_view(bytes, None));
        push(&mut self.json, "accessors", accessor)
    }

    /// Appends float data as a new buffer view and accessor; returns the accessor's index.
    fn append_accessor(&mut self, values: &[f32], components: usize, target: Option<u64>, with_bounds: bool) -> usize {
        let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        let views = self.append_view(&bytes, target);
        let ty = match components {
            1 => "SCALAR",
            2 => "VEC2",
            3 => "VEC3",
            _ => "VEC4",
        };
        let mut accessor = json!({ "bufferView": views, "componentType": FLOAT, "count": values.len() / components.max(1), "type": ty });
        if with_bounds {
            let (min, max) = bounds(values, components);
            accessor["min"] = json!(min);
            accessor["max"] = json!(max);
        }
        push(&mut self.json, "accessors", accessor)
    }

    fn append_scalars(&mut self, values: &[f32], with_bounds: bool) -> usize {
        self.append_accessor(values, 1, None, with_bounds)
    }

    /// Merges the buffers (and the appended data) into one, embeds or copies images, and
    /// writes the file.
    fn finish(mut self, path: &Path, binary: bool) -> Result<(), IoError> {
        let had_external = self.json.get("buffers").and_then(Value::as_array).is_some_and(|b| {
            b.iter().any(|b| b.get("uri").and_then(Value::as_str).is_some_and(|u| !u.starts_with("data:")))
        });
        let mut buffers = std::mem::take(&mut self.buffers);
        buffers.push(std::mem::take(&mut self.appended));
        let mut merged: Vec<u8> = Vec::new();
        let mut base = Vec::with_capacity(buffers.len());
        for b in &buffers {
            while !merged.len().is_multiple_of(8) {
                merged.push(0);
            }
            base.push(merged.len());
            merged.extend_from_slice(b);
        }
        if let Some(views) = self.json.get_mut("bufferViews").and_then(Value::as_array_mut) {
            for view in views {
                let b = view.get("buffer").and_then(Value::as_u64).unwrap_or(0) as usize;
                let offset = view.get("byteOffset").and_then(Value::as_u64).unwrap_or(0) as usize;
                view["buffer"] = json!(0);
                view["byteOffset"] = json!(offset + base.get(b).copied().unwrap_or(0));
            }
        }
        let source_dir = self.doc.path.parent().unwrap_or(Path::new(".")).to_path_buf();
        let out_dir = path.parent().filter(|d| !d.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf();
        let mut copies: Vec<(PathBuf, Vec<u8>)> = Vec::new();
        // Images embedded in the binary chunk: (image, offset, length), given views below.
        let mut image_views = Vec::new();
        if let Some(images) = self.json.get_mut("images").and_then(Value::as_array_mut) {
            for (i, image) in images.iter_mut().enumerate() {
                let Some(uri) = image.get("uri").and_then(Value::as_str).map(str::to_string) else { continue };
                // An image that cannot be read stays as it was: a faithful copy, not a failure.
                if uri.starts_with("data:") {
                    // Self-contained already: kept as written.
                    continue;
                }
                let Some(bytes) = image_bytes(&source_dir, &uri) else { continue };
                if binary {
                    while !merged.len().is_multiple_of(8) {
                        merged.push(0);
                    }
                    image_views.push((i, merged.len(), bytes.len()));
                    merged.extend_from_slice(&bytes);
                    if let Some(o) = image.as_object_mut() {
                        o.remove("uri");
                    }
                    image["mimeType"] = json!(mime_type(&uri));
                } else if is_plain_relative(&uri) {
                    if !same_dir(&source_dir, &out_dir) {
                        copies.push((out_dir.join(percent_decoded(&uri)), bytes));
                    }
                } else {
                    let encoded = base64::engine::general_purpose::STANDARD.encode(&bytes);
                    image["uri"] = json!(format!("data:{};base64,{encoded}", mime_type(&uri)));
                }
            }
        }
        for (i, offset, len) in image_views {
            let view =
                push(&mut self.json, "bufferViews", json!({ "buffer": 0, "byteOffset": offset, "byteLength": len }));
            self.json["images"][i]["bufferView"] = json!(view);
        }
        let mut buffer = json!({ "byteLength": merged.len() });
        if let Some(old) = self.json.pointer("/buffers/0") {
            for key in ["name", "extras", "extensions"] {
                if let Some(v) = old.get(key) {
                    buffer[key] = v.clone();
                }
            }
        }
        let mut external: Option<(PathBuf, &[u8])> = None;
        if !binary {
            if had_external {
                let stem = path.file_stem().map_or_else(|| "buffer".into(), |s| s.to_string_lossy().into_owned());
                let name = format!("{stem}.bin");
                buffer["uri"] = json!(name);
                external = Some((out_dir.join(&name), &merged));
            } else {
                let encoded = base64::engine::general_purpose::STANDARD.encode(&merged);
                buffer["uri"] = json!(format!("data:application/octet-stream;base64,{encoded}"));
            }
        }
        self.json["buffers"] = json!([buffer]);
        if merged.is_empty() {
            self.json.as_object_mut().map(|o| o.remove("buffers"));
        }
        for (target, bytes) in &copies {
            if let Some(dir) = target.parent() {
                std::fs::create_dir_all(dir).map_err(|e| IoError::io(dir, "create the folder of an image", e))?;
            }
            write_atomically(target, |w| w.write_all(bytes))?;
        }
        if let Some((bin_path, bytes)) = external {
            write_atomically(&bin_path, |w| w.write_all(bytes))?;
        }
        if binary {
            let text = serde_json::to_vec(&self.json)
                .map_err(|e| IoError::invalid_input(path, format!("JSON encoding failed: {e}")))?;
            write_atomically(path, |w| write_glb_container(w, &text, &merged))
        } else {
            let text = serde_json::to_vec_pretty(&self.json)
                .map_err(|e| IoError::invalid_input(path, format!("JSON encoding failed: {e}")))?;
            write_atomically(path, |w| w.write_all(&text))
        }
    }
}

/// Appends `value` to the array `json[key]` (created if missing); returns its index.
fn push(json: &mut Value, key: &str, value: Value) -> usize {
    match json.get_mut(key).and_then(Value::as_array_mut) {
        Some(list) => {
            list.push(value);
            list.len() - 1
        }
        None => {
            json[key] = json!([value]);
            0
        }
    }
}

/// Per-component minimum and maximum of flat rows.
fn bounds(values: &[f32], components: usize) -> (Vec<f32>, Vec<f32>) {
    let c = components.max(1);
    let mut min = vec![f32::INFINITY; c];
    let mut max = vec![f32::NEG_INFINITY; c];
    for row in values.chunks_exact(c) {
        for (k, v) in row.iter().enumerate() {
            min[k] = min[k].min(*v);
            max[k] = max[k].max(*v);
        }
    }
    if values.is_empty() { (vec![0.0; c], vec![0.0; c]) } else { (min, max) }
}

fn is_glb(path: &Path) -> Result<bool, IoError> {
    match path.extension().map(|e| e.to_ascii_lowercase()) {
        Some(e) if e == "glb" => Ok(true),
        Some(e) if e == "gltf" => Ok(false),
        _ => Err(IoError::invalid_input(path, "a glTF file name must end in .glb (binary) or .gltf (JSON)")),
    }
}

/// The bytes of an image URI: a base64 `data:` URI or a file relative to the glTF's folder.
fn image_bytes(dir: &Path, uri: &str) -> Option<Vec<u8>> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let (header, payload) = rest.split_once(',')?;
        return header
            .ends_with(";base64")
            .then(|| base64::engine::general_purpose::STANDARD.decode(payload.trim()).ok())
            .flatten();
    }
    std::fs::read(dir.join(percent_decoded(uri))).ok()
}

fn percent_decoded(uri: &str) -> String {
    crate::gltf_binary::percent_decode(uri)
}

/// A relative path that stays inside its folder (no scheme, no `..`, not absolute).
fn is_plain_relative(uri: &str) -> bool {
    let path = Path::new(uri);
    !uri.contains(':') && path.is_relative() && !path.components().any(|c| matches!(c, std::path::Component::ParentDir))
}

fn same_dir(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// The MIME type of an image, from its `data:` header or its extension.
fn mime_type(uri: &str) -> String {
    if let Some(rest) = uri.strip_prefix("data:")
        && let Some((header, _)) = rest.split_once(';')
    {
        return header.to_string();
    }
    let ext = Path::new(uri).extension().map(|e| e.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    match ext.as_str() {
        "jpg" | "jpeg" => "image/jpeg",
        "webp" => "image/webp",
        "ktx2" => "image/ktx2",
        _ => "image/png",
    }
    .to_string()
}
