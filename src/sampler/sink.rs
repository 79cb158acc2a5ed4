//! Where the sampler hands its draws: the contract between sampling and storage.
//!
//! The sampler calls [`ChainSink::record`] once per ensemble per step, in step order, and
//! [`ChainSink::checkpoint`] every checkpoint interval and at the end of a run. A sink that
//! persists draws must make every recorded step durable when `checkpoint` returns, together
//! with the sampler state it is given, so that a killed run resumes from there and ends with
//! the same chains as an uninterrupted one.

use serde::Serialize;

/// One ensemble's walkers after one step.
#[derive(Debug, Clone, Copy)]
pub struct StepView<'a> {
    /// Index of the independent ensemble (0-based).
    pub ensemble: usize,
    /// Step number (0-based, counting from the start of the run, burn-in included).
    pub step: u64,
    /// Number of sampled dimensions.
    pub ndim: usize,
    /// Walker positions, `walkers × ndim`, row-major.
    pub positions: &'a [f64],
    /// Log-density of each walker.
    pub log_density: &'a [f64],
    /// Derived values of each walker (`walkers × nderived`, row-major); empty when none.
    pub derived: &'a [f64],
}

impl StepView<'_> {
    /// Number of walkers in this view.
    pub fn walkers(&self) -> usize {
        self.log_density.len()
    }
}

/// A destination for draws.
pub trait ChainSink {
    /// The sink's error type.
    type Error: std::error::Error + Send + Sync + 'static;

    /// Receives one ensemble's walkers after one step.
    ///
    /// # Errors
    /// When the draws cannot be stored; the sampler stops the run.
    fn record(&mut self, step: &StepView<'_>) -> Result<(), Self::Error>;

    /// Makes everything recorded so far durable together with `state`, the point from which
    /// a resumed run continues.
    ///
    /// # Errors
    /// When the draws or the state cannot be written; the sampler stops the run.
    fn checkpoint<S: Serialize>(&mut self, state: &S) -> Result<(), Self::Error>;
}
