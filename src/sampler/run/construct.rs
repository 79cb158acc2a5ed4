//! Building a sampler: from starting walkers ([`EnsembleSampler::new`]) or from a saved
//! state ([`EnsembleSampler::from_state`]), whose walkers are re-evaluated to check that the
//! density is the same.

use rayon::prelude::*;

use super::super::config::SamplerConfig;
use super::super::ensemble::{Ensemble, EnsembleState, Streams, UpdateBlock, Work};
use super::super::error::SamplerError;
use super::super::history::RowHistory;
use super::super::moves::SLICE_MU0;
use super::super::report::TAU_WINDOWS;
use super::plan::{blocks_of, carry_fits_match, check_dims, fresh_carry_fits, slice_slots};
use super::state::{SamplerState, STATE_VERSION};
use super::EnsembleSampler;
use crate::density::{sort, Eval, LogDensity};
use crate::diagnostics::{blockwise_condition_number, WALKER_CONDITION_LIMIT};

/// Relative tolerance between a stored and a re-evaluated log-density on resume.
pub const RESUME_RTOL: f64 = 1e-9;

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
    pub(super) fn at_first_step(
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
        if state.moves.as_slice() != config.moves() {
            return mismatch(format!(
                "the chains were drawn with the moves {:?}, the configuration has {:?}; resume with the original moves",
                state.moves,
                config.moves()
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
    pub(super) fn assemble(
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
            step_moves: vec![config.moves()[0].0; ensembles.len()],
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
}
