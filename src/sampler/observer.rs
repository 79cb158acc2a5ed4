//! Progress reporting: the sampler never prints, it tells an observer.

use std::time::Duration;

use super::report::RunReport;

/// Where a run starts and how far it may go.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunStart {
    /// Steps already in the chains (non-zero after a resume).
    pub first_step: u64,
    /// Step count at which the run stops at the latest (the fixed end or the cap).
    pub last_step: u64,
    /// Whether the run may stop earlier because it converged.
    pub until_converged: bool,
}

/// Progress after one step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Progress {
    /// Steps completed (including earlier runs).
    pub step: u64,
    /// Step count at which the run stops at the latest.
    pub last_step: u64,
    /// Mean acceptance fraction of the moves' proposals over all walkers and ensembles so far
    /// (NaN when every update so far was a slice update, which always moves).
    pub acceptance: f64,
    /// Latest estimate of the largest autocorrelation time, in steps: from the last check of
    /// the stopping rule, in this run or an earlier one of the same sampler.
    pub tau_max: Option<f64>,
    /// Largest split R̂ between the ensembles at that check (after its burn-in); `None` before
    /// the first check or with a single ensemble.
    pub r_hat_max: Option<f64>,
    /// Estimated time to the end (the fixed end, or the length that trusts τ_max when
    /// converging).
    pub eta: Option<Duration>,
}

/// Receives progress of a run; every method does nothing by default.
pub trait Observer {
    /// Called once before the first step.
    fn on_start(&mut self, _start: &RunStart) {}
    /// Called after every step.
    fn on_step(&mut self, _progress: &Progress) {}
    /// Called once after the last step (also when the run fails, with `None`).
    fn on_finish(&mut self, _report: Option<&RunReport>) {}
    /// A message from what drives the runs, between two of them: why a fit samples on
    /// after its summaries, which can take minutes that no step shows.
    fn on_note(&mut self, _note: &str) {}
    /// Asked after every step: `true` ends the run there, after a checkpoint, with
    /// [`StopReason::Interrupted`](super::StopReason::Interrupted) (e.g. on Ctrl-C), so that
    /// it can be resumed.
    fn stop_requested(&mut self) -> bool {
        false
    }
    /// Whether [`on_step`](Self::on_step) shows the progress to someone: only then does the
    /// sampler compute the R̂ of [`Progress::r_hat_max`] at checks of its stopping rule that
    /// do not need it themselves.
    fn shows_progress(&self) -> bool {
        true
    }
}

/// An observer that ignores everything.
#[derive(Debug, Clone, Copy, Default)]
pub struct Silent;

impl Observer for Silent {
    fn shows_progress(&self) -> bool {
        false
    }
}
