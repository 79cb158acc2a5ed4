//! Building a sampler: from starting walkers ([`EnsembleSampler::new`]) or from a saved
//! state ([`EnsembleSampler::from_state`]), whose walkers are re-evaluated to check that the
//! density is the same.

use rayon::prelude::*;

use super::super::config::SamplerConfig;
use super::super::ensemble::{Ensemble, EnsembleState, Streams, UpdateBlock, Work};
use super::super::error::SamplerError;
use super::super::evaluator::EvalKind;
use super::super::executor::Parallelism;
use super::super::history::RowHistory;
use super::super::moves::SLICE_MU0;
use super::super::report::TAU_WINDOWS;
use super::plan::{blocks_of, carry_fits_match, check_dims, fresh_carry_fits, slice_slots};
use super::state::{specs, written, SamplerState, STATE_VERSION};
use super::EnsembleSampler;
use crate::density::{sort, BlockedDensity, Eval, LogDensity, Target};
use crate::diagnostics::{blockwise_condition_number, WALKER_CONDITION_LIMIT};

/// Relative tolerance between a stored and a re-evaluated log-density on resume.
pub const RESUME_RTOL: f64 = 1e-9;

/// What a sampler makes of its density under its configuration: the dimensions, and the
/// blocks a step updates with the state each walker keeps for them.
pub(super) struct Layout<'a> {
    pub ndim: usize,
    pub nderived: usize,
    pub state_len: usize,
    /// The density's blocks, when the blocks are updated one after the other.
    pub blocked: Option<&'a dyn BlockedDensity>,
    pub blocks: Vec<UpdateBlock<'a>>,
}

impl<'a> Layout<'a> {
    /// The layout of `target` under `config`, checked.
    ///
    /// # Errors
    /// [`SamplerError::InvalidConfig`] for invalid blocks, or too few walkers.
    pub fn new<D: LogDensity + ?Sized>(
        target: Target<'a, D>,
        config: &SamplerConfig,
    ) -> Result<Self, SamplerError> {
        let density = target.density();
        let ndim = density.dim();
        let blocks = blocks_of(target, config)?;
        check_dims(ndim, &blocks, config)?;
        // A walker keeps a state only when its blocks are updated one at a time.
        let blocked = target.blocked_density().filter(|_| !blocks.is_empty());
        Ok(Self {
            ndim,
            nderived: density.derived_names().len(),
            state_len: blocked.map_or(0, |b| b.state_len()),
            blocked,
            blocks,
        })
    }

    /// How a walker is evaluated in full: filling its state when it keeps one.
    pub fn full(&self) -> EvalKind<'a> {
        match self.blocked {
            Some(blocked) => EvalKind::FullWithState(blocked),
            None => EvalKind::Full,
        }
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
        target: impl Into<Target<'a, D>>,
        config: SamplerConfig,
        initial: Vec<Vec<Vec<f64>>>,
    ) -> Result<Self, SamplerError> {
        let target = target.into();
        let layout = Layout::new(target, &config)?;
        let block_coords: Vec<Vec<usize>> =
            layout.blocks.iter().map(|b| b.coords.clone()).collect();
        shape(
            "initial ensembles".into(),
            config.ensembles(),
            initial.len(),
        )?;
        let (ndim, walkers) = (layout.ndim, config.walkers());
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
            let Evaluated {
                log_density,
                derived,
                state: cache,
            } = evaluate_start(target.density(), &layout, e, &positions)?;
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
                slice_scales: vec![SLICE_MU0; slice_slots(&config, &layout.blocks)],
                slice_updates: 0,
                carry_fits: fresh_carry_fits(&layout.blocks),
            });
            caches.push(cache);
        }
        let rows = config.history_rows_for(ndim);
        Ok(Self::at_first_step(
            target.density(),
            layout,
            config,
            states,
            caches,
            rows,
        ))
    }

    /// A sampler whose ensembles are `states` with `caches`, before its first step, keeping
    /// `history_rows` rows of history.
    pub(super) fn at_first_step(
        density: &'a D,
        layout: Layout<'a>,
        config: SamplerConfig,
        states: Vec<EnsembleState>,
        caches: Vec<Vec<f64>>,
        history_rows: usize,
    ) -> Self {
        let coords = config.walkers() * density.dim();
        let history = RowHistory::new(config.ensembles(), coords, history_rows);
        Self::assemble(
            density,
            layout,
            config,
            states,
            caches,
            0,
            history,
            vec![None; TAU_WINDOWS.len()],
        )
    }

    /// A sampler continuing from `state` (as passed to
    /// [`ChainSink::checkpoint`](crate::sampler::ChainSink::checkpoint)). The
    /// stored log-densities are re-evaluated to make sure the density is the same one.
    ///
    /// # Errors
    /// [`SamplerError::StateMismatch`] when the state does not fit the density or config.
    pub fn from_state(
        target: impl Into<Target<'a, D>>,
        config: SamplerConfig,
        state: SamplerState,
    ) -> Result<Self, SamplerError> {
        let target = target.into();
        let mismatch = |detail: String| Err(SamplerError::StateMismatch { detail });
        if state.updates != config.updates() {
            return mismatch(format!(
                "the chains were drawn with {} updates, the configuration has {}; resume with the original updates",
                state.updates.as_str(),
                config.updates().as_str()
            ));
        }
        let layout = Layout::new(target, &config)?;
        check_state(&state, &config, &layout)?;
        let mut state = state;
        let Some(mut history) = state.history.take() else {
            return mismatch(
                "the state holds no history (checkpoints leave it out): rebuild it from the \
                 chains with SamplerState::rebuild_history"
                    .into(),
            );
        };
        let (ndim, walkers) = (layout.ndim, config.walkers());
        if history.series.len() != config.ensembles()
            || history.series.iter().any(|c| c.len() != walkers * ndim)
        {
            return mismatch("history does not match the ensembles".into());
        }
        let mut caches = Vec::with_capacity(state.ensembles.len());
        for (e, s) in state.ensembles.iter_mut().enumerate() {
            if s.positions.len() != walkers * ndim
                || s.log_density.len() != walkers
                || !(s.derived.is_empty() || s.derived.len() == walkers * layout.nderived)
                || s.walker_rngs.len() != walkers
                || s.accepted.len() != walkers
                || s.slice_scales.len() != slice_slots(&config, &layout.blocks)
                || !carry_fits_match(&s.carry_fits, &layout.blocks)
            {
                return mismatch(format!("arrays of ensemble {e} have the wrong sizes"));
            }
            caches.push(evaluate_resumed(target.density(), &layout, e, s)?);
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
            target.density(),
            layout,
            config,
            ensembles,
            caches,
            step,
            history,
            last_tau,
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
    pub(super) fn assemble(
        density: &'a D,
        layout: Layout<'a>,
        config: SamplerConfig,
        states: Vec<EnsembleState>,
        caches: Vec<Vec<f64>>,
        step: u64,
        history: RowHistory,
        last_tau: Vec<Option<Vec<Vec<f64>>>>,
    ) -> Self {
        let Layout {
            ndim,
            nderived,
            state_len,
            blocks,
            ..
        } = layout;
        let ensembles: Vec<Ensemble> = states
            .into_iter()
            .zip(caches)
            .map(|(s, c)| Ensemble::new(s, c, ndim, nderived, state_len))
            .collect();
        let half = config.walkers() / 2;
        let carry_jumps = if blocks.iter().any(|b| b.carry_measured) {
            vec![[0.0; 2]; blocks.len()]
        } else {
            Vec::new()
        };
        Self {
            independent_parts: blocks.iter().filter(|b| b.independent()).count(),
            carry_jumps,
            pending: (0..ensembles.len()).map(|_| None).collect(),
            step_moves: vec![0; ensembles.len()],
            work: Work::new(ensembles.len(), half, ndim, nderived, state_len),
            block_streams: (0..ensembles.len()).map(|_| Streams::new()).collect(),
            eval_ns: vec![None; 2 * blocks.len().max(1)],
            half_steps: 0,
            density,
            config,
            ndim,
            nderived,
            state_len,
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
            parallelism: Parallelism::default(),
        }
    }
}

/// Starting walkers evaluated: each one's log-density, derived values (`walkers × nderived`)
/// and state (`walkers × state_len`, at least one value per walker).
struct Evaluated {
    log_density: Vec<f64>,
    derived: Vec<f64>,
    state: Vec<f64>,
}

/// Ensemble `e`'s starting walkers at `positions`, evaluated in parallel.
///
/// # Errors
/// [`SamplerError::BadInitialWalker`] naming the first walker the density refuses.
fn evaluate_start<D: LogDensity + ?Sized>(
    density: &D,
    layout: &Layout,
    e: usize,
    positions: &[f64],
) -> Result<Evaluated, SamplerError> {
    let (ndim, nderived, state_len) = (layout.ndim, layout.nderived, layout.state_len);
    let walkers = positions.len() / ndim;
    let kind = layout.full();
    // Strides ≥ 1: without derived values or state an empty buffer would cut the zip short
    // and leave every walker unevaluated.
    let stride = nderived.max(1);
    let mut strided = vec![0.0; walkers * stride];
    let mut cache = vec![0.0; walkers * state_len.max(1)];
    let evals: Vec<Eval> = positions
        .par_chunks(ndim)
        .zip(strided.par_chunks_mut(stride))
        .zip(cache.par_chunks_mut(state_len.max(1)))
        .map(|((x, d), c)| sort(kind.evaluate(density, x, &mut d[..nderived], &mut c[..state_len])))
        .collect();
    let derived: Vec<f64> = strided
        .chunks(stride)
        .flat_map(|d| d[..nderived].iter().copied())
        .collect();
    let mut log_density = vec![0.0; walkers];
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
    Ok(Evaluated {
        log_density,
        derived,
        state: cache,
    })
}

/// Re-evaluates the walkers of a resumed ensemble `e` (`s`): each stored log-density must be
/// the density's, and the derived values and the states (not stored) come back from the
/// evaluation. Returns the states, `walkers × state_len`.
///
/// # Errors
/// [`SamplerError::StateMismatch`] naming the first walker whose stored log-density the
/// density does not give.
fn evaluate_resumed<D: LogDensity + ?Sized>(
    density: &D,
    layout: &Layout,
    e: usize,
    s: &mut EnsembleState,
) -> Result<Vec<f64>, SamplerError> {
    let (ndim, nderived, state_len) = (layout.ndim, layout.nderived, layout.state_len);
    let walkers = s.log_density.len();
    let kind = layout.full();
    let mut scratch = vec![0.0; nderived];
    let mut cache = vec![0.0; walkers * state_len];
    s.derived = vec![0.0; walkers * nderived];
    for w in 0..walkers {
        let x = &s.positions[w * ndim..(w + 1) * ndim];
        let stored = s.log_density[w];
        let c = &mut cache[w * state_len..(w + 1) * state_len];
        match sort(kind.evaluate(density, x, &mut scratch, c)) {
            Eval::Finite(v) if (v - stored).abs() <= RESUME_RTOL * v.abs().max(1.0) => {
                s.derived[w * nderived..(w + 1) * nderived].copy_from_slice(&scratch);
            }
            other => {
                return Err(SamplerError::StateMismatch {
                    detail: format!(
                        "walker {w} of ensemble {e} at {x:?} has stored log-density {stored} but \
                         the density gives {other:?}; resume with the same model and data"
                    ),
                })
            }
        }
    }
    Ok(cache)
}

/// Whether a saved `state` fits the sampler's `config` and `layout`: its version, dimensions,
/// ensembles and moves.
///
/// # Errors
/// [`SamplerError::StateMismatch`] saying what differs.
fn check_state(
    state: &SamplerState,
    config: &SamplerConfig,
    layout: &Layout,
) -> Result<(), SamplerError> {
    let (ndim, nderived, walkers) = (layout.ndim, layout.nderived, config.walkers());
    let detail = if state.version != STATE_VERSION {
        format!("state version {} (expected {STATE_VERSION})", state.version)
    } else if state.ndim != ndim || state.nderived != nderived {
        format!(
            "state has {} parameters and {} derived values, the density {ndim} and {nderived}",
            state.ndim, state.nderived
        )
    } else if state.walkers != walkers || state.ensembles.len() != config.ensembles() {
        format!(
            "state has {} ensembles of {} walkers, the configuration {} of {walkers}",
            state.ensembles.len(),
            state.walkers,
            config.ensembles()
        )
    } else if state.moves != specs(config.moves()) {
        format!(
            "the chains were drawn with the moves {}, the configuration has {}; resume with the original moves",
            written(&state.moves),
            written(&specs(config.moves()))
        )
    } else {
        return Ok(());
    };
    Err(SamplerError::StateMismatch { detail })
}
