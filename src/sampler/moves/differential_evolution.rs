//! Differential evolution.

use rand::Rng;
use rand_distr::StandardNormal;

use super::{ActiveHalf, Correction, MoveSpec, ProposalMove, Proposed};
use crate::sampler::SamplerError;

/// Differential evolution (ter Braak 2006; emcee's `DEMove`): a step along the difference of
/// two complement walkers.
///
/// # Formula
/// `Y = X + γ (X_j − X_k)` with `j ≠ k` from the complement and
/// `γ = γ₀ (1 + σ N(0, 1))`; `γ₀ = 2.38 / √(2 ndim)` unless given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DifferentialEvolution {
    gamma: Option<f64>,
    sigma: f64,
}

impl DifferentialEvolution {
    /// Differential evolution with `γ₀ = gamma` (`None` for `2.38 / √(2 ndim)`) and relative
    /// jitter `sigma` of γ.
    ///
    /// # Errors
    /// [`SamplerError::InvalidMove`] unless `gamma` is finite and > 0 and `sigma` finite
    /// and ≥ 0.
    pub fn new(gamma: Option<f64>, sigma: f64) -> Result<Self, SamplerError> {
        let bad = |detail: String| Err(SamplerError::InvalidMove { detail });
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
        Ok(Self { gamma, sigma })
    }

    /// The move a spec of kind `differential_evolution` records.
    pub(super) fn from_spec(spec: &MoveSpec) -> Result<Self, SamplerError> {
        let spec = spec.only(&["gamma", "sigma"])?;
        Self::new(
            spec.number("gamma")?,
            spec.required("sigma", MoveSpec::number)?,
        )
    }
}

impl Default for DifferentialEvolution {
    /// emcee's defaults: `γ₀ = 2.38/√(2 ndim)`, `σ = 1e-5`.
    fn default() -> Self {
        Self {
            gamma: None,
            sigma: 1e-5,
        }
    }
}

impl ProposalMove for DifferentialEvolution {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new("differential_evolution")
            .with("gamma", self.gamma)
            .with("sigma", self.sigma)
    }

    fn min_complement(&self, _dim: usize) -> usize {
        2
    }

    fn propose(&self, half: ActiveHalf<'_>) -> Proposed {
        let ndim = half.dim();
        let g0 = self
            .gamma
            .unwrap_or_else(|| 2.38 / (2.0 * ndim as f64).sqrt());
        let (sigma, complement) = (self.sigma, half.complement());
        half.propose_each(|walker, rng, out| {
            let (a, b) = complement.pick_two(rng);
            let n: f64 = rng.sample(StandardNormal);
            let g = g0 * (1.0 + sigma * n);
            for (((o, &xi), &ai), &bi) in out.iter_mut().zip(walker.x).zip(a).zip(b) {
                *o = xi + g * (ai - bi);
            }
            Correction::SYMMETRIC
        })
    }
}
