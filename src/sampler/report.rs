//! What a run reports: acceptance, rejections, evaluations, τ, R̂ and convergence.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use rayon::prelude::*;

use super::history::RowHistory;
use crate::diagnostics::{pooled_integrated_time, rhat_by, Problem, DEFAULT_WINDOW_FACTOR};

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
    /// The observer asked the run to stop ([`Observer::stop_requested`](super::Observer)).
    Interrupted,
}

/// Counters of one ensemble.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnsembleReport {
    /// Acceptance fraction of each walker over all its Metropolis–Hastings proposals so far
    /// (slice updates and exact draws, which always move, are left out); NaN when it has had
    /// none.
    pub acceptance: Vec<f64>,
    /// Proposals rejected because the density refused them, per reason.
    pub rejections: BTreeMap<String, u64>,
    /// Log-density evaluations (including the initial ones).
    pub evaluations: u64,
}

/// Integrated autocorrelation times, in steps, and what follows from them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TauReport {
    /// τ per parameter, pooled over every walker of every ensemble
    /// ([`pooled_integrated_time`]).
    #[serde(default)]
    pub per_parameter: Vec<f64>,
    /// Largest τ.
    pub max: f64,
    /// Smallest τ.
    pub min: f64,
    /// Whether the steps after the burn-in are more than
    /// [`tau_trusted_length`](crate::diagnostics::tau_trusted_length) τ_max for the walkers
    /// of all ensembles, so that τ can be trusted (the summary judges each quantity's τ on
    /// the same draws).
    pub reliable: bool,
    /// The steps in all that τ_max needs to be trusted: the burn-in, then the trusted length
    /// (0 in reports written before it was recorded).
    #[serde(default)]
    pub needed_steps: u64,
    /// The step from which τ was estimated: 0 (the whole chains), or a quarter or half of the
    /// way in when the start's transient would otherwise dominate τ.
    #[serde(default)]
    pub from_step: u64,
    /// Suggested burn-in, max(`from_step`, ⌈2 τ_max⌉) steps, and at least the steps during
    /// which the slice move's scale was tuned. (No thinning is suggested: thinning adds no
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

    /// Mean acceptance fraction over all walkers of all ensembles that had proposals to
    /// accept; NaN when none had (the slice move alone).
    pub fn mean_acceptance(&self) -> f64 {
        // Ensemble by ensemble, as before walkers without proposals existed (same rounding).
        let (s, n) = self.ensembles.iter().fold((0.0, 0usize), |(s, n), e| {
            let proposing = || e.acceptance.iter().filter(|a| !a.is_nan());
            (s + proposing().sum::<f64>(), n + proposing().count())
        });
        if n == 0 && self.ensembles.iter().any(|e| !e.acceptance.is_empty()) {
            f64::NAN
        } else {
            s / n.max(1) as f64
        }
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

/// Where τ is estimated from, as fractions of the steps run: the whole chains, then after the
/// first quarter, then after the first half. A chain that starts away from the typical set
/// carries its transient in every autocorrelation estimate over the whole chain (a
/// Lotka–Volterra posterior of `tests/posteriordb.rs`: τ 334 steps over the whole chain, 19
/// after its first quarter), so a rule that only looked from step 0 would run hundreds of τ
/// longer than needed. The first window that is long enough for its own τ wins,
/// and the burn-in is at least its start: the kept draws are the ones τ was measured on.
pub(crate) const TAU_WINDOWS: [f64; 3] = [0.0, 0.25, 0.5];

/// The first kept history row at or after `fraction` of `steps`, and its step.
fn window_start(history: &RowHistory, steps: u64, fraction: f64) -> (usize, u64) {
    let target = (fraction * steps as f64).floor() as u64;
    let row = (0..history.rows)
        .find(|&r| history.step_of(r) >= target)
        .unwrap_or(history.rows);
    (row, history.step_of(row))
}

/// τ (in steps) per parameter, pooled over the walkers of every ensemble (each about its
/// ensemble's mean), from the history
/// rows from `first_row` on; `None` when they are too few or a parameter never moved. The
/// parameters are independent, so they are computed in parallel when `parallel`.
fn tau_from_rows(
    history: &RowHistory,
    ndim: usize,
    first_row: usize,
    parallel: bool,
) -> Option<Vec<f64>> {
    let thin = history.thin as f64;
    let walkers = history.width / ndim;
    let per_parameter = map_indices(ndim, parallel, |p| {
        let series: Vec<Vec<f64>> = history
            .data
            .iter()
            .flat_map(|ensemble| {
                let buf = &ensemble[first_row * history.width..];
                (0..walkers).map(move |w| history.column(buf, w * ndim + p))
            })
            .collect();
        let refs: Vec<&[f64]> = series.iter().map(Vec::as_slice).collect();
        pooled_integrated_time(&refs, walkers, DEFAULT_WINDOW_FACTOR)
            .ok()
            .filter(|t| t.tau.is_finite())
            // Thinning by m ≪ τ scales the integrated time by 1/m.
            .map(|t| t.tau * thin)
    });
    per_parameter.into_iter().collect()
}

/// τ on each of the [`TAU_WINDOWS`] of a history of `steps` steps: the window's first step
/// and its τ per parameter (`None` where it cannot be estimated).
pub(crate) fn tau_windows(
    history: &RowHistory,
    ndim: usize,
    steps: u64,
    parallel: bool,
) -> Vec<(u64, Option<Vec<f64>>)> {
    TAU_WINDOWS
        .iter()
        .map(|&f| tau_window(history, ndim, steps, f, parallel))
        .collect()
}

/// τ on the window that starts at `fraction` of a history of `steps` steps: the window's first
/// step and its τ per parameter (`None` where it cannot be estimated).
pub(crate) fn tau_window(
    history: &RowHistory,
    ndim: usize,
    steps: u64,
    fraction: f64,
    parallel: bool,
) -> (u64, Option<Vec<f64>>) {
    let (row, from_step) = window_start(history, steps, fraction);
    (from_step, tau_from_rows(history, ndim, row, parallel))
}

/// τ report from the τ per parameter estimated on the steps from `from_step` to `steps`,
/// trusted on more than `tau_factor` τ_max steps; the burn-in is at least `min_burn_in`
/// steps.
pub(crate) fn tau_report(
    per_parameter: Vec<f64>,
    from_step: u64,
    steps: u64,
    tau_factor: f64,
    min_burn_in: u64,
) -> TauReport {
    let all = per_parameter.iter().copied();
    let max = all.clone().fold(f64::NEG_INFINITY, f64::max);
    let min = all.fold(f64::INFINITY, f64::min);
    let burn_in = from_step.max((2.0 * max).ceil() as u64).max(min_burn_in);
    TauReport {
        reliable: steps.saturating_sub(burn_in) as f64 > tau_factor * max,
        needed_steps: burn_in + (tau_factor * max).ceil() as u64,
        burn_in,
        from_step,
        per_parameter,
        max,
        min,
    }
}

/// The report of the first window long enough for its τ (more than `tau_factor` τ_max
/// steps); when none is, the window closest to it, whose τ says how much longer to run.
pub(crate) fn chosen_tau_report(
    windows: Vec<(u64, Option<Vec<f64>>)>,
    steps: u64,
    tau_factor: f64,
    min_burn_in: u64,
) -> Option<TauReport> {
    let reports: Vec<TauReport> = windows
        .into_iter()
        .filter_map(|(from, t)| t.map(|t| tau_report(t, from, steps, tau_factor, min_burn_in)))
        .collect();
    let length_in_tau = |t: &TauReport| (steps - t.from_step) as f64 / t.max;
    let first_reliable = reports.iter().position(|t| t.reliable);
    let closest = || {
        (0..reports.len())
            .max_by(|&a, &b| length_in_tau(&reports[a]).total_cmp(&length_in_tau(&reports[b])))
    };
    let i = first_reliable.or_else(closest)?;
    reports.into_iter().nth(i)
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

#[cfg(test)]
mod tests {
    use super::*;

    fn window(from: u64, tau: f64) -> (u64, Option<Vec<f64>>) {
        (from, Some(vec![tau, tau / 2.0]))
    }

    #[test]
    fn the_whole_chains_are_preferred_when_long_enough() {
        let t = chosen_tau_report(
            vec![window(0, 10.0), window(250, 5.0), window(500, 5.0)],
            1000,
            50.0,
            0,
        )
        .expect("a report");
        assert_eq!((t.from_step, t.burn_in, t.max), (0, 20, 10.0));
        assert!(t.reliable);
    }

    #[test]
    fn a_transient_moves_the_window_and_the_burn_in_with_it() {
        // τ over the whole chains is inflated by the start; after a quarter it is short.
        let t = chosen_tau_report(
            vec![window(0, 100.0), window(250, 10.0), window(500, 10.0)],
            1000,
            50.0,
            0,
        )
        .expect("a report");
        assert_eq!((t.from_step, t.burn_in, t.max), (250, 250, 10.0));
        assert!(t.reliable);
        // A window's own 2 τ can exceed its start.
        let t = chosen_tau_report(vec![window(0, 400.0), window(2, 10.0)], 1000, 50.0, 0)
            .expect("a report");
        assert_eq!((t.from_step, t.burn_in), (2, 20));
    }

    #[test]
    fn without_a_long_enough_window_the_closest_is_reported_unreliable() {
        let t = chosen_tau_report(
            vec![window(0, 100.0), window(250, 40.0), (500, None)],
            1000,
            50.0,
            0,
        )
        .expect("a report");
        // 750 / 40 = 18.75 τ beats 1000 / 100 = 10 τ.
        assert_eq!((t.from_step, t.max), (250, 40.0));
        assert!(!t.reliable);
        assert!(chosen_tau_report(vec![(0, None)], 1000, 50.0, 0).is_none());
    }
}
