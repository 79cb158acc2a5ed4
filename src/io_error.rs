//! The one shape of a failed file-system operation. Every error of the crate that touches
//! files (model files, data sets, chains, run directories, a summary's working files) carries
//! this, so that each says the same three things: what was being done, to which path, and why
//! it failed.

use std::io;
use std::path::{Path, PathBuf};

/// A file-system operation that failed: `cannot {action} {path}: {cause}`.
#[derive(Debug, thiserror::Error)]
#[error("cannot {action} {}: {source}", path.display())]
pub struct IoError {
    /// What was being done, as a verb with its object: "read", "create", "rename … to …".
    pub action: &'static str,
    /// The file or directory at fault.
    pub path: PathBuf,
    /// The cause.
    #[source]
    pub source: io::Error,
}

impl IoError {
    /// The failure of `action` on `path`.
    pub fn new(action: &'static str, path: impl Into<PathBuf>, source: io::Error) -> Self {
        Self {
            action,
            path: path.into(),
            source,
        }
    }

    /// The failure of `action` on `path`, for `map_err`:
    /// `fs::read(&path).map_err(IoError::at("read", &path))`.
    pub fn at<'a>(action: &'static str, path: &'a Path) -> impl FnOnce(io::Error) -> Self + 'a {
        move |source| Self::new(action, path, source)
    }

    /// The kind of the cause (e.g. [`io::ErrorKind::NotFound`]).
    pub fn kind(&self) -> io::ErrorKind {
        self.source.kind()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_the_action_the_path_and_the_cause() {
        let path = Path::new("runs/demo/summary.json");
        let e = IoError::at("read", path)(io::Error::new(io::ErrorKind::NotFound, "gone"));
        assert_eq!(e.to_string(), "cannot read runs/demo/summary.json: gone");
        assert_eq!(e.kind(), io::ErrorKind::NotFound);
        assert!(std::error::Error::source(&e).is_some());
    }
}
