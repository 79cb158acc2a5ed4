//! What a fit of a slide still being recorded says about its peak: the pieces `slipbayes watch`
//! puts together after each refit (the command itself follows the file and writes the
//! directory).
//!
//! - [`warm_point`]: the start of the next refit, from the last one's posterior medians, so
//!   that a refit skips the rough start from the data;
//! - [`PeakSoFar`]: the posterior of F_peak, τ_peak, t_peak and μ_s, and the probability that
//!   the peak is already inside the record;
//! - [`forecast`]: the posterior predictive of the rest of the slide;
//! - [`Criterion`]: when to stop watching.

use super::{draws_from, FitError, FitOutcome, FitSummary};
use crate::density::LogDensity;
use crate::model::{Band, Posterior};

/// Draws the peak's probability and the forecast bands read from a refit's chains.
const WATCH_DRAWS: usize = 400;

/// The start of a refit of `posterior` (the same model on more data) from an earlier fit's
/// summary: each sampled coordinate `ln_NAME[GROUP]` at the log of `NAME[GROUP]`'s posterior
/// median. `None` when a coordinate is not of that form or not in the summary.
pub fn warm_point(posterior: &Posterior, summary: &FitSummary) -> Option<Vec<f64>> {
    posterior
        .param_names()
        .iter()
        .map(|coordinate| {
            let column = coordinate.strip_prefix("ln_")?;
            let q = summary.parameters.iter().find(|q| q.column == column)?;
            let median = q.stats.median;
            (median > 0.0).then(|| median.ln())
        })
        .collect()
}

/// One of a peak's quantities: posterior median and equal-tailed interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval {
    /// Posterior median.
    pub median: f64,
    /// Lower end of the interval.
    pub low: f64,
    /// Upper end of the interval.
    pub high: f64,
}

impl Interval {
    /// The interval's width relative to its median.
    pub fn relative_width(&self) -> f64 {
        (self.high - self.low) / self.median.abs()
    }
}

/// The posterior of a first slide's peak after one refit.
#[derive(Debug, Clone, PartialEq)]
pub struct PeakSoFar {
    /// The run (slide) whose peak it is.
    pub run: String,
    /// Instrument time of the last point fitted (s).
    pub record_end_s: f64,
    /// Peak force (N).
    pub f_peak: Interval,
    /// Interface time of the peak (s).
    pub tau_peak: Interval,
    /// Instrument time of the peak (s).
    pub t_peak: Interval,
    /// Static friction coefficient, when the normal force is known.
    pub mu_s: Option<Interval>,
    /// Posterior probability that the peak lies inside the record (t_peak ≤ its end).
    pub p_in_record: f64,
}

impl PeakSoFar {
    /// The peak of run `run` (a first slide of `posterior`) in the fit `outcome`.
    ///
    /// # Errors
    /// [`FitError::InvalidSpec`] when the run has no peak in the summary; as
    /// [`kept_draws`](super::kept_draws) when its draws of t_peak cannot be read.
    pub fn of(outcome: &FitOutcome, posterior: &Posterior, run: &str) -> Result<Self, FitError> {
        let summary = &outcome.summary;
        let interval = |name: &str| {
            summary.find(name, run).map(|q| Interval {
                median: q.stats.median,
                low: q.stats.ci_low,
                high: q.stats.ci_high,
            })
        };
        let missing = || FitError::InvalidSpec {
            what: "quantity",
            problem: format!("run `{run}` has no peak in the summary: is it a first slide?"),
        };
        let record_end_s = posterior
            .record_ends()
            .into_iter()
            .find(|(name, _)| *name == run)
            .map(|(_, end)| end)
            .ok_or_else(missing)?;
        let t_peak = interval("t_peak").ok_or_else(missing)?;
        let column = crate::density::label("t_peak", run);
        let draws = draws_from(&outcome.dir, &summary.sampler, &[column], WATCH_DRAWS)?;
        let inside = draws.iter().filter(|d| d[0] <= record_end_s).count();
        Ok(Self {
            run: run.to_owned(),
            record_end_s,
            f_peak: interval("F_peak").ok_or_else(missing)?,
            tau_peak: interval("tau_peak").ok_or_else(missing)?,
            t_peak,
            mu_s: interval("mu_s"),
            p_in_record: inside as f64 / draws.len().max(1) as f64,
        })
    }

    /// Whether the peak is inside the record, beyond it, or either, in a sentence.
    pub fn statement(&self) -> String {
        let p = self.p_in_record;
        if p >= 0.95 {
            format!("the peak is inside the record (P = {p:.2}): F_peak is measured")
        } else if p <= 0.05 {
            format!(
                "the peak lies beyond the record (P inside = {p:.2}): F_peak is extrapolated by \
                 the law"
            )
        } else {
            format!(
                "the peak may or may not be inside the record yet (P = {p:.2}): F_peak is partly \
                 extrapolated"
            )
        }
    }
}

/// When to stop watching.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Criterion {
    /// F_peak's interval narrower than this fraction of its median, in a converged refit.
    Width(f64),
    /// The peak inside the record with probability at least 0.95, in a converged refit.
    PeakObserved,
}

impl Criterion {
    /// Whether a refit that found `peak` (converged or not) meets the criterion.
    pub fn met(&self, peak: &PeakSoFar, converged: bool) -> bool {
        converged
            && match *self {
                Criterion::Width(w) => peak.f_peak.relative_width() <= w,
                Criterion::PeakObserved => peak.p_in_record >= 0.95,
            }
    }

    /// The criterion in words.
    pub fn describe(&self) -> String {
        match *self {
            Criterion::Width(w) => {
                format!(
                    "F_peak's 95 % interval narrower than {} % of its median",
                    100.0 * w
                )
            }
            Criterion::PeakObserved => "the peak inside the record (P ≥ 0.95)".to_owned(),
        }
    }
}

/// The posterior predictive of run `run` of `posterior` from the end of its record to
/// `horizon_s` (instrument time), at `points` times, from the kept draws of `outcome`.
///
/// # Errors
/// As [`kept_draws`](super::kept_draws); [`FitError::Predictive`] when a draw has no valid law.
pub fn forecast(
    outcome: &FitOutcome,
    posterior: &Posterior,
    run: &str,
    horizon_s: f64,
    points: usize,
    seed: u64,
) -> Result<Band, FitError> {
    let (index, end) = posterior
        .record_ends()
        .into_iter()
        .enumerate()
        .find(|(_, (name, _))| *name == run)
        .map(|(i, (_, end))| (i, end))
        .ok_or_else(|| FitError::InvalidSpec {
            what: "quantity",
            problem: format!("no run `{run}` to forecast"),
        })?;
    let points = points.max(2);
    let times: Vec<f64> = (0..points)
        .map(|i| end + (horizon_s - end).max(0.0) * i as f64 / (points - 1) as f64)
        .collect();
    let draws = draws_from(
        &outcome.dir,
        &outcome.summary.sampler,
        &posterior.param_names(),
        WATCH_DRAWS,
    )?;
    posterior
        .forecast_band(&draws, index, &times, seed)
        .map_err(FitError::Predictive)
}

/// A forecast as CSV, in the layout of `predictive.csv` (its observed forces NaN: they are
/// not recorded yet).
pub fn forecast_csv(band: &Band) -> String {
    super::run_dir::predictive_csv(std::slice::from_ref(band))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn peak(width: f64, p: f64) -> PeakSoFar {
        let i = Interval {
            median: 1.0,
            low: 1.0 - width / 2.0,
            high: 1.0 + width / 2.0,
        };
        PeakSoFar {
            run: "first".into(),
            record_end_s: 10.0,
            f_peak: i,
            tau_peak: i,
            t_peak: i,
            mu_s: None,
            p_in_record: p,
        }
    }

    #[test]
    fn criteria_need_a_converged_refit() {
        let narrow = peak(0.005, 0.5);
        assert!(Criterion::Width(0.01).met(&narrow, true));
        assert!(!Criterion::Width(0.01).met(&narrow, false));
        assert!(!Criterion::Width(0.001).met(&narrow, true));
        assert!(!Criterion::PeakObserved.met(&narrow, true));
        assert!(Criterion::PeakObserved.met(&peak(0.5, 0.97), true));
        assert!(peak(0.5, 0.97)
            .statement()
            .starts_with("the peak is inside"));
        assert!(peak(0.5, 0.01)
            .statement()
            .starts_with("the peak lies beyond"));
        assert!(peak(0.5, 0.5).statement().contains("may or may not"));
    }
}
