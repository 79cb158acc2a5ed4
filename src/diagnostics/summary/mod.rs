//! The posterior summary of one quantity of an ensemble run, by one engine whether the draws
//! fit in memory or not: R-hat between independent ensembles, ESS over walkers, intervals
//! over all draws.
//!
//! # Why R-hat between ensembles, and ESS over walkers
//!
//! An ensemble sampler moves each walker using the positions of the others, so the walkers of
//! one ensemble are coupled: they can agree perfectly with one another while the ensemble as a
//! whole sits in one mode or has not yet relaxed. R-hat compares units that were run
//! independently, so here the unit is the *ensemble*: each ensemble is one chain whose draws at
//! every step are all of its walkers. As in ArviZ, each ensemble is split into its first and
//! last `steps/2` steps; the within-chain variance of a half-ensemble is taken over all its
//! walkers' draws, the between-chain variance over the half-ensemble means; draws are
//! rank-normalised over everything, and the folded (tail) R-hat is computed likewise. With one
//! walker per ensemble this is ArviZ's `rhat` exactly (tested against ArviZ). With a single
//! ensemble there is nothing independent to compare, so `r_hat` is `None` rather than a
//! reassuring number from two time halves.
//!
//! The effective sample size is ArviZ's multi-chain Geyer ESS with *every walker of every
//! ensemble* as a chain (split in halves, as ArviZ does). Walkers that have not mixed with one
//! another have different means; that between-walker variance enters the pooled variance and
//! lowers the ESS, as it should. With one walker per ensemble this is ArviZ's ESS exactly.
//! What it cannot see is correlation *across* walkers at equal times (the coupling above); the
//! emcee estimate `tau`, reported alongside, shares this limitation, and the summary's
//! `r_hat` between independent ensembles is the guard against it.
//!
//! Point estimates and intervals (mean, sd, median, equal-tailed interval, HDI) pool all
//! draws of all walkers of all ensembles.
//!
//! # One engine, in memory or out of core
//!
//! A quantity's draws are kept in a [`Workspace`]: in memory ([`Workspace::in_memory`], what
//! [`summarize`] of [`EnsembleDraws`] uses), or, for a long run, in working files of a
//! directory once they exceed [`Limits::run_draws`] (what a fit uses, through a
//! [`DrawsWriter`]). The same code reads them back one walker (or one half-walker) at a time:
//!
//! - Mean, sd, MCSE of the mean and sd, ESS of the mean, tail ESS (indicators of the exact
//!   5 % and 95 % quantiles) and τ stream over the walkers, each sum taken in ArviZ's order
//!   (`store`, `draws`).
//! - Everything that needs the draws in order comes from an external sort (`sort`):
//!   quantiles (median, equal-tailed interval, the 5 % and 95 % quantiles) pick their order
//!   statistics from one merged stream; the HDI scans two merged streams `floor(p n)` apart.
//! - Rank-normalised R̂ and bulk ESS take each draw's average rank over all draws from the
//!   merged stream (`ranks`); the folded draws |x − median| of the tail R̂ go through the
//!   same sort.
//!
//! Whether a quantity spills to files or not, the numbers are the same to the bit: the
//! tests compare both paths with each other and with ArviZ's functions of
//! [`crate::diagnostics::arviz`] on the same draws.

mod draws;
mod ranks;
mod sort;
mod store;
#[cfg(test)]
mod tests;

use serde::{Deserialize, Deserializer, Serialize};

pub use draws::{DrawsWriter, EnsembleDraws, WalkerDraws};
pub use store::{Limits, Workspace};

use super::arviz::{
    eti_at, hdi_scan, hdi_span, median_at, mquantile_at, Autocov, EssRows, TAIL_PROBS,
};
use super::autocorr::{pooled_time_of_acf, PooledAcf, DEFAULT_WINDOW_FACTOR};
use super::error::{check_prob, DiagnosticsError};
use draws::Moments;
use ranks::{rank_scores, Scores};
use sort::{pick, positions, Runs};
use store::Store;

/// A posterior summary of one scalar quantity, with ArviZ's meaning for every field: one row
/// of `summary.json` and `summary.csv`. NaN values are written as JSON `null` and read back as
/// NaN.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Posterior mean over all draws.
    #[serde(deserialize_with = "nullable")]
    pub mean: f64,
    /// Posterior standard deviation over all draws (`ddof = 1`).
    #[serde(deserialize_with = "nullable")]
    pub sd: f64,
    /// Posterior median (numpy).
    #[serde(deserialize_with = "nullable")]
    pub median: f64,
    /// Lower end of the equal-tailed interval of probability `ci_prob` (numpy linear quantile
    /// `(1 - ci_prob)/2`).
    #[serde(deserialize_with = "nullable")]
    pub ci_low: f64,
    /// Upper end of the equal-tailed interval.
    #[serde(deserialize_with = "nullable")]
    pub ci_high: f64,
    /// Probability of the equal-tailed interval.
    pub ci_prob: f64,
    /// Lower end of the highest-density interval of probability `hdi_prob` (ArviZ, unimodal).
    #[serde(deserialize_with = "nullable")]
    pub hdi_low: f64,
    /// Upper end of the highest-density interval.
    #[serde(deserialize_with = "nullable")]
    pub hdi_high: f64,
    /// Probability of the HDI.
    pub hdi_prob: f64,
    /// Bulk ESS, every walker of every ensemble as a chain.
    #[serde(deserialize_with = "nullable")]
    pub ess_bulk: f64,
    /// Tail ESS (smaller of the 5 % and 95 % quantile ESS), walkers as chains.
    #[serde(deserialize_with = "nullable")]
    pub ess_tail: f64,
    /// Rank-normalised split R̂ between ensembles; `None` with one ensemble or when every
    /// draw is equal.
    pub r_hat: Option<f64>,
    /// Monte-Carlo standard error of the mean.
    #[serde(deserialize_with = "nullable")]
    pub mcse_mean: f64,
    /// Monte-Carlo standard error of the sd.
    #[serde(deserialize_with = "nullable")]
    pub mcse_sd: f64,
    /// ESS of the mean, walkers as chains.
    #[serde(deserialize_with = "nullable")]
    pub ess_mean: f64,
    /// The pooled integrated autocorrelation time of the draws, in draws, over all walkers of
    /// all ensembles ([`pooled_integrated_time`](crate::diagnostics::pooled_integrated_time));
    /// `None` when every draw is the same value, which leaves it undefined.
    pub tau: Option<f64>,
    /// Whether `tau` is trustworthy: draws per walker at least
    /// [`tau_trusted_length`](crate::diagnostics::tau_trusted_length) τ for this many walkers.
    pub tau_reliable: Option<bool>,
}

fn nullable<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// Rank-normalised split R-hat between the ensembles of `x` (see the module documentation);
/// NaN when every draw is equal.
///
/// # Errors
/// Fewer than two ensembles.
pub fn ensemble_rhat(x: &EnsembleDraws) -> Result<f64, DiagnosticsError> {
    if x.ensembles() < 2 {
        return Err(DiagnosticsError::TooFewChains {
            what: "R-hat between ensembles",
            have: x.ensembles(),
            needed: 2,
        });
    }
    let ws = Workspace::in_memory();
    let draws = x.to_walker_draws(&ws)?;
    let runs = draws.sorted_runs(|_| true, |v| v)?;
    let split_median = order_statistics(&draws, &runs, &[])?.split_median;
    let scores = split_rank_scores(&draws, &runs)?;
    drop(runs);
    rhat_between_ensembles(&draws, scores, split_median)
}

/// Summarises one scalar quantity of an ensemble run: the equal-tailed interval of
/// probability `ci_prob` and the HDI of probability `hdi_prob` (ArviZ's default is 0.94 for
/// both). The draws are summarised in memory; a fit of many draws writes them to a
/// [`DrawsWriter`] and calls [`summarize_draws`], which gives the same numbers.
///
/// # Errors
/// `ci_prob` or `hdi_prob` outside (0, 1).
pub fn summarize(
    x: &EnsembleDraws,
    ci_prob: f64,
    hdi_prob: f64,
) -> Result<Summary, DiagnosticsError> {
    let ws = Workspace::in_memory();
    summarize_draws(&x.to_walker_draws(&ws)?, ci_prob, hdi_prob)
}

/// The summary of the draws `x`, in the memory their [`Workspace`] allows (see the module
/// documentation).
///
/// # Errors
/// `ci_prob` or `hdi_prob` outside (0, 1); fewer draws than the HDI of `hdi_prob` needs; a
/// working file that cannot be written or read.
pub fn summarize_draws(
    x: &WalkerDraws,
    ci_prob: f64,
    hdi_prob: f64,
) -> Result<Summary, DiagnosticsError> {
    check_prob("ci_prob", ci_prob, false)?;
    check_prob("hdi_prob", hdi_prob, false)?;
    let inc = hdi_span(x.len(), hdi_prob)?;

    // τ, walker by walker; the draws sorted in runs.
    let mut acf = PooledAcf::new(x.steps, x.walkers);
    x.each_walker(|_, s| {
        acf.push(s);
        Ok(())
    })?;
    let chains = x.ensembles * x.walkers;
    let autocorr = acf
        .finish()
        .map(|rho| pooled_time_of_acf(&rho, DEFAULT_WINDOW_FACTOR, chains));
    let m = x.moments()?;
    let runs = x.sorted_runs(|_| true, |v| v)?;
    let order = order_statistics(x, &runs, &[ci_prob])?;
    let hdi = {
        let (mut low, mut high) = (runs.merge(), runs.merge());
        let mut error = None;
        for _ in 0..inc {
            high.next()?;
        }
        let mut error_high = None;
        let hdi = hdi_scan(low.values(&mut error), high.values(&mut error_high));
        if let Some(e) = error.or(error_high) {
            return Err(e);
        }
        hdi
    };
    let ess = MomentEss::of(x, &m, order.tails)?;

    // Normal scores of the ranks of the split draws: bulk ESS and bulk R̂.
    let scores = split_rank_scores(x, &runs)?;
    drop(runs);
    let ess_bulk = Scores::of(&scores, x).ess()?;
    let r_hat = if x.ensembles >= 2 {
        Some(rhat_between_ensembles(x, scores, order.split_median)?).filter(|r| !r.is_nan())
    } else {
        None
    };
    let ci = order.intervals[0];
    Ok(Summary {
        mean: m.mean,
        sd: m.var.sqrt(),
        median: order.median,
        ci_low: ci.0,
        ci_high: ci.1,
        ci_prob,
        hdi_low: hdi.0,
        hdi_high: hdi.1,
        hdi_prob,
        ess_bulk,
        ess_tail: ess.q05.min(ess.q95),
        r_hat,
        mcse_mean: m.var.sqrt() / ess.mean.sqrt(),
        mcse_sd: ess.mcse_sd(&m),
        ess_mean: ess.mean,
        tau: autocorr.map(|a| a.tau),
        tau_reliable: autocorr.map(|a| a.reliable),
    })
}

/// The order statistics a summary reads, from one merged stream of the sorted draws.
struct OrderStatistics {
    median: f64,
    /// The equal-tailed interval of each probability asked for.
    intervals: Vec<(f64, f64)>,
    /// The quantiles of [`TAIL_PROBS`], whose indicators give the tail ESS.
    tails: (f64, f64),
    /// The median of the split draws, about which the tail R̂ folds them.
    split_median: f64,
}

/// The median, the equal-tailed intervals of `interval_probs`, the tail quantiles of every
/// draw, and the median of the split draws, of the draws `x` sorted in `runs`.
fn order_statistics(
    x: &WalkerDraws,
    runs: &Runs,
    interval_probs: &[f64],
) -> Result<OrderStatistics, DiagnosticsError> {
    let n = x.len();
    let kept = split_draws(x);
    let wanted = positions(|at| {
        median_at(n, at);
        for &p in interval_probs {
            eti_at(n, at, p);
        }
        mquantile_at(n, at, TAIL_PROBS.0);
        mquantile_at(n, at, TAIL_PROBS.1);
    });
    let wanted_split = positions(|at| {
        median_at(kept, at);
    });
    let (all, of_split) = pick(runs, &wanted, &wanted_split, |i| x.in_split(i))?;
    let at = |i| all.at(i);
    Ok(OrderStatistics {
        median: median_at(n, &at),
        intervals: interval_probs.iter().map(|&p| eti_at(n, &at, p)).collect(),
        tails: (
            mquantile_at(n, &at, TAIL_PROBS.0),
            mquantile_at(n, &at, TAIL_PROBS.1),
        ),
        split_median: median_at(kept, &|i| of_split.at(i)),
    })
}

/// Draws in the split chains: the first and last `steps/2` of every walker.
fn split_draws(x: &WalkerDraws) -> usize {
    2 * x.chains() * (x.steps / 2)
}

/// The normal scores of the ranks of the split draws of `x`, sorted in `runs`, by index.
fn split_rank_scores<'w>(x: &WalkerDraws<'w>, runs: &Runs) -> Result<Store<'w>, DiagnosticsError> {
    let ws = x.ws();
    let split = |i: u32| x.in_split(i);
    rank_scores(
        ws,
        ws.spills(x.len()),
        runs,
        x.len(),
        &split,
        split_draws(x),
    )
}

/// R̂ between the ensembles of `x` from the bulk scores of its split draws: the larger of
/// the bulk R̂ and the tail R̂ (of the draws folded about `split_median`), NaN if either is,
/// as ArviZ takes Python's `max()`.
fn rhat_between_ensembles(
    x: &WalkerDraws,
    bulk_scores: Store,
    split_median: f64,
) -> Result<f64, DiagnosticsError> {
    let bulk = Scores::of(&bulk_scores, x).rhat()?;
    drop(bulk_scores);
    let folded = x.sorted_runs(|i| x.in_split(i), |v| (v - split_median).abs())?;
    let scores = split_rank_scores(x, &folded)?;
    drop(folded);
    let tail = Scores::of(&scores, x).rhat()?;
    Ok(if bulk.is_nan() || tail.is_nan() {
        f64::NAN
    } else {
        bulk.max(tail)
    })
}

/// ESS over the split half-walkers of the draws, of their squared deviations (the MCSE of
/// the sd) and of the indicators of the two tail quantiles.
struct MomentEss {
    mean: f64,
    sd: f64,
    q05: f64,
    q95: f64,
}

impl MomentEss {
    fn of(x: &WalkerDraws, m: &Moments, tails: (f64, f64)) -> Result<Self, DiagnosticsError> {
        let half = x.steps / 2;
        let mut autocov = Autocov::new(half);
        let mut ess = [
            EssRows::new(half),
            EssRows::new(half),
            EssRows::new(half),
            EssRows::new(half),
        ];
        let mut mapped = vec![0.0; half];
        x.each_half(|s| {
            ess[0].push(s, &mut autocov);
            for (o, &v) in mapped.iter_mut().zip(s) {
                *o = (v - m.mean) * (v - m.mean);
            }
            ess[1].push(&mapped, &mut autocov);
            for (k, q) in [tails.0, tails.1].into_iter().enumerate() {
                for (o, &v) in mapped.iter_mut().zip(s) {
                    *o = if v <= q { 1.0 } else { 0.0 };
                }
                ess[2 + k].push(&mapped, &mut autocov);
            }
        })?;
        let [mean, sd, q05, q95] = ess.map(EssRows::finish);
        Ok(Self { mean, sd, q05, q95 })
    }

    /// ArviZ's MCSE of the sd from the moments and the ESS of the squared deviations.
    fn mcse_sd(&self, m: &Moments) -> f64 {
        let varvar = (m.mean_sq - m.evar * m.evar) / self.sd;
        (varvar / m.evar / 4.0).sqrt()
    }
}
