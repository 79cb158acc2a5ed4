//! Posterior summaries of affine-invariant ensemble output: R-hat between independent
//! ensembles, ESS over walkers, intervals over all draws.
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

use std::borrow::Cow;

use serde::{Deserialize, Deserializer, Serialize};

use super::arviz::{
    ess_bulk_mat, ess_mean_mat, ess_tail_mat, eti_sorted, hdi_sorted, mcse_mean_mat, mcse_sd_mat,
    mean, median_of_sorted, rhat_rank_of_split, sorted, var, Mat, MIN_DRAWS,
};
use super::autocorr::{integrated_time, DEFAULT_WINDOW_FACTOR};
use super::error::{check_prob, DiagnosticsError};

/// Draws of one scalar quantity from independent ensembles of walkers: `ensembles x walkers x
/// steps`, stored walker-major (`[e][w][t]`, each walker's series contiguous). Validated on
/// construction: rectangular, at least [`MIN_DRAWS`] steps, all finite.
#[derive(Debug, Clone)]
pub struct EnsembleDraws {
    data: Vec<f64>,
    ensembles: usize,
    walkers: usize,
    steps: usize,
}

impl EnsembleDraws {
    /// Wraps `data` laid out as `data[(e * walkers + w) * steps + t]`.
    ///
    /// # Errors
    /// No ensembles or walkers, `data.len()` not equal to the product of the shape, fewer
    /// than [`MIN_DRAWS`] steps, or a non-finite draw (reported as chain `e * walkers + w`
    /// at index `t`).
    pub fn new(
        data: Vec<f64>,
        ensembles: usize,
        walkers: usize,
        steps: usize,
    ) -> Result<Self, DiagnosticsError> {
        if ensembles == 0 || walkers == 0 {
            return Err(DiagnosticsError::NoChains { needed: 1 });
        }
        let expected = ensembles * walkers * steps;
        if data.len() != expected {
            return Err(DiagnosticsError::InvalidArgument {
                name: "data.len()",
                value: data.len() as f64,
                reason: "must equal ensembles * walkers * steps",
            });
        }
        if steps < MIN_DRAWS {
            return Err(DiagnosticsError::TooFewDraws {
                what: "ensemble diagnostics",
                have: steps,
                needed: MIN_DRAWS,
            });
        }
        if let Some((i, &v)) = data.iter().enumerate().find(|(_, v)| !v.is_finite()) {
            return Err(DiagnosticsError::NonFinite {
                chain: i / steps,
                index: i % steps,
                value: v,
            });
        }
        Ok(EnsembleDraws {
            data,
            ensembles,
            walkers,
            steps,
        })
    }

    /// Builds the draws from `f(ensemble, walker, step)`, e.g. reading one parameter out of
    /// the sampler's step-major storage.
    ///
    /// # Errors
    /// As [`EnsembleDraws::new`].
    pub fn from_fn(
        ensembles: usize,
        walkers: usize,
        steps: usize,
        mut f: impl FnMut(usize, usize, usize) -> f64,
    ) -> Result<Self, DiagnosticsError> {
        let mut data = Vec::with_capacity(ensembles * walkers * steps);
        for e in 0..ensembles {
            for w in 0..walkers {
                for t in 0..steps {
                    data.push(f(e, w, t));
                }
            }
        }
        Self::new(data, ensembles, walkers, steps)
    }

    /// Builds the draws from `draws[e][w][t]`.
    ///
    /// # Errors
    /// As [`EnsembleDraws::new`], and ragged input (reported as chain `e * walkers + w`).
    pub fn from_nested(draws: &[Vec<Vec<f64>>]) -> Result<Self, DiagnosticsError> {
        let ensembles = draws.len();
        let walkers = draws.first().map_or(0, Vec::len);
        let steps = draws.first().and_then(|e| e.first()).map_or(0, Vec::len);
        for (e, ens) in draws.iter().enumerate() {
            if ens.len() != walkers {
                return Err(DiagnosticsError::InvalidArgument {
                    name: "walkers in an ensemble",
                    value: ens.len() as f64,
                    reason: "every ensemble must have as many walkers as ensemble 0",
                });
            }
            for (w, series) in ens.iter().enumerate() {
                if series.len() != steps {
                    return Err(DiagnosticsError::RaggedChains {
                        chain: e * walkers + w,
                        len: series.len(),
                        expected: steps,
                    });
                }
            }
        }
        let data = draws.iter().flatten().flatten().copied().collect();
        Self::new(data, ensembles, walkers, steps)
    }

    /// Number of independent ensembles.
    pub fn ensembles(&self) -> usize {
        self.ensembles
    }

    /// Walkers per ensemble.
    pub fn walkers(&self) -> usize {
        self.walkers
    }

    /// Steps per walker.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Walker `w` of ensemble `e`, over steps. Panics if out of range (a programming error).
    pub fn series(&self, e: usize, w: usize) -> &[f64] {
        assert!(
            e < self.ensembles && w < self.walkers,
            "walker out of range"
        );
        let start = (e * self.walkers + w) * self.steps;
        &self.data[start..start + self.steps]
    }

    /// Every walker's series, ensemble-major.
    fn walker_series(&self) -> Vec<&[f64]> {
        self.data.chunks_exact(self.steps).collect()
    }

    /// Every walker of every ensemble as one chain.
    fn walker_mat(&self) -> Mat<'_> {
        Mat {
            rows: self.ensembles * self.walkers,
            cols: self.steps,
            data: Cow::Borrowed(&self.data),
        }
    }

    /// Split half-ensembles as chains: first halves of all ensembles, then last halves (ArviZ
    /// order); a half-ensemble's row holds all its walkers' draws of that half.
    fn split_ensemble_mat(&self) -> Mat<'static> {
        let half = self.steps / 2;
        let mut data = Vec::with_capacity(2 * self.ensembles * self.walkers * half);
        for second in [false, true] {
            for e in 0..self.ensembles {
                for w in 0..self.walkers {
                    let s = self.series(e, w);
                    data.extend_from_slice(if second {
                        &s[self.steps - half..]
                    } else {
                        &s[..half]
                    });
                }
            }
        }
        Mat {
            rows: 2 * self.ensembles,
            cols: self.walkers * half,
            data: data.into(),
        }
    }
}

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
    /// emcee's integrated autocorrelation time of the draws, in draws (ACF averaged over all
    /// walkers of all ensembles); `None` when a walker is constant (stuck), which leaves it
    /// undefined.
    pub tau: Option<f64>,
    /// Whether `tau` is trustworthy: draws per walker at least 50 τ.
    pub tau_reliable: Option<bool>,
}

fn nullable<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// Rank-normalised split R-hat between the ensembles of `x` (see the module documentation).
///
/// # Errors
/// Fewer than two ensembles.
pub fn ensemble_rhat(x: &EnsembleDraws) -> Result<f64, DiagnosticsError> {
    if x.ensembles < 2 {
        return Err(DiagnosticsError::TooFewChains {
            what: "R-hat between ensembles",
            have: x.ensembles,
            needed: 2,
        });
    }
    Ok(rhat_rank_of_split(&x.split_ensemble_mat()))
}

/// Summarises one scalar quantity of an ensemble run: the equal-tailed interval of
/// probability `ci_prob` and the HDI of probability `hdi_prob` (ArviZ's default is 0.94 for
/// both).
///
/// # Errors
/// `ci_prob` or `hdi_prob` outside (0, 1).
pub fn summarize(
    x: &EnsembleDraws,
    ci_prob: f64,
    hdi_prob: f64,
) -> Result<Summary, DiagnosticsError> {
    check_prob("ci_prob", ci_prob, false)?;
    check_prob("hdi_prob", hdi_prob, false)?;
    let all = &x.data;
    // One working copy at a time: the sorted draws serve the intervals and the median, then go
    // before the rank-normalised diagnostics make theirs.
    let (median, ci, hdi) = {
        let s = sorted(all);
        (
            median_of_sorted(&s),
            eti_sorted(&s, ci_prob),
            hdi_sorted(&s, hdi_prob)?,
        )
    };
    let r_hat = if x.ensembles >= 2 {
        Some(rhat_rank_of_split(&x.split_ensemble_mat())).filter(|r| !r.is_nan())
    } else {
        None
    };
    let walkers = x.walker_mat();
    let autocorr = integrated_time(&x.walker_series(), DEFAULT_WINDOW_FACTOR).ok();
    Ok(Summary {
        mean: mean(all),
        sd: var(all, 1).sqrt(),
        median,
        ci_low: ci.0,
        ci_high: ci.1,
        ci_prob,
        hdi_low: hdi.0,
        hdi_high: hdi.1,
        hdi_prob,
        ess_bulk: ess_bulk_mat(&walkers),
        ess_tail: ess_tail_mat(&walkers),
        r_hat,
        mcse_mean: mcse_mean_mat(&walkers),
        mcse_sd: mcse_sd_mat(&walkers),
        ess_mean: ess_mean_mat(&walkers),
        tau: autocorr.map(|a| a.tau),
        tau_reliable: autocorr.map(|a| a.reliable),
    })
}
