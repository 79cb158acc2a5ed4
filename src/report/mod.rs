//! Reports a scientist would put in a paper: `report.html` (one self-contained file) and
//! `report.md`, with SVG figures in `figures/`, built from a finished run directory.
//!
//! A report answers at a glance: does the model fit the data, did the sampler converge, what is
//! the static friction peak with its uncertainty, and do the materials differ. It reads back
//! what a fit wrote (`summary.json`, `settings.json`, `predictive.csv`, `chains/`) and redraws,
//! from posterior draws, the curves the data do not sample (interface time, sliding distance,
//! the peak against t0) through the model's [`Posterior`]. It knows nothing of how the
//! chains were sampled, and never refits.
//!
//! Layout written into the run directory:
//! ```text
//! DIR/report.html      self-contained: inline CSS and SVG, no scripts, no external URLs
//! DIR/report.md        the same content, figures linked from figures/
//! DIR/figures/*.svg    one file per figure
//! ```

mod content;
mod curves;
mod document;
mod inputs;
mod plots;
mod units;

use std::path::{Path, PathBuf};

use crate::model::{ModelSpec, Posterior};

pub use document::{render_html, render_markdown, Block};
pub use inputs::{data_records, read_run, DataRecord, RunInputs, MODEL_TOML, SETTINGS_JSON};
pub use units::{significant, DisplayUnit};

/// File name of the HTML report inside the run directory.
pub const REPORT_HTML: &str = "report.html";
/// File name of the Markdown report inside the run directory.
pub const REPORT_MD: &str = "report.md";
/// Folder of the SVG figures inside the run directory.
pub const FIGURES_DIR: &str = "figures";

/// Errors building a report.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file of the run directory could not be read.
    #[error("reading {path}: {source}; is this a finished run directory (slipbayes fit --out)?")]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// A file of the run directory is malformed.
    #[error("{path}: {message}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where and what.
        message: String,
    },
    /// The chains could not be read.
    #[error("reading the chains of {dir}: {source}")]
    Chains {
        /// The run directory.
        dir: PathBuf,
        /// The cause.
        source: crate::storage::StorageError,
    },
    /// The model of the run could not be loaded again.
    #[error("loading the model of the run from {path}: {message}")]
    Model {
        /// The model file.
        path: PathBuf,
        /// The cause and what to do.
        message: String,
    },
    /// The run's files do not match its model (e.g. a run missing from predictive.csv).
    #[error("{dir}: {problem}")]
    Mismatch {
        /// The run directory.
        dir: PathBuf,
        /// What does not match.
        problem: String,
    },
    /// A posterior draw gave an invalid law.
    #[error("redrawing a curve from a posterior draw: {0}")]
    Law(crate::law::LawError),
    /// A figure could not be drawn.
    #[error(transparent)]
    Draw(#[from] crate::plot::DrawError),
    /// A report file could not be written.
    #[error("writing {path}: {source}")]
    Write {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

/// Where a report was written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReportFiles {
    /// `report.html`.
    pub html: PathBuf,
    /// `report.md`.
    pub markdown: PathBuf,
    /// The SVG figures, in report order.
    pub figures: Vec<PathBuf>,
}

/// Builds the report of the finished run in `dir` (fitted with `spec`, whose posterior is
/// `posterior`) and writes `report.html`, `report.md` and `figures/*.svg` into it, each file
/// atomically.
///
/// # Errors
/// [`ReportError`] naming the file that is missing, malformed or cannot be written, or the
/// figure that cannot be drawn.
pub fn write_report(
    dir: &Path,
    spec: &ModelSpec,
    posterior: &Posterior,
) -> Result<ReportFiles, ReportError> {
    let inputs = read_run(dir)?;
    let content = content::build(&inputs, spec, posterior)?;
    let figures_dir = dir.join(FIGURES_DIR);
    std::fs::create_dir_all(&figures_dir).map_err(|source| ReportError::Write {
        path: figures_dir.clone(),
        source,
    })?;
    let write = |path: PathBuf, bytes: &[u8]| {
        crate::data::write_atomically(&path, bytes)
            .map_err(|source| ReportError::Write {
                path: path.clone(),
                source,
            })
            .map(|()| path)
    };
    let mut figures = Vec::new();
    for block in &content.blocks {
        if let Block::Figure { file, svg, .. } = block {
            figures.push(write(figures_dir.join(file), svg.as_bytes())?);
        }
    }
    let markdown = write(
        dir.join(REPORT_MD),
        render_markdown(&content.title, &content.blocks).as_bytes(),
    )?;
    let html = write(
        dir.join(REPORT_HTML),
        render_html(&content.title, &content.blocks).as_bytes(),
    )?;
    Ok(ReportFiles {
        html,
        markdown,
        figures,
    })
}

/// The model of the finished run in `dir`: its `model.toml`, with data paths resolved against
/// the directory `settings.json` records (`data_dir`, relative to the run directory), or, for
/// runs that predate it, against the directory of the model file it names.
///
/// # Errors
/// [`ReportError::Read`] or [`ReportError::Parse`] for a missing or malformed file;
/// [`ReportError::Model`] when the model is invalid.
pub fn load_model(dir: &Path) -> Result<ModelSpec, ReportError> {
    let settings_path = dir.join(SETTINGS_JSON);
    let text = std::fs::read_to_string(&settings_path).map_err(|source| ReportError::Read {
        path: settings_path.clone(),
        source,
    })?;
    let record: inputs::RunRecord =
        serde_json::from_str(&text).map_err(|e| ReportError::Parse {
            path: settings_path.clone(),
            message: format!("line {}, column {}: {e}", e.line(), e.column()),
        })?;
    let base_dir = match &record.data_dir {
        Some(d) => dir.join(d),
        None => Path::new(&record.model_file)
            .parent()
            .map(Path::to_path_buf)
            .unwrap_or_default(),
    };
    let model_path = dir.join(MODEL_TOML);
    let text = std::fs::read_to_string(&model_path).map_err(|source| ReportError::Read {
        path: model_path.clone(),
        source,
    })?;
    let file: crate::model::ModelFile = toml::from_str(&text).map_err(|e| ReportError::Parse {
        path: model_path.clone(),
        message: e.to_string(),
    })?;
    ModelSpec::validate(file, base_dir, model_path.clone()).map_err(|e| ReportError::Model {
        path: model_path,
        message: e.to_string(),
    })
}

/// `target` relative to `base` (both made absolute against the working directory), e.g.
/// `../../models` from `reports/demo` to `models`: how a run directory records where its
/// data are, so that it can be moved together with them.
///
/// # Errors
/// The I/O error of making a path absolute.
pub fn relative_path(base: &Path, target: &Path) -> std::io::Result<PathBuf> {
    use std::path::Component;
    let normal = |p: &Path| -> std::io::Result<Vec<std::ffi::OsString>> {
        let mut parts: Vec<std::ffi::OsString> = Vec::new();
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
    }
}
