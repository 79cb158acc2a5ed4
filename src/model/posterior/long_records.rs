//! Long records: every run of more than `[likelihood] exact_up_to` observations (with a
//! tolerance above 0) is evaluated on sufficient statistics of bins of its points
//! ([`crate::model::sufficient`]), so that a likelihood evaluation solves the model at a few
//! thousand times instead of at every one of 10⁶ (docs/model.md §5, "Long records").
//!
//! The bins are chosen where the model's interpolation error is small at *reference*
//! parameters: first the rough start (each slide fitted alone on about 5,000 of its points),
//! then, once a mode of that reduced posterior is known, draws from the Laplace approximation
//! there and the same draws pushed twice as far from their mean: the region the posterior
//! can reach. At every evaluation a bin that a kink of the model at
//! the evaluated parameters enters (t0, the end of the elastic loading, a repeat slide's
//! plateau) is evaluated point by point.

use rand::SeedableRng;
use rayon::prelude::*;

use super::layout::SigmaSource;
use super::Posterior;
use crate::data::import::Binning;
use crate::density::Target;
use crate::law::{LawError, ObservedSlide, Scene};
use crate::model::sufficient::{
    log_likelihood_bound, max_error_for, plan_bins, PlanSettings, Reduction, ReferenceModel,
};
use crate::optimize::{initial_around_optimum, SearchStart};

/// Degree of the polynomial that stands in for the model within a bin. Measured on the
/// PTFE slide of docs/model.md §7 sampled 50 times a second (`examples/bin_degree.rs`): the
/// model evaluations per likelihood evaluation fall with the degree up to about 9 and then
/// level off, while the cost of each bin's quadratic form grows as (q + 1)².
pub const BIN_DEGREE: usize = 7;

/// Fewest points in a bin: four per interpolation point (a bin is worth its q + 1 model
/// evaluations and (q + 1)² products only if it replaces several times as many points).
const MIN_BIN_POINTS: usize = 4 * (BIN_DEGREE + 1);

/// Most points in a bin: a bin that a kink enters at some parameters is evaluated point by
/// point, at most this many (about 0.2 ms).
const MAX_BIN_POINTS: usize = 1 << 14;

/// The bound is stated at half the record's noise estimate (from second differences): below
/// the residuals' RMS at any parameters even if the estimate is somewhat high (the model's
/// curvature between neighbouring points adds to it; noise correlated from point to point
/// lowers it).
const NOISE_MARGIN: f64 = 0.5;

/// Laplace draws among the reference points (each also pushed out, below).
const REFERENCE_DRAWS: usize = 12;

/// How far the second set of reference points lies from the Laplace draws' mean, in units
/// of their own distance.
const REFERENCE_STRETCH: f64 = 2.0;

/// Seed of the Laplace draws that serve as reference points (fixed: the bins are a function
/// of the model and the data).
const REFERENCE_SEED: u64 = 0x10_4e_c0_2d;

impl Posterior {
    /// Reduces every long run to sufficient statistics (a no-op when none is long): bins chosen
    /// at the rough start, then again at the Laplace draws around the mode of the first
    /// reduction. Leaves the rough start computed. A run whose bins cannot be
    /// chosen (no reference point where its model can be evaluated, no noise) stays exact.
    pub(super) fn reduce_long_runs(&mut self) {
        let long = self.long_runs();
        if long.is_empty() {
            return;
        }
        let start = self.heuristic_start();
        self.install_reductions(&long, std::slice::from_ref(&start.point));
        self.reduced_at = vec![start.point.clone()];
        let dim = self.coords.len();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(REFERENCE_SEED);
        if let Ok(found) = initial_around_optimum(
            Target::blocked(&*self),
            SearchStart {
                point: &start.point,
                map: self.search_map(),
            },
            REFERENCE_DRAWS,
            1,
            &mut rng,
        ) {
            // The posterior's region only: the rough start may lie far from it, and a kink
            // there (a repeat slide's plateau, seconds off) would keep many points exact.
            let draws = &found.walkers[0];
            let mean: Vec<f64> = (0..dim)
                .map(|c| draws.iter().map(|w| w[c]).sum::<f64>() / draws.len() as f64)
                .collect();
            let mut references = Vec::with_capacity(2 * draws.len());
            for w in draws {
                references.push(w.clone());
                references.push(
                    mean.iter()
                        .zip(w)
                        .map(|(m, v)| m + REFERENCE_STRETCH * (v - m))
                        .collect(),
                );
            }
            self.install_reductions(&long, &references);
            self.reduced_at = references;
        }
        // The start depends on the data alone: the reduced posterior's is this one.
        let _ = self.start.set(start);
    }

    /// The long runs, each with its tolerance: from the runs' observation counts alone.
    pub(super) fn long_runs(&self) -> Vec<(usize, f64)> {
        let points: Vec<usize> = self.runs.iter().map(|r| r.data.n_obs).collect();
        self.spec
            .reduction_tolerances(&points)
            .into_iter()
            .enumerate()
            // A rate-and-state slide is an ODE solved over the whole record, whose cost does
            // not fall with fewer evaluation times as a closed form's does: it stays exact.
            .filter(|&(i, _)| self.runs[i].law.in_interface_time())
            .filter_map(|(i, tolerance)| tolerance.map(|t| (i, t)))
            .collect()
    }

    /// Chooses the bins of each of the `long` runs (with its tolerance) at `references`, on
    /// every core, and installs them (or none).
    pub(super) fn install_reductions(&mut self, long: &[(usize, f64)], references: &[Vec<f64>]) {
        let planned: Vec<Option<(Reduction, Binning)>> = long
            .par_iter()
            .map(|&(i, tolerance)| self.plan_run(i, tolerance, references))
            .collect();
        for (&(i, _), plan) in long.iter().zip(planned) {
            let r = &mut self.runs[i];
            let (reduction, binning) = plan.unzip();
            r.reduction = reduction;
            r.data.provenance.binning = binning;
        }
    }

    /// The bins of run `i` for a log-likelihood error of at most `tolerance`, chosen at the
    /// parameter points `references`; `None` when none can be chosen.
    fn plan_run(
        &self,
        i: usize,
        tolerance: f64,
        references: &[Vec<f64>],
    ) -> Option<(Reduction, Binning)> {
        let r = &self.runs[i];
        let d = &r.data;
        let noise_n = NOISE_MARGIN * d.noise_estimate_detrended();
        if !(noise_n.is_finite() && noise_n > 0.0) {
            return None;
        }
        let obs_times = &d.model_times[..d.n_obs];
        let t_last = d.model_times[d.model_times.len() - 1];
        let mut models: Vec<Box<ReferenceModel>> = Vec::new();
        // Per kink of the model (t0, end of the loading; a repeat slide's start and plateau):
        // the earliest and latest time it takes over the references.
        let mut kinks = [(f64::INFINITY, f64::NEG_INFINITY); 2];
        for x in references {
            let f_end = match r.follows.map(|j| self.end_force(x, j)) {
                Some(Ok(f)) => Some(f),
                Some(Err(_)) => continue,
                None => None,
            };
            let Ok(k) = r.kinks(x, f_end) else { continue };
            match r.scene {
                Scene::Repeat => {
                    let Ok(slide) = r.repeat_slide(x, f_end) else {
                        continue;
                    };
                    models.push(Box::new(move |t: &[f64], out: &mut [f64]| {
                        slide.forces(t, out).is_ok()
                    }));
                }
                Scene::First | Scene::StiffFast => {
                    let (Ok(law), Ok(elastic)) = (r.law(x), r.elastic(x)) else {
                        continue;
                    };
                    let slide = ObservedSlide::new(law, elastic);
                    // A reference must reach the end of the record (no stick-slip on the way).
                    if slide.force_at(t_last).is_err() {
                        continue;
                    }
                    // The serial solve: the points of a trial bin lie close together but far
                    // from t0, where the batched kernel's anchors would start every lane far off.
                    models.push(Box::new(move |t: &[f64], out: &mut [f64]| {
                        slide.for_each_force_serial(t, |j, _, f| out[j] = f).is_ok()
                    }));
                }
            }
            for (range, k) in kinks.iter_mut().zip(k) {
                if k.is_finite() {
                    *range = (range.0.min(k), range.1.max(k));
                }
            }
        }
        if models.is_empty() {
            return None;
        }
        // No bin within the kinks' spread over the references, nor as far again on either
        // side: where a walker puts a kink it rarely opens a bin.
        let excluded: Vec<(f64, f64)> = kinks
            .iter()
            .filter(|(lo, hi)| lo <= hi)
            .map(|&(lo, hi)| (lo - (hi - lo), hi + (hi - lo)))
            .collect();
        // An integrated σ's prior truncation enters the bound through 1 + s²/H².
        let inflation = match r.sigma {
            SigmaSource::Marginal(g) => 1.0 + (noise_n / self.sigma_groups[g].high).powi(2),
            SigmaSource::Coord(_) => 1.0,
        };
        let settings = PlanSettings {
            degree: BIN_DEGREE,
            max_error_n: max_error_for(tolerance, d.n_obs, noise_n, inflation),
            min_points: MIN_BIN_POINTS,
            max_points: MAX_BIN_POINTS,
        };
        let references: Vec<&ReferenceModel> = models.iter().map(|m| m.as_ref()).collect();
        let planned = plan_bins(obs_times, &excluded, &settings, &references);
        let reduction = Reduction::new(
            obs_times,
            &d.force,
            &d.model_times[d.n_obs..],
            BIN_DEGREE,
            &planned,
        );
        if reduction.bins() == 0 {
            return None;
        }
        let binned = reduction.binned_points();
        let binning = Binning {
            bins: reduction.bins(),
            points_per_bin: binned as f64 / reduction.bins() as f64,
            exact_points: d.n_obs - binned,
            evaluations: reduction.evaluations(),
            degree: BIN_DEGREE,
            tolerance,
            bound: log_likelihood_bound(d.n_obs, reduction.sum_sq_error(), noise_n, inflation),
            noise_n,
        };
        Some((reduction, binning))
    }

    /// The force of first slide `run` at its last model time (F_end) at `x`, solved there
    /// alone.
    fn end_force(&self, x: &[f64], run: usize) -> Result<f64, LawError> {
        let r = &self.runs[run];
        let slide = ObservedSlide::new(r.law(x)?, r.elastic(x)?);
        slide.force_at(r.data.model_times[r.data.model_times.len() - 1])
    }
}
