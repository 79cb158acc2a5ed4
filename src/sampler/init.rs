//! Starting the ensembles close to the posterior, so that burn-in is short.
//!
//! The mode is found with L-BFGS on finite-difference gradients, polished with Nelder–Mead
//! (no gradients needed, robust to the rejections a density may return near the edge of its
//! support), the local curvature with a central
//! finite-difference Hessian, and walkers are drawn from the Laplace approximation
//! `N(mode, H⁻¹)`. When `H` is not positive definite, the directions without positive
//! curvature get a small fixed spread instead.

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use rand::Rng;
use rand_distr::StandardNormal;

use super::density::{classify, Eval, LogDensity};
use super::error::SamplerError;
use super::lbfgs::{lbfgs, LbfgsOptions};
use super::run::{walker_condition_number, WALKER_CONDITION_LIMIT};

/// Options of [`nelder_mead`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NelderMeadOptions {
    /// Initial simplex edge relative to `max(|x_i|, 1)`.
    pub initial_step: f64,
    /// Stop when the spread of function values in the simplex is below this (absolute).
    pub f_tol: f64,
    /// Stop when every simplex edge is below `x_tol · max(|x_i|, 1)`.
    pub x_tol: f64,
    /// Largest number of function evaluations.
    pub max_evals: usize,
    /// Restarts from the best point (a collapsed simplex can stall away from the minimum).
    pub restarts: usize,
}

impl Default for NelderMeadOptions {
    fn default() -> Self {
        Self {
            initial_step: 0.1,
            f_tol: 1e-10,
            x_tol: 1e-8,
            max_evals: 20_000,
            restarts: 3,
        }
    }
}

/// Minimises `f` from `start` with the Nelder–Mead simplex method using the
/// dimension-adaptive coefficients of Gao & Han (2012). `f` may return +∞ (or NaN) for
/// points it refuses. Returns the best point, its value and the number of evaluations.
pub fn nelder_mead<F: FnMut(&[f64]) -> f64>(
    mut f: F,
    start: &[f64],
    options: &NelderMeadOptions,
) -> (Vec<f64>, f64, usize) {
    let n = start.len();
    let nf = n as f64;
    let (alpha, beta, gamma, delta) = (1.0, 1.0 + 2.0 / nf, 0.75 - 0.5 / nf, 1.0 - 1.0 / nf);
    let mut evals = 0usize;
    let mut eval = |x: &[f64], evals: &mut usize| {
        *evals += 1;
        let v = f(x);
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    };
    let mut best = start.to_vec();
    let mut fbest = eval(&best, &mut evals);
    for _restart in 0..=options.restarts {
        let mut simplex: Vec<Vec<f64>> = vec![best.clone()];
        for i in 0..n {
            let mut v = best.clone();
            v[i] += options.initial_step * best[i].abs().max(1.0);
            simplex.push(v);
        }
        let mut fv: Vec<f64> = Vec::with_capacity(n + 1);
        fv.push(fbest);
        for v in simplex.iter().skip(1) {
            fv.push(eval(v, &mut evals));
        }
        let mut centroid = vec![0.0; n];
        let mut trial = vec![0.0; n];
        let mut trial2 = vec![0.0; n];
        while evals < options.max_evals {
            // Order: best first, worst last.
            let mut order: Vec<usize> = (0..=n).collect();
            order.sort_by(|&a, &b| fv[a].total_cmp(&fv[b]));
            simplex = order.iter().map(|&i| simplex[i].clone()).collect();
            fv = order.iter().map(|&i| fv[i]).collect();
            let size = simplex.iter().skip(1).fold(0.0f64, |m, v| {
                v.iter()
                    .zip(&simplex[0])
                    .map(|(a, b)| (a - b).abs() / b.abs().max(1.0))
                    .fold(m, f64::max)
            });
            if (fv[n] - fv[0]).abs() <= options.f_tol && size <= options.x_tol {
                break;
            }
            centroid.iter_mut().for_each(|c| *c = 0.0);
            for v in &simplex[..n] {
                for (c, &x) in centroid.iter_mut().zip(v) {
                    *c += x / nf;
                }
            }
            let point = |t: f64, out: &mut [f64], worst: &[f64]| {
                for ((o, &c), &w) in out.iter_mut().zip(&centroid).zip(worst) {
                    *o = c + t * (c - w);
                }
            };
            point(alpha, &mut trial, &simplex[n]);
            let fr = eval(&trial, &mut evals);
            if fr < fv[0] {
                point(alpha * beta, &mut trial2, &simplex[n]);
                let fe = eval(&trial2, &mut evals);
                if fe < fr {
                    simplex[n].copy_from_slice(&trial2);
                    fv[n] = fe;
                } else {
                    simplex[n].copy_from_slice(&trial);
                    fv[n] = fr;
                }
            } else if fr < fv[n - 1] {
                simplex[n].copy_from_slice(&trial);
                fv[n] = fr;
            } else {
                // Outside or inside contraction.
                let outside = fr < fv[n];
                let t = if outside { alpha * gamma } else { -gamma };
                point(t, &mut trial2, &simplex[n]);
                let fc = eval(&trial2, &mut evals);
                if fc < fr.min(fv[n]) {
                    simplex[n].copy_from_slice(&trial2);
                    fv[n] = fc;
                } else {
                    // Shrink towards the best vertex.
                    let (head, rest) = simplex.split_at_mut(1);
                    for (v, f) in rest.iter_mut().zip(fv.iter_mut().skip(1)) {
                        for (vj, &bj) in v.iter_mut().zip(&head[0]) {
                            *vj = bj + delta * (*vj - bj);
                        }
                        *f = eval(v, &mut evals);
                    }
                }
            }
        }
        let (ib, &fb) = fv
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &fbest));
        let improved = fb < fbest - options.f_tol;
        if fb <= fbest {
            best = simplex[ib].clone();
            fbest = fb;
        }
        if !improved || evals >= options.max_evals {
            break;
        }
    }
    (best, fbest, evals)
}

/// Covariance of the Laplace approximation at `mode` of the log-density `log_f`, from a
/// central finite-difference Hessian: `(Σ, positive_definite)`, `Σ` row-major `n × n`.
///
/// Directions without positive curvature (or when a difference point is refused) get the
/// fallback standard deviation `fallback_sd · max(|x_i|, 1)` along the coordinate axes.
pub fn laplace_covariance<F: FnMut(&[f64]) -> f64>(
    mut log_f: F,
    mode: &[f64],
    fallback_sd: f64,
) -> (Vec<f64>, bool) {
    let n = mode.len();
    // ε^(1/4): balances truncation (h²) against rounding (ε/h²) of the second difference.
    let h: Vec<f64> = mode
        .iter()
        .map(|x| f64::EPSILON.powf(0.25) * x.abs().max(1.0))
        .collect();
    let f0 = log_f(mode);
    let mut x = mode.to_vec();
    let mut at = |x: &mut Vec<f64>, moves: &[(usize, f64)]| {
        for &(i, d) in moves {
            x[i] += d;
        }
        let v = log_f(x);
        for &(i, d) in moves {
            x[i] -= d;
        }
        x.copy_from_slice(mode);
        v
    };
    let mut hess = DMatrix::<f64>::zeros(n, n);
    let mut finite = f0.is_finite();
    for i in 0..n {
        let fp = at(&mut x, &[(i, h[i])]);
        let fm = at(&mut x, &[(i, -h[i])]);
        finite &= fp.is_finite() && fm.is_finite();
        hess[(i, i)] = -(fp - 2.0 * f0 + fm) / (h[i] * h[i]);
        for j in 0..i {
            let fpp = at(&mut x, &[(i, h[i]), (j, h[j])]);
            let fpm = at(&mut x, &[(i, h[i]), (j, -h[j])]);
            let fmp = at(&mut x, &[(i, -h[i]), (j, h[j])]);
            let fmm = at(&mut x, &[(i, -h[i]), (j, -h[j])]);
            finite &= fpp.is_finite() && fpm.is_finite() && fmp.is_finite() && fmm.is_finite();
            let v = -(fpp - fpm - fmp + fmm) / (4.0 * h[i] * h[j]);
            hess[(i, j)] = v;
            hess[(j, i)] = v;
        }
    }
    let fallback = |i: usize| (fallback_sd * mode[i].abs().max(1.0)).powi(2);
    if !finite {
        let mut cov = vec![0.0; n * n];
        for i in 0..n {
            cov[i * n + i] = fallback(i);
        }
        return (cov, false);
    }
    let eig = SymmetricEigen::new(hess);
    let lmax = eig.eigenvalues.iter().copied().fold(0.0f64, f64::max);
    let mut pd = true;
    let mut inv = DVector::<f64>::zeros(n);
    for (k, &l) in eig.eigenvalues.iter().enumerate() {
        // Curvature this small relative to the largest is numerically zero.
        if l > lmax * 1e-12 && l > 0.0 {
            inv[k] = 1.0 / l;
        } else {
            pd = false;
            // Spread along this eigenvector as the fallback would along an axis.
            let v = eig.eigenvectors.column(k);
            inv[k] = (0..n).map(|i| v[i] * v[i] * fallback(i)).sum();
        }
    }
    let cov = &eig.eigenvectors * DMatrix::from_diagonal(&inv) * eig.eigenvectors.transpose();
    let mut out = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            out[i * n + j] = cov[(i, j)];
        }
    }
    (out, pd)
}

/// The mode found and the curvature used for the start.
#[derive(Debug, Clone, PartialEq)]
pub struct Optimum {
    /// Position of the mode.
    pub x: Vec<f64>,
    /// Log-density there.
    pub log_density: f64,
    /// Covariance of the Laplace approximation (row-major `ndim × ndim`).
    pub covariance: Vec<f64>,
    /// Whether the Hessian was positive definite (otherwise a fallback spread was used).
    pub positive_definite: bool,
    /// Log-density evaluations spent (optimisation, Hessian and drawing walkers).
    pub evaluations: usize,
}

/// Initial walkers and how they were found.
#[derive(Debug, Clone, PartialEq)]
pub struct Start {
    /// `walkers[ensemble][walker]`, ready for [`EnsembleSampler::new`](super::EnsembleSampler::new).
    pub walkers: Vec<Vec<Vec<f64>>>,
    /// The mode and curvature.
    pub optimum: Optimum,
}

/// Relative fallback spread along directions without positive curvature.
pub const FALLBACK_SPREAD: f64 = 1e-3;
/// Attempts to draw a walker inside the support before giving up.
pub const MAX_DRAW_ATTEMPTS: usize = 1000;

/// Finds the mode of `density` from `start` and draws `ensembles × walkers` walkers from
/// the Laplace approximation there (redrawing points the density refuses).
///
/// # Errors
/// [`SamplerError::Optimisation`] when `start` is not inside the support, no finite mode is
/// found, walkers cannot be drawn inside the support, or they do not span the space.
pub fn initial_around_optimum<D: LogDensity + ?Sized, R: Rng>(
    density: &D,
    start: &[f64],
    walkers: usize,
    ensembles: usize,
    rng: &mut R,
) -> Result<Start, SamplerError> {
    let n = density.dim();
    if start.len() != n {
        return Err(SamplerError::Shape {
            what: "optimisation start".into(),
            expected: n,
            got: start.len(),
        });
    }
    let mut scratch = vec![0.0; density.derived_names().len()];
    let mut evaluations = 0usize;
    let mut log_f = |x: &[f64]| {
        evaluations += 1;
        match classify(density, x, &mut scratch) {
            Eval::Finite(v) => v,
            _ => f64::NEG_INFINITY,
        }
    };
    let f_start = log_f(start);
    if !f_start.is_finite() {
        return Err(SamplerError::Optimisation {
            detail: format!(
                "the log-density at the start {start:?} is not finite; start inside the support"
            ),
        });
    }
    // L-BFGS gets close cheaply in many dimensions; Nelder–Mead then polishes without
    // trusting finite-difference gradients at the end.
    let (near, _) = lbfgs(|x| -log_f(x), start, &LbfgsOptions::default());
    let polish = NelderMeadOptions {
        initial_step: 1e-3,
        max_evals: 200 * n,
        restarts: 1,
        ..NelderMeadOptions::default()
    };
    let (mode, neg, _) = nelder_mead(|x| -log_f(x), &near, &polish);
    if !neg.is_finite() {
        return Err(SamplerError::Optimisation {
            detail: format!("Nelder–Mead ended at {mode:?} with log-density {}", -neg),
        });
    }
    let (cov, pd) = laplace_covariance(&mut log_f, &mode, FALLBACK_SPREAD);
    let eig = SymmetricEigen::new(DMatrix::from_row_slice(n, n, &cov));
    // Σ = V Λ Vᵀ, so x = mode + V Λ^{1/2} z with z standard normal.
    let root =
        &eig.eigenvectors * DMatrix::from_diagonal(&eig.eigenvalues.map(|l| l.max(0.0).sqrt()));
    let mut z = DVector::<f64>::zeros(n);
    let mut all = Vec::with_capacity(ensembles);
    for e in 0..ensembles {
        let mut ens = Vec::with_capacity(walkers);
        for w in 0..walkers {
            let mut attempts = 0;
            let x = loop {
                attempts += 1;
                z.iter_mut().for_each(|v| *v = rng.sample(StandardNormal));
                let d = &root * &z;
                let x: Vec<f64> = mode.iter().zip(d.iter()).map(|(m, d)| m + d).collect();
                if log_f(&x).is_finite() {
                    break x;
                }
                if attempts >= MAX_DRAW_ATTEMPTS {
                    return Err(SamplerError::Optimisation {
                        detail: format!(
                            "could not draw walker {w} of ensemble {e} inside the support around the mode {mode:?} \
                             in {MAX_DRAW_ATTEMPTS} attempts"
                        ),
                    });
                }
            };
            ens.push(x);
        }
        let flat: Vec<f64> = ens.iter().flatten().copied().collect();
        let condition = walker_condition_number(&flat, n);
        if condition.is_nan() || condition > WALKER_CONDITION_LIMIT {
            return Err(SamplerError::Optimisation {
                detail: format!(
                    "walkers drawn around the mode {mode:?} are degenerate (condition number {condition:e})"
                ),
            });
        }
        all.push(ens);
    }
    let log_density = log_f(&mode);
    Ok(Start {
        walkers: all,
        optimum: Optimum {
            x: mode,
            log_density,
            covariance: cov,
            positive_definite: pd,
            evaluations,
        },
    })
}
