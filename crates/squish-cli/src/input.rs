//! Meshes read from files for the two-object commands, with the bookkeeping that keeps outputs
//! in the file's own vertex order: glTF files duplicate vertices along UV seams, so they are
//! welded (exact duplicates) for processing and the results are mapped back to every file vertex.
//! Each input is kept whole ([`MeshDocument`]), so that results written in the input's format
//! keep everything else the file holds (UVs, materials, skins, extra properties).

use std::ffi::{OsStr, OsString};
use std::path::{Path, PathBuf};

use glam::DVec3;
use squish::TriMesh;
use squish_io::{MeshDocument, MeshFormat, WeldMode, Welded, weld_positions};

use crate::error::CliError;

/// When to weld exact duplicate positions before processing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum WeldChoice {
    /// glTF files only (their seams duplicate vertices).
    #[default]
    Auto,
    /// Always.
    Always,
    /// Never.
    Never,
}

/// A mesh read from a file, ready for the deformer.
pub struct InputMesh {
    pub path: PathBuf,
    pub format: MeshFormat,
    /// The whole file, for writing results back into it.
    pub document: MeshDocument,
    /// The file's mesh, vertices in file order.
    pub file: TriMesh,
    /// The mesh the deformer works on (welded, or the file's mesh).
    pub mesh: TriMesh,
    /// File vertex → processed vertex when welded.
    welded: Option<Vec<u32>>,
}

impl InputMesh {
    /// Reads `path` and welds it according to `weld`.
    pub fn read(path: &Path, weld: WeldChoice) -> Result<Self, CliError> {
        let format = MeshFormat::from_path(path)?;
        let document = MeshDocument::read(path)?;
        let file = document.mesh()?;
        let do_weld = match weld {
            WeldChoice::Auto => matches!(format, MeshFormat::Gltf | MeshFormat::Glb),
            WeldChoice::Always => true,
            WeldChoice::Never => false,
        };
        let (mesh, welded) = if do_weld {
            let Welded { positions, triangles, vertex_map, collapsed_triangles, .. } =
                weld_positions(&file.positions, &file.triangles, WeldMode::Exact);
            if collapsed_triangles > 0 {
                return Err(CliError::input(format!(
                    "{}: welding duplicate vertices collapsed {collapsed_triangles} triangles; use --weld never",
                    path.display()
                )));
            }
            (TriMesh { positions, triangles }, Some(vertex_map))
        } else {
            (file.clone(), None)
        };
        Ok(Self { path: path.to_path_buf(), format, document, file, mesh, welded })
    }

    /// File vertex → processed vertex, when the file was welded.
    pub fn weld_map(&self) -> Option<&[u32]> {
        self.welded.as_deref()
    }

    /// The file name without its extension, byte for byte (a name that is not UTF-8 stays as
    /// it is in the output names).
    pub fn stem(&self) -> OsString {
        self.path.file_stem().map_or_else(|| OsString::from("mesh"), OsStr::to_os_string)
    }

    /// Processed positions expanded back to the file's vertices (same order and count).
    pub fn to_file_positions(&self, positions: &[DVec3]) -> Vec<DVec3> {
        match &self.welded {
            Some(map) => map.iter().map(|&v| positions[v as usize]).collect(),
            None => positions.to_vec(),
        }
    }

    /// Per processed vertex values expanded to the file's vertices.
    pub fn to_file_values<T: Copy>(&self, values: &[T]) -> Vec<T> {
        match &self.welded {
            Some(map) => map.iter().map(|&v| values[v as usize]).collect(),
            None => values.to_vec(),
        }
    }

    /// Writes processed positions to `path`: into a copy of the input when the formats match
    /// (everything but positions and normals kept), else as a plain mesh.
    pub fn write_result(&self, path: &Path, positions: &[DVec3]) -> Result<(), CliError> {
        self.document.write_with_positions(path, &self.to_file_positions(positions))?;
        Ok(())
    }
}

/// Output format choice.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum FormatChoice {
    Obj,
    Ply,
    Glb,
    Gltf,
}

impl FormatChoice {
    /// The file extension.
    pub fn extension(self) -> &'static str {
        match self {
            Self::Obj => "obj",
            Self::Ply => "ply",
            Self::Glb => "glb",
            Self::Gltf => "gltf",
        }
    }

    /// The extension of an input format (to write results like the input).
    pub fn extension_of(format: MeshFormat) -> &'static str {
        match format {
            MeshFormat::Obj => "obj",
            MeshFormat::Ply => "ply",
            MeshFormat::Gltf => "gltf",
            MeshFormat::Glb => "glb",
        }
    }
}

/// Output names for two inputs: their stems, disambiguated when equal.
pub fn output_stems(a: &InputMesh, b: &InputMesh) -> [OsString; 2] {
    let (mut sa, mut sb) = (a.stem(), b.stem());
    if sa == sb {
        sa.push("_a");
        sb.push("_b");
    }
    [sa, sb]
}

/// `dir/<stem>.<ext>`, keeping the stem's bytes.
pub fn output_path(dir: &Path, stem: &OsStr, extension: &str) -> PathBuf {
    let mut name = stem.to_os_string();
    name.push(".");
    name.push(extension);
    dir.join(name)
}

/// The stems as names for messages and reports (bytes that are not UTF-8 shown as U+FFFD).
pub fn display_names(stems: &[OsString; 2]) -> [String; 2] {
    [0, 1].map(|i| stems[i].to_string_lossy().into_owned())
}

/// Creates the output directory (and parents).
pub fn create_dir(dir: &Path) -> Result<(), CliError> {
    std::fs::create_dir_all(dir)
        .map_err(|e| CliError::failure(format!("cannot create the output directory {}: {e}", dir.display())))
}

/// Writes `text` to `path` atomically.
pub fn write_text(path: &Path, text: &str) -> Result<(), CliError> {
    squish_io::write_atomically(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), CliError> {
    squish_io::write_atomically(path, |w| w.write_all(bytes))?;
    Ok(())
}
