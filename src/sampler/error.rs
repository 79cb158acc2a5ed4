//! Errors of the sampler; each names the setting, walker or step at fault.

use thiserror::Error;

/// What can go wrong in setting up or running the sampler.
#[derive(Debug, Error)]
pub enum SamplerError {
    /// A configuration value is out of range.
    #[error("invalid sampler setting `{name}` = {value}: {requirement}")]
    InvalidConfig {
        /// The setting.
        name: &'static str,
        /// Its value, as given.
        value: String,
        /// What it must satisfy.
        requirement: String,
    },
    /// A move's parameters are invalid or the ensemble is too small for it.
    #[error("invalid move: {detail}")]
    InvalidMove {
        /// What is wrong.
        detail: String,
    },
    /// The initial walkers (or a resumed state) do not have the expected shape.
    #[error("shape mismatch in {what}: expected {expected}, got {got}")]
    Shape {
        /// Which array.
        what: String,
        /// Expected size.
        expected: usize,
        /// Actual size.
        got: usize,
    },
    /// An initial walker is not a valid starting point.
    #[error(
        "initial walker {walker} of ensemble {ensemble} at {position:?} is not a valid start: {reason}; \
         start the walkers inside the support (e.g. with optimize::initial_around_optimum)"
    )]
    BadInitialWalker {
        /// Ensemble index.
        ensemble: usize,
        /// Walker index.
        walker: usize,
        /// The walker's position.
        position: Vec<f64>,
        /// Why it is invalid.
        reason: String,
    },
    /// The initial walkers of an ensemble span less than the full parameter space.
    #[error(
        "initial walkers of ensemble {ensemble} are (nearly) linearly dependent: condition number of the \
         centred walker matrix is {condition:e} (limit {limit:e}); spread them in every direction"
    )]
    DegenerateEnsemble {
        /// Ensemble index.
        ensemble: usize,
        /// Condition number found.
        condition: f64,
        /// Largest condition number accepted.
        limit: f64,
    },
    /// The log-density reported a fatal fault (or +∞) during the run.
    #[error(
        "log-density failed fatally at step {step}, ensemble {ensemble}, walker {walker}, position {position:?}: {message}"
    )]
    FatalDensity {
        /// Ensemble index.
        ensemble: usize,
        /// Walker index.
        walker: usize,
        /// Step number (0-based, from the start of the chains).
        step: u64,
        /// Proposed position that failed.
        position: Vec<f64>,
        /// The density's message.
        message: String,
    },
    /// A resumed state does not match the density or configuration.
    #[error("cannot resume from the given state: {detail}")]
    StateMismatch {
        /// What does not match.
        detail: String,
    },
    /// The sampler's history was released and not restored before another run.
    #[error(
        "the sampler's history was released: restore it from the chains (restore_history) \
         before running on"
    )]
    HistoryReleased,
    /// An earlier run of this sampler stopped on an error mid-step.
    #[error("the sampler stopped on an error mid-step; resume from the last checkpoint instead")]
    Poisoned,
    /// The sink could not store draws or a checkpoint.
    #[error("chain sink failed at step {step}")]
    Sink {
        /// Step at which it failed.
        step: u64,
        /// The sink's error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync + 'static>,
    },
}
