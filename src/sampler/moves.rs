//! Proposal moves of the affine-invariant ensemble sampler.
//!
//! Every move proposes a new position for one walker of the active half from the positions
//! of the complementary half only (which stays fixed while the active half is updated), so the
//! red-blue update keeps the target invariant. The proposals are affine-invariant and need no
//! tuning beyond their defaults.

use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::error::SamplerError;

/// A proposal move; mix several with weights in [`SamplerConfig`](super::SamplerConfig).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Move {
    /// Goodman–Weare stretch move.
    ///
    /// # Formula
    /// `Y = X_j + z (X − X_j)`, `X_j` from the complement, `z = ((a−1)u + 1)² / a`,
    /// `u ~ U(0, 1)` (so `g(z) ∝ 1/√z` on `[1/a, a]`); the log acceptance ratio gains
    /// `(ndim − 1) ln z`.
    Stretch {
        /// Scale `a > 1`; 2 is the usual choice.
        a: f64,
    },
    /// Differential evolution (ter Braak 2006; emcee's `DEMove`).
    ///
    /// # Formula
    /// `Y = X + γ (X_j − X_k)` with `j ≠ k` from the complement and
    /// `γ = γ₀ (1 + σ N(0, 1))`; `γ₀ = 2.38 / √(2 ndim)` unless given.
    DifferentialEvolution {
        /// `γ₀`; `None` for `2.38 / √(2 ndim)`.
        gamma: Option<f64>,
        /// Relative jitter `σ` of `γ` (emcee: 1e-5).
        sigma: f64,
    },
    /// Walk move (emcee's `WalkMove`): a Gaussian step centred on the walker whose covariance
    /// is the sample covariance of the complement, or of a random subset of it.
    ///
    /// # Formula
    /// `Y = X + (s − 1)^{-1/2} Σ_j (Z_j − Z̄) X_j` over `s` complement walkers, `Z_j ~ N(0, 1)`:
    /// exactly `N(X, Ĉ)` with `Ĉ` their unbiased sample covariance, without factorising `Ĉ`.
    Walk {
        /// Subset size `s ≥ 2`; `None` for the whole complement.
        subset: Option<usize>,
    },
}

impl Move {
    /// Stretch move with `a = 2`.
    pub fn stretch() -> Self {
        Self::Stretch { a: 2.0 }
    }

    /// Differential evolution with emcee's defaults (`γ₀ = 2.38/√(2 ndim)`, `σ = 1e-5`).
    pub fn differential_evolution() -> Self {
        Self::DifferentialEvolution {
            gamma: None,
            sigma: 1e-5,
        }
    }

    /// Walk move over the whole complement.
    pub fn walk() -> Self {
        Self::Walk { subset: None }
    }

    /// Checks the move's own parameters.
    pub(crate) fn validate(&self) -> Result<(), SamplerError> {
        let bad = |what: String| Err(SamplerError::InvalidMove { detail: what });
        match *self {
            Self::Stretch { a } if !(a.is_finite() && a > 1.0) => {
                bad(format!("stretch scale a = {a} must be finite and > 1"))
            }
            Self::DifferentialEvolution { gamma, sigma } => {
                if let Some(g) = gamma {
                    if !(g.is_finite() && g > 0.0) {
                        return bad(format!(
                            "differential-evolution gamma = {g} must be finite and > 0"
                        ));
                    }
                }
                if !(sigma.is_finite() && sigma >= 0.0) {
                    return bad(format!(
                        "differential-evolution sigma = {sigma} must be finite and >= 0"
                    ));
                }
                Ok(())
            }
            Self::Walk { subset: Some(s) } if s < 2 => {
                bad(format!("walk subset size {s} must be at least 2"))
            }
            _ => Ok(()),
        }
    }

    /// Checks that the complement (half the ensemble) is large enough for this move.
    pub(crate) fn validate_complement(&self, complement: usize) -> Result<(), SamplerError> {
        let need = match *self {
            Self::Stretch { .. } => 1,
            Self::DifferentialEvolution { .. } => 2,
            Self::Walk { subset } => subset.unwrap_or(2).max(2),
        };
        if complement < need {
            return Err(SamplerError::InvalidMove {
                detail: format!(
                    "{self:?} needs at least {need} walkers in each half, the ensemble has {complement}"
                ),
            });
        }
        Ok(())
    }

    /// Writes a proposal for the walker at `x` into `out` and returns the log of the
    /// proposal's correction factor (added to the log acceptance ratio).
    ///
    /// `positions` holds all walkers (`walkers × ndim`), `complement` the indices of the
    /// complementary half; `idx` and `z` are scratch of at least `complement.len()`.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn propose<R: Rng>(
        &self,
        x: &[f64],
        positions: &[f64],
        complement: &[usize],
        rng: &mut R,
        out: &mut [f64],
        idx: &mut [usize],
        z: &mut [f64],
    ) -> f64 {
        let ndim = x.len();
        let row = |i: usize| &positions[i * ndim..(i + 1) * ndim];
        let nc = complement.len();
        match *self {
            Self::Stretch { a } => {
                let j = row(complement[rng.random_range(0..nc)]);
                let u: f64 = rng.random();
                let zz = ((a - 1.0) * u + 1.0).powi(2) / a;
                for ((o, &xi), &xj) in out.iter_mut().zip(x).zip(j) {
                    *o = xj + zz * (xi - xj);
                }
                (ndim as f64 - 1.0) * zz.ln()
            }
            Self::DifferentialEvolution { gamma, sigma } => {
                let g0 = gamma.unwrap_or_else(|| 2.38 / (2.0 * ndim as f64).sqrt());
                let i1 = rng.random_range(0..nc);
                let mut i2 = rng.random_range(0..nc - 1);
                if i2 >= i1 {
                    i2 += 1;
                }
                let n: f64 = rng.sample(StandardNormal);
                let g = g0 * (1.0 + sigma * n);
                let (a, b) = (row(complement[i1]), row(complement[i2]));
                for (((o, &xi), &ai), &bi) in out.iter_mut().zip(x).zip(a).zip(b) {
                    *o = xi + g * (ai - bi);
                }
                0.0
            }
            Self::Walk { subset } => {
                let s = subset.unwrap_or(nc).min(nc);
                let idx = &mut idx[..nc];
                idx.copy_from_slice(complement);
                if s < nc {
                    // Partial Fisher–Yates: the first `s` entries become a uniform subset.
                    for k in 0..s {
                        let r = rng.random_range(k..nc);
                        idx.swap(k, r);
                    }
                }
                let z = &mut z[..s];
                for zj in z.iter_mut() {
                    *zj = rng.sample(StandardNormal);
                }
                let mean = z.iter().sum::<f64>() / s as f64;
                let scale = 1.0 / (s as f64 - 1.0).sqrt();
                out.copy_from_slice(x);
                for (&zj, &i) in z.iter().zip(idx.iter()) {
                    let c = scale * (zj - mean);
                    // Centred on `x` (allowed because Σ (Z_j − Z̄) = 0) to avoid cancellation
                    // when the ensemble sits far from the origin.
                    for ((o, &xj), &xi) in out.iter_mut().zip(row(i)).zip(x) {
                        *o += c * (xj - xi);
                    }
                }
                0.0
            }
        }
    }
}
