//! The ensemble sampler: a loop of steps over several ensembles, each step recorded, checked
//! against the stopping rule and checkpointed.
//!
//! The parts of the sampler each have a file: building it and resuming it (`construct`), the
//! blocks a step updates (`plan`), one step (`step`), evaluating a half-step's proposals
//! (`evaluate`), the stopping rule (`stop`), progress and the run's report (`progress`), and
//! checkpoints (`state`). This file holds the sampler itself and its run loop.

use std::time::Instant;

use super::config::{SamplerConfig, Steps};
use super::ensemble::{Ensemble, Fatal, Streams, UpdateBlock, Work};
use super::error::SamplerError;
use super::executor::Parallelism;
use super::history::RowHistory;
use super::observer::{Observer, RunStart};
use super::report::{RunReport, StopReason};
use super::sink::{ChainSink, StepView};
use crate::density::LogDensity;

mod construct;
mod evaluate;
mod plan;
mod progress;
mod replica;
mod state;
mod step;
mod stop;
#[cfg(test)]
mod tests;

pub use construct::RESUME_RTOL;
pub(crate) use replica::{RunOutcome, RunRequest};
pub use state::{SamplerState, STATE_VERSION};
pub use step::{CARRY_FIT_STEPS, CARRY_MIN_JUMP_RATIO, CARRY_TUNE_STEPS};

/// Least wall time between two R̂ computed for progress display alone.
const SHOWN_R_HAT_EVERY: std::time::Duration = std::time::Duration::from_secs(20);

/// Affine-invariant ensemble sampler over a [`LogDensity`], running several independent
/// ensembles side by side. Built from `&density` it updates every coordinate at once; built
/// from [`Target::blocked`](crate::density::Target::blocked) it updates a
/// [`BlockedDensity`](crate::density::BlockedDensity)'s blocks one after the other when its configuration asks for blocked
/// updates.
pub struct EnsembleSampler<'a, D: LogDensity + ?Sized> {
    density: &'a D,
    config: SamplerConfig,
    ndim: usize,
    nderived: usize,
    /// Values of state each walker keeps for the updates of its blocks (0 for joint updates).
    state_len: usize,
    /// The blocks updated one after the other in a step; empty for joint updates.
    blocks: Vec<UpdateBlock<'a>>,
    /// How many of them are independent of one another (the parts a shared block's update
    /// may be split into).
    independent_parts: usize,
    ensembles: Vec<Ensemble>,
    /// Move of the current step per ensemble (its index in the configuration's moves).
    step_moves: Vec<usize>,
    /// Proposals of all ensembles' active halves, evaluated in one loop.
    work: Work,
    /// Per ensemble, the generators of an independent block's update, re-keyed in place for
    /// each (the ensemble's own generators wait here meanwhile).
    block_streams: Vec<Streams>,
    pending: Vec<Option<Fatal>>,
    step: u64,
    history: RowHistory,
    /// Estimated cost of one density evaluation (ns) per block (one entry for joint updates),
    /// to decide whether a half-step is worth parallelising; `None` until measured.
    eval_ns: Vec<Option<f64>>,
    /// Half-steps evaluated so far (for occasional re-timing).
    half_steps: u64,
    /// τ of each window of the stopping rule at its last check (`TAU_WINDOWS` order).
    last_tau: Vec<Option<Vec<Vec<f64>>>>,
    /// Per block, the squared distances moved by its exact draws and by its carried moves
    /// during the first [`CARRY_TUNE_STEPS`] steps; empty when no block's carried move is
    /// optional.
    carry_jumps: Vec<[f64; 2]>,
    /// Any run stops here (a wall-time budget), whatever its [`Steps`].
    deadline: Option<Instant>,
    /// τ_max and R̂ of the last stopping-rule check, shown in progress until the next one
    /// (also through the fixed-length runs a fit adds after its stopping rule).
    shown_tau: Option<f64>,
    shown_r_hat: Option<f64>,
    /// When the R̂ shown was last computed for display alone (a pass over the whole history,
    /// so at most every [`SHOWN_R_HAT_EVERY`]).
    shown_r_hat_at: Option<Instant>,
    poisoned: bool,
    /// The history was released ([`release_history`](Self::release_history)) and must be
    /// restored before the next run.
    history_released: bool,
    /// Where the proposals are evaluated: in this process, or through a parallel engine.
    parallelism: Parallelism<'a>,
}

impl<D: LogDensity + ?Sized> std::fmt::Debug for EnsembleSampler<'_, D> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("EnsembleSampler")
            .field("config", &self.config)
            .field("ndim", &self.ndim)
            .field("step", &self.step)
            .finish_non_exhaustive()
    }
}

impl<'a, D: LogDensity + ?Sized> EnsembleSampler<'a, D> {
    /// Stops every later run at `deadline` (with [`StopReason::TimeCap`]), or never.
    pub fn set_deadline(&mut self, deadline: Option<Instant>) {
        self.deadline = deadline;
    }

    /// Evaluates the proposals of every half-step through `parallelism` (a parallel engine
    /// such as the ranks of an MPI job), except the slice move's updates, which run here. The
    /// chains stay the same bits.
    pub fn set_parallelism(&mut self, parallelism: Parallelism<'a>) {
        self.parallelism = parallelism;
    }

    /// Steps completed so far.
    pub fn step(&self) -> u64 {
        self.step
    }

    /// The configuration.
    pub fn config(&self) -> &SamplerConfig {
        &self.config
    }

    /// Current walker positions of ensemble `e` (`walkers × ndim`, row-major).
    pub fn positions(&self, e: usize) -> &[f64] {
        &self.ensembles[e].s.positions
    }

    /// Runs `steps`, handing every (ensemble, step) to `sink` in order and progress to
    /// `observer`. The sink's `checkpoint` is called every `checkpoint_every` steps and at the
    /// end.
    ///
    /// # Errors
    /// [`SamplerError::FatalDensity`] when the density fails fatally (the sampler must then be
    /// rebuilt from the last checkpoint), [`SamplerError::Sink`] when the sink fails,
    /// [`SamplerError::InvalidConfig`] for an invalid stopping rule.
    pub fn run<S: ChainSink, O: Observer + ?Sized>(
        &mut self,
        steps: Steps,
        sink: &mut S,
        observer: &mut O,
    ) -> Result<RunReport, SamplerError> {
        let result = self.run_steps(steps, sink, observer);
        match &result {
            Ok(r) => observer.on_finish(Some(r)),
            Err(_) => observer.on_finish(None),
        }
        result
    }

    /// The run loop: step, record, check whether to stop, checkpoint, report progress.
    fn run_steps<S: ChainSink, O: Observer + ?Sized>(
        &mut self,
        steps: Steps,
        sink: &mut S,
        observer: &mut O,
    ) -> Result<RunReport, SamplerError> {
        if self.poisoned {
            return Err(SamplerError::Poisoned);
        }
        if self.history_released {
            return Err(SamplerError::HistoryReleased);
        }
        let first = self.step;
        let (last, rule) = match steps {
            Steps::Fixed(n) => (first + n, None),
            Steps::UntilConverged(rule) => {
                rule.validate()?;
                (rule.max_steps.max(first), Some(rule))
            }
        };
        observer.on_start(&RunStart {
            first_step: first,
            last_step: last,
            until_converged: rule.is_some(),
        });
        let started = Instant::now();
        self.shown_r_hat_at.get_or_insert(started);
        let mut stopped_by = if rule.is_some() {
            StopReason::StepCap
        } else {
            StopReason::FixedSteps
        };
        let mut checkpointed_at = None;
        while self.step < last {
            let step_no = self.step;
            self.advance(step_no)?;
            self.step += 1;
            self.record(step_no, sink)?;
            let stop = self.stop_reason(rule.as_ref(), last, observer);
            let due = self
                .config
                .checkpoint_every()
                .is_some_and(|k| self.step % k == 0);
            if due || stop.is_some() || self.step == last {
                self.checkpoint(sink)?;
                checkpointed_at = Some(self.step);
            }
            observer.on_step(&self.progress(first, last, started, rule.map(|r| r.tau_factor)));
            if let Some(reason) = stop {
                stopped_by = reason;
                break;
            }
        }
        if checkpointed_at != Some(self.step) {
            self.checkpoint(sink)?;
        }
        Ok(self.report(self.step - first, stopped_by))
    }

    /// Keeps the step `step_no` just taken in the stopping rule's history (when it is one of
    /// the rows kept) and hands every ensemble's walkers to `sink`.
    fn record<S: ChainSink>(&mut self, step_no: u64, sink: &mut S) -> Result<(), SamplerError> {
        if self.history.wants(step_no) {
            for (e, ens) in self.ensembles.iter().enumerate() {
                self.history.push(e, &ens.s.positions);
            }
            self.history.finish_row();
        }
        for (e, ens) in self.ensembles.iter().enumerate() {
            let view = StepView {
                ensemble: e,
                step: step_no,
                ndim: self.ndim,
                positions: &ens.s.positions,
                log_density: &ens.s.log_density,
                derived: &ens.s.derived,
            };
            sink.record(&view).map_err(|err| SamplerError::Sink {
                step: step_no,
                source: Box::new(err),
            })?;
        }
        Ok(())
    }

    /// Why the run stops after the step just taken, if it does: the stopping rule holds (on
    /// the steps it checks), the deadline passed, or the observer asks to stop (the last two
    /// only before the run's last step).
    fn stop_reason<O: Observer + ?Sized>(
        &mut self,
        rule: Option<&super::config::StopRule>,
        last: u64,
        observer: &mut O,
    ) -> Option<StopReason> {
        if let Some(rule) = rule {
            if rule.due(self.step) && self.check_stop(rule, observer.shows_progress()) {
                return Some(StopReason::Converged);
            }
        }
        if self.step < last && self.deadline.is_some_and(|d| Instant::now() >= d) {
            return Some(StopReason::TimeCap);
        }
        if self.step < last && observer.stop_requested() {
            return Some(StopReason::Interrupted);
        }
        None
    }
}
