//! # squish-io — file formats for Squish
//!
//! Meshes in and out of the tools riggers and animators use: Wavefront OBJ, Stanford PLY (ASCII
//! and binary) and glTF 2.0 (`.gltf` and `.glb`, with node hierarchies, skins and animations),
//! converted into the core types of [`squish`] (`TriMesh`, `Skeleton`, `AnimationClip`, `Skin`,
//! `SkinWeights`).
//!
//! - [`read_mesh`] / [`write_mesh`] pick the format from the extension;
//! - every writer replaces its file atomically ([`write_atomically`]): an error never leaves a
//!   half-written file behind;
//! - every error ([`IoError`]) names the file, the place in it (line, byte offset or glTF
//!   element) and what to do about it.
//!
//! Scene files ([`scene`]) describe an animated shot — meshes, keyframed parameters, colliding
//! pairs, frames, outputs — and evaluate it frame by frame ([`Scene::evaluate`]).
//!
//! Readers keep the file's vertices exactly, in order and in number, so that per-vertex data and
//! frame-to-frame correspondence survive; glTF seams can be welded on request ([`WeldMode`]).

mod atomic;
mod error;
mod gltf_binary;
mod gltf_document;
mod gltf_read;
mod gltf_scene;
mod gltf_texture;
mod gltf_write;
mod morph;
mod obj;
mod pc2;
mod ply;
pub mod scene;
mod uvs;
mod weld;

use std::path::Path;

use glam::DVec3;
use squish::TriMesh;

pub use atomic::write_atomically;
pub use error::IoError;
pub use gltf_document::{GltfAttributeCounts, GltfDocument, MorphAnimation};
pub use gltf_read::{GltfReadOptions, read_gltf};
pub use gltf_scene::{
    GltfAnimation, GltfMesh, GltfNode, GltfScene, GltfSkin, InstancePose, MeshInstance, MorphWeightsTrack,
};
pub use gltf_texture::{GltfImage, base_color_image};
pub use gltf_write::{
    AnimatedMesh, GltfWriteOptions, NamedMesh, read_animated_glb, write_animated_glb, write_gltf, write_gltf_meshes,
};
pub use morph::{MorphFrame, MorphKeys, SparseDisplacement};
pub use obj::{ObjAttributeCounts, ObjDocument, parse_obj, read_obj, write_obj, write_obj_with};
pub use pc2::{PointCache, read_pc2, write_pc2};
pub use ply::{
    PlyColumn, PlyData, PlyDocument, PlyElement, PlyFormat, PlyProperty, PlyWriteOptions, ScalarType, VertexProperty,
    read_ply, read_ply_data, write_ply, write_ply_with, write_point_cloud_ply,
};
pub use scene::{Scene, SceneDescription, parse_frame_selection};
pub use uvs::{document_uvs, welded_uvs};
pub use weld::{WeldMode, Welded, weld_positions};

/// The mesh formats, recognized by extension (case-insensitive).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum MeshFormat {
    Obj,
    Ply,
    Gltf,
    Glb,
}

impl MeshFormat {
    /// The format of `path`, from its extension.
    pub fn from_path(path: &Path) -> Result<Self, IoError> {
        let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
        match ext.as_deref() {
            Some("obj") => Ok(Self::Obj),
            Some("ply") => Ok(Self::Ply),
            Some("gltf") => Ok(Self::Gltf),
            Some("glb") => Ok(Self::Glb),
            _ => Err(IoError::UnsupportedExtension { path: path.to_path_buf() }),
        }
    }
}

/// Reads a triangle mesh from `.obj`, `.ply`, `.gltf` or `.glb`, keeping the file's vertices.
/// For glTF: every mesh instance of the file, posed at rest (skinned meshes skinned by the rest
/// pose, others moved by their node's world transform), concatenated in node order; seams are
/// not welded (use [`read_mesh_with`]).
pub fn read_mesh(path: &Path) -> Result<TriMesh, IoError> {
    read_mesh_with(path, WeldMode::Off)
}

/// As [`read_mesh`], welding vertices first (glTF: per mesh, before posing; OBJ/PLY: the whole
/// mesh). Welding can drop triangles that collapse (only with a tolerance).
pub fn read_mesh_with(path: &Path, weld: WeldMode) -> Result<TriMesh, IoError> {
    let mesh = match MeshFormat::from_path(path)? {
        MeshFormat::Obj => read_obj(path)?,
        MeshFormat::Ply => read_ply(path)?,
        MeshFormat::Gltf | MeshFormat::Glb => {
            return read_gltf(path, &GltfReadOptions { weld })?.merged_mesh();
        }
    };
    if weld == WeldMode::Off {
        return Ok(mesh);
    }
    let welded = weld_positions(&mesh.positions, &mesh.triangles, weld);
    TriMesh::new(welded.positions, welded.triangles).map_err(|e| IoError::mesh(path, e))
}

/// Writes a mesh as `.obj`, `.ply` (binary little endian, doubles), `.gltf` (embedded buffer)
/// or `.glb`, atomically. glTF rounds coordinates to `f32`.
pub fn write_mesh(path: &Path, mesh: &TriMesh) -> Result<(), IoError> {
    match MeshFormat::from_path(path)? {
        MeshFormat::Obj => write_obj(path, mesh),
        MeshFormat::Ply => write_ply(path, mesh, &PlyWriteOptions::default()),
        MeshFormat::Gltf | MeshFormat::Glb => write_gltf(path, mesh, &GltfWriteOptions::default()),
    }
}

/// A mesh file kept whole, of any format, for writing results back into it: "the input
/// document + new positions → the output document". Deformation changes positions (and the
/// normals that follow from them); everything else the file holds comes out unchanged (see
/// [`ObjDocument`], [`PlyDocument`], [`GltfDocument`]).
#[derive(Clone, Debug)]
pub enum MeshDocument {
    Obj(ObjDocument),
    Ply(PlyDocument),
    Gltf(Box<GltfDocument>),
}

impl MeshDocument {
    /// Reads `.obj`, `.ply`, `.gltf` or `.glb` (by extension), keeping the whole file.
    pub fn read(path: &Path) -> Result<Self, IoError> {
        Ok(match MeshFormat::from_path(path)? {
            MeshFormat::Obj => Self::Obj(ObjDocument::read(path)?),
            MeshFormat::Ply => Self::Ply(PlyDocument::read(path)?),
            MeshFormat::Gltf | MeshFormat::Glb => Self::Gltf(Box::new(GltfDocument::read(path)?)),
        })
    }

    /// The file read.
    pub fn path(&self) -> &Path {
        match self {
            Self::Obj(d) => d.path(),
            Self::Ply(d) => d.path(),
            Self::Gltf(d) => d.path(),
        }
    }

    /// The mesh of the file, vertices in file order: what [`read_mesh`] returns, and the
    /// vertices [`Self::write_with_positions`] takes positions for.
    pub fn mesh(&self) -> Result<TriMesh, IoError> {
        match self {
            Self::Obj(d) => Ok(d.mesh().clone()),
            Self::Ply(d) => d.mesh(),
            Self::Gltf(d) => d.mesh(),
        }
    }

    /// True if writing to `path` keeps the file's other contents: the output's format is the
    /// document's (glTF and GLB count as one). Otherwise positions and faces alone are written.
    pub fn passes_through_to(&self, path: &Path) -> bool {
        matches!(
            (self, MeshFormat::from_path(path)),
            (Self::Obj(_), Ok(MeshFormat::Obj))
                | (Self::Ply(_), Ok(MeshFormat::Ply))
                | (Self::Gltf(_), Ok(MeshFormat::Gltf | MeshFormat::Glb))
        )
    }

    /// Writes `positions` (one per vertex of [`Self::mesh`]) to `path`, atomically: into a copy
    /// of the document when [`Self::passes_through_to`] holds, else as a mesh of the output's
    /// format: positions and faces, and for a glTF document its first UV set and normals
    /// ([`GltfDocument::write_converted`]).
    pub fn write_with_positions(&self, path: &Path, positions: &[DVec3]) -> Result<(), IoError> {
        if self.passes_through_to(path) {
            return match self {
                Self::Obj(d) => {
                    d.write_with_positions(path, positions)?;
                    d.copy_material_libraries(path).map(|_| ())
                }
                Self::Ply(d) => d.write_with_positions(path, positions),
                Self::Gltf(d) => d.write_with_positions(path, positions),
            };
        }
        if let Self::Gltf(d) = self {
            // UVs and normals, which OBJ and PLY hold too.
            return d.write_converted(path, None, positions);
        }
        let mesh = self.mesh()?;
        if positions.len() != mesh.num_vertices() {
            return Err(IoError::invalid_input(
                path,
                format!(
                    "{} positions for the {} vertices of {}",
                    positions.len(),
                    mesh.num_vertices(),
                    self.path().display()
                ),
            ));
        }
        write_mesh(path, &TriMesh { positions: positions.to_vec(), triangles: mesh.triangles })
    }
}
