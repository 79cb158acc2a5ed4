//! The ensemble sampler: construction, checks of the start, the run loop and resuming.

use std::time::{Duration, Instant};

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::config::{SamplerConfig, Steps, Updates};
use super::ensemble::{
    BlockTerms, Ensemble, EnsembleState, Fatal, ProposalBuffers, SliceContext, Streams,
    UpdateBlock, Work,
};
use super::error::SamplerError;
use super::history::{rebuild, History, RowHistory};
use super::moves::{CarryTuning, Move, MoveSpec, SLICE_ADAPT_STEPS, SLICE_MU0};
use super::observer::{Observer, Progress, RunStart};
use super::offload::{Batch, BlockShares, EvalKind, Offload, Shares};
use super::report::{
    chosen_tau_report, rhat_from_history, tau_windows, EnsembleReport, RunReport, StopReason,
    TAU_WINDOWS,
};
use super::sink::{ChainSink, StepView};
use crate::density::{sort, Eval, LogDensity};
use crate::diagnostics::{
    blockwise_condition_number, stuck_walkers, Problem, RHAT_MAX, TAU_FACTOR,
    WALKER_CONDITION_LIMIT,
};

mod phase;

pub use phase::{PhaseOutcome, PhaseRequest, ReplicaShares};

/// Version of the [`SamplerState`] layout.
pub const STATE_VERSION: u32 = 1;

/// Everything needed to continue a run exactly where it stopped (serde-serialisable).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SamplerState {
    /// Layout version ([`STATE_VERSION`]).
    pub version: u32,
    /// Seed the streams were derived from (informative; the streams themselves are stored).
    pub seed: u64,
    /// Sampled dimensions.
    pub ndim: usize,
    /// Derived values per walker.
    pub nderived: usize,
    /// Walkers per ensemble.
    pub walkers: usize,
    /// The moves (their specs) and weights the chains were drawn with; a resumed run must use
    /// the same to continue the same chains (states written before moves were selectable used
    /// the stretch move alone).
    #[serde(default = "stretch_alone")]
    pub moves: Vec<(MoveSpec, f64)>,
    /// Joint or blocked updates (states written before blocked updates existed were joint).
    #[serde(default)]
    pub updates: Updates,
    /// Steps completed.
    pub step: u64,
    /// Per-ensemble state.
    pub ensembles: Vec<EnsembleState>,
    /// Thinned history used by τ and R̂. Checkpoints leave it out (`None`): which rows it keeps
    /// follows from the step count and the configured history rows, and their values are in
    /// the chains, so [`SamplerState::rebuild_history`] restores it from them and a checkpoint
    /// stays as small as one step of the ensembles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub history: Option<History>,
    /// τ per (ensemble, parameter) at the last stopping-rule check, over the whole chains.
    pub last_tau: Option<Vec<Vec<f64>>>,
    /// The same after the first quarter and after the first half of the steps (the later
    /// windows the stopping rule looks at; empty in states written before it did).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub last_tau_later: Vec<Option<Vec<Vec<f64>>>>,
    /// Per block, the squared distances its exact draws and its carried moves moved it over
    /// the tuning steps (empty when no block's carried move is optional).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub carry_jumps: Vec<[f64; 2]>,
}

impl SamplerState {
    /// Restores the history a checkpoint leaves out, from the chains: `column(p)` gives
    /// parameter `p` of every recorded row (step, then ensemble, then walker, steps `0..step`).
    /// `config` is the run's; the rows kept are those an uninterrupted run with it would have
    /// kept, so a resumed run stops where it would have.
    ///
    /// # Errors
    /// What `column` returns, or [`SamplerError::Shape`] when a column has the wrong length.
    pub fn rebuild_history<E: From<SamplerError>>(
        &mut self,
        config: &SamplerConfig,
        mut column: impl FnMut(usize) -> Result<Vec<f64>, E>,
    ) -> Result<(), E> {
        let rows = self.step as usize * self.ensembles.len() * self.walkers;
        self.rebuild_history_rows(config, |p, wanted| {
            let values = column(p)?;
            if values.len() != rows {
                return Err(SamplerError::Shape {
                    what: format!("chains of parameter {p} for the history"),
                    expected: rows,
                    got: values.len(),
                }
                .into());
            }
            Ok(wanted.iter().map(|&r| values[r]).collect())
        })
    }

    /// [`rebuild_history`](Self::rebuild_history) from the rows it keeps alone:
    /// `column(p, rows)` gives parameter `p` at the recorded `rows` (increasing indices in
    /// the chains' order), so that a long run's history is restored without reading whole
    /// columns.
    ///
    /// # Errors
    /// What `column` returns, or [`SamplerError::Shape`] when it gives the wrong number of
    /// values.
    pub fn rebuild_history_rows<E: From<SamplerError>>(
        &mut self,
        config: &SamplerConfig,
        column: impl FnMut(usize, &[usize]) -> Result<Vec<f64>, E>,
    ) -> Result<(), E> {
        let shape = (self.ensembles.len(), self.walkers, self.ndim);
        let max_rows = config.history_rows_for(self.ndim);
        self.history = Some(rebuild(self.step, max_rows, shape, column)?);
        Ok(())
    }
}

fn stretch_alone() -> Vec<(MoveSpec, f64)> {
    vec![(Move::stretch().spec(), 1.0)]
}

/// The specs and weights of `moves`.
fn specs(moves: &[(Move, f64)]) -> Vec<(MoveSpec, f64)> {
    moves.iter().map(|(m, w)| (m.spec(), *w)).collect()
}

/// A mixture's specs and weights as a list, `stretch(a=2)=0.5, ...`.
fn written(moves: &[(MoveSpec, f64)]) -> String {
    let parts: Vec<String> = moves.iter().map(|(m, w)| format!("{m}={w}")).collect();
    parts.join(", ")
}

/// Least wall time between two R̂ computed for progress display alone.
const SHOWN_R_HAT_EVERY: std::time::Duration = std::time::Duration::from_secs(20);

/// Affine-invariant ensemble sampler over a [`LogDensity`], running several independent
/// ensembles side by side.
pub struct EnsembleSampler<'a, D: LogDensity + ?Sized> {
    density: &'a D,
    config: SamplerConfig,
    ndim: usize,
    nderived: usize,
    cache_len: usize,
    /// The blocks updated one after the other in a step; empty for joint updates.
    blocks: Vec<UpdateBlock>,
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
    /// Where the proposals are evaluated when not in this process alone.
    offload: Option<&'a mut dyn Offload>,
    /// Whether the density merges updates of its independent blocks made apart
    /// ([`LogDensity::log_density_from_cache`]); `None` until asked.
    merges: Option<bool>,
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

fn shape(what: String, expected: usize, got: usize) -> Result<(), SamplerError> {
    if expected == got {
        Ok(())
    } else {
        Err(SamplerError::Shape {
            what,
            expected,
            got,
        })
    }
}

impl<'a, D: LogDensity + ?Sized> EnsembleSampler<'a, D> {
    /// A sampler starting from `initial[ensemble][walker]` (each of length `density.dim()`).
    ///
    /// # Errors
    /// [`SamplerError::Shape`] for wrong sizes, [`SamplerError::InvalidConfig`] for fewer than
    /// `2·ndim` walkers, [`SamplerError::BadInitialWalker`] for a non-finite start or one whose
    /// log-density is not finite, [`SamplerError::DegenerateEnsemble`] for walkers that do not
    /// span the space.
    pub fn new(
        density: &'a D,
        config: SamplerConfig,
        initial: Vec<Vec<Vec<f64>>>,
    ) -> Result<Self, SamplerError> {
        let ndim = density.dim();
        let nderived = density.derived_names().len();
        let cache_len = density.cache_len();
        let blocks = blocks_of(density, &config)?;
        check_dims(ndim, &blocks, &config)?;
        let block_coords: Vec<Vec<usize>> = blocks.iter().map(|b| b.coords.clone()).collect();
        shape(
            "initial ensembles".into(),
            config.ensembles(),
            initial.len(),
        )?;
        let walkers = config.walkers();
        let mut states = Vec::with_capacity(initial.len());
        let mut caches = Vec::with_capacity(initial.len());
        for (e, ens) in initial.into_iter().enumerate() {
            shape(format!("walkers of ensemble {e}"), walkers, ens.len())?;
            let mut positions = Vec::with_capacity(walkers * ndim);
            for (w, x) in ens.iter().enumerate() {
                shape(format!("walker {w} of ensemble {e}"), ndim, x.len())?;
                if let Some(v) = x.iter().find(|v| !v.is_finite()) {
                    return Err(SamplerError::BadInitialWalker {
                        ensemble: e,
                        walker: w,
                        position: x.clone(),
                        reason: format!("coordinate {v} is not finite"),
                    });
                }
                positions.extend_from_slice(x);
            }
            let condition = blockwise_condition_number(&positions, ndim, &block_coords);
            if condition.is_nan() || condition > WALKER_CONDITION_LIMIT {
                return Err(SamplerError::DegenerateEnsemble {
                    ensemble: e,
                    condition,
                    limit: WALKER_CONDITION_LIMIT,
                });
            }
            // Stride ≥ 1: without derived values an empty buffer would cut the zip short and
            // leave every walker unevaluated.
            let stride = nderived.max(1);
            let mut strided = vec![0.0; walkers * stride];
            // Stride ≥ 1 here too, for the same reason.
            let mut cache = vec![0.0; walkers * cache_len.max(1)];
            let mut log_density = vec![0.0; walkers];
            let evals: Vec<Eval> = positions
                .par_chunks(ndim)
                .zip(strided.par_chunks_mut(stride))
                .zip(cache.par_chunks_mut(cache_len.max(1)))
                .map(|((x, d), c)| {
                    sort(density.log_density_cached(x, &mut d[..nderived], &mut c[..cache_len]))
                })
                .collect();
            let derived: Vec<f64> = strided
                .chunks(stride)
                .flat_map(|d| d[..nderived].iter().copied())
                .collect();
            for (w, ev) in evals.into_iter().enumerate() {
                let reason = match ev {
                    Eval::Finite(v) => {
                        log_density[w] = v;
                        continue;
                    }
                    Eval::Rejected(r) => format!("log-density rejected the point ({r})"),
                    Eval::Fatal(m) => format!("log-density failed: {m}"),
                };
                return Err(SamplerError::BadInitialWalker {
                    ensemble: e,
                    walker: w,
                    position: positions[w * ndim..(w + 1) * ndim].to_vec(),
                    reason,
                });
            }
            let (ensemble_rng, walker_rngs) = Ensemble::fresh_rngs(config.seed(), e, walkers);
            states.push(EnsembleState {
                positions,
                log_density,
                derived,
                ensemble_rng,
                walker_rngs,
                accepted: vec![0; walkers],
                rejections: Default::default(),
                evaluations: walkers as u64,
                slice_scales: vec![SLICE_MU0; slice_slots(&config, &blocks)],
                slice_updates: 0,
                carry_fits: fresh_carry_fits(&blocks),
            });
            caches.push(cache);
        }
        let rows = config.history_rows_for(ndim);
        Ok(Self::at_first_step(
            density, config, blocks, states, caches, rows,
        ))
    }

    /// A sampler whose ensembles are `states` with `caches`, before its first step, keeping
    /// `history_rows` rows of history.
    fn at_first_step(
        density: &'a D,
        config: SamplerConfig,
        blocks: Vec<UpdateBlock>,
        states: Vec<EnsembleState>,
        caches: Vec<Vec<f64>>,
        history_rows: usize,
    ) -> Self {
        let coords = config.walkers() * density.dim();
        let history = RowHistory::new(config.ensembles(), coords, history_rows);
        Self::assemble(
            density,
            config,
            blocks,
            states,
            caches,
            0,
            history,
            vec![None; TAU_WINDOWS.len()],
        )
    }

    /// A sampler continuing from `state` (as passed to [`ChainSink::checkpoint`]). The
    /// stored log-densities are re-evaluated to make sure the density is the same one.
    ///
    /// # Errors
    /// [`SamplerError::StateMismatch`] when the state does not fit the density or config.
    pub fn from_state(
        density: &'a D,
        config: SamplerConfig,
        state: SamplerState,
    ) -> Result<Self, SamplerError> {
        let mismatch = |detail: String| Err(SamplerError::StateMismatch { detail });
        let ndim = density.dim();
        let nderived = density.derived_names().len();
        let cache_len = density.cache_len();
        if state.updates != config.updates() {
            return mismatch(format!(
                "the chains were drawn with {} updates, the configuration has {}; resume with the original updates",
                state.updates.as_str(),
                config.updates().as_str()
            ));
        }
        let blocks = blocks_of(density, &config)?;
        check_dims(ndim, &blocks, &config)?;
        let walkers = config.walkers();
        if state.version != STATE_VERSION {
            return mismatch(format!(
                "state version {} (expected {STATE_VERSION})",
                state.version
            ));
        }
        if state.ndim != ndim || state.nderived != nderived {
            return mismatch(format!(
                "state has {} parameters and {} derived values, the density {ndim} and {nderived}",
                state.ndim, state.nderived
            ));
        }
        if state.walkers != walkers || state.ensembles.len() != config.ensembles() {
            return mismatch(format!(
                "state has {} ensembles of {} walkers, the configuration {} of {walkers}",
                state.ensembles.len(),
                state.walkers,
                config.ensembles()
            ));
        }
        if state.moves != specs(config.moves()) {
            return mismatch(format!(
                "the chains were drawn with the moves {}, the configuration has {}; resume with the original moves",
                written(&state.moves),
                written(&specs(config.moves()))
            ));
        }
        let mut state = state;
        let Some(mut history) = state.history.take() else {
            return mismatch(
                "the state holds no history (checkpoints leave it out): rebuild it from the \
                 chains with SamplerState::rebuild_history"
                    .into(),
            );
        };
        if history.series.len() != config.ensembles()
            || history.series.iter().any(|c| c.len() != walkers * ndim)
        {
            return mismatch("history does not match the ensembles".into());
        }
        let mut scratch = vec![0.0; nderived];
        let mut caches = Vec::with_capacity(state.ensembles.len());
        for (e, s) in state.ensembles.iter_mut().enumerate() {
            if s.positions.len() != walkers * ndim
                || s.log_density.len() != walkers
                || !(s.derived.is_empty() || s.derived.len() == walkers * nderived)
                || s.walker_rngs.len() != walkers
                || s.accepted.len() != walkers
                || s.slice_scales.len() != slice_slots(&config, &blocks)
                || !carry_fits_match(&s.carry_fits, &blocks)
            {
                return mismatch(format!("arrays of ensemble {e} have the wrong sizes"));
            }
            // The caches and derived values are not stored: the check's full evaluation
            // rebuilds them.
            let mut cache = vec![0.0; walkers * cache_len];
            s.derived = vec![0.0; walkers * nderived];
            for w in 0..walkers {
                let x = &s.positions[w * ndim..(w + 1) * ndim];
                let stored = s.log_density[w];
                let c = &mut cache[w * cache_len..(w + 1) * cache_len];
                match sort(density.log_density_cached(x, &mut scratch, c)) {
                    Eval::Finite(v) if (v - stored).abs() <= RESUME_RTOL * v.abs().max(1.0) => {
                        s.derived[w * nderived..(w + 1) * nderived].copy_from_slice(&scratch);
                    }
                    other => {
                        return mismatch(format!(
                            "walker {w} of ensemble {e} at {x:?} has stored log-density {stored} but the \
                             density gives {other:?}; resume with the same model and data"
                        ))
                    }
                }
            }
            caches.push(cache);
        }
        let SamplerState {
            ensembles,
            step,
            last_tau,
            last_tau_later,
            carry_jumps,
            ..
        } = state;
        let mut later = last_tau_later.into_iter();
        let last_tau = std::iter::once(last_tau)
            .chain((1..TAU_WINDOWS.len()).map(|_| later.next().flatten()))
            .collect();
        history.max_rows = config.history_rows_for(ndim).max(history.rows + 1);
        let history = RowHistory::from_history(&history, walkers * ndim);
        let mut sampler = Self::assemble(
            density, config, blocks, ensembles, caches, step, history, last_tau,
        );
        if !carry_jumps.is_empty() {
            if carry_jumps.len() != sampler.carry_jumps.len() {
                return mismatch(format!(
                    "the state holds tuning jumps for {} blocks, the density has {} blocks with \
                     an optional carried move; resume with the same model",
                    carry_jumps.len(),
                    sampler.carry_jumps.len()
                ));
            }
            sampler.carry_jumps = carry_jumps;
        }
        Ok(sampler)
    }

    #[allow(clippy::too_many_arguments)]
    fn assemble(
        density: &'a D,
        config: SamplerConfig,
        blocks: Vec<UpdateBlock>,
        states: Vec<EnsembleState>,
        caches: Vec<Vec<f64>>,
        step: u64,
        history: RowHistory,
        last_tau: Vec<Option<Vec<Vec<f64>>>>,
    ) -> Self {
        let ndim = density.dim();
        let nderived = density.derived_names().len();
        let cache_len = density.cache_len();
        let ensembles: Vec<Ensemble> = states
            .into_iter()
            .zip(caches)
            .map(|(s, c)| Ensemble::new(s, c, ndim, nderived, cache_len))
            .collect();
        let half = config.walkers() / 2;
        let carry_jumps = if blocks.iter().any(|b| b.carry_measured) {
            vec![[0.0; 2]; blocks.len()]
        } else {
            Vec::new()
        };
        Self {
            carry_jumps,
            pending: (0..ensembles.len()).map(|_| None).collect(),
            step_moves: vec![0; ensembles.len()],
            work: Work::new(ensembles.len(), half, ndim, nderived, cache_len),
            block_streams: (0..ensembles.len()).map(|_| Streams::new()).collect(),
            eval_ns: vec![None; 2 * blocks.len().max(1)],
            half_steps: 0,
            density,
            config,
            ndim,
            nderived,
            cache_len,
            blocks,
            ensembles,
            step,
            history,
            last_tau,
            deadline: None,
            shown_tau: None,
            shown_r_hat: None,
            shown_r_hat_at: None,
            poisoned: false,
            history_released: false,
            offload: None,
            merges: None,
        }
    }

    /// A copy of the complete state, from which [`from_state`](Self::from_state) continues.
    pub fn state(&self) -> SamplerState {
        SamplerState {
            version: STATE_VERSION,
            seed: self.config.seed(),
            ndim: self.ndim,
            nderived: self.nderived,
            walkers: self.config.walkers(),
            moves: specs(self.config.moves()),
            updates: self.config.updates(),
            step: self.step,
            ensembles: self.ensembles.iter().map(|e| e.s.clone()).collect(),
            history: (!self.history_released).then(|| self.history.to_history()),
            last_tau: self.last_tau[0].clone(),
            last_tau_later: self.last_tau[1..].to_vec(),
            carry_jumps: self.carry_jumps.clone(),
        }
    }

    /// Frees the thinned history of the stopping rule (its rows are in the chains), so that
    /// what the caller does between runs (summaries of every recorded draw, say) has its
    /// memory; [`restore_history`](Self::restore_history) brings it back before the next
    /// run, which refuses to start without it. A state taken meanwhile has no history, like a
    /// checkpoint.
    pub fn release_history(&mut self) {
        if self.history_released {
            return;
        }
        let h = &self.history;
        let mut empty = RowHistory::new(0, h.width, h.max_rows);
        (empty.thin, empty.rows) = (h.thin, h.rows);
        self.history = empty;
        self.history_released = true;
    }

    /// Restores a released history from the recorded chains: `column(p, rows)` gives
    /// parameter `p` at the recorded `rows` (increasing indices in the chains' order: step,
    /// then ensemble, then walker). The rows are those the history held, bit for bit. Does
    /// nothing when the history was not released.
    ///
    /// # Errors
    /// What `column` returns; [`SamplerError::Shape`] when it gives the wrong number of
    /// values.
    pub fn restore_history<E: From<SamplerError>>(
        &mut self,
        column: impl FnMut(usize, &[usize]) -> Result<Vec<f64>, E>,
    ) -> Result<(), E> {
        if !self.history_released {
            return Ok(());
        }
        let shape = (self.ensembles.len(), self.config.walkers(), self.ndim);
        let (thin, rows, max_rows) = (self.history.thin, self.history.rows, self.history.max_rows);
        let restored = rebuild(self.step, max_rows, shape, column)?;
        if (restored.thin, restored.rows) != (thin, rows) {
            return Err(SamplerError::Shape {
                what: format!("history restored at step {} (thinning {thin})", self.step),
                expected: rows,
                got: restored.rows,
            }
            .into());
        }
        self.history = RowHistory::from_history(&restored, self.config.walkers() * self.ndim);
        self.history.max_rows = max_rows;
        self.history_released = false;
        Ok(())
    }

    /// Stops every later run at `deadline` (with [`StopReason::TimeCap`]), or never.
    pub fn set_deadline(&mut self, deadline: Option<Instant>) {
        self.deadline = deadline;
    }

    /// Evaluates the proposals of every half-step through `offload` (other processes), except
    /// the slice move's updates, which run here. The chains stay the same bits (see
    /// [`Offload`]).
    pub fn set_offload(&mut self, offload: &'a mut dyn Offload) {
        self.offload = Some(offload);
    }

    /// Updates of each walker per step by the moves: one per block (and one more for a block
    /// drawn exactly whose followers the density carries, which the moves then move too; the
    /// exact draws, always accepted, do not count towards the acceptance rate), one when
    /// joint.
    fn updates_per_step(&self) -> u64 {
        self.blocks
            .iter()
            .filter(|b| !b.conditional || b.density_carries)
            .count()
            .max(1) as u64
    }

    /// Updates of each walker of ensemble `e` so far by Metropolis–Hastings proposals: the
    /// moves' updates but the slice move's (which always move, so that counting them would
    /// inflate the acceptance fraction) and the carried moves dropped after tuning.
    fn proposals_per_walker(&self, e: &Ensemble) -> u64 {
        let dropped: u64 = (0..self.blocks.len())
            .filter(|&b| !self.keeps_carried_move(b, &self.blocks[b], self.step))
            .map(|_| self.step.saturating_sub(CARRY_TUNE_STEPS))
            .sum();
        self.updates_per_step() * self.step - e.s.slice_updates - dropped
    }

    /// Whether block `b` (`block`), drawn exactly and carried by the moves, is still moved by
    /// the moves at step `step`. Both updates run in every step of a block whose carried move is not
    /// optional, and during the first [`CARRY_TUNE_STEPS`] steps of one whose carried move
    /// is. After those, the carried move is kept only if it moved the block at least
    /// [`CARRY_MIN_JUMP_RATIO`] times as far (in squared distance, summed over every walker)
    /// as the exact draws did: where the data pin the members, the exact draw does the work
    /// and the carried move, which re-evaluates every run the block's followers touch, is
    /// mostly rejected (the pooled friction posteriors: at most 3 % of the exact draws'
    /// squared jump); where the data say little, the carried move goes further than the exact
    /// draw (the centred eight schools: 2.2–2.8 times). The choice depends only on the chains, so it is the same on
    /// any number of threads, and it is made before the suggested burn-in ends.
    fn keeps_carried_move(&self, b: usize, block: &UpdateBlock, step: u64) -> bool {
        if !block.carry_measured || step < CARRY_TUNE_STEPS {
            return true;
        }
        let [exact, carried] = self.carry_jumps[b];
        carried >= CARRY_MIN_JUMP_RATIO * exact
    }

    /// The coordinates of `block` of every walker of every ensemble.
    fn block_positions(&self, block: &UpdateBlock) -> Vec<f64> {
        self.ensembles
            .iter()
            .flat_map(|e| e.s.positions.chunks_exact(self.ndim))
            .flat_map(|w| block.coords.iter().map(move |&c| w[c]))
            .collect()
    }

    /// The steps the suggested burn-in covers at least: those during which the slice move's
    /// μ was tuned, and those that chose whether to keep optional carried moves (none
    /// without either).
    fn min_burn_in(&self) -> u64 {
        let slice = if self.config.moves().iter().any(|(m, _)| m.is_slice()) {
            SLICE_ADAPT_STEPS
        } else {
            0
        };
        let carry = if self.carry_jumps.is_empty() {
            0
        } else {
            CARRY_TUNE_STEPS
        };
        let fit = if self.blocks.iter().any(|b| b.tuned_carry) {
            CARRY_FIT_STEPS
        } else {
            0
        };
        slice.max(carry).max(fit)
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
        let result = self.run_inner(steps, sink, observer);
        match &result {
            Ok(r) => observer.on_finish(Some(r)),
            Err(_) => observer.on_finish(None),
        }
        result
    }

    fn run_inner<S: ChainSink, O: Observer + ?Sized>(
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
            let mut stop = false;
            if let Some(rule) = rule {
                if self.step % rule.check_every == 0
                    && self.check_stop(&rule, observer.shows_progress())
                {
                    stop = true;
                    stopped_by = StopReason::Converged;
                }
            }
            if !stop && self.step < last && self.deadline.is_some_and(|d| Instant::now() >= d) {
                stop = true;
                stopped_by = StopReason::TimeCap;
            }
            if !stop && self.step < last && observer.stop_requested() {
                stop = true;
                stopped_by = StopReason::Interrupted;
            }
            let due = self
                .config
                .checkpoint_every()
                .is_some_and(|k| self.step % k == 0);
            if due || stop || self.step == last {
                self.checkpoint(sink)?;
                checkpointed_at = Some(self.step);
            }
            observer.on_step(&self.progress(first, last, started, rule.map(|r| r.tau_factor)));
            if stop {
                break;
            }
        }
        if checkpointed_at != Some(self.step) {
            self.checkpoint(sink)?;
        }
        Ok(self.report(self.step - first, stopped_by))
    }

    fn checkpoint<S: ChainSink>(&self, sink: &mut S) -> Result<(), SamplerError> {
        // A borrowed view serialising exactly like `self.state()`, so that a checkpoint
        // copies nothing unless the sink serialises it.
        sink.checkpoint(&StateView {
            seed: self.config.seed(),
            ndim: self.ndim,
            nderived: self.nderived,
            walkers: self.config.walkers(),
            moves: self.config.moves(),
            updates: self.config.updates(),
            step: self.step,
            ensembles: &self.ensembles,
            last_tau: &self.last_tau,
            carry_jumps: &self.carry_jumps,
        })
        .map_err(|err| SamplerError::Sink {
            step: self.step,
            source: Box::new(err),
        })
    }

    /// One step of every ensemble: one update of every walker (joint), or one update of
    /// every walker in each block in turn (blocked). All randomness is drawn serially,
    /// ensemble by ensemble; per half-step the proposals of all ensembles are evaluated in one
    /// loop (see [`evaluate`](Self::evaluate)).
    fn advance(&mut self, step_no: u64) -> Result<(), SamplerError> {
        let blocks = std::mem::take(&mut self.blocks);
        let result = if blocks.is_empty() {
            self.update(None, false)
        } else {
            self.update_blocks(&blocks, step_no)
        };
        if result.is_ok() && step_no < CARRY_FIT_STEPS && blocks.iter().any(|b| b.tuned_carry) {
            let freeze = step_no + 1 == CARRY_FIT_STEPS / 2 || step_no + 1 == CARRY_FIT_STEPS;
            for ens in &mut self.ensembles {
                ens.tune_carry(&blocks, freeze);
            }
        }
        self.blocks = blocks;
        result.map_err(|(e, f)| {
            self.poisoned = true;
            SamplerError::FatalDensity {
                ensemble: e,
                walker: f.walker,
                step: step_no,
                position: f.position,
                message: f.message,
            }
        })
    }

    /// One update of every walker in each of `blocks` in turn. A run of independent blocks
    /// goes to the offload's processes in shares when it splits them (see
    /// [`update_run`](Self::update_run)).
    fn update_blocks(
        &mut self,
        blocks: &[UpdateBlock],
        step_no: u64,
    ) -> Result<(), (usize, Fatal)> {
        let mut b = 0;
        while b < blocks.len() {
            if let Some(run) = self.split_run(blocks, b) {
                b = run.end;
                self.update_run(blocks, run)?;
                continue;
            }
            let block = &blocks[b];
            // A conditional block is drawn exactly; when the density also carries its followers
            // (the non-centred map), a move of the block with its followers follows, so that the
            // two parametrisations of a hierarchical model interweave (Yu & Meng 2011): the exact
            // draw mixes where the data pin the members, the carried move where they do not.
            let tuning = block.carry_measured && step_no < CARRY_TUNE_STEPS;
            let before = tuning.then(|| self.block_positions(block));
            if block.conditional {
                self.update(Some((b, block)), true)?;
            }
            let drawn = tuning.then(|| self.block_positions(block));
            if !block.conditional
                || (block.density_carries && self.keeps_carried_move(b, block, step_no))
            {
                self.update(Some((b, block)), false)?;
            }
            if let (Some(before), Some(drawn)) = (before, drawn) {
                let after = self.block_positions(block);
                self.carry_jumps[b][0] += squared_distance(&before, &drawn);
                self.carry_jumps[b][1] += squared_distance(&drawn, &after);
            }
            b += 1;
        }
        Ok(())
    }

    /// Updates every walker of every ensemble once: all coordinates, or those of `block`
    /// (its index and coordinates), by the moves or, when `exact`, by an exact draw from the
    /// block's conditional. Returns the first fatal evaluation.
    fn update(
        &mut self,
        block: Option<(usize, &UpdateBlock)>,
        exact: bool,
    ) -> Result<(), (usize, Fatal)> {
        // An independent block draws from its own streams (keyed by its first coordinate, a
        // name that does not depend on the blocks' order), the ensembles' own streams waiting.
        let keyed = block
            .filter(|(_, ub)| ub.independent)
            .map(|(_, ub)| ub.coords[0]);
        if let Some(key) = keyed {
            let (seed, step, walkers) = (self.config.seed(), self.step, self.config.walkers());
            for (e, (ens, streams)) in self
                .ensembles
                .iter_mut()
                .zip(&mut self.block_streams)
                .enumerate()
            {
                streams.rekey(seed, e, key, walkers, step);
                ens.swap_streams(streams);
            }
        }
        let result = self.update_walkers(block, exact);
        if keyed.is_some() {
            for (ens, streams) in self.ensembles.iter_mut().zip(&mut self.block_streams) {
                ens.swap_streams(streams);
            }
        }
        result
    }

    /// [`update`](Self::update) with the ensembles' streams in place.
    fn update_walkers(
        &mut self,
        block: Option<(usize, &UpdateBlock)>,
        exact: bool,
    ) -> Result<(), (usize, Fatal)> {
        let half = self.config.walkers() / 2;
        let (ndim, stride, cstride) = (self.ndim, self.nderived.max(1), self.cache_len.max(1));
        for (ens, mv) in self.ensembles.iter_mut().zip(self.step_moves.iter_mut()) {
            *mv = ens.start_step(self.config.moves());
        }
        for h in 0..2 {
            let moves = self.config.moves();
            let Work {
                proposals,
                derived,
                cache,
                ..
            } = &mut self.work;
            let density = self.density;
            for (((((ens, mv), p), props), der), cac) in self
                .ensembles
                .iter_mut()
                .zip(&self.step_moves)
                .zip(self.pending.iter_mut())
                .zip(proposals.chunks_exact_mut(half * ndim))
                .zip(derived.chunks_exact_mut(half * stride))
                .zip(cache.chunks_exact_mut(half * cstride))
            {
                // An ensemble whose first half failed fatally does not go on (as before).
                if p.is_some() {
                    continue;
                }
                let out = ProposalBuffers {
                    proposals: props,
                    derived: der,
                    cache: cac,
                };
                match (block, &moves[*mv].0) {
                    (Some((b, ub)), _) if exact => {
                        let ln_conditional = |x: &[f64]| density.conditional_log_density(b, x);
                        *p = ens.draw_conditional(h, ub, &ln_conditional, out).err();
                    }
                    // A slice half-step runs below, walker by walker.
                    (_, Move::Slice(_)) => {}
                    (Some((b, ub)), Move::Proposal(mv)) if ub.density_carries => {
                        let carry =
                            |from: &[f64], to: &mut [f64]| density.carry_followers(b, from, to);
                        ens.draw(mv.as_ref(), h, Some((b, ub, Some(&carry))), out);
                    }
                    (_, Move::Proposal(mv)) => {
                        ens.draw(mv.as_ref(), h, block.map(|(b, ub)| (b, ub, None)), out)
                    }
                }
            }
            let moves = self.config.moves();
            let is_slice = |&m: &usize| moves[m].0.is_slice();
            let (any_slice, all_slice) = (
                self.step_moves.iter().any(is_slice),
                self.step_moves.iter().all(is_slice),
            );
            if !exact && any_slice {
                self.slice_half_step(h, block);
            }
            if exact || !all_slice {
                self.evaluate(block.map(|b| b.0), exact);
            }
            let Work {
                proposals,
                derived,
                cache,
                evals,
            } = &self.work;
            // An independent block's move is accepted on the change of its own terms, which
            // the other independent blocks' updates leave alone.
            let density = self.density;
            let local = block
                .filter(|(_, ub)| ub.independent)
                .map(|(b, _)| move |x: &[f64], c: &[f64]| density.block_log_density(b, x, c));
            for (((((ens, p), props), der), cac), ev) in self
                .ensembles
                .iter_mut()
                .zip(self.pending.iter_mut())
                .zip(proposals.chunks_exact(half * ndim))
                .zip(derived.chunks_exact(half * stride))
                .zip(cache.chunks_exact(half * cstride))
                .zip(evals.chunks_exact(half))
            {
                if p.is_none() {
                    let local = local.as_ref().map(|f| f as &BlockTerms);
                    *p = ens.accept(h, props, der, cac, ev, local).err();
                }
            }
        }
        if !exact {
            let slot = block.map_or(0, |b| b.0);
            let adapt = self.step < SLICE_ADAPT_STEPS;
            let moves = self.config.moves();
            for ((ens, mv), p) in self
                .ensembles
                .iter_mut()
                .zip(&self.step_moves)
                .zip(&self.pending)
            {
                if moves[*mv].0.is_slice() && p.is_none() {
                    ens.finish_slice_update(slot, adapt);
                }
            }
        }
        match self
            .pending
            .iter_mut()
            .enumerate()
            .find_map(|(e, p)| p.take().map(|f| (e, f)))
        {
            Some(fatal) => Err(fatal),
            None => Ok(()),
        }
    }

    /// Evaluates the proposals in [`Work`] (in full, or as updates of `block`): on the rayon
    /// pool when parallel evaluation is allowed and the half-step's estimated serial cost
    /// exceeds [`PARALLEL_MIN_WORK_NS`] (below it the synchronisation costs more than it
    /// saves), serially otherwise. The results are the same either way, so the choice (which
    /// depends on timing) cannot change the chains.
    fn evaluate(&mut self, block: Option<usize>, exact: bool) {
        let density = self.density;
        let (ndim, nderived, cache_len) = (self.ndim, self.nderived, self.cache_len);
        let half = self.config.walkers() / 2;
        // The ensembles whose half-step is a slice update have their points already.
        let moves = self.config.moves();
        let skip: Vec<bool> = self
            .step_moves
            .iter()
            .map(|&m| !exact && moves[m].0.is_slice())
            .collect();
        let Work {
            proposals,
            derived,
            cache,
            evals,
        } = &mut self.work;
        let n = half * skip.iter().filter(|&&s| !s).count();
        let threads = rayon::current_num_threads();
        // Exact draws move no followers and cost less: timed apart from the moves.
        // (`self.blocks` is taken out during a step: the slots' count is the blocks'.)
        let slot = block.unwrap_or(0) + if exact { self.eval_ns.len() / 2 } else { 0 };
        let cost = &mut self.eval_ns[slot];
        let parallel = self.config.parallel()
            && threads > 1
            && cost.is_some_and(|c| c * n as f64 >= PARALLEL_MIN_WORK_NS);
        self.half_steps += 1;
        let timed = parallel || cost.is_none() || self.half_steps % RETIME_EVERY == 0;
        let started = timed.then(Instant::now);
        let kind = match block {
            None => EvalKind::Full,
            Some(b) if exact => EvalKind::BlockAlone(b),
            Some(b) => EvalKind::Block(b),
        };
        let slots: Vec<usize> = (0..evals.len()).filter(|&k| !skip[k / half]).collect();
        let local = |kind: EvalKind, x: &[f64], d: &mut [f64], c: &mut [f64]| {
            kind.evaluate(density, x, d, c)
        };
        // With another process to share with, a shared block's update may be split by
        // independent block (the contacts' terms where the contacts are).
        let splitter = match kind {
            EvalKind::Block(b) if self.offload.is_some() && density.block_splits(b) => {
                Some(BlockShares { density, block: b })
            }
            _ => None,
        };
        let parts = match splitter {
            Some(_) => density.independent_blocks().len(),
            None => 0,
        };
        let mut batch = Batch {
            kind,
            ndim,
            nderived,
            cache_len,
            slots: &slots,
            proposals,
            derived,
            cache,
            evals,
            local: &local,
            // Another process's share costs far more than a parallel loop: this process's
            // share always goes to the pool.
            parallel: if self.offload.is_some() {
                self.config.parallel() && threads > 1
            } else {
                parallel
            },
            shares: splitter.as_ref().map(|s| (s as &dyn Shares, parts)),
        };
        match self.offload.as_deref_mut() {
            Some(offload) => {
                offload.evaluate(&mut batch);
                return;
            }
            None => batch.evaluate_here(0..n),
        }
        if let Some(t) = started {
            let ns = t.elapsed().as_secs_f64() * 1e9;
            // In parallel the wall time times the threads over-estimates the cost (it
            // includes the synchronisation), which errs on the side of staying parallel.
            let per = if parallel {
                ns * threads.min(n) as f64 / n as f64
            } else {
                ns / n as f64
            };
            *cost = Some(match *cost {
                Some(c) => 0.5 * (c + per),
                None => per,
            });
        }
    }

    /// The half-step `h` of every ensemble whose move this step is the slice move, on all
    /// coordinates or those of `block`: each active walker's whole slice update (direction,
    /// stepping out, shrinkage, as many evaluations as it needs) is one task, and the tasks
    /// of every ensemble run together, on the rayon pool when parallel evaluation is allowed
    /// and the work is worth it. Each task reads only the fixed complement and its own
    /// walker, draws only from the walker's own stream, and writes only its own buffers of
    /// [`Work`]; the outcomes are taken in walker order. So the chains do not depend on the
    /// number of threads or on the (timing-based) choice to run in parallel. The new points
    /// are then accepted as they are by [`Ensemble::accept`].
    fn slice_half_step(&mut self, h: usize, block: Option<(usize, &UpdateBlock)>) {
        let half = self.config.walkers() / 2;
        let (ndim, stride, cstride) = (self.ndim, self.nderived.max(1), self.cache_len.max(1));
        let slot = block.map_or(0, |b| b.0);
        let moves = self.config.moves();
        let contexts: Vec<Option<SliceContext>> = self
            .ensembles
            .iter()
            .zip(&self.step_moves)
            .zip(&self.pending)
            .map(|((ens, &m), p)| match &moves[m].0 {
                Move::Slice(directions) if p.is_none() => {
                    Some(ens.slice_context(h, directions.as_ref(), slot, block.map(|b| b.1)))
                }
                _ => None,
            })
            .collect();
        let Work {
            proposals,
            derived,
            cache,
            evals,
        } = &mut self.work;
        let mut tasks = Vec::new();
        for (((((ens, context), props), der), cac), ev) in self
            .ensembles
            .iter_mut()
            .zip(&contexts)
            .zip(proposals.chunks_exact_mut(half * ndim))
            .zip(derived.chunks_exact_mut(half * stride))
            .zip(cache.chunks_exact_mut(half * cstride))
            .zip(evals.chunks_exact_mut(half))
        {
            if let Some(context) = context {
                let out = ProposalBuffers {
                    proposals: props,
                    derived: der,
                    cache: cac,
                };
                tasks.extend(ens.slice_tasks(h, context, out, ev));
            }
        }
        let density = self.density;
        let threads = rayon::current_num_threads();
        // A slice update costs a few evaluations; until one has been timed, assume it is worth
        // spreading (the choice cannot change the chains).
        let cost = &mut self.eval_ns[slot];
        let parallel = self.config.parallel()
            && threads > 1
            && cost.is_none_or(|c| {
                c * (SLICE_EVALS_GUESS * tasks.len()) as f64 >= PARALLEL_MIN_WORK_NS
            });
        let started = Instant::now();
        let run = |t: &mut super::ensemble::SliceTask| t.run(density, block);
        let outcomes: Vec<_> = if parallel {
            tasks.par_iter_mut().map(run).collect()
        } else {
            tasks.iter_mut().map(run).collect()
        };
        drop(tasks);
        let evaluations: u64 = outcomes
            .iter()
            .filter_map(|o| o.as_ref().ok())
            .map(|o| o.evaluations())
            .sum();
        if evaluations > 0 {
            let ns = started.elapsed().as_secs_f64() * 1e9;
            let per = ns * if parallel { threads as f64 } else { 1.0 } / evaluations as f64;
            *cost = Some(cost.map_or(per, |c| 0.5 * (c + per)));
        }
        let mut outcomes = outcomes.into_iter();
        for ((ens, context), p) in self
            .ensembles
            .iter_mut()
            .zip(&contexts)
            .zip(self.pending.iter_mut())
        {
            if context.is_some() {
                *p = ens.finish_slice(outcomes.by_ref().take(half)).err();
            }
        }
    }

    /// Applies the stopping rule and returns whether it holds. Each window
    /// of `TAU_WINDOWS` is judged on its own τ: long enough (more than `tau_factor` τ_max
    /// steps from its start), settled (τ changed by less than the rule allows since the last
    /// check of the same window), and R̂ below the bound after the burn-in
    /// max(start, 2 τ_max, the slice move's tuning). The first window that passes stops the run.
    /// Keeps τ_max of the window closest to being long enough for progress, and with
    /// `show_r_hat` its R̂.
    fn check_stop(&mut self, rule: &super::config::StopRule, show_r_hat: bool) -> bool {
        let windows = tau_windows(&self.history, self.ndim, self.step, self.config.parallel());
        // Every coordinate's τ, averaged over the ensembles (each estimates the same τ, and
        // the maximum change over ensembles × coordinates single estimates would mostly
        // measure their noise), changed by less than the rule allows.
        let mean_tau = |t: &[Vec<f64>]| -> Vec<f64> {
            let mut m = vec![0.0; self.ndim];
            for e in t {
                for (a, v) in m.iter_mut().zip(e) {
                    *a += v / t.len() as f64;
                }
            }
            m
        };
        let mut shown: Option<(f64, f64, u64)> = None;
        let mut met = false;
        // Whether this check already computed an R̂ that progress can show.
        let mut r_hat_computed = false;
        for (i, (from_step, tau)) in windows.into_iter().enumerate() {
            let previous = std::mem::replace(&mut self.last_tau[i], tau.clone());
            let Some(tau) = tau else {
                continue;
            };
            let tmax = tau
                .iter()
                .flatten()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max);
            let length = (self.step - from_step) as f64;
            // The τ shown in progress is the one of the window closest to being long enough.
            if shown.is_none_or(|(l, _, _)| length / tmax > l) {
                shown = Some((length / tmax, tmax, from_step));
            }
            if met {
                continue;
            }
            let long_enough = length > rule.tau_factor * tmax;
            let settled = previous.is_some_and(|prev| {
                mean_tau(&prev)
                    .iter()
                    .zip(mean_tau(&tau))
                    .all(|(p, t)| ((t - p) / t).abs() < rule.tau_rel_change)
            });
            if !(long_enough && settled) {
                continue;
            }
            let burn_in = self.window_burn_in(from_step, tmax);
            let r_hat =
                rhat_from_history(&self.history, self.ndim, burn_in, self.config.parallel());
            if let Some(r) = &r_hat {
                self.shown_r_hat = Some(r.iter().copied().fold(f64::NEG_INFINITY, f64::max));
                r_hat_computed = true;
            }
            met = match r_hat {
                Some(r) => r.iter().all(|&v| v < rule.rhat_max),
                None => self.ensembles.len() < 2,
            };
        }
        let Some((_, tmax, from_step)) = shown else {
            return met;
        };
        self.shown_tau = Some(tmax);
        // R̂ for display alone is a pass over the whole history (done at every check it took
        // 7 of the demo's 50 s, measured under load): only for an observer that shows it, and
        // at most every `SHOWN_R_HAT_EVERY`; in between the progress shows the last R̂
        // computed.
        let due = self
            .shown_r_hat_at
            .is_none_or(|t| t.elapsed() >= SHOWN_R_HAT_EVERY);
        if show_r_hat && due && !r_hat_computed {
            let burn_in = self.window_burn_in(from_step, tmax);
            if let Some(r) =
                rhat_from_history(&self.history, self.ndim, burn_in, self.config.parallel())
            {
                self.shown_r_hat = Some(r.into_iter().fold(f64::NEG_INFINITY, f64::max));
            }
            self.shown_r_hat_at = Some(Instant::now());
        }
        met
    }

    /// The burn-in of a stopping-rule window that starts at `from_step` with τ_max `tmax`:
    /// max(start, 2 τ_max, the slice move's tuning).
    fn window_burn_in(&self, from_step: u64, tmax: f64) -> u64 {
        from_step
            .max((2.0 * tmax).ceil() as u64)
            .max(self.min_burn_in())
    }

    fn progress(
        &self,
        first: u64,
        last: u64,
        started: Instant,
        tau_factor: Option<f64>,
    ) -> Progress {
        let tau_max = self.shown_tau;
        // Over the moves' proposals only; NaN when every update was a slice update.
        let (acc, n) = self.ensembles.iter().fold((0u64, 0u64), |(a, n), e| {
            let proposals = self.proposals_per_walker(e) * e.s.accepted.len() as u64;
            (a + e.s.accepted.iter().sum::<u64>(), n + proposals)
        });
        let acceptance = if self.step == 0 {
            0.0
        } else {
            acc as f64 / n as f64
        };
        let done = self.step - first;
        let target = match (tau_factor, tau_max) {
            (Some(f), Some(t)) => ((f * t).ceil() as u64).clamp(self.step, last),
            (Some(_), None) => last,
            _ => last,
        };
        let eta = (done > 0).then(|| {
            let per_step = started.elapsed().as_secs_f64() / done as f64;
            Duration::from_secs_f64(per_step * (target - self.step) as f64)
        });
        Progress {
            step: self.step,
            last_step: last,
            acceptance,
            tau_max,
            r_hat_max: self.shown_r_hat,
            eta,
        }
    }

    /// The report of the current chains (τ and R̂ from the whole history).
    fn report(&self, steps_run: u64, stopped_by: StopReason) -> RunReport {
        let steps = self.step;
        let ensembles: Vec<EnsembleReport> = self
            .ensembles
            .iter()
            .map(|e| EnsembleReport {
                // NaN for walkers updated by the slice move alone: no proposal to accept.
                acceptance: e
                    .s
                    .accepted
                    .iter()
                    .map(|&a| {
                        if steps == 0 {
                            0.0
                        } else {
                            a as f64 / self.proposals_per_walker(e) as f64
                        }
                    })
                    .collect(),
                rejections: e.s.rejections.clone(),
                evaluations: e.s.evaluations,
            })
            .collect();
        let mut problems = Vec::new();
        let parallel = self.config.parallel();
        let tau = chosen_tau_report(
            tau_windows(&self.history, self.ndim, steps, parallel),
            steps,
            TAU_FACTOR,
            self.min_burn_in(),
        );
        match &tau {
            None => problems.push(Problem::NoAutocorrelationTime { steps }),
            Some(t) if !t.reliable => problems.push(Problem::ChainsTooShort {
                steps: steps - t.from_step,
                tau_max: t.max,
            }),
            Some(_) => {}
        }
        let rhat = tau
            .as_ref()
            .and_then(|t| rhat_from_history(&self.history, self.ndim, t.burn_in, parallel));
        if let Some(r) = &rhat {
            for (name, &v) in self.density.param_names().into_iter().zip(r) {
                if v.is_nan() {
                    problems.push(Problem::RHatUndefined { quantity: name });
                } else if v >= RHAT_MAX {
                    problems.push(Problem::RHat {
                        quantity: name,
                        r_hat: v,
                    });
                }
            }
        } else if self.ensembles.len() > 1 {
            problems.push(Problem::RHatNotComputed);
        }
        problems.extend(stuck_walkers(
            ensembles.iter().map(|e| e.acceptance.as_slice()),
            steps,
        ));
        RunReport {
            steps_run,
            total_steps: steps,
            stopped_by,
            ensembles,
            tau,
            rhat,
            converged: problems.is_empty(),
            problems,
        }
    }
}

/// One proposal's buffers as the evaluation loop zips them: position, derived values, cache,
/// outcome.
/// Serial cost (ns) of a half-step's evaluations above which they are spread over the rayon
/// pool. One parallel loop costs a few to tens of µs of synchronisation on a busy
/// two-core machine (measured by `cargo bench --bench sampler`), so parallelism pays only
/// well above that.
const PARALLEL_MIN_WORK_NS: f64 = 100_000.0;

/// Evaluations a slice update is assumed to cost when deciding whether to run a half-step's
/// slice updates in parallel (zeus reports about five on Gaussian targets once μ is tuned).
const SLICE_EVALS_GUESS: usize = 5;

/// Half-steps between re-timings of serial evaluations (each timing costs two clock reads).
const RETIME_EVERY: u64 = 64;

/// Borrowed form of [`SamplerState`] for checkpoints; serialises to the same fields but the
/// history, which [`SamplerState::rebuild_history`] restores from the chains.
struct StateView<'s> {
    seed: u64,
    ndim: usize,
    nderived: usize,
    walkers: usize,
    moves: &'s [(Move, f64)],
    updates: Updates,
    step: u64,
    ensembles: &'s [Ensemble],
    last_tau: &'s [Option<Vec<Vec<f64>>>],
    carry_jumps: &'s [[f64; 2]],
}

impl Serialize for StateView<'_> {
    fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        struct Ensembles<'s>(&'s [Ensemble]);
        impl Serialize for Ensembles<'_> {
            fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
                ser.collect_seq(self.0.iter().map(|e| &e.s))
            }
        }
        // The exact count of fields written: binary formats write it ahead of them.
        let fields = 11 + usize::from(!self.carry_jumps.is_empty());
        let mut st = ser.serialize_struct("SamplerState", fields)?;
        st.serialize_field("version", &STATE_VERSION)?;
        st.serialize_field("seed", &self.seed)?;
        st.serialize_field("ndim", &self.ndim)?;
        st.serialize_field("nderived", &self.nderived)?;
        st.serialize_field("walkers", &self.walkers)?;
        st.serialize_field("moves", self.moves)?;
        st.serialize_field("updates", &self.updates)?;
        st.serialize_field("step", &self.step)?;
        st.serialize_field("ensembles", &Ensembles(self.ensembles))?;
        st.serialize_field("last_tau", &self.last_tau[0])?;
        st.serialize_field("last_tau_later", &self.last_tau[1..])?;
        if self.carry_jumps.is_empty() {
            st.skip_field("carry_jumps")?;
        } else {
            st.serialize_field("carry_jumps", self.carry_jumps)?;
        }
        st.end()
    }
}

/// Steps during which a block both drawn exactly and carried by the moves gets both updates
/// before the sampler decides whether the carried move is worth its evaluations (when the
/// density makes it optional, [`LogDensity::carried_move_optional`]).
pub const CARRY_TUNE_STEPS: u64 = 50;

/// Steps over which a regression carrying a block's followers is tuned (where it is, see
/// [`CarryFit`](super::CarryFit)): fitted to the ensemble's draws of the first half of them
/// (while the complement's regression carries the followers), then refitted to those of
/// the second half (carried by the first fit), then fixed. The suggested burn-in covers them.
pub const CARRY_FIT_STEPS: u64 = 100;

/// The carried move of such a block is kept when its squared jumps over the tuning steps are
/// at least this fraction of the exact draws' (measured: 2.2–2.8 on the centred eight schools,
/// where it is needed; at most 0.03 on the pooled friction posteriors, where it is not).
pub const CARRY_MIN_JUMP_RATIO: f64 = 0.1;

fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// Relative tolerance between a stored and a re-evaluated log-density on resume.
pub const RESUME_RTOL: f64 = 1e-9;

/// The blocks a step updates in turn: the density's, validated, when the configuration asks
/// for blocked updates and the density has two or more, with their links when it asks for
/// hierarchical ones; none (joint updates) otherwise.
fn blocks_of<D: LogDensity + ?Sized>(
    density: &D,
    config: &SamplerConfig,
) -> Result<Vec<UpdateBlock>, SamplerError> {
    let blocks = match config.updates() {
        Updates::Joint => return Ok(Vec::new()),
        Updates::Blocked | Updates::Hierarchical => density.blocks(),
    };
    // One block (or none) is the whole space: joint updates.
    if blocks.len() <= 1 {
        return Ok(Vec::new());
    }
    let ndim = density.dim();
    let mut seen = vec![false; ndim];
    let disjoint = blocks
        .iter()
        .flatten()
        .all(|&i| i < ndim && !std::mem::replace(&mut seen[i], true));
    if !disjoint || blocks.iter().any(Vec::is_empty) || seen.contains(&false) {
        return Err(SamplerError::InvalidConfig {
            name: "blocks",
            value: format!("{blocks:?}"),
            requirement: format!(
                "the density's blocks must be non-empty, disjoint and cover all {ndim} coordinates"
            ),
        });
    }
    let hierarchical = config.updates() == Updates::Hierarchical;
    let links = if hierarchical {
        density.block_links()
    } else {
        Vec::new()
    };
    if !links.is_empty() {
        let in_range = links
            .iter()
            .flat_map(|l| l.given.iter().chain(&l.followers))
            .all(|&i| i < ndim);
        let outside = links
            .iter()
            .zip(&blocks)
            .all(|(l, b)| !l.given.iter().chain(&l.followers).any(|i| b.contains(i)));
        if links.len() != blocks.len() || !in_range || !outside {
            return Err(SamplerError::InvalidConfig {
                name: "block_links",
                value: format!("{links:?}"),
                requirement: format!(
                    "one entry per block ({}), each naming coordinates below {ndim} outside its block",
                    blocks.len()
                ),
            });
        }
    }
    let conditional = density.conditional_blocks();
    if let Some(&b) = conditional.iter().find(|&&b| b >= blocks.len()) {
        return Err(SamplerError::InvalidConfig {
            name: "conditional_blocks",
            value: format!("{conditional:?}"),
            requirement: format!(
                "block {b} does not exist: name blocks below {}",
                blocks.len()
            ),
        });
    }
    let independent = density.independent_blocks();
    if let Some(&b) = independent.iter().find(|&&b| {
        b >= blocks.len()
            || conditional.contains(&b)
            || (hierarchical && density.carries_followers(b))
            || links.get(b).is_some_and(|l| !l.followers.is_empty())
    }) {
        return Err(SamplerError::InvalidConfig {
            name: "independent_blocks",
            value: format!("{independent:?}"),
            requirement: format!(
                "block {b} cannot be updated independently: name existing blocks (below {}) \
                 that are not drawn exactly and have no followers",
                blocks.len()
            ),
        });
    }
    let mut links = links.into_iter();
    Ok(blocks
        .into_iter()
        .enumerate()
        .map(|(b, coords)| UpdateBlock {
            coords,
            links: links.next().unwrap_or_default(),
            conditional: conditional.contains(&b),
            density_carries: hierarchical && density.carries_followers(b),
            carry_measured: hierarchical
                && conditional.contains(&b)
                && density.carries_followers(b)
                && density.carried_move_optional(b),
            tuned_carry: false,
            independent: independent.contains(&b),
        })
        .map(|mut b| {
            b.tuned_carry = hierarchical
                && !b.density_carries
                && config
                    .carry()
                    .tunes(b.links.followers.len(), config.walkers());
            b
        })
        .collect())
}

/// A fresh tuning for every block whose followers are carried by a tuned regression; none
/// when no block is.
fn fresh_carry_fits(blocks: &[UpdateBlock]) -> Vec<Option<CarryTuning>> {
    if !blocks.iter().any(|b| b.tuned_carry) {
        return Vec::new();
    }
    blocks
        .iter()
        .map(|b| {
            b.tuned_carry
                .then(|| CarryTuning::new(b.coords.len(), b.links.followers.len()))
        })
        .collect()
}

/// Whether a stored state's tunings are those `blocks` need.
fn carry_fits_match(fits: &[Option<CarryTuning>], blocks: &[UpdateBlock]) -> bool {
    if !blocks.iter().any(|b| b.tuned_carry) {
        return fits.is_empty();
    }
    fits.len() == blocks.len()
        && fits.iter().zip(blocks).all(|(f, b)| match f {
            Some(t) => b.tuned_carry && t.fits(b.coords.len(), b.links.followers.len()),
            None => !b.tuned_carry,
        })
}

/// Update slots with a slice scale μ of their own: one for joint updates, one per block
/// otherwise; none when the moves hold no slice move.
fn slice_slots(config: &SamplerConfig, blocks: &[UpdateBlock]) -> usize {
    if config.moves().iter().any(|(m, _)| m.is_slice()) {
        blocks.len().max(1)
    } else {
        0
    }
}

/// The walkers must span the space each move acts in: the whole space, or each block.
fn check_dims(
    ndim: usize,
    blocks: &[UpdateBlock],
    config: &SamplerConfig,
) -> Result<(), SamplerError> {
    let span = blocks.iter().map(|b| b.coords.len()).max().unwrap_or(ndim);
    if ndim == 0 {
        return Err(SamplerError::InvalidConfig {
            name: "dim",
            value: "0".into(),
            requirement: "the density must have at least one parameter".into(),
        });
    }
    if config.walkers() < 2 * span {
        let what = if blocks.is_empty() {
            "ndim"
        } else {
            "the largest block"
        };
        return Err(SamplerError::InvalidConfig {
            name: "walkers",
            value: config.walkers().to_string(),
            requirement: format!(
                "must be at least 2 × {what} = {} for this density",
                2 * span
            ),
        });
    }
    for (m, _) in config.moves() {
        m.validate_complement(config.walkers() / 2, span)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::density::{BlockLinks, LogDensityError};
    use crate::sampler::{MemorySink, Move, NullSink, Silent};

    /// A 3-D standard normal without derived values.
    struct Normal3;
    impl LogDensity for Normal3 {
        fn dim(&self) -> usize {
            3
        }
        fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
            Ok(-0.5 * x.iter().map(|v| v * v).sum::<f64>())
        }
    }

    /// Normal3 in two blocks with links as given.
    struct Linked(Vec<BlockLinks>);
    impl LogDensity for Linked {
        fn dim(&self) -> usize {
            3
        }
        fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
            Normal3.log_density(x, d)
        }
        fn blocks(&self) -> Vec<Vec<usize>> {
            vec![vec![0], vec![1, 2]]
        }
        fn block_links(&self) -> Vec<BlockLinks> {
            self.0.clone()
        }
    }

    #[test]
    fn hierarchical_updates_take_the_links_and_refuse_bad_ones() {
        let link = |given: Vec<usize>, followers: Vec<usize>| BlockLinks { given, followers };
        let config = |u| SamplerConfig::new(8, 1, 5).unwrap().with_updates(u);
        let good = Linked(vec![link(vec![], vec![1, 2]), link(vec![0], vec![])]);
        let blocks = blocks_of(&good, &config(Updates::Hierarchical)).unwrap();
        assert_eq!(blocks[0].links.followers, [1, 2]);
        assert_eq!(blocks[1].links.given, [0]);
        // Plain blocked updates ignore them.
        let blocks = blocks_of(&good, &config(Updates::Blocked)).unwrap();
        assert!(blocks.iter().all(|b| b.links == BlockLinks::default()));
        for bad in [
            vec![link(vec![], vec![1, 2])],
            vec![link(vec![], vec![0]), link(vec![0], vec![])],
            vec![link(vec![], vec![3]), link(vec![0], vec![])],
        ] {
            match blocks_of(&Linked(bad), &config(Updates::Hierarchical)) {
                Err(SamplerError::InvalidConfig { name, .. }) => assert_eq!(name, "block_links"),
                other => panic!("expected bad block_links, got {other:?}"),
            }
        }
    }

    fn sampler(ensembles: usize) -> EnsembleSampler<'static, Normal3> {
        let config = SamplerConfig::new(8, ensembles, 5)
            .unwrap()
            .with_moves(vec![
                (Move::stretch(), 1.0),
                (Move::differential_evolution(), 1.0),
                (Move::walk(), 1.0),
            ])
            .unwrap();
        let init: Vec<Vec<Vec<f64>>> = (0..ensembles)
            .map(|e| {
                (0..8)
                    .map(|w| {
                        let w = w as f64;
                        vec![
                            0.1 * w,
                            0.05 * ((3.0 * w + e as f64) % 8.0),
                            0.02 * (5.0 * w % 8.0),
                        ]
                    })
                    .collect()
            })
            .collect();
        EnsembleSampler::new(&Normal3, config, init).unwrap()
    }

    /// The stored log-density of every walker is the density at its position, from the
    /// start (a density without derived values once left them all at 0) and after each step.
    #[test]
    fn stored_log_density_matches_the_position() {
        let mut s = sampler(2);
        for step in 0..=40 {
            if step > 0 {
                s.run(Steps::Fixed(1), &mut NullSink, &mut Silent).unwrap();
            }
            for (e, ens) in s.ensembles.iter().enumerate() {
                for (w, (x, &stored)) in ens
                    .s
                    .positions
                    .chunks(3)
                    .zip(&ens.s.log_density)
                    .enumerate()
                {
                    let lp = Normal3.log_density(x, &mut []).unwrap();
                    assert!(
                        (lp - stored).abs() <= 1e-12,
                        "step {step}, ensemble {e}, walker {w}: stored {stored}, density {lp}"
                    );
                }
            }
        }
    }

    /// A hierarchical normal: μ ~ N(0, 3²) shared, members θ_j ~ N(μ, 1) each observed once
    /// (y_j ~ N(θ_j, 0.5²)), in blocks listed in `order` (μ's first). The cache holds each
    /// member's terms; the members' blocks are independent given μ. One derived value, the
    /// sum of the coordinates, reads the whole point.
    struct Members {
        y: Vec<f64>,
        order: Vec<usize>,
    }
    impl Members {
        fn member(&self, j: usize, x: &[f64]) -> f64 {
            let (t, r) = (x[j + 1] - x[0], (self.y[j] - x[j + 1]) / 0.5);
            -0.5 * (t * t + r * r)
        }
        fn total(&self, x: &[f64], cache: &[f64], derived: &mut [f64]) -> f64 {
            derived[0] = x.iter().sum();
            cache.iter().fold(-0.5 * x[0] * x[0] / 9.0, |lp, c| lp + c)
        }
    }
    impl LogDensity for Members {
        fn dim(&self) -> usize {
            self.y.len() + 1
        }
        fn derived_names(&self) -> Vec<String> {
            vec!["sum".into()]
        }
        fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
            let mut cache = vec![0.0; self.y.len()];
            self.log_density_cached(x, d, &mut cache)
        }
        fn blocks(&self) -> Vec<Vec<usize>> {
            self.order.iter().map(|&b| vec![b]).collect()
        }
        fn independent_blocks(&self) -> Vec<usize> {
            (0..self.order.len())
                .filter(|&b| self.order[b] != 0)
                .collect()
        }
        fn block_log_density(&self, block: usize, _x: &[f64], cache: &[f64]) -> f64 {
            cache[self.order[block] - 1]
        }
        fn log_density_from_cache(
            &self,
            x: &[f64],
            derived: &mut [f64],
            cache: &[f64],
        ) -> Option<f64> {
            Some(self.total(x, cache, derived))
        }
        fn cache_len(&self) -> usize {
            self.y.len()
        }
        fn log_density_cached(
            &self,
            x: &[f64],
            d: &mut [f64],
            cache: &mut [f64],
        ) -> Result<f64, LogDensityError> {
            for (j, c) in cache.iter_mut().enumerate() {
                *c = self.member(j, x);
            }
            Ok(self.total(x, cache, d))
        }
        fn log_density_block(
            &self,
            block: usize,
            x: &[f64],
            d: &mut [f64],
            cache: &mut [f64],
        ) -> Result<f64, LogDensityError> {
            match self.order[block] {
                0 => self.log_density_cached(x, d, cache),
                c => {
                    cache[c - 1] = self.member(c - 1, x);
                    Ok(self.total(x, cache, d))
                }
            }
        }
    }

    /// The members' blocks are updated in whatever order the density lists them with the
    /// same chains, bit for bit, under every kind of move: each draws from streams keyed by
    /// its first coordinate and accepts on its own terms.
    #[test]
    fn independent_blocks_give_the_same_chains_in_any_order() {
        let y = vec![0.3, -1.2, 2.0, 0.7];
        let init: Vec<Vec<Vec<f64>>> = (0..2)
            .map(|e| {
                (0..12)
                    .map(|w| {
                        (0..5)
                            .map(|i| 0.1 * ((w * 7 + i * 3 + e) % 11) as f64 - 0.5)
                            .collect()
                    })
                    .collect()
            })
            .collect();
        // Updated in `shares` shares, all but the first on replicas (1: not split).
        let run_split = |order: Vec<usize>, moves: Vec<(Move, f64)>, shares: usize| {
            let density = Members {
                y: y.clone(),
                order,
            };
            let config = SamplerConfig::new(12, 2, 11)
                .unwrap()
                .with_updates(Updates::Blocked)
                .with_moves(moves)
                .unwrap();
            let mut replicas = ReplicaShares::new(&density, &config, shares).unwrap();
            let mut s = EnsembleSampler::new(&density, config, init.clone()).unwrap();
            if shares > 1 {
                s.set_offload(&mut replicas);
            }
            s.run(Steps::Fixed(40), &mut NullSink, &mut Silent).unwrap();
            let blocks = s.blocks.iter().filter(|b| b.independent).count();
            assert_eq!(blocks, 4);
            s.ensembles
                .iter()
                .map(|e| {
                    (
                        (
                            e.s.positions.clone(),
                            e.s.log_density.clone(),
                            e.s.derived.clone(),
                        ),
                        (
                            e.s.accepted.clone(),
                            e.s.evaluations,
                            e.s.slice_scales.clone(),
                            e.s.slice_updates,
                        ),
                    )
                })
                .collect::<Vec<_>>()
        };
        // The slice move's scales are kept per block in the blocks' order: left out here.
        let run = |order: Vec<usize>, moves: Vec<(Move, f64)>| {
            let mut chains = run_split(order, moves, 1);
            for (_, (_, _, scales, _)) in &mut chains {
                scales.clear();
            }
            chains
        };
        for moves in [
            vec![
                (Move::stretch(), 1.0),
                (Move::differential_evolution(), 1.0),
            ],
            vec![(Move::student_t(), 1.0)],
            vec![(Move::slice(), 1.0)],
        ] {
            let listed = run(vec![0, 1, 2, 3, 4], moves.clone());
            for order in [vec![0, 4, 3, 2, 1], vec![0, 2, 4, 1, 3]] {
                assert_eq!(run(order, moves.clone()), listed, "moves {moves:?}");
            }
            // Updated at the same time in shares on replicas, merged: the same bits.
            let whole = run_split(vec![0, 1, 2, 3, 4], moves.clone(), 1);
            for shares in [2, 3, 4] {
                let split = run_split(vec![0, 1, 2, 3, 4], moves.clone(), shares);
                assert_eq!(split, whole, "moves {moves:?}, {shares} shares");
            }
            // The walkers did move.
            let start: Vec<f64> = init[0].concat();
            assert!(listed[0]
                .0
                 .0
                .iter()
                .zip(&start)
                .any(|(a, b)| a.to_bits() != b.to_bits()));
        }
    }

    /// A block named independent that has followers, or is drawn exactly, is refused.
    #[test]
    fn independent_blocks_with_followers_are_refused() {
        let link = |given: Vec<usize>, followers: Vec<usize>| BlockLinks { given, followers };
        struct Claims(Linked);
        impl LogDensity for Claims {
            fn dim(&self) -> usize {
                3
            }
            fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
                self.0.log_density(x, d)
            }
            fn blocks(&self) -> Vec<Vec<usize>> {
                self.0.blocks()
            }
            fn block_links(&self) -> Vec<BlockLinks> {
                self.0.block_links()
            }
            fn independent_blocks(&self) -> Vec<usize> {
                vec![0, 1]
            }
        }
        let density = Claims(Linked(vec![
            link(vec![], vec![1, 2]),
            link(vec![0], vec![]),
        ]));
        let config = SamplerConfig::new(8, 1, 5)
            .unwrap()
            .with_updates(Updates::Hierarchical);
        match blocks_of(&density, &config) {
            Err(SamplerError::InvalidConfig { name, .. }) => assert_eq!(name, "independent_blocks"),
            other => panic!("expected refused independent_blocks, got {other:?}"),
        }
    }

    /// A checkpoint serialises the borrowed view exactly like the owned state.
    #[test]
    fn checkpoint_view_serialises_like_the_state() {
        let mut s = sampler(2);
        let mut sink = MemorySink::new();
        s.run(Steps::Fixed(30), &mut sink, &mut Silent).unwrap();
        let mut state = s.state();
        let history = state.history.take();
        assert_eq!(
            sink.last_checkpoint.as_deref(),
            Some(serde_json::to_string(&state).unwrap().as_str())
        );
        // What the checkpoint leaves out, the chains restore bit for bit.
        let mut restored: SamplerState =
            serde_json::from_str(sink.last_checkpoint.as_deref().unwrap()).unwrap();
        restored
            .rebuild_history::<SamplerError>(&s.config, |p| Ok(sink.position_column(p)))
            .unwrap();
        assert_eq!(restored.history, history);
    }
}
