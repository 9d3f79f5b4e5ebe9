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
use squish_shot::files::output_dir_error;

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

/// Says on stderr which stems are not UTF-8: the output files keep their exact bytes, but the
/// console, report.json (JSON text is Unicode) and object names show the undecodable bytes as
/// U+FFFD.
pub fn note_undecodable_names(stems: &[OsString; 2]) {
    for stem in stems {
        if stem.to_str().is_none() {
            eprintln!(
                "note: the file name {} is not UTF-8: the output files keep its bytes, messages and report.json show them as U+FFFD",
                stem.to_string_lossy()
            );
        }
    }
}

/// Outputs written into a hidden staging folder inside the output folder, then moved into it
/// together ([`StagedOutputs::commit`]): a command that fails halfway leaves none of its new
/// files, and the files of an earlier run stay as they were. Dropped without a commit, the
/// staging folder and what it holds are deleted.
pub struct StagedOutputs {
    dir: PathBuf,
    staging: tempfile::TempDir,
}

impl StagedOutputs {
    /// A staging folder inside `dir` (which must exist).
    pub fn new(dir: &Path) -> Result<Self, CliError> {
        let staging = tempfile::Builder::new()
            .prefix(".squish-staging.")
            .suffix(".tmp")
            .tempdir_in(dir)
            .map_err(|e| output_dir_error(dir, "write into", e))?;
        Ok(Self { dir: dir.to_path_buf(), staging })
    }

    /// Where to write the output that ends up at `final_path` (a path inside the output folder).
    pub fn path(&self, final_path: &Path) -> PathBuf {
        let name = final_path.file_name().unwrap_or(final_path.as_os_str());
        self.staging.path().join(name)
    }

    /// Moves every staged file into the output folder (renames within one file system).
    pub fn commit(self) -> Result<(), CliError> {
        let entries = std::fs::read_dir(self.staging.path())
            .map_err(|e| CliError::failure(format!("cannot list {}: {e}", self.staging.path().display())))?;
        let mut names: Vec<std::ffi::OsString> = entries.flatten().map(|e| e.file_name()).collect();
        names.sort();
        // A folder where a file goes is the one thing that makes a rename within a folder fail:
        // checked for every file before the first is moved.
        if let Some(name) = names.iter().find(|name| self.dir.join(name).is_dir()) {
            return Err(CliError::input(format!(
                "cannot write {}: a folder of that name is in the way; move it, or give -o another folder (nothing was written)",
                self.dir.join(name).display()
            )));
        }
        for name in names {
            let target = self.dir.join(&name);
            std::fs::rename(self.staging.path().join(&name), &target).map_err(|e| {
                CliError::failure(format!("cannot move the output {} into place: {e}", target.display()))
            })?;
        }
        Ok(())
    }
}
