//! A scene file as a shot: each frame of the scene ([`Scene::evaluate`], the library's owned
//! frame with every pair; the library leaves out the pairs disabled at a frame), and each
//! object's file numbering, so that results are written
//! with the vertices of the input file — same count, same order — even when the scene layer
//! welded them (glTF seams, `weld = true`).

use std::path::PathBuf;

use glam::DVec3;
use squish::TriMesh;
use squish_io::scene::{FramePattern, MeshSource, Weld};
use squish_io::{GltfReadOptions, Scene, WeldMode, read_gltf, read_mesh, weld_positions};

use crate::error::ShotError;
use crate::shot::ShotSource;
use squish::pipeline::OwnedFrame;

/// A loaded scene as a [`ShotSource`].
pub struct SceneShot<'a> {
    pub scene: &'a Scene,
}

impl ShotSource for SceneShot<'_> {
    fn frame(&self, frame: i64) -> Result<OwnedFrame, ShotError> {
        Ok(self.scene.evaluate(frame as f64)?)
    }
}

/// How an object's processed vertices relate to its file's.
#[derive(Clone, Debug)]
pub struct FileNumbering {
    /// The file's triangles, in file numbering.
    pub triangles: Vec<[u32; 3]>,
    /// For each file vertex, its processed vertex (`None`: the same numbering).
    pub vertex_map: Option<Vec<u32>>,
    /// Why the file numbering could not be rebuilt, if it could not (the results are then
    /// written with the processed, welded vertices).
    pub note: Option<String>,
}

impl FileNumbering {
    /// Number of vertices written.
    pub fn vertex_count(&self, processed: usize) -> usize {
        self.vertex_map.as_ref().map_or(processed, Vec::len)
    }

    /// Processed positions expanded to the file's vertices.
    pub fn positions(&self, positions: &[DVec3]) -> Vec<DVec3> {
        match &self.vertex_map {
            Some(map) => map.iter().map(|&v| positions[v as usize]).collect(),
            None => positions.to_vec(),
        }
    }

    /// The mesh to write.
    pub fn file_mesh(&self, positions: &[DVec3]) -> TriMesh {
        TriMesh { positions: self.positions(positions), triangles: self.triangles.clone() }
    }
}

/// The file numbering of every object of `scene`, given the objects at one frame (`reference`).
///
/// The scene layer welds some sources (glTF by default, OBJ/PLY with `weld = …`) and keeps no
/// public trace of the file's vertices, so this re-reads the source once and welds it the same
/// way (welding is deterministic), then checks the result against the scene's own mesh. When the
/// check fails, results keep the scene's vertices and the note says so.
pub fn file_numbering(scene: &Scene, reference: &OwnedFrame) -> Vec<FileNumbering> {
    let description = scene.description();
    description
        .objects
        .iter()
        .zip(&reference.objects)
        .map(|(spec, object)| {
            let same = |note: Option<String>| FileNumbering {
                triangles: object.mesh.triangles.clone(),
                vertex_map: None,
                note,
            };
            if spec.mesh.weld() == Weld::Off {
                return same(None);
            }
            let file = match source_file_mesh(&spec.mesh, scene) {
                Ok(mesh) => mesh,
                Err(why) => return same(Some(why)),
            };
            let welded = weld_positions(&file.positions, &file.triangles, spec.mesh.weld().mode());
            if welded.triangles != object.mesh.triangles || welded.positions.len() != object.mesh.num_vertices() {
                return same(Some(format!(
                    "the welded file mesh ({} vertices) does not match the scene's ({} vertices)",
                    welded.positions.len(),
                    object.mesh.num_vertices()
                )));
            }
            FileNumbering { triangles: file.triangles, vertex_map: Some(welded.vertex_map), note: None }
        })
        .map(|mut n| {
            if let Some(note) = &mut n.note {
                *note = format!("{note}; results are written with the welded vertices");
            }
            n
        })
        .collect()
}

/// The unwelded mesh of a source, as in its file (the rest pose for glTF: only the numbering
/// and triangles are used).
fn source_file_mesh(source: &MeshSource, scene: &Scene) -> Result<TriMesh, String> {
    match source {
        MeshSource::File { file, .. } => read_mesh(file).map_err(|e| e.to_string()),
        MeshSource::Sequence { pattern, .. } => {
            // The scene welds every frame like the first file of its range that exists.
            let text = pattern.to_str().ok_or("the sequence path is not UTF-8")?;
            let pattern = FramePattern::parse(text)?;
            let reference: Option<PathBuf> = scene.frames().map(|f| pattern.path(f)).find(|p| p.is_file());
            let path = reference.ok_or("no file of the sequence exists")?;
            read_mesh(&path).map_err(|e| e.to_string())
        }
        MeshSource::Gltf(g) => {
            let file = read_gltf(&g.file, &GltfReadOptions { weld: WeldMode::Off }).map_err(|e| e.to_string())?;
            let instances = file.instances();
            let node = match &g.node {
                Some(name) => instances.iter().find(|i| file.nodes[i.node].name == *name),
                None => instances.first().filter(|_| instances.len() == 1),
            }
            .ok_or("cannot find the node's mesh")?;
            let mesh = file.meshes.get(node.mesh).ok_or("cannot find the node's mesh")?;
            Ok(TriMesh { positions: mesh.positions.clone(), triangles: mesh.triangles.clone() })
        }
    }
}
