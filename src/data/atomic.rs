//! Durable file operations: atomic replacement and directory syncs.

use std::ffi::OsString;
use std::fs::{self, File};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// Writes `bytes` to `path` so that `path` holds either its old content or all of `bytes`,
/// never a mixture, even if the process or machine dies: the bytes go to a temporary file
/// `.NAME.tmp` in the same directory, which is fsynced, renamed over `path`, and the directory
/// is fsynced so that the rename survives a crash.
///
/// # Errors
/// Any I/O error; the temporary file is removed when the write itself fails.
pub fn write_atomically(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let tmp = temporary_path(path)?;
    let written = (|| {
        let mut file = File::create(&tmp)?;
        file.write_all(bytes)?;
        file.sync_all()
    })();
    if let Err(err) = written {
        // Best effort: the temporary file is garbage either way and its name marks it so.
        let _ = fs::remove_file(&tmp);
        return Err(err);
    }
    fs::rename(&tmp, path)?;
    sync_dir(parent_dir(path))
}

/// The temporary sibling `.NAME.tmp` used while writing `path`.
pub(crate) fn temporary_path(path: &Path) -> io::Result<PathBuf> {
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("{} does not name a file", path.display()),
        )
    })?;
    let mut tmp = OsString::from(".");
    tmp.push(name);
    tmp.push(".tmp");
    Ok(parent_dir(path).join(tmp))
}

/// Whether a file name is one of the temporaries of [`write_atomically`].
#[cfg_attr(not(feature = "parquet"), allow(dead_code))]
pub(crate) fn is_temporary_name(name: &str) -> bool {
    name.len() > ".tmp".len() + 1 && name.starts_with('.') && name.ends_with(".tmp")
}

/// The directory holding `path` (`.` for a bare file name).
pub(crate) fn parent_dir(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Makes the entries of a directory (creations, renames, removals) durable.
pub(crate) fn sync_dir(dir: &Path) -> io::Result<()> {
    #[cfg(unix)]
    {
        File::open(dir)?.sync_all()
    }
    #[cfg(not(unix))]
    {
        // Directories cannot be opened for syncing on other platforms; renames there are made
        // durable by the file system's own journal.
        let _ = dir;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn write_atomically_replaces_content_and_leaves_no_temporary() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("summary.json");
        write_atomically(&path, b"first").expect("first write");
        write_atomically(&path, b"second, longer").expect("second write");
        assert_eq!(fs::read(&path).expect("read back"), b"second, longer");
        let names: Vec<_> = fs::read_dir(dir.path())
            .expect("list")
            .map(|e| e.expect("entry").file_name())
            .collect();
        assert_eq!(names, vec![OsString::from("summary.json")]);
    }

    #[test]
    fn write_atomically_into_missing_directory_fails_without_creating_it() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("absent").join("x.json");
        assert!(write_atomically(&path, b"x").is_err());
        assert!(!dir.path().join("absent").exists());
    }

    #[test]
    fn temporary_names_are_recognised() {
        let tmp = temporary_path(Path::new("a/checkpoint.json")).expect("path");
        assert_eq!(tmp, Path::new("a/.checkpoint.json.tmp"));
        assert!(is_temporary_name(".checkpoint.json.tmp"));
        assert!(!is_temporary_name("checkpoint.json"));
        assert!(!is_temporary_name(".tmp"));
    }
}
