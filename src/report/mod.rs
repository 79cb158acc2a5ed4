//! Reports a scientist would put in a paper: `report.html` (one self-contained file) and
//! `report.md`, with SVG figures in `figures/`, built from a finished run directory.
//!
//! A report answers at a glance: does the model fit the data, did the sampler converge, what is
//! the static friction peak with its uncertainty, and do the materials differ. It reads the
//! run directory and nothing else: what a fit wrote (`model.toml`, `summary.json`,
//! `settings.json`, `predictive.csv`, `curves.json`, `truth.json`, `chains/`), including the
//! curves the data do not sample (interface time, sliding distance, the peak against t0),
//! which the fit redrew from posterior draws. It knows nothing of how the chains were
//! sampled, loads neither the model's data nor its posterior, and never refits.
//!
//! Layout written into the run directory:
//! ```text
//! DIR/report.html      self-contained: inline CSS and SVG, no scripts, no external URLs
//! DIR/report.md        the same content, figures linked from figures/
//! DIR/figures/*.svg    one file per figure
//! ```
//!
//! `slipbayes compare --report OUT` writes its ranking of fits with the fits overlaid on the
//! data run by run ([`write_comparison`]):
//! ```text
//! OUT/compare.html, OUT/compare.md, OUT/figures/compare-<run>.svg
//! ```

mod comparison;
mod content;
mod contours;
mod density;
mod document;
mod inputs;
mod plots;
mod truth;
mod units;

use std::path::{Path, PathBuf};

use crate::data::atomic::is_temporary_name;
use crate::fit::run_dir::{FIGURES_DIR, REPORT_HTML, REPORT_MD};
use crate::fit::{RunDir, RunDirError};

pub use comparison::write_comparison;
pub use document::Block;
pub(crate) use document::{render_html, render_markdown};
pub(crate) use inputs::RunInputs;

/// Errors building a report.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file of the run directory is missing, malformed or cannot be written.
    #[error(transparent)]
    RunDir(#[from] RunDirError),
    /// The chains lack a column the report needs.
    #[error("reading the chains of {}", dir.display())]
    Chains {
        /// The run directory.
        dir: PathBuf,
        /// The cause.
        #[source]
        source: crate::storage::StorageError,
    },
    /// The run's files do not match its model (e.g. a run missing from predictive.csv).
    #[error("{}: {problem}", dir.display())]
    Mismatch {
        /// The run directory.
        dir: PathBuf,
        /// What does not match.
        problem: String,
    },
    /// A figure could not be drawn.
    #[error(transparent)]
    Draw(#[from] crate::plot::DrawError),
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

/// Builds the report of the finished run in `dir` from its files alone (the directory may
/// have moved, and the run's data files need not exist any more; nothing is refitted) and
/// writes `report.html`, `report.md` and `figures/*.svg` into it, each file atomically.
///
/// # Errors
/// [`ReportError`] naming the file that is missing, malformed or cannot be written, or the
/// figure that cannot be drawn.
pub fn write_report(dir: &RunDir) -> Result<ReportFiles, ReportError> {
    let inputs = RunInputs::read(dir)?;
    let content = content::build(&inputs)?;
    let figures = write_figures(dir, &content.blocks)?;
    let markdown = dir.write(
        REPORT_MD,
        render_markdown(&content.title, &content.blocks).as_bytes(),
    )?;
    let html = dir.write(
        REPORT_HTML,
        render_html(&content.title, &content.blocks).as_bytes(),
    )?;
    Ok(ReportFiles {
        html,
        markdown,
        figures,
    })
}

/// Removes the temporaries a report killed while writing its figures left in `figures_dir`
/// (the run directory's own are removed when its fit is resumed).
fn remove_temporaries(figures_dir: &Path) -> Result<(), ReportError> {
    let io = |action, path: &Path| {
        let path = path.to_path_buf();
        move |e| RunDirError::from(crate::IoError::new(action, path, e))
    };
    for entry in std::fs::read_dir(figures_dir).map_err(io("list", figures_dir))? {
        let entry = entry.map_err(io("list", figures_dir))?;
        let path = entry.path();
        if entry.file_name().to_str().is_some_and(is_temporary_name) {
            std::fs::remove_file(&path).map_err(io("remove", &path))?;
        }
    }
    Ok(())
}

/// Writes every figure of `blocks` into `dir/figures/`, each atomically; their paths in order.
fn write_figures(dir: &RunDir, blocks: &[Block]) -> Result<Vec<PathBuf>, ReportError> {
    let figures_dir = dir.file(FIGURES_DIR);
    std::fs::create_dir_all(&figures_dir)
        .map_err(|e| RunDirError::from(crate::IoError::new("create", &figures_dir, e)))?;
    remove_temporaries(&figures_dir)?;
    let mut figures = Vec::new();
    for block in blocks {
        if let Block::Figure { file, svg, .. } = block {
            figures.push(dir.write(&format!("{FIGURES_DIR}/{file}"), svg.as_bytes())?);
        }
    }
    Ok(figures)
}
