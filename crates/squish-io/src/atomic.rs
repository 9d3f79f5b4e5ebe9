//! Atomic file replacement: every writer of this crate goes through [`write_atomically`], so a
//! crash, a full disk or an error halfway through never leaves a truncated mesh where a good
//! one was (users point Squish at their working files and re-run it many times).
//!
//! The data goes to a temporary file in the destination folder (same file system, so the final
//! rename is atomic), is flushed and fsynced, then renamed over the target. On any failure the
//! temporary file is deleted and the target is untouched.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

use crate::IoError;

/// Writes `path` atomically with the bytes `write` produces.
///
/// The new file gets the permissions a freshly created file would get (`0o666` minus the
/// umask on Unix), not the owner-only mode of temporary files.
pub fn write_atomically<F>(path: &Path, write: F) -> Result<(), IoError>
where
    F: FnOnce(&mut dyn Write) -> std::io::Result<()>,
{
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let file_name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let prefix = format!(".{file_name}.");
    let mut builder = tempfile::Builder::new();
    builder.prefix(&prefix).suffix(".tmp");
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        builder.permissions(std::fs::Permissions::from_mode(0o666));
    }
    let mut temp = builder.tempfile_in(dir).map_err(|e| IoError::io(path, "create a temporary file to write", e))?;
    {
        let mut writer = BufWriter::new(temp.as_file_mut());
        write(&mut writer).map_err(|e| IoError::io(path, "write", e))?;
        writer.flush().map_err(|e| IoError::io(path, "write", e))?;
    }
    temp.as_file().sync_all().map_err(|e| IoError::io(path, "write (sync to disk)", e))?;
    // On failure, `PersistError` hands the temporary file back; dropping it deletes it.
    temp.persist(path).map_err(|e| IoError::io(path, "replace", e.error))?;
    sync_dir(dir);
    Ok(())
}

/// Makes the rename itself durable. Best effort: some file systems (and Windows) cannot sync a
/// directory, and the data is already safe in the renamed file.
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    }

    #[test]
    fn failure_halfway_leaves_the_old_file_and_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("mesh.obj");
        write_atomically(&path, |w| w.write_all(b"old content\n")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"old content\n");

        let err = write_atomically(&path, |w| {
            // Enough bytes to get past the BufWriter into the temporary file.
            w.write_all(&vec![b'x'; 1 << 20])?;
            Err(std::io::Error::other("simulated failure"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("mesh.obj") && err.to_string().contains("simulated failure"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), b"old content\n");
        assert_eq!(entries(dir.path()), vec!["mesh.obj".to_string()]);
    }

    #[test]
    fn success_replaces_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.ply");
        write_atomically(&path, |w| w.write_all(b"1")).unwrap();
        write_atomically(&path, |w| w.write_all(b"22")).unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"22");
        assert_eq!(entries(dir.path()), vec!["a.ply".to_string()]);
        #[cfg(unix)]
        {
            // Same mode as a plainly created file (whatever the umask), not the owner-only
            // mode of temporary files.
            use std::os::unix::fs::PermissionsExt;
            let plain = dir.path().join("plain");
            File::create(&plain).unwrap();
            let expected = std::fs::metadata(&plain).unwrap().permissions().mode();
            std::fs::remove_file(&plain).unwrap();
            assert_eq!(std::fs::metadata(&path).unwrap().permissions().mode(), expected);
        }
    }

    #[test]
    fn missing_directory_is_a_clean_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("no/such/dir/out.obj");
        let err = write_atomically(&path, |w| w.write_all(b"1")).unwrap_err();
        assert!(err.to_string().contains("out.obj"), "{err}");
    }
}
