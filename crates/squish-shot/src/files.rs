//! Output folders and whole files: the folder a job writes into (created, or an error naming it
//! and the fix), and text or bytes written atomically (a temporary file renamed into place).

use std::path::Path;

use crate::error::ShotError;

/// Creates the output folder (and its parents). A path that is a file, or a folder that cannot
/// be written, is bad input whichever job meets it.
pub fn create_dir(dir: &Path) -> Result<(), ShotError> {
    if dir.exists() && !dir.is_dir() {
        return Err(ShotError::OutputIsFile { dir: dir.to_path_buf() });
    }
    std::fs::create_dir_all(dir).map_err(|error| output_dir_error(dir, "create", error))
}

/// The error of an output folder that cannot be created or written (`action`: "create",
/// "write into"); [`ShotError::kind`] tells whether the user can fix it by choosing another
/// folder.
pub fn output_dir_error(dir: &Path, action: &'static str, error: std::io::Error) -> ShotError {
    ShotError::OutputDir { dir: dir.to_path_buf(), action, error }
}

/// Writes `text` to `path` atomically.
pub fn write_text(path: &Path, text: &str) -> Result<(), ShotError> {
    squish_io::write_atomically(path, |w| w.write_all(text.as_bytes()))?;
    Ok(())
}

/// Writes `bytes` to `path` atomically.
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), ShotError> {
    squish_io::write_atomically(path, |w| w.write_all(bytes))?;
    Ok(())
}
