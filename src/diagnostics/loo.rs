//! Leave-one-out cross-validation by Pareto-smoothed importance sampling (PSIS-LOO), and the
//! comparison of models by it: what ArviZ's `loo` and `compare` compute, from the same
//! pointwise log-likelihoods.
//!
//! # Why importance sampling, and why smoothed
//! The expected log predictive density of a point left out, elpd_i = ln p(y_i | y_−i), needs the
//! posterior without that point. The posterior draws θ_s weighted by 1/p(y_i | θ_s) estimate
//! it without refitting (Vehtari, Gelman & Gabry 2017), but those weights can have an infinite
//! variance when the point is influential. PSIS fits a generalised Pareto distribution to the
//! largest weights and replaces them by its quantiles; the fitted shape k̂ says whether the
//! estimate can be trusted (Vehtari, Simpson, Gelman, Yao & Gabry 2024): below
//! min(1 − 1/log₁₀ S, 0.7) for S draws it is reliable, above it the estimate is not, and the
//! point should be left out by a refit (K-fold) instead.
//!
//! # The same numbers as ArviZ
//! Every step follows arviz 0.23's `psislw`, `_gpdfit`, `_gpinv`, `loo` and `compare` (the
//! cut-off of the tail, the empirical-Bayes fit of k with its prior, the truncation of smoothed
//! weights at the largest raw weight, the standard errors with a population variance), so the
//! values agree with ArviZ on the same matrix to rounding (tests/loo.rs, 1e-9 relative).
//! Stacking weights maximise the same log score; they are found here by the EM iteration of a
//! mixture's weights to 1e-12, where ArviZ stops its general-purpose optimiser earlier.

use rayon::prelude::*;

/// What is wrong with the log-likelihoods given.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum LooError {
    /// The matrix does not have `points × draws` values.
    #[error(
        "the pointwise log-likelihood has {got} values, expected {points} points x {draws} draws"
    )]
    Shape {
        /// Values given.
        got: usize,
        /// Points declared.
        points: usize,
        /// Draws declared.
        draws: usize,
    },
    /// Too few draws for the Pareto fit of the tail.
    #[error("PSIS-LOO needs at least {needed} draws, got {draws}: run the sampler longer")]
    TooFewDraws {
        /// Draws given.
        draws: usize,
        /// The fewest accepted.
        needed: usize,
    },
    /// A log-likelihood that is NaN or infinite.
    #[error(
        "the log-likelihood of point {point} at draw {draw} is {value}: PSIS-LOO needs finite \
         values (a draw where a point is impossible has no importance weight)"
    )]
    NonFinite {
        /// Point index.
        point: usize,
        /// Draw index.
        draw: usize,
        /// The value.
        value: f64,
    },
    /// A relative efficiency outside (0, ∞).
    #[error("relative efficiency r_eff = {0} is impossible: it is ESS / draws, a positive number")]
    REff(f64),
    /// Models compared on different data.
    #[error(
        "model {name:?} has {points} points but {first:?} has {expected}: models are compared on \
         the same data points"
    )]
    DifferentData {
        /// The model at fault.
        name: String,
        /// Its points.
        points: usize,
        /// The first model's name.
        first: String,
        /// The first model's points.
        expected: usize,
    },
    /// Fewer than two models.
    #[error("a comparison needs at least two models, got {0}")]
    TooFewModels(usize),
}

/// The fewest draws [`psis_loo`] accepts (the Pareto fit needs more than 4 tail draws).
pub const MIN_LOO_DRAWS: usize = 25;

/// PSIS-LOO of one model on its data points.
#[derive(Debug, Clone, PartialEq)]
pub struct Loo {
    /// elpd_loo: the sum of the points' leave-one-out log predictive densities.
    pub elpd: f64,
    /// Its standard error, √(n · Var(elpd_i)).
    pub se: f64,
    /// Effective number of parameters, lppd − elpd_loo.
    pub p_loo: f64,
    /// Each point's elpd_i.
    pub pointwise: Vec<f64>,
    /// Each point's Pareto shape k̂ (∞ where the tail had too few draws to fit).
    pub pareto_k: Vec<f64>,
    /// The k̂ above which a point's estimate is unreliable: min(1 − 1/log₁₀ S, 0.7).
    pub good_k: f64,
    /// Draws used.
    pub draws: usize,
}

impl Loo {
    /// The LOO of the union of disjoint sets of points, e.g. of a model's runs: elpd and p_loo
    /// add up, the standard error is that of all the points together.
    ///
    /// # Panics
    /// When `parts` is empty.
    pub(crate) fn concatenate<'a>(parts: impl IntoIterator<Item = &'a Loo>) -> Loo {
        let mut parts = parts.into_iter();
        let mut total = parts.next().expect("at least one part").clone();
        for part in parts {
            total.elpd += part.elpd;
            total.p_loo += part.p_loo;
            total.pointwise.extend_from_slice(&part.pointwise);
            total.pareto_k.extend_from_slice(&part.pareto_k);
        }
        total.se = (total.pointwise.len() as f64 * population_variance(&total.pointwise)).sqrt();
        total
    }

    /// Points whose k̂ exceeds [`Loo::good_k`]: their elpd_i is not to be trusted.
    pub fn unreliable_points(&self) -> Vec<usize> {
        (0..self.pareto_k.len())
            .filter(|&i| self.pareto_k[i] > self.good_k)
            .collect()
    }
}

/// PSIS-LOO from the pointwise log-likelihood `log_lik`, point-major (`log_lik[i * draws + s]`
/// is ln p(y_i | θ_s)), with `r_eff` the draws' relative efficiency ESS / draws (1 for
/// independent draws; it sets how many draws make the tail).
///
/// # Errors
/// [`LooError`] for a matrix of the wrong size, too few draws, a non-finite value or an
/// impossible `r_eff`.
pub fn psis_loo(log_lik: &[f64], draws: usize, r_eff: f64) -> Result<Loo, LooError> {
    if draws < MIN_LOO_DRAWS {
        return Err(LooError::TooFewDraws {
            draws,
            needed: MIN_LOO_DRAWS,
        });
    }
    if log_lik.len() % draws != 0 {
        return Err(LooError::Shape {
            got: log_lik.len(),
            points: log_lik.len() / draws,
            draws,
        });
    }
    if !(r_eff > 0.0 && r_eff.is_finite()) {
        return Err(LooError::REff(r_eff));
    }
    if let Some(at) = log_lik.iter().position(|v| !v.is_finite()) {
        return Err(LooError::NonFinite {
            point: at / draws,
            draw: at % draws,
            value: log_lik[at],
        });
    }
    let points = log_lik.len() / draws;
    let tail = tail_length(draws, r_eff);
    // Points are independent, and smoothing each one's tail is nearly all of LOO's cost
    // (tens of µs a point: a run of 27,000 points takes a second on one thread), so they are
    // smoothed in parallel; the sums below run in point order, the same bits on any number of
    // threads.
    let per_point: Vec<(f64, f64, f64)> = log_lik
        .par_chunks_exact(draws)
        .map_init(
            || vec![0.0; draws],
            |weights, row| {
                for (w, &l) in weights.iter_mut().zip(row) {
                    *w = -l;
                }
                let k = smooth(weights, tail);
                for (w, &l) in weights.iter_mut().zip(row) {
                    *w += l;
                }
                (
                    log_sum_exp(weights),
                    k,
                    log_sum_exp(row) - (draws as f64).ln(),
                )
            },
        )
        .collect();
    let pointwise: Vec<f64> = per_point.iter().map(|p| p.0).collect();
    let pareto_k: Vec<f64> = per_point.iter().map(|p| p.1).collect();
    let lppd: f64 = per_point.iter().map(|p| p.2).sum();
    let elpd: f64 = pointwise.iter().sum();
    Ok(Loo {
        elpd,
        se: (points as f64 * population_variance(&pointwise)).sqrt(),
        p_loo: lppd - elpd,
        pointwise,
        pareto_k,
        good_k: (1.0 - 1.0 / (draws as f64).log10()).min(0.7),
        draws,
    })
}

/// Draws in the fitted tail: ⌈min(S/5, 3√(S/r_eff))⌉.
fn tail_length(draws: usize, r_eff: f64) -> usize {
    let s = draws as f64;
    (s / 5.0).min(3.0 * (s / r_eff).sqrt()).ceil() as usize
}

/// Pareto-smooths the log importance weights `x` in place and normalises them (their
/// log-sum-exp becomes 0); returns k̂.
fn smooth(x: &mut [f64], tail: usize) -> f64 {
    let max = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    for v in x.iter_mut() {
        *v -= max;
    }
    // The (tail + 1)-th largest weight is the cut-off; the tail is what lies strictly above.
    // Only the tail needs sorting: a selection finds the cut-off in linear time, and ties
    // are broken by the draw's index, so the order is the one a stable sort gives.
    let by_weight = |&a: &usize, &b: &usize| x[a].total_cmp(&x[b]).then(a.cmp(&b));
    let mut order: Vec<usize> = (0..x.len()).collect();
    let at = x.len() - tail - 1;
    order.select_nth_unstable_by(at, by_weight);
    order[at + 1..].sort_unstable_by(by_weight);
    let cutoff = x[order[at]].max(f64::MIN_POSITIVE.ln());
    let exp_cutoff = cutoff.exp();
    let tail_draws: Vec<usize> = order[at + 1..]
        .iter()
        .copied()
        .filter(|&i| x[i] > cutoff)
        .collect();
    let k = if tail_draws.len() <= 4 {
        f64::INFINITY
    } else {
        let excess: Vec<f64> = tail_draws
            .iter()
            .map(|&i| x[i].exp() - exp_cutoff)
            .collect();
        let (k, sigma) = fit_generalised_pareto(&excess);
        if k.is_finite() {
            let n = tail_draws.len() as f64;
            for (j, &i) in tail_draws.iter().enumerate() {
                let p = (j as f64 + 0.5) / n;
                x[i] = (pareto_quantile(p, k, sigma) + exp_cutoff).ln();
            }
            // No smoothed weight above the largest raw one.
            for v in x.iter_mut() {
                if *v > 0.0 {
                    *v = 0.0;
                }
            }
        }
        k
    };
    let total = log_sum_exp(x);
    for v in x.iter_mut() {
        *v -= total;
    }
    k
}

/// Zhang & Stephens' empirical-Bayes estimate of the generalised Pareto shape k and scale σ
/// from sorted exceedances, with the weakly informative prior on k that PSIS uses (k shrunk
/// towards 0.5 as if by 10 more observations).
fn fit_generalised_pareto(sorted: &[f64]) -> (f64, f64) {
    const PRIOR_BS: f64 = 3.0;
    const PRIOR_K: f64 = 10.0;
    let n = sorted.len();
    let nf = n as f64;
    let m = 30 + (nf.sqrt() as usize);
    let quartile = sorted[(nf / 4.0 + 0.5) as usize - 1];
    let largest = sorted[n - 1];
    let mean_log1p = |b: f64| sorted.iter().map(|&x| (-b * x).ln_1p()).sum::<f64>() / nf;
    let b: Vec<f64> = (1..=m)
        .map(|j| {
            (1.0 - (m as f64 / (j as f64 - 0.5)).sqrt()) / (PRIOR_BS * quartile) + 1.0 / largest
        })
        .collect();
    let log_lik: Vec<f64> = b
        .iter()
        .map(|&b| {
            let k = mean_log1p(b);
            nf * ((-(b / k)).ln() - k - 1.0)
        })
        .collect();
    // Each candidate's posterior weight, 1 / Σ_l exp(ℓ_l − ℓ_j) = exp(ℓ_j − ℓ_max) / Σ_l
    // exp(ℓ_l − ℓ_max): m exponentials rather than m²; negligible ones dropped.
    let top = log_lik.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let scale: f64 = log_lik.iter().map(|&l| (l - top).exp()).sum();
    let weights: Vec<f64> = log_lik.iter().map(|&l| (l - top).exp() / scale).collect();
    let kept: Vec<(f64, f64)> = b
        .iter()
        .zip(&weights)
        .filter(|(_, &w)| w >= 10.0 * f64::EPSILON)
        .map(|(&b, &w)| (b, w))
        .collect();
    let total: f64 = kept.iter().map(|&(_, w)| w).sum();
    let b_post: f64 = kept.iter().map(|&(b, w)| b * (w / total)).sum();
    let k = mean_log1p(b_post);
    let sigma = -k / b_post;
    ((nf * k + PRIOR_K * 0.5) / (nf + PRIOR_K), sigma)
}

/// The generalised Pareto quantile of probability `p` in (0, 1) with shape `k`, scale `sigma`
/// (NaN for a scale that is not positive).
fn pareto_quantile(p: f64, k: f64, sigma: f64) -> f64 {
    if sigma <= 0.0 {
        return f64::NAN;
    }
    let x = if k.abs() < f64::EPSILON {
        -(-p).ln_1p()
    } else {
        (-k * (-p).ln_1p()).exp_m1() / k
    };
    x * sigma
}

/// ln Σ exp(x), from the largest value.
fn log_sum_exp(x: &[f64]) -> f64 {
    let max = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if max == f64::NEG_INFINITY {
        return max;
    }
    x.iter().map(|&v| (v - max).exp()).sum::<f64>().ln() + max
}

fn population_variance(x: &[f64]) -> f64 {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    x.iter().map(|&v| (v - mean) * (v - mean)).sum::<f64>() / n
}

/// One model's row of a [`compare`] table.
#[derive(Debug, Clone, PartialEq)]
pub struct Compared {
    /// The model's name.
    pub name: String,
    /// 0 for the model with the highest elpd_loo, then 1, 2, ...
    pub rank: usize,
    /// Its elpd_loo.
    pub elpd: f64,
    /// Its effective number of parameters.
    pub p_loo: f64,
    /// How much lower its elpd_loo is than the best model's (0 for the best).
    pub elpd_diff: f64,
    /// Standard error of that difference, from the pointwise differences (0 for the best).
    pub dse: f64,
    /// Its standard error of elpd_loo.
    pub se: f64,
    /// Its stacking weight: the models' weights maximise the leave-one-out log score of
    /// their mixture, Σ_i ln Σ_m w_m exp(elpd_{m,i}).
    pub weight: f64,
    /// Whether some point's k̂ exceeds the model's [`Loo::good_k`].
    pub warning: bool,
}

/// Compares models fitted to the same data points by PSIS-LOO, best first (as ArviZ's
/// `compare` with stacking weights). A difference within about two `dse` is no evidence that
/// one model predicts better than the other.
///
/// # Errors
/// [`LooError::TooFewModels`] for fewer than two models, [`LooError::DifferentData`] when
/// their numbers of points differ.
pub fn compare(models: &[(&str, &Loo)]) -> Result<Vec<Compared>, LooError> {
    if models.len() < 2 {
        return Err(LooError::TooFewModels(models.len()));
    }
    let (first, first_loo) = models[0];
    let points = first_loo.pointwise.len();
    for &(name, loo) in &models[1..] {
        if loo.pointwise.len() != points {
            return Err(LooError::DifferentData {
                name: name.to_owned(),
                points: loo.pointwise.len(),
                first: first.to_owned(),
                expected: points,
            });
        }
    }
    let mut order: Vec<usize> = (0..models.len()).collect();
    order.sort_by(|&a, &b| models[b].1.elpd.total_cmp(&models[a].1.elpd));
    let weights = stacking_weights(&models.iter().map(|(_, l)| *l).collect::<Vec<_>>());
    let best = &models[order[0]].1.pointwise;
    Ok(order
        .iter()
        .enumerate()
        .map(|(rank, &m)| {
            let (name, loo) = models[m];
            let diff: Vec<f64> = best
                .iter()
                .zip(&loo.pointwise)
                .map(|(b, x)| b - x)
                .collect();
            Compared {
                name: name.to_owned(),
                rank,
                elpd: loo.elpd,
                p_loo: loo.p_loo,
                elpd_diff: diff.iter().sum(),
                dse: (points as f64 * population_variance(&diff)).sqrt(),
                se: loo.se,
                weight: weights[m],
                warning: !loo.unreliable_points().is_empty(),
            }
        })
        .collect())
}

/// Stacking weights of `models`: the w on the simplex maximising Σ_i ln Σ_m w_m exp(elpd_{m,i}),
/// by the EM iteration of mixture weights (each step raises the score; stopped when no weight
/// moves by more than 1e-12, or after 100,000 steps).
fn stacking_weights(models: &[&Loo]) -> Vec<f64> {
    let m = models.len();
    let points = models[0].pointwise.len();
    // exp(elpd_{m,i} − max_m elpd_{m,i}): each point's densities relative to its best model,
    // which leaves the maximiser unchanged and keeps the exponentials finite.
    let mut density = vec![0.0; points * m];
    for i in 0..points {
        let top = models
            .iter()
            .map(|l| l.pointwise[i])
            .fold(f64::NEG_INFINITY, f64::max);
        for (k, l) in models.iter().enumerate() {
            density[i * m + k] = (l.pointwise[i] - top).exp();
        }
    }
    let mut w = vec![1.0 / m as f64; m];
    let mut next = vec![0.0; m];
    for _ in 0..100_000 {
        next.fill(0.0);
        for row in density.chunks_exact(m) {
            let mixture: f64 = row.iter().zip(&w).map(|(d, w)| d * w).sum();
            for ((n, d), w) in next.iter_mut().zip(row).zip(&w) {
                *n += d * w / mixture;
            }
        }
        let mut moved: f64 = 0.0;
        for (w, n) in w.iter_mut().zip(&next) {
            let n = n / points as f64;
            moved = moved.max((n - *w).abs());
            *w = n;
        }
        if moved < 1e-12 {
            break;
        }
    }
    w
}

/// The stacking log score Σ_i ln Σ_m w_m exp(elpd_{m,i}) of weights `w` (what [`compare`]'s
/// weights maximise).
pub fn stacking_score(models: &[&Loo], w: &[f64]) -> f64 {
    let points = models[0].pointwise.len();
    let mut terms = vec![0.0; models.len()];
    (0..points)
        .map(|i| {
            for ((t, l), w) in terms.iter_mut().zip(models).zip(w) {
                *t = w.ln() + l.pointwise[i];
            }
            log_sum_exp(&terms)
        })
        .sum()
}
