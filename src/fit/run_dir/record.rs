//! `settings.json`: what produced a run, enough to re-run it exactly.

use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

use crate::fit::FitSettings;

/// The run record (`settings.json`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    /// Version of slipbayes that wrote the run.
    pub slipbayes_version: String,
    /// The command line.
    pub command: Vec<String>,
    /// The model file given.
    pub model_file: String,
    /// Directory the model's data paths are relative to, relative to the run directory (so
    /// that `slipbayes report DIR` finds the data again); absent in runs written before
    /// reports existed.
    #[serde(default)]
    pub data_dir: Option<String>,
    /// The settings of the fit.
    pub settings: FitSettings,
    /// Sampled dimension.
    pub dimension: usize,
    /// Names of the sampled coordinates.
    #[serde(default)]
    pub sampled_coordinates: Vec<String>,
    /// Each coordinate's prior, in words.
    #[serde(default)]
    pub priors: Vec<(String, String)>,
}

/// `target` relative to `base` (both made absolute against the working directory), e.g.
/// `../../models` from `reports/demo` to `models`: how a run directory records where its
/// data are, so that it can be moved together with them.
///
/// # Errors
/// The I/O error of making a path absolute.
pub(crate) fn relative_path(base: &Path, target: &Path) -> std::io::Result<PathBuf> {
    use std::path::Component;
    let normal = |p: &Path| -> std::io::Result<Vec<std::ffi::OsString>> {
        let mut parts: Vec<std::ffi::OsString> = Vec::new();
        // The parent of a bare file name (`model.toml`) is the empty path: the working
        // directory.
        let p = if p.as_os_str().is_empty() {
            Path::new(".")
        } else {
            p
        };
        for c in std::path::absolute(p)?.components() {
            match c {
                Component::ParentDir => {
                    parts.pop();
                }
                Component::CurDir => {}
                other => parts.push(other.as_os_str().to_owned()),
            }
        }
        Ok(parts)
    };
    let (base, target) = (normal(base)?, normal(target)?);
    let common = base.iter().zip(&target).take_while(|(a, b)| a == b).count();
    let mut out = PathBuf::new();
    for _ in common..base.len() {
        out.push("..");
    }
    for part in &target[common..] {
        out.push(part);
    }
    if out.as_os_str().is_empty() {
        out.push(".");
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn relative_paths_climb_and_descend() {
        let rel = relative_path(Path::new("/a/reports/demo"), Path::new("/a/models")).unwrap();
        assert_eq!(rel, PathBuf::from("../../models"));
        let rel = relative_path(Path::new("/a/b"), Path::new("/a/b")).unwrap();
        assert_eq!(rel, PathBuf::from("."));
        let rel = relative_path(Path::new("/a/b/../c"), Path::new("/a/c/d")).unwrap();
        assert_eq!(rel, PathBuf::from("d"));
        // A model given as a bare file name has the empty path as its directory.
        let here = std::env::current_dir().unwrap();
        let rel = relative_path(&here.join("runs/r1"), Path::new("")).unwrap();
        assert_eq!(rel, PathBuf::from("../.."));
    }
}
