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
//!
//! `slipbayes compare --report OUT` writes its ranking of fits with the fits overlaid on the
//! data run by run ([`write_comparison`]):
//! ```text
//! OUT/compare.html, OUT/compare.md, OUT/figures/compare-<run>.svg
//! ```

mod comparison;
mod content;
mod contours;
mod curves;
mod document;
mod inputs;
mod plots;
mod truth;
mod units;

use std::path::PathBuf;

use crate::fit::run_dir::{FIGURES_DIR, REPORT_HTML, REPORT_MD};
use crate::fit::{RunDir, RunDirError};
use crate::model::Posterior;

pub use comparison::{write_comparison, COMPARE_HTML, COMPARE_MD};
pub use document::{render_html, render_markdown, Block};
pub use inputs::{coverage_95, RunInputs};
pub use units::{significant, DisplayUnit};

/// Errors building a report.
#[derive(Debug, thiserror::Error)]
pub enum ReportError {
    /// A file of the run directory is missing, malformed or cannot be written.
    #[error(transparent)]
    RunDir(#[from] RunDirError),
    /// The model of the run (its `model.toml` and the data it names) could not be loaded
    /// again.
    #[error("rebuilding the posterior of {}: {source}", dir.display())]
    Model {
        /// The run directory.
        dir: PathBuf,
        /// The cause, naming the file, line or key.
        #[source]
        source: crate::model::PosteriorError,
    },
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
    /// A posterior draw gave an invalid law.
    #[error("redrawing a curve from a posterior draw: {0}")]
    Law(crate::law::LawError),
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

/// Rebuilds the report of the finished run in `dir` from its files alone: the model is read
/// from its `model.toml` (the data files must still be where it says), nothing is refitted.
///
/// # Errors
/// As [`write_report`], and [`ReportError::Model`] when the model cannot be loaded again.
pub fn rebuild_report(dir: &RunDir) -> Result<ReportFiles, ReportError> {
    let spec = dir.read_model()?;
    let posterior = Posterior::new(&spec).map_err(|source| ReportError::Model {
        dir: dir.path().to_path_buf(),
        source,
    })?;
    write_report(dir, &posterior)
}

/// Builds the report of the finished run in `dir`, fitted with `posterior` (whose model
/// names the runs, contacts and materials and redraws the curves the data do not sample),
/// and writes `report.html`, `report.md` and `figures/*.svg` into it, each file atomically.
///
/// # Errors
/// [`ReportError`] naming the file that is missing, malformed or cannot be written, or the
/// figure that cannot be drawn.
pub fn write_report(dir: &RunDir, posterior: &Posterior) -> Result<ReportFiles, ReportError> {
    let inputs = RunInputs::read(dir)?;
    let content = content::build(&inputs, posterior)?;
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

/// Writes every figure of `blocks` into `dir/figures/`, each atomically; their paths in order.
fn write_figures(dir: &RunDir, blocks: &[Block]) -> Result<Vec<PathBuf>, ReportError> {
    let figures_dir = dir.file(FIGURES_DIR);
    std::fs::create_dir_all(&figures_dir).map_err(|source| RunDirError::Write {
        path: figures_dir.clone(),
        source,
    })?;
    let mut figures = Vec::new();
    for block in blocks {
        if let Block::Figure { file, svg, .. } = block {
            figures.push(dir.write(&format!("{FIGURES_DIR}/{file}"), svg.as_bytes())?);
        }
    }
    Ok(figures)
}
