//! What a run reports: acceptance, rejections, evaluations, τ, R̂ and convergence.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use rayon::prelude::*;

use super::history::RowHistory;
use crate::diagnostics::{integrated_time, rhat_by, Problem, DEFAULT_WINDOW_FACTOR};

/// Why the run stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum StopReason {
    /// The fixed number of steps was run.
    FixedSteps,
    /// The stopping rule was met.
    Converged,
    /// The step cap was reached before the stopping rule was met.
    StepCap,
    /// The sampler's deadline passed before the run's steps were done or its stopping rule
    /// was met.
    TimeCap,
}

/// Counters of one ensemble.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnsembleReport {
    /// Acceptance fraction of each walker over all steps so far.
    pub acceptance: Vec<f64>,
    /// Proposals rejected because the density refused them, per reason.
    pub rejections: BTreeMap<String, u64>,
    /// Log-density evaluations (including the initial ones).
    pub evaluations: u64,
}

/// Integrated autocorrelation times, in steps, and what follows from them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TauReport {
    /// τ per ensemble (outer) and parameter (inner).
    pub per_ensemble: Vec<Vec<f64>>,
    /// Largest τ.
    pub max: f64,
    /// Smallest τ.
    pub min: f64,
    /// Whether the chains are longer than 50 τ_max, so that τ can be trusted.
    pub reliable: bool,
    /// Suggested burn-in, ⌈2 τ_max⌉ steps. (No thinning is suggested: thinning adds no
    /// information, and the diagnostics use every post-burn-in draw.)
    pub burn_in: u64,
}

/// Summary of a run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunReport {
    /// Steps run by this call.
    pub steps_run: u64,
    /// Steps in the chains (including earlier runs).
    pub total_steps: u64,
    /// Why the run stopped.
    pub stopped_by: StopReason,
    /// Counters per ensemble.
    pub ensembles: Vec<EnsembleReport>,
    /// τ estimate at the end, when one could be made.
    pub tau: Option<TauReport>,
    /// R̂ between ensembles per parameter after burn-in (two or more ensembles).
    pub rhat: Option<Vec<f64>>,
    /// Whether the run looks converged: τ trusted, R̂ below
    /// [`RHAT_MAX`](crate::diagnostics::RHAT_MAX), no stuck walkers. When false, `problems`
    /// says why.
    pub converged: bool,
    /// Reasons for not trusting the chains.
    pub problems: Vec<Problem>,
}

impl RunReport {
    /// Total log-density evaluations over all ensembles.
    pub fn evaluations(&self) -> u64 {
        self.ensembles.iter().map(|e| e.evaluations).sum()
    }

    /// Mean acceptance fraction over all walkers of all ensembles.
    pub fn mean_acceptance(&self) -> f64 {
        let (s, n) = self.ensembles.iter().fold((0.0, 0usize), |(s, n), e| {
            (s + e.acceptance.iter().sum::<f64>(), n + e.acceptance.len())
        });
        s / n.max(1) as f64
    }
}

/// Maps `f` over `0..n`, on the rayon pool when `parallel`; the results (and their order)
/// are the same either way.
fn map_indices<T: Send>(n: usize, parallel: bool, f: impl Fn(usize) -> T + Sync + Send) -> Vec<T> {
    if parallel {
        (0..n).into_par_iter().map(f).collect()
    } else {
        (0..n).map(f).collect()
    }
}

/// τ (in steps) per ensemble and parameter from the history; `None` when the history is too
/// short or a series is constant. The (ensemble, parameter) pairs are independent, so they
/// are computed in parallel when `parallel`.
pub(crate) fn tau_from_history(
    history: &RowHistory,
    ndim: usize,
    parallel: bool,
) -> Option<Vec<Vec<f64>>> {
    let thin = history.thin as f64;
    let walkers = history.width / ndim;
    let ensembles = history.data.len();
    let flat = map_indices(ensembles * ndim, parallel, |i| {
        let (e, p) = (i / ndim, i % ndim);
        let buf = &history.data[e];
        let series: Vec<Vec<f64>> = (0..walkers)
            .map(|w| history.column(buf, w * ndim + p))
            .collect();
        let refs: Vec<&[f64]> = series.iter().map(Vec::as_slice).collect();
        integrated_time(&refs, DEFAULT_WINDOW_FACTOR)
            .ok()
            .filter(|t| t.tau.is_finite())
            // Thinning by m ≪ τ scales the integrated time by 1/m.
            .map(|t| t.tau * thin)
    });
    let flat: Option<Vec<f64>> = flat.into_iter().collect();
    Some(flat?.chunks(ndim).map(<[f64]>::to_vec).collect())
}

/// τ report from per-ensemble τ and the chain length.
pub(crate) fn tau_report(per_ensemble: Vec<Vec<f64>>, steps: u64, tau_factor: f64) -> TauReport {
    let all = per_ensemble.iter().flatten().copied();
    let max = all.clone().fold(f64::NEG_INFINITY, f64::max);
    let min = all.fold(f64::INFINITY, f64::min);
    TauReport {
        reliable: steps as f64 > tau_factor * max,
        burn_in: (2.0 * max).ceil() as u64,
        per_ensemble,
        max,
        min,
    }
}

/// Rank-normalised split R̂ (ArviZ, Vehtari et al. 2021) between ensembles per parameter,
/// from the history rows after `burn_in` steps. The chain of an ensemble is its draws in
/// step order, walkers interleaved within a step, so R̂ compares ensembles (and early with
/// late halves), never walkers of one ensemble (which are not independent). `None` with
/// fewer than two ensembles or too few rows. Parameters one at a time, whatever `parallel`:
/// each holds 12 bytes per draw of the history while its R̂ is computed, and a run's peak
/// memory should not hold that once per thread.
pub(crate) fn rhat_from_history(
    history: &RowHistory,
    ndim: usize,
    burn_in: u64,
    _parallel: bool,
) -> Option<Vec<f64>> {
    if history.data.len() < 2 {
        return None;
    }
    let first = (0..history.rows).find(|&r| history.step_of(r) >= burn_in)?;
    if history.rows - first < 4 {
        return None;
    }
    let width = history.width;
    let (start, draws) = (first * width, (history.rows - first) * width / ndim);
    map_indices(ndim, false, |p| {
        // Row-major rows, walkers interleaved within a row: parameter p of every walker,
        // read where the history holds it (no copy of the chains).
        rhat_by(history.data.len(), draws, &|e, t| {
            history.data[e][start + t * ndim + p]
        })
        .ok()
    })
    .into_iter()
    .collect()
}
