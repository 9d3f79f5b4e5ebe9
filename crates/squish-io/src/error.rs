//! The error type of every reader and writer. Each error names the file and, where the format
//! has one, the place in it (line for text formats, byte offset for binary data, element for
//! glTF), says what is wrong, and hints at the fix: the people reading these messages are artists
//! and TDs who need to know which exporter setting to change.

use std::path::{Path, PathBuf};

use squish::MeshError;
use squish::animation::AnimationError;
use squish::skinning::SkinError;

/// Errors of `squish-io`.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    /// The operating system refused an operation (missing file, permissions, full disk).
    #[error("cannot {action} {}: {source}{}", .path.display(), io_hint(.source))]
    Io {
        path: PathBuf,
        /// What was being done, e.g. "open", "read", "write".
        action: &'static str,
        source: std::io::Error,
    },
    /// The extension names no supported format.
    #[error("{}: unknown mesh format {}; use a file ending in .obj, .ply, .gltf or .glb", .path.display(), describe_extension(.path))]
    UnsupportedExtension { path: PathBuf },
    /// A problem on a line of a text file (OBJ, ASCII PLY and PLY headers).
    #[error("{}:{line}: {message}", .path.display())]
    Line { path: PathBuf, line: usize, message: String },
    /// A problem at a byte offset of binary data (binary PLY, GLB).
    #[error("{}: at byte {offset}: {message}", .path.display())]
    Offset { path: PathBuf, offset: u64, message: String },
    /// A problem in a named element (glTF accessor, primitive, node, skin, animation …).
    #[error("{}: {element}: {message}", .path.display())]
    Element { path: PathBuf, element: String, message: String },
    /// A problem with the file as a whole (e.g. invalid JSON, nothing to read).
    #[error("{}: {message}", .path.display())]
    Format { path: PathBuf, message: String },
    /// The data read is not a valid mesh.
    #[error("{}: {source}", .path.display())]
    Mesh { path: PathBuf, source: MeshError },
    /// Skin data read from `element` is invalid.
    #[error("{}: {element}: {source}", .path.display())]
    Skin { path: PathBuf, element: String, source: SkinError },
    /// Animation data read from `element` is invalid.
    #[error("{}: {element}: {source}", .path.display())]
    Animation { path: PathBuf, element: String, source: AnimationError },
    /// A writer was given data it cannot write (nothing was written).
    #[error("cannot write {}: {message}", .path.display())]
    InvalidInput { path: PathBuf, message: String },
}

impl IoError {
    /// The file the error is about.
    pub fn path(&self) -> &Path {
        match self {
            Self::Io { path, .. }
            | Self::UnsupportedExtension { path }
            | Self::Line { path, .. }
            | Self::Offset { path, .. }
            | Self::Element { path, .. }
            | Self::Format { path, .. }
            | Self::Mesh { path, .. }
            | Self::Skin { path, .. }
            | Self::Animation { path, .. }
            | Self::InvalidInput { path, .. } => path,
        }
    }

    pub(crate) fn io(path: &Path, action: &'static str, source: std::io::Error) -> Self {
        Self::Io { path: path.to_path_buf(), action, source }
    }

    pub(crate) fn line(path: &Path, line: usize, message: impl Into<String>) -> Self {
        Self::Line { path: path.to_path_buf(), line, message: message.into() }
    }

    pub(crate) fn offset(path: &Path, offset: u64, message: impl Into<String>) -> Self {
        Self::Offset { path: path.to_path_buf(), offset, message: message.into() }
    }

    pub(crate) fn element(path: &Path, element: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Element { path: path.to_path_buf(), element: element.into(), message: message.into() }
    }

    pub(crate) fn format(path: &Path, message: impl Into<String>) -> Self {
        Self::Format { path: path.to_path_buf(), message: message.into() }
    }

    pub(crate) fn mesh(path: &Path, source: MeshError) -> Self {
        Self::Mesh { path: path.to_path_buf(), source }
    }

    pub(crate) fn invalid_input(path: &Path, message: impl Into<String>) -> Self {
        Self::InvalidInput { path: path.to_path_buf(), message: message.into() }
    }
}

fn io_hint(error: &std::io::Error) -> &'static str {
    match error.kind() {
        std::io::ErrorKind::NotFound => {
            " (check the path and spelling; relative paths start from the current directory)"
        }
        std::io::ErrorKind::PermissionDenied => " (check the file and folder permissions)",
        std::io::ErrorKind::IsADirectory => " (it is a folder: give the path of a file in it)",
        std::io::ErrorKind::UnexpectedEof => " (the file is truncated; export it again)",
        _ => "",
    }
}

fn describe_extension(path: &Path) -> String {
    match path.extension() {
        Some(ext) => format!("'.{}'", ext.to_string_lossy()),
        None => "(the name has no extension)".to_string(),
    }
}
