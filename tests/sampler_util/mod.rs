//! Shared targets and Monte-Carlo error estimates for the sampler tests.
#![allow(dead_code)]

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use slipbayes::density::{LogDensity, LogDensityError};
use slipbayes::diagnostics::mcse_mean;
use slipbayes::sampler::MemoryChain;

/// A zero-mean Gaussian with a given covariance.
pub struct Gaussian {
    pub cov: DMatrix<f64>,
    pub precision: DMatrix<f64>,
}

impl Gaussian {
    pub fn new(cov: DMatrix<f64>) -> Self {
        let precision = cov.clone().try_inverse().expect("covariance invertible");
        Self { cov, precision }
    }

    /// Covariance `Q diag(λ) Qᵀ`, `λ` log-spaced from 1 to `condition`, `Q` a random rotation.
    pub fn rotated(ndim: usize, condition: f64, seed: u64) -> Self {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let a = DMatrix::<f64>::from_fn(ndim, ndim, |_, _| rng.sample(StandardNormal));
        let q = a.qr().q();
        let lambda = DMatrix::from_diagonal(&nalgebra::DVector::from_fn(ndim, |i, _| {
            condition.powf(i as f64 / (ndim as f64 - 1.0))
        }));
        let cov = &q * lambda * q.transpose();
        Self::new((&cov + cov.transpose()) * 0.5)
    }

    /// Correlation `rho^|i−j|` (AR(1)-like), variances `1 + i`.
    pub fn correlated(ndim: usize, rho: f64) -> Self {
        Self::new(DMatrix::from_fn(ndim, ndim, |i, j| {
            rho.powi((i as i32 - j as i32).abs()) * ((1.0 + i as f64) * (1.0 + j as f64)).sqrt()
        }))
    }
}

impl LogDensity for Gaussian {
    fn dim(&self) -> usize {
        self.cov.nrows()
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        let mut q = 0.0;
        for (i, xi) in x.iter().enumerate() {
            let row: f64 = x
                .iter()
                .enumerate()
                .map(|(j, xj)| self.precision[(i, j)] * xj)
                .sum();
            q += xi * row;
        }
        Ok(-0.5 * q)
    }
}

/// Mean of `g` over the draws after `burn` steps and its Monte-Carlo standard error.
///
/// The per-step average of `g` over the walkers of one ensemble is one chain (a function of
/// the ensemble's Markov state); the independent ensembles are the chains handed to the
/// diagnostics' MCSE (ArviZ's `mcse_mean`: sd / √ESS with Geyer's ESS).
pub fn mean_and_mcse(chains: &[MemoryChain], burn: usize, g: impl Fn(&[f64]) -> f64) -> (f64, f64) {
    let series: Vec<Vec<f64>> =
        chains
            .iter()
            .map(|c| {
                let stride = c.walkers * c.ndim;
                (burn..c.steps.len())
                    .map(|s| {
                        (0..c.walkers)
                            .map(|w| {
                                g(&c.positions
                                    [s * stride + w * c.ndim..s * stride + (w + 1) * c.ndim])
                            })
                            .sum::<f64>()
                            / c.walkers as f64
                    })
                    .collect()
            })
            .collect();
    let refs: Vec<&[f64]> = series.iter().map(Vec::as_slice).collect();
    let n: usize = series.iter().map(Vec::len).sum();
    let mean = series.iter().flatten().sum::<f64>() / n as f64;
    (mean, mcse_mean(&refs).expect("MCSE"))
}

/// Asserts that `estimate` is within `k` standard errors of `truth`.
pub fn assert_within(what: &str, estimate: (f64, f64), truth: f64, k: f64) {
    let (m, se) = estimate;
    assert!(
        (m - truth).abs() <= k * se,
        "{what}: estimate {m} ± {se} (MCSE) is {:.2} MCSE from the truth {truth}",
        (m - truth).abs() / se
    );
}
