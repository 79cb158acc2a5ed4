//! Errors of a fit: each says which stage failed, on which directory or quantity, and keeps
//! the underlying error as its source (printed as "caused by" by the binary).

use std::path::PathBuf;

use thiserror::Error;

use crate::diagnostics::DiagnosticsError;
use crate::sampler::SamplerError;
use crate::storage::StorageError;

/// What can go wrong in [`run_fit`](super::run_fit).
#[derive(Debug, Error)]
pub enum FitError {
    /// A setting of [`FitSettings`](super::FitSettings) is out of range or contradicts
    /// another.
    #[error("invalid fit setting `{name}` = {value}: {requirement}")]
    InvalidSetting {
        /// The setting.
        name: &'static str,
        /// Its value, as given.
        value: String,
        /// What it must satisfy.
        requirement: String,
    },
    /// A reported quantity or comparison does not fit the density's columns.
    #[error("invalid {what}: {problem}")]
    InvalidSpec {
        /// "quantity" or "comparison".
        what: &'static str,
        /// What is wrong and how to fix it.
        problem: String,
    },
    /// The sampler settings were refused.
    #[error("invalid sampler settings")]
    Config(#[source] SamplerError),
    /// No starting walkers could be found around the optimum. Where the density can say what
    /// fails in its own terms, the message is that (the optimiser's error, with its vectors of
    /// coordinates, stays in `optimizer`); else it is the optimiser's error.
    #[error(
        "cannot find starting walkers: {}",
        match why {
            Some(w) => format!("{w} ({})", optimizer.summary()),
            None => optimizer.to_string(),
        }
    )]
    Start {
        /// The start point given.
        start: Vec<f64>,
        /// What the density says fails at the start
        /// ([`LogDensity::explain`](crate::density::LogDensity::explain)), when it can say.
        why: Option<String>,
        /// What the optimiser met.
        optimizer: crate::optimize::OptimizeError,
    },
    /// Sampling (or setting up the sampler) failed.
    #[error("{context}")]
    Sampler {
        /// What was being done, naming the run directory.
        context: String,
        /// The sampler's error.
        #[source]
        source: SamplerError,
    },
    /// Storing, resuming or reading the chains failed.
    #[error("{context}")]
    Storage {
        /// What was being done, naming the run directory.
        context: String,
        /// The storage error.
        #[source]
        source: StorageError,
    },
    /// The observer asked the run to stop; the chains and checkpoint are written up to `step`,
    /// and the run continues with a resume.
    #[error("the fit in {} was interrupted at step {step}; its checkpoint is written and it can be resumed", dir.display())]
    Interrupted {
        /// The run directory.
        dir: PathBuf,
        /// Steps in the chains.
        step: u64,
    },
    /// A resumed run does not match the requested settings.
    #[error("cannot resume the run in {}: {problem}", dir.display())]
    ResumeMismatch {
        /// The run directory.
        dir: PathBuf,
        /// What does not match and what to do.
        problem: String,
    },
    /// The chains read back do not have the layout the sampler writes.
    #[error("the chains in {} are inconsistent: {problem}; start a new run with --overwrite", dir.display())]
    Inconsistent {
        /// The run directory.
        dir: PathBuf,
        /// What contradicts what.
        problem: String,
    },
    /// Too few steps remain after burn-in for any summary.
    #[error(
        "only {kept} steps remain after a burn-in of {burn_in} of {total} steps, at least {needed} \
         are needed for a summary; run more steps"
    )]
    TooFewDraws {
        /// Steps kept.
        kept: usize,
        /// Steps discarded.
        burn_in: u64,
        /// Steps in the chains.
        total: u64,
        /// Steps needed.
        needed: usize,
    },
    /// A posterior summary could not be computed.
    #[error("cannot summarise {quantity}")]
    Diagnostics {
        /// The quantity (`name[group]`) or comparison.
        quantity: String,
        /// The diagnostics error.
        #[source]
        source: DiagnosticsError,
    },
    /// A file of the run directory could not be written or read back.
    #[error(transparent)]
    RunDir(#[from] super::RunDirError),
    /// A posterior draw has no valid law, so its predictive curve cannot be drawn.
    #[error("computing the posterior predictive bands")]
    Predictive(#[source] crate::law::LawError),
    /// A posterior draw has no valid law, so a curve of the report cannot be redrawn.
    #[error("redrawing a curve of the report from a posterior draw")]
    Curves(#[source] crate::law::LawError),
    /// Leave-one-out cross-validation failed at a posterior draw.
    #[error("computing the leave-one-out predictive accuracy (PSIS-LOO)")]
    Loo(#[source] crate::model::PointwiseError),
    /// A fold of K-fold cross-validation cannot be built (a run too short for the folds).
    #[error("fold {fold} of the cross-validation cannot be fitted (use fewer folds)")]
    Fold {
        /// The fold (0-based).
        fold: usize,
        /// Why.
        #[source]
        source: crate::model::PosteriorError,
    },
}
