//! Outputs written atomically: to a temporary file in the target's folder, then renamed over
//! the target. A failure at any point (a full disk, an error while producing the data) leaves
//! the previous file as it was and no temporary file behind.

use crate::IoError;
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

/// The folder `path` will be written in (`.` for a bare file name).
fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Checks, before any work, that `path` can be written: its folder exists, is a folder and
/// accepts new files, and `path` itself is not a folder. The check creates and removes a
/// temporary file in the folder, which is what [`write_atomically`] will do.
pub fn check_writable(path: &Path) -> Result<(), IoError> {
    if path.is_dir() {
        return Err(IoError::new(
            path,
            "is a folder; expected a file path to write",
        ));
    }
    let folder = folder_of(path);
    if !folder.is_dir() {
        return Err(IoError::new(
            path,
            format!(
                "the folder {} does not exist; create it first or choose another output path",
                folder.display()
            ),
        ));
    }
    check_folder_writable(&folder)
}

/// Checks that new files can be created in `folder` (which must exist).
pub fn check_folder_writable(folder: &Path) -> Result<(), IoError> {
    if !folder.is_dir() {
        return Err(IoError::new(
            folder,
            "is not an existing folder; expected a folder to write outputs in",
        ));
    }
    tempfile::Builder::new()
        .prefix(".optik-check-")
        .tempfile_in(folder)
        .map(drop)
        .map_err(|e| IoError::os(folder, "cannot create files in this folder", e))
}

/// Writes `path` through `write`: the bytes go to a temporary file in the same folder, which
/// replaces `path` only once `write` and the flush to disk have succeeded. On any error the old
/// `path` is intact and the temporary file is removed.
pub fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut dyn Write) -> std::io::Result<()>,
) -> Result<(), IoError> {
    write_file_atomically(path, |file| {
        let mut w = BufWriter::new(file);
        write(&mut w)?;
        w.flush()
    })
}

/// Writes `bytes` to `path` atomically (see [`write_atomically`]).
pub fn write_bytes(path: &Path, bytes: &[u8]) -> Result<(), IoError> {
    write_atomically(path, |w| w.write_all(bytes))
}

/// Like [`write_atomically`], handing `write` the temporary file itself, for writers that seek
/// (zip archives).
pub(crate) fn write_file_atomically(
    path: &Path,
    write: impl FnOnce(&mut File) -> std::io::Result<()>,
) -> Result<(), IoError> {
    let folder = folder_of(path);
    let mut temp = tempfile::Builder::new()
        .prefix(".optik-")
        .suffix(".part")
        .tempfile_in(&folder)
        .map_err(|e| {
            IoError::os(
                path,
                &format!("cannot create a temporary file in {}", folder.display()),
                e,
            )
        })?;
    write(temp.as_file_mut()).map_err(|e| IoError::os(path, "cannot write", e))?;
    temp.as_file()
        .sync_all()
        .map_err(|e| IoError::os(path, "cannot write to disk", e))?;
    // A new file gets the usual permissions (tempfile makes them private, 0600).
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let mode = std::fs::metadata(path).map_or(0o644, |m| m.permissions().mode());
        std::fs::set_permissions(temp.path(), std::fs::Permissions::from_mode(mode))
            .map_err(|e| IoError::os(path, "cannot set the permissions of the new file", e))?;
    }
    temp.persist(path)
        .map_err(|e| IoError::os(path, "cannot replace the file", e.error))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn failed_write_keeps_the_previous_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.npz");
        write_bytes(&path, b"good").unwrap();
        let err = write_atomically(&path, |w| {
            w.write_all(b"half")?;
            Err(std::io::Error::other("disk full"))
        })
        .unwrap_err();
        assert!(err.to_string().contains("disk full"), "{err}");
        assert_eq!(std::fs::read(&path).unwrap(), b"good");
        // No temporary file is left behind.
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().collect();
        assert_eq!(names.len(), 1);
        write_bytes(&path, b"better").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"better");
    }

    #[test]
    fn missing_folder_is_reported_before_work() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("missing").join("x.npz");
        let err = check_writable(&path).unwrap_err();
        assert!(err.to_string().contains("does not exist"), "{err}");
        assert!(check_writable(dir.path()).is_err());
        assert!(check_writable(&dir.path().join("x.npz")).is_ok());
        assert!(check_folder_writable(&dir.path().join("missing")).is_err());
    }
}
