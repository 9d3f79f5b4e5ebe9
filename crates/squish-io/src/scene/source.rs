//! Mesh sources, loaded once when the scene loads and read-only afterwards (so a scene is
//! `Send + Sync` and frames can be evaluated on any thread in any order):
//!
//! - a static file: the mesh, welded if asked;
//! - a sequence: the pattern, plus a reference frame (the first file of the scene's range that
//!   exists) whose topology every other frame must match, and whose weld map every frame
//!   reuses — welding each frame on its own could merge different vertices on different
//!   frames;
//! - a glTF node: the parsed file (shared between objects of the same file) and the node and
//!   animation to pose; posing a frame is morphs + skinning on the stored arrays, no parsing.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use squish::TriMesh;

use super::frames::FramePattern;
use super::types::{GltfSource, MeshSource, Weld};
use squish::params::Uvs;

use crate::{
    GltfReadOptions, GltfScene, IoError, MeshDocument, MeshFormat, WeldMode, document_uvs, read_gltf, read_mesh,
    weld_positions, welded_uvs,
};

/// How the object's vertices relate to the file's: per-vertex data may be given in either
/// numbering.
#[derive(Clone, Debug)]
pub(crate) struct VertexNumbering {
    /// Vertices of the object (after welding).
    pub(crate) count: usize,
    /// Vertices in the file (before welding).
    pub(crate) file_count: usize,
    /// For each file vertex, its object vertex (when welding merged some).
    pub(crate) file_to_vertex: Option<Vec<u32>>,
}

/// A loaded mesh source.
#[derive(Debug)]
pub(crate) enum SourceAssets {
    Static(TriMesh),
    Sequence(SequenceAssets),
    Gltf(GltfAssets),
}

#[derive(Debug)]
pub(crate) struct SequenceAssets {
    pub(crate) pattern: FramePattern,
    pub(crate) reference_frame: i64,
    pub(crate) reference_path: PathBuf,
    /// The reference file's vertex count and triangles, as read.
    pub(crate) file_vertex_count: usize,
    pub(crate) file_triangles: Vec<[u32; 3]>,
    /// With welding: the file vertex kept for each object vertex, and the welded triangles.
    pub(crate) weld: Option<(Vec<u32>, Vec<[u32; 3]>)>,
}

#[derive(Debug)]
pub(crate) struct GltfAssets {
    pub(crate) scene: Arc<GltfScene>,
    pub(crate) node: usize,
    pub(crate) animation: Option<usize>,
    pub(crate) duration: f64,
    /// Scene frame at which animation time 0 plays.
    pub(crate) start_frame: f64,
    pub(crate) fps: f64,
    pub(crate) repeat: bool,
}

impl GltfAssets {
    /// Animation time of a scene frame: `(frame − start_frame) / fps`, wrapped into the clip's
    /// duration when repeating.
    pub(crate) fn time(&self, frame: f64) -> f64 {
        let t = (frame - self.start_frame) / self.fps;
        if self.repeat && self.duration > 0.0 { t.rem_euclid(self.duration) } else { t }
    }
}

/// glTF files parsed so far, by path and welding, so that objects sharing a file parse it once.
#[derive(Default)]
pub(crate) struct GltfCache {
    files: HashMap<(PathBuf, String), Arc<GltfScene>>,
}

impl GltfCache {
    pub(crate) fn get(&mut self, path: &Path, weld: WeldMode) -> Result<Arc<GltfScene>, IoError> {
        let key = (path.to_path_buf(), format!("{weld:?}"));
        if let Some(scene) = self.files.get(&key) {
            return Ok(scene.clone());
        }
        let scene = Arc::new(read_gltf(path, &GltfReadOptions { weld })?);
        self.files.insert(key, scene.clone());
        Ok(scene)
    }
}

/// Loads an object's mesh source. `object` names it in messages; `frames` is the scene's range
/// (a sequence's reference frame is searched in it); `fps` converts frames to glTF time.
pub(crate) fn load_source(
    object: &str,
    source: &MeshSource,
    frames: (i64, i64),
    fps: f64,
    cache: &mut GltfCache,
) -> Result<(SourceAssets, VertexNumbering), IoError> {
    match source {
        MeshSource::File { file, weld } => {
            let mesh = read_static(file)?;
            let file_count = mesh.num_vertices();
            if *weld == Weld::Off {
                let numbering = VertexNumbering { count: file_count, file_count, file_to_vertex: None };
                return Ok((SourceAssets::Static(mesh), numbering));
            }
            let welded = weld_positions(&mesh.positions, &mesh.triangles, weld.mode());
            let numbering =
                VertexNumbering { count: welded.positions.len(), file_count, file_to_vertex: Some(welded.vertex_map) };
            let mesh = TriMesh::new(welded.positions, welded.triangles).map_err(|e| IoError::mesh(file, e))?;
            Ok((SourceAssets::Static(mesh), numbering))
        }
        MeshSource::Sequence { pattern, weld } => load_sequence(object, pattern, *weld, frames),
        MeshSource::Gltf(g) => load_gltf(object, g, frames.0, fps, cache),
    }
}

/// Reads an OBJ or PLY file (glTF sources go through [`load_gltf`]).
fn read_static(path: &Path) -> Result<TriMesh, IoError> {
    match MeshFormat::from_path(path)? {
        MeshFormat::Obj | MeshFormat::Ply => read_mesh(path),
        MeshFormat::Gltf | MeshFormat::Glb => Err(IoError::format(
            path,
            "a glTF file in a mesh sequence is not supported; use one animated glTF, or OBJ / PLY frames",
        )),
    }
}

fn pattern_of(pattern: &Path) -> Result<FramePattern, IoError> {
    let text = pattern
        .to_str()
        .ok_or_else(|| IoError::format(pattern, "the sequence path is not valid UTF-8; rename the folder or files"))?;
    FramePattern::parse(text).map_err(|e| IoError::format(pattern, e))
}

fn load_sequence(
    object: &str,
    pattern: &Path,
    weld: Weld,
    (start, end): (i64, i64),
) -> Result<(SourceAssets, VertexNumbering), IoError> {
    let pattern = pattern_of(pattern)?;
    let Some(reference_frame) = (start..=end).find(|&f| pattern.path(f).is_file()) else {
        return Err(IoError::format(
            &pattern.path(start),
            format!(
                "no file of the mesh sequence of object \"{object}\" exists for frames {start} to {end} (this is frame {start}'s expected path); check the folder and the {{frame}} pattern"
            ),
        ));
    };
    let reference_path = pattern.path(reference_frame);
    let mesh = read_static(&reference_path)?;
    let file_count = mesh.num_vertices();
    let (weld, numbering) = if weld == Weld::Off {
        (None, VertexNumbering { count: file_count, file_count, file_to_vertex: None })
    } else {
        let w = weld_positions(&mesh.positions, &mesh.triangles, weld.mode());
        let numbering =
            VertexNumbering { count: w.positions.len(), file_count, file_to_vertex: Some(w.vertex_map.clone()) };
        (Some((w.representatives, w.triangles)), numbering)
    };
    let assets = SequenceAssets {
        pattern,
        reference_frame,
        reference_path,
        file_vertex_count: file_count,
        file_triangles: mesh.triangles,
        weld,
    };
    Ok((SourceAssets::Sequence(assets), numbering))
}

impl SequenceAssets {
    /// The object's mesh at whole frame `frame`: the file read, checked against the reference
    /// topology, welded like the reference.
    pub(crate) fn mesh_at(&self, object: &str, frame: i64) -> Result<TriMesh, IoError> {
        let path = self.pattern.path(frame);
        if !path.is_file() {
            return Err(IoError::format(
                &path,
                format!(
                    "frame {frame} of the mesh sequence of object \"{object}\" is missing (this is its expected path); export that frame or shorten `frames`"
                ),
            ));
        }
        let mesh = read_static(&path)?;
        if mesh.num_vertices() != self.file_vertex_count || mesh.triangles != self.file_triangles {
            let detail =
                if mesh.num_vertices() != self.file_vertex_count || mesh.num_triangles() != self.file_triangles.len() {
                    format!(
                        "{} vertices and {} triangles, but frame {} ({}) has {} and {}",
                        mesh.num_vertices(),
                        mesh.num_triangles(),
                        self.reference_frame,
                        self.reference_path.display(),
                        self.file_vertex_count,
                        self.file_triangles.len()
                    )
                } else {
                    format!(
                        "the same counts but different triangles than frame {} ({})",
                        self.reference_frame,
                        self.reference_path.display()
                    )
                };
            return Err(IoError::format(
                &path,
                format!(
                    "frame {frame} of object \"{object}\" has {detail}; every frame of a sequence needs the same vertices and triangles in the same order (export with a fixed topology, without remeshing or modifiers that change it)"
                ),
            ));
        }
        match &self.weld {
            None => Ok(mesh),
            Some((representatives, triangles)) => {
                let positions = representatives.iter().map(|&v| mesh.positions[v as usize]).collect();
                TriMesh::new(positions, triangles.clone()).map_err(|e| IoError::mesh(&path, e))
            }
        }
    }

    /// Positions at a possibly fractional frame: linear between the two neighbouring files.
    pub(crate) fn mesh_at_fractional(&self, object: &str, frame: f64) -> Result<TriMesh, IoError> {
        let lo = frame.floor();
        let s = frame - lo;
        let lo = lo as i64;
        let mut mesh = self.mesh_at(object, lo)?;
        if s > 0.0 {
            let hi = self.mesh_at(object, lo + 1)?;
            for (p, q) in mesh.positions.iter_mut().zip(&hi.positions) {
                *p += (*q - *p) * s;
            }
        }
        Ok(mesh)
    }
}

fn load_gltf(
    object: &str,
    g: &GltfSource,
    scene_start: i64,
    fps: f64,
    cache: &mut GltfCache,
) -> Result<(SourceAssets, VertexNumbering), IoError> {
    let scene = cache.get(&g.file, g.weld.mode())?;
    let instances = scene.instances();
    let node_label = |i: usize| format!("\"{}\"", scene.nodes[i].name);
    let mesh_nodes: Vec<String> = instances.iter().map(|inst| node_label(inst.node)).collect();
    let node = match &g.node {
        Some(name) => {
            let named: Vec<usize> = (0..scene.nodes.len()).filter(|&i| scene.nodes[i].name == *name).collect();
            match named.iter().find(|&&i| scene.nodes[i].mesh.is_some()) {
                Some(&i) => i,
                None => {
                    let names: Vec<&str> = instances.iter().map(|inst| scene.nodes[inst.node].name.as_str()).collect();
                    let hint = match squish::params::did_you_mean(name, &names) {
                        Some(s) => format!(" (did you mean \"{s}\"?)"),
                        None => String::new(),
                    };
                    let what = if named.is_empty() { "no node is named" } else { "the node has no mesh:" };
                    return Err(IoError::format(
                        &g.file,
                        format!(
                            "object \"{object}\": {what} \"{name}\"{hint}; nodes with a mesh: {}",
                            mesh_nodes.join(", ")
                        ),
                    ));
                }
            }
        }
        None => match instances.as_slice() {
            [one] => one.node,
            [] => {
                return Err(IoError::format(
                    &g.file,
                    format!("object \"{object}\": the file has no node with a mesh; export the mesh object"),
                ));
            }
            _ => {
                return Err(IoError::format(
                    &g.file,
                    format!(
                        "object \"{object}\": the file has {} nodes with a mesh ({}); choose one with mesh = {{ file = …, node = \"…\" }}",
                        instances.len(),
                        mesh_nodes.join(", ")
                    ),
                ));
            }
        },
    };
    let names: Vec<&str> = scene.animations.iter().map(|a| a.name.as_str()).collect();
    let quoted = || names.iter().map(|n| format!("\"{n}\"")).collect::<Vec<_>>().join(", ");
    let animation = match &g.animation {
        Some(name) => match scene.find_animation(name) {
            Some(a) => Some(a),
            None => {
                let hint = match squish::params::did_you_mean(name, &names) {
                    Some(s) => format!(" (did you mean \"{s}\"?)"),
                    None => String::new(),
                };
                let list = if names.is_empty() {
                    "the file has none".to_string()
                } else {
                    format!("the file has {}", quoted())
                };
                return Err(IoError::format(
                    &g.file,
                    format!("object \"{object}\": no animation is named \"{name}\"{hint}; {list}"),
                ));
            }
        },
        None => match names.len() {
            0 => None,
            1 => Some(0),
            _ => {
                return Err(IoError::format(
                    &g.file,
                    format!(
                        "object \"{object}\": the file has {} animations ({}); choose one with mesh = {{ file = …, animation = \"…\" }}",
                        names.len(),
                        quoted()
                    ),
                ));
            }
        },
    };
    let scene = match animation {
        Some(a) if g.amplitude != 1.0 => Arc::new(scene.with_amplified_rotations(a, g.amplitude)?),
        None if g.amplitude != 1.0 => {
            return Err(IoError::format(
                &g.file,
                format!("object \"{object}\": `amplitude` scales an animation, and the file has none; remove it"),
            ));
        }
        _ => scene,
    };
    let mesh_index = scene.nodes[node].mesh.unwrap_or_default();
    let gltf_mesh = &scene.meshes[mesh_index];
    let numbering = VertexNumbering {
        count: gltf_mesh.positions.len(),
        file_count: gltf_mesh.file_vertex_count,
        file_to_vertex: gltf_mesh.vertex_map.clone(),
    };
    // Checks the pose once here so that a broken skin or clip fails at load, not on frame 37.
    let duration = animation.map_or(0.0, |a| scene.animations[a].duration());
    let assets = GltfAssets {
        scene: scene.clone(),
        node,
        animation,
        duration,
        start_frame: g.start_frame.unwrap_or(scene_start as f64),
        fps,
        repeat: g.repeat,
    };
    scene.posed_mesh(node, animation, 0.0)?;
    Ok((SourceAssets::Gltf(assets), numbering))
}

/// The untransformed mesh of a source at `frame`.
pub(crate) fn source_mesh(object: &str, source: &SourceAssets, frame: f64) -> Result<TriMesh, IoError> {
    match source {
        SourceAssets::Static(mesh) => Ok(mesh.clone()),
        SourceAssets::Sequence(seq) => seq.mesh_at_fractional(object, frame),
        SourceAssets::Gltf(g) => g.scene.posed_mesh(g.node, g.animation, g.time(frame)),
    }
}

/// The texture coordinates of a loaded source in the object's numbering (`crate::uvs`), or why
/// it has none: a static file (`file`) or a sequence's reference file read again as a document
/// (UVs are the same on every frame of a sequence), a glTF node's mesh as loaded.
pub(crate) fn source_uvs(source: &SourceAssets, file: &Path, numbering: &VertexNumbering) -> Result<Uvs, String> {
    let path = match source {
        SourceAssets::Gltf(g) => {
            let mesh = g.scene.nodes[g.node].mesh.and_then(|m| g.scene.meshes.get(m));
            return mesh
                .and_then(|m| m.corner_uvs.clone())
                .map(Uvs::PerCorner)
                .ok_or_else(|| "a primitive of its mesh has no TEXCOORD_0".to_string());
        }
        SourceAssets::Static(_) => file,
        SourceAssets::Sequence(seq) => seq.reference_path.as_path(),
    };
    let document = MeshDocument::read(path).map_err(|e| e.to_string())?;
    let uvs = document_uvs(&document)?;
    match &numbering.file_to_vertex {
        Some(map) => Ok(welded_uvs(&uvs, &document.mesh().map_err(|e| e.to_string())?.triangles, map)),
        None => Ok(uvs),
    }
}

/// Averages per-file-vertex values onto the object's vertices.
pub(crate) fn to_object_vertices(values: &[f64], numbering: &VertexNumbering) -> Option<Vec<f64>> {
    if values.len() == numbering.count {
        return Some(values.to_vec());
    }
    let map = numbering.file_to_vertex.as_ref()?;
    if values.len() != numbering.file_count || map.len() != values.len() {
        return None;
    }
    let mut sum = vec![0.0; numbering.count];
    let mut n = vec![0u32; numbering.count];
    for (&v, &x) in map.iter().zip(values) {
        sum[v as usize] += x;
        n[v as usize] += 1;
    }
    Some(sum.iter().zip(&n).map(|(s, &k)| if k > 0 { s / k as f64 } else { 0.0 }).collect())
}
