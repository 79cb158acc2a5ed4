//! The independence proposal from a kernel density estimate of the complement.

use rand::Rng;

use super::complement::ComplementFit;
use super::{ActiveHalf, Correction, MoveSpec, ProposalMove, Proposed, WalkerRng};
use crate::sampler::SamplerError;

/// Independence proposal from a Gaussian kernel density estimate of the complement (emcee's
/// `KDEMove`): pick a complement walker, add a Gaussian step with the complement's sample
/// covariance scaled by `h²`. Follows non-Gaussian shapes (skewed, curved, several modes)
/// that a single Gaussian fitted to the complement misses; affine-invariant, valid because
/// the complement stays fixed during a half-step; needs more complement walkers than
/// dimensions.
///
/// # Formula
/// `Y = X_j + h L Z`, `X_j` uniform over the complement, `L Lᵀ = Ĉ`, `Z ~ N(0, I)`;
/// `q(y) ∝ Σ_j exp(−|L⁻¹(y − X_j)|² / 2h²)`; the log acceptance ratio gains
/// `ln q(X) − ln q(Y)`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Kde {
    bandwidth: Option<f64>,
}

impl Kde {
    /// The KDE proposal with bandwidth `h` (`None` for Scott's factor `n^(−1/(ndim+4))`, `n`
    /// the complement's size: scipy's `gaussian_kde` default, which emcee uses).
    ///
    /// # Errors
    /// [`SamplerError::InvalidMove`] unless `h` is finite and > 0.
    pub fn new(bandwidth: Option<f64>) -> Result<Self, SamplerError> {
        match bandwidth {
            Some(h) if !(h.is_finite() && h > 0.0) => Err(SamplerError::InvalidMove {
                detail: format!("KDE bandwidth {h} must be finite and > 0"),
            }),
            _ => Ok(Self { bandwidth }),
        }
    }

    /// The move a spec of kind `kde` records.
    pub(super) fn from_spec(spec: &MoveSpec) -> Result<Self, SamplerError> {
        Self::new(spec.only(&["bandwidth"])?.number("bandwidth")?)
    }
}

impl ProposalMove for Kde {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new("kde").with("bandwidth", self.bandwidth)
    }

    fn min_complement(&self, dim: usize) -> usize {
        // A full-rank sample covariance needs dim + 1 points.
        dim + 1
    }

    fn propose(&self, half: ActiveHalf<'_>) -> Proposed {
        let c = half.complement();
        match KdeFit::new(c.rows, c.walkers, c.dim, self.bandwidth) {
            Some(mut fit) => half.propose_each(|walker, rng, out| {
                Correction::from_log(fit.propose(walker.x, rng, out))
            }),
            // The complement lies in a subspace.
            None => half.stay(),
        }
    }
}

/// The Gaussian kernel density estimate of the complement.
#[derive(Debug, Clone)]
pub(crate) struct KdeFit {
    /// The kernel: zero mean, covariance `h² Ĉ`.
    kernel: ComplementFit,
    /// The complement's walkers (the kernels' centres), `ndim` per row.
    centres: Vec<f64>,
    /// The centres whitened by the kernel's Cholesky factor, `ndim` per row.
    white: Vec<f64>,
    /// Scratch for a whitened point's squared distances to the centres.
    r2: Vec<f64>,
}

impl KdeFit {
    /// Fits the complement's walkers (`positions` of all walkers, `ndim` per row) with
    /// bandwidth `h` (`None`: Scott's factor); `None` when their covariance is not positive
    /// definite.
    pub fn new(
        positions: &[f64],
        complement: &[usize],
        ndim: usize,
        bandwidth: Option<f64>,
    ) -> Option<Self> {
        let n = complement.len();
        if n <= ndim {
            return None;
        }
        let h = bandwidth.unwrap_or_else(|| (n as f64).powf(-1.0 / (ndim as f64 + 4.0)));
        let view = super::Complement {
            rows: positions,
            dim: ndim,
            walkers: complement,
        };
        let (_, cov) = view.moments();
        let mut kernel = ComplementFit::from_moments(vec![0.0; ndim], cov * (h * h), None)?;
        let mut centres = Vec::with_capacity(n * ndim);
        let mut white = Vec::with_capacity(n * ndim);
        for c in view.iter() {
            centres.extend_from_slice(c);
            kernel.whiten(c);
            white.extend_from_slice(&kernel.u);
        }
        Some(Self {
            kernel,
            centres,
            white,
            r2: vec![0.0; n],
        })
    }

    /// ln q(x) up to a constant shared by every point.
    fn log_q(&mut self, x: &[f64]) -> f64 {
        self.kernel.whiten(x);
        let u = &self.kernel.u;
        for (r, w) in self.r2.iter_mut().zip(self.white.chunks_exact(u.len())) {
            *r = u.iter().zip(w).map(|(a, b)| (a - b) * (a - b)).sum();
        }
        // log-sum-exp of −r²/2 about the nearest centre.
        let nearest = self.r2.iter().copied().fold(f64::INFINITY, f64::min);
        let sum: f64 = self.r2.iter().map(|r| (-0.5 * (r - nearest)).exp()).sum();
        -0.5 * nearest + sum.ln()
    }

    /// Writes a proposal into `out` and returns ln q(x) − ln q(out).
    pub fn propose(&mut self, x: &[f64], rng: &mut WalkerRng, out: &mut [f64]) -> f64 {
        let ndim = x.len();
        let j = rng.random_range(0..self.r2.len());
        self.kernel.draw(rng, out);
        for (o, &c) in out.iter_mut().zip(&self.centres[j * ndim..(j + 1) * ndim]) {
            *o += c;
        }
        self.log_q(x) - self.log_q(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn the_kde_correction_is_the_ratio_of_mixture_densities() {
        // The same complement, covariance 1/3·I; bandwidth 0.5 gives kernels of variance 1/12.
        let positions = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0];
        let mut fit = KdeFit::new(&positions, &[0, 1, 2, 3], 2, Some(0.5)).unwrap();
        // ln Σ_j exp(e_j) written out about the largest exponent, in the original coordinates.
        let log_q = |p: &[f64]| {
            let e: Vec<f64> = positions
                .chunks(2)
                .map(|c| -6.0 * ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)))
                .collect();
            let top = e.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            top + e.iter().map(|v| (v - top).exp()).sum::<f64>().ln()
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let x = [0.3, 0.9];
        let mut y = [0.0; 2];
        for _ in 0..20 {
            let log_ratio = fit.propose(&x, &mut rng, &mut y);
            assert!((log_ratio - (log_q(&x) - log_q(&y))).abs() < 1e-12);
        }
        // Far from every centre the log-sum-exp must not underflow.
        let far = [40.0, -30.0];
        assert!(fit.log_q(&far).is_finite());
        assert!((fit.log_q(&far) - log_q(&far)).abs() < 1e-9 * log_q(&far).abs());
        // Scott's factor by default: n^(−1/(d+4)) = 4^(−1/6).
        let scott = KdeFit::new(&positions, &[0, 1, 2, 3], 2, None).unwrap();
        let h2 = 4f64.powf(-1.0 / 3.0);
        assert!((scott.kernel.chol[0] - (h2 / 3.0).sqrt()).abs() < 1e-14);
    }
}
