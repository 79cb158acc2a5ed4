//! Shared targets and Monte-Carlo error estimates for the sampler tests.
#![allow(dead_code)]

use nalgebra::DMatrix;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::StandardNormal;
use slipbayes::sampler::{LogDensity, LogDensityError, MemoryChain};

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

    /// Strongly correlated: unit variances, correlation `rho` between neighbours' chain.
    pub fn correlated(ndim: usize, rho: f64) -> Self {
        Self::new(DMatrix::from_fn(ndim, ndim, |i, j| {
            rho.powi((i as i32 - j as i32).abs()) * (1.0 + i as f64)
        }))
    }
}

impl LogDensity for Gaussian {
    fn dim(&self) -> usize {
        self.cov.nrows()
    }
    fn log_density(&self, x: &[f64], _d: &mut [f64]) -> Result<f64, LogDensityError> {
        let n = x.len();
        let mut q = 0.0;
        for i in 0..n {
            let mut row = 0.0;
            for j in 0..n {
                row += self.precision[(i, j)] * x[j];
            }
            q += x[i] * row;
        }
        Ok(-0.5 * q)
    }
}

/// Mean of `g` over the draws and its Monte-Carlo standard error by batch means.
///
/// The per-step average over the walkers of one ensemble is a single time series; it is cut
/// into `batches` batches per ensemble after `burn` steps, and the batch means of all
/// (independent) ensembles are pooled. Batches much longer than τ make the batch means
/// nearly independent, so their spread gives the error of the overall mean.
pub fn batch_means(
    chains: &[MemoryChain],
    burn: usize,
    batches: usize,
    g: impl Fn(&[f64]) -> f64,
) -> (f64, f64) {
    let mut means = Vec::new();
    for c in chains {
        let steps = c.steps.len();
        let stride = c.walkers * c.ndim;
        let series: Vec<f64> = (burn..steps)
            .map(|s| {
                (0..c.walkers)
                    .map(|w| g(&c.positions[s * stride + w * c.ndim..s * stride + (w + 1) * c.ndim]))
                    .sum::<f64>()
                    / c.walkers as f64
            })
            .collect();
        let len = series.len() / batches;
        for b in 0..batches {
            means.push(series[b * len..(b + 1) * len].iter().sum::<f64>() / len as f64);
        }
    }
    let n = means.len() as f64;
    let mean = means.iter().sum::<f64>() / n;
    let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
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
