//! K-fold cross-validation by time blocks: the fallback where PSIS-LOO is unreliable.
//!
//! PSIS-LOO estimates each point's leave-one-out predictive density from one fit by
//! importance sampling; where a point's Pareto k̂ exceeds the good k̂ (about 0.7) that estimate
//! is unreliable. K-fold replaces the estimate by refits: each run's observations are cut into
//! `folds` contiguous blocks of time, fold j leaves out block j of every run and is fitted
//! like any model (its own run directory under `kfold/fold-j`), and each left-out point is
//! scored by its log predictive density under the draws of the fit that did not see it,
//!
//! ```text
//! elpd_i = ln (1/S) Σ_s N(y_i | F_i(θ_s), σ_s²),   θ_s, σ_s drawn from fold(i)'s posterior.
//! ```
//!
//! Blocks of time rather than scattered points: neighbouring points of a slide are close in
//! force, so a scattered left-out point is almost seen by its neighbours; a block asks the
//! model to predict a stretch of the record it has not seen, which is what separates a law
//! that describes the slide from one that only follows it.

use std::ops::Range;

use super::model::{summary_spec, LOO_DRAWS};
use super::run_dir::{KFoldPoint, KFoldSummary, RunKFold};
use super::{draws_from, run_fit, FitError, FitSettings, RunDir};
use crate::density::{LogDensity, Target};
use crate::model::Posterior;
use crate::sampler::{Observer, Parallelism};

/// Folds by default: ten, as is usual for K-fold cross-validation; the cost is ten fits.
pub const DEFAULT_FOLDS: usize = 10;

/// Blocks of time each fold leaves out of a run, by default, spread over the record. One
/// block per fold would leave out a tenth of a slide at a stretch: the fold that loses the
/// start of a first slide must then extrapolate its whole rise backwards, and that one fold
/// swamps every other (measured: one-contact fit, 5 folds of one block, fold 0 scored −1.27e6
/// against +4.6e3 for each other fold). Ten blocks per fold leave gaps of a hundredth of the
/// record, which a law that describes the slide bridges and a law that does not, does not.
pub const DEFAULT_BLOCKS_PER_FOLD: usize = 10;

/// How the observations are dealt to folds: `folds` folds, each leaving out `blocks_per_fold`
/// blocks of time of every run ([`time_blocks`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Folds {
    /// Number of folds (refits).
    pub folds: usize,
    /// Blocks of time each fold leaves out of each run.
    pub blocks_per_fold: usize,
}

impl Default for Folds {
    fn default() -> Self {
        Self {
            folds: DEFAULT_FOLDS,
            blocks_per_fold: DEFAULT_BLOCKS_PER_FOLD,
        }
    }
}

/// The directory, inside a fit's run directory, that holds its folds' run directories.
pub const KFOLD_DIR: &str = "kfold";

/// The observations of a run of `points` that each of `folds` folds leaves out: the run is cut
/// into `folds × blocks_per_fold` contiguous blocks of time whose sizes differ by at most one
/// (fewer when the run is too short for that many), and block m goes to fold m mod `folds`.
/// Each fold's blocks are in increasing order; together the folds cover every point once.
pub fn time_blocks(points: usize, folds: usize, blocks_per_fold: usize) -> Vec<Vec<Range<usize>>> {
    let blocks = (folds * blocks_per_fold.max(1)).min(points).max(1);
    let (size, extra) = (points / blocks, points % blocks);
    let mut per_fold = vec![Vec::new(); folds];
    let mut start = 0;
    for m in 0..blocks {
        let end = start + size + usize::from(m < extra);
        per_fold[m % folds].push(start..end);
        start = end;
    }
    per_fold
}

/// What K-fold cross-validation produced: every observation's score and their summary.
#[derive(Debug, Clone, PartialEq)]
pub struct KFold {
    /// Per observation, run by run.
    pub points: Vec<KFoldPoint>,
    /// Totals.
    pub summary: KFoldSummary,
}

/// Cross-validates `posterior` (the model and data of the fit in `dir`) with the folds of
/// `folds`: fits every fold with `settings` into `dir/kfold/fold-j` (a fold whose
/// summary is already there is reused when `resume`, one with a checkpoint continues) and
/// scores each left-out observation. `lpd` is the full fit's log predictive density of its
/// own data, if known (for p_kfold). Progress of each fold's fit goes to `observer`.
///
/// # Errors
/// [`FitError::InvalidSetting`] for fewer than two folds; [`FitError::Fold`] for a run too
/// short for them (each fold must keep [`MIN_POINTS`](crate::model::data::MIN_POINTS) of
/// every run); as
/// [`run_fit`] for each fold; [`FitError::Loo`] for a run on sufficient statistics or a draw
/// that cannot be scored.
pub fn kfold(
    posterior: &Posterior,
    folds: Folds,
    settings: &FitSettings,
    dir: &RunDir,
    resume: bool,
    lpd: Option<f64>,
    observer: &mut impl Observer,
) -> Result<KFold, FitError> {
    // Refuse what cannot be scored before any fold is fitted.
    posterior.pointwise_available().map_err(FitError::Loo)?;
    let Folds {
        folds,
        blocks_per_fold,
    } = folds;
    if folds < 2 {
        return Err(FitError::InvalidSetting {
            name: "folds",
            value: folds.to_string(),
            requirement: "at least 2 (each fold leaves out one block of time of every run)".into(),
        });
    }
    let runs = posterior.run_points();
    let blocks: Vec<Vec<Vec<Range<usize>>>> = runs
        .iter()
        .map(|(_, points)| time_blocks(*points, folds, blocks_per_fold))
        .collect();
    let mut scores: Vec<Vec<f64>> = runs.iter().map(|(_, n)| vec![0.0; *n]).collect();
    let mut fold_of: Vec<Vec<usize>> = runs.iter().map(|(_, n)| vec![0; *n]).collect();
    let mut unconverged_folds = Vec::new();
    let mut draws_used = usize::MAX;
    for fold in 0..folds {
        let held_out: Vec<Vec<Range<usize>>> = blocks.iter().map(|b| b[fold].clone()).collect();
        let held_out_points: Vec<Vec<usize>> = held_out
            .iter()
            .map(|ranges| ranges.iter().cloned().flatten().collect())
            .collect();
        let fold_posterior = posterior
            .without(&held_out)
            .map_err(|source| FitError::Fold { fold, source })?;
        let fold_dir = RunDir::new(dir.path().join(KFOLD_DIR).join(format!("fold-{fold}")));
        let summary = fit_fold(&fold_posterior, settings, &fold_dir, resume, observer)?;
        if !summary.sampler.converged {
            unconverged_folds.push(fold);
        }
        let draws = draws_from(
            &fold_dir,
            &summary.sampler,
            &posterior.param_names(),
            LOO_DRAWS,
        )?;
        draws_used = draws_used.min(draws.len());
        // ln p(y_i | θ_s) of the left-out points, draw by draw, then their log mean.
        let mut terms: Vec<Vec<Vec<f64>>> = held_out_points
            .iter()
            .map(|points| vec![Vec::with_capacity(draws.len()); points.len()])
            .collect();
        for x in &draws {
            let values = posterior
                .log_likelihood_under(&fold_posterior, x)
                .map_err(FitError::Loo)?;
            for ((run_terms, points), run_values) in
                terms.iter_mut().zip(&held_out_points).zip(values)
            {
                for (point_terms, &i) in run_terms.iter_mut().zip(points) {
                    point_terms.push(run_values[i]);
                }
            }
        }
        for (run, (run_terms, points)) in terms.iter().zip(&held_out_points).enumerate() {
            for (&i, point_terms) in points.iter().zip(run_terms) {
                scores[run][i] = log_mean_exp(point_terms);
                fold_of[run][i] = fold;
            }
        }
    }
    Ok(assemble(
        posterior,
        folds,
        scores,
        fold_of,
        draws_used,
        unconverged_folds,
        lpd,
    ))
}

/// Fits one fold, or reads back a finished one when resuming.
fn fit_fold(
    posterior: &Posterior,
    settings: &FitSettings,
    dir: &RunDir,
    resume: bool,
    observer: &mut impl Observer,
) -> Result<super::FitSummary, FitError> {
    if resume {
        if let Ok(summary) = dir.read_summary() {
            return Ok(summary);
        }
    }
    let continues = resume && dir.chain_files().checkpoint.exists();
    let settings = FitSettings {
        overwrite: true,
        ..settings.clone()
    };
    let outcome = run_fit(
        Target::blocked(posterior),
        &summary_spec(posterior),
        posterior.search_start(),
        &settings,
        dir,
        continues,
        observer,
        Parallelism::default(),
    )?;
    Ok(outcome.summary)
}

/// ln of the mean of e^v over `values`, without overflow.
fn log_mean_exp(values: &[f64]) -> f64 {
    let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !max.is_finite() {
        return max;
    }
    let sum: f64 = values.iter().map(|v| (v - max).exp()).sum();
    max + (sum / values.len() as f64).ln()
}

/// Sum and standard error √(n · var) of pointwise values, as PSIS-LOO reports them.
fn sum_and_se(values: &[f64]) -> (f64, f64) {
    let n = values.len() as f64;
    let sum: f64 = values.iter().sum();
    let mean = sum / n;
    let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0).max(1.0);
    (sum, (n * var).sqrt())
}

fn assemble(
    posterior: &Posterior,
    folds: usize,
    scores: Vec<Vec<f64>>,
    fold_of: Vec<Vec<usize>>,
    draws: usize,
    unconverged_folds: Vec<usize>,
    lpd: Option<f64>,
) -> KFold {
    let mut points = Vec::new();
    let mut runs = Vec::new();
    for (run, ((name, _), (run_scores, run_folds))) in posterior
        .run_points()
        .into_iter()
        .zip(scores.iter().zip(&fold_of))
        .enumerate()
    {
        let observed = posterior.observed_forces(run);
        for (i, (&score, &fold)) in run_scores.iter().zip(run_folds).enumerate() {
            points.push(KFoldPoint {
                run: name.to_owned(),
                point: i,
                observed_n: observed[i],
                fold,
                elpd_kfold: score,
            });
        }
        let (elpd, se) = sum_and_se(run_scores);
        runs.push(RunKFold {
            run: name.to_owned(),
            points: run_scores.len(),
            elpd_kfold: elpd,
            se,
        });
    }
    let all: Vec<f64> = scores.concat();
    let (elpd_kfold, se) = sum_and_se(&all);
    KFold {
        points,
        summary: KFoldSummary {
            folds,
            elpd_kfold,
            se,
            p_kfold: lpd.map(|lpd| lpd - elpd_kfold),
            draws,
            unconverged_folds,
            runs,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_blocks_cover_the_points_once_in_blocks_of_sizes_within_one() {
        for points in [7, 10, 23, 100, 3001] {
            for (folds, per_fold) in [(2, 1), (3, 4), (5, 10), (7, 2), (10, 10)] {
                let folds_blocks = time_blocks(points, folds, per_fold);
                assert_eq!(folds_blocks.len(), folds);
                let mut all: Vec<Range<usize>> = folds_blocks.iter().flatten().cloned().collect();
                all.sort_by_key(|b| b.start);
                assert_eq!(all.len(), (folds * per_fold).min(points));
                assert_eq!(all[0].start, 0);
                assert_eq!(all[all.len() - 1].end, points);
                for pair in all.windows(2) {
                    assert_eq!(pair[0].end, pair[1].start);
                }
                let sizes: Vec<usize> = all.iter().map(|b| b.len()).collect();
                let (lo, hi) = (sizes.iter().min().unwrap(), sizes.iter().max().unwrap());
                assert!(
                    hi - lo <= 1,
                    "{points} points, {folds}×{per_fold}: {sizes:?}"
                );
                for fold in &folds_blocks {
                    assert!(fold.windows(2).all(|p| p[0].end <= p[1].start));
                }
            }
        }
    }

    #[test]
    fn log_mean_exp_is_exact_and_does_not_overflow() {
        let v = [-1000.0, -1000.0 + 2f64.ln()];
        assert!((log_mean_exp(&v) - (-1000.0 + 1.5f64.ln())).abs() < 1e-12);
        assert!(log_mean_exp(&[f64::NEG_INFINITY; 3]).is_infinite());
    }
}
