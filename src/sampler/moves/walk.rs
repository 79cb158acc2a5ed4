//! The walk move.

use rand::Rng;
use rand_distr::StandardNormal;

use super::{ActiveHalf, Correction, MoveSpec, ProposalMove, Proposed};
use crate::sampler::SamplerError;

/// Walk move (emcee's `WalkMove`): a Gaussian step centred on the walker whose covariance is
/// the sample covariance of the complement, or of a random subset of it.
///
/// # Formula
/// `Y = X + (s − 1)^{-1/2} Σ_j (Z_j − Z̄) X_j` over `s` complement walkers, `Z_j ~ N(0, 1)`:
/// exactly `N(X, Ĉ)` with `Ĉ` their unbiased sample covariance, without factorising `Ĉ`.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Walk {
    subset: Option<usize>,
}

impl Walk {
    /// The walk move over subsets of `subset` complement walkers (`None`: the whole
    /// complement, the default).
    ///
    /// # Errors
    /// [`SamplerError::InvalidMove`] when `subset` is below 2.
    pub fn new(subset: Option<usize>) -> Result<Self, SamplerError> {
        match subset {
            Some(s) if s < 2 => Err(SamplerError::InvalidMove {
                detail: format!("walk subset size {s} must be at least 2"),
            }),
            _ => Ok(Self { subset }),
        }
    }

    /// The move a spec of kind `walk` records.
    pub(super) fn from_spec(spec: &MoveSpec) -> Result<Self, SamplerError> {
        Self::new(spec.only(&["subset"])?.count("subset")?)
    }
}

impl ProposalMove for Walk {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new("walk").with("subset", self.subset)
    }

    fn min_complement(&self, _dim: usize) -> usize {
        self.subset.unwrap_or(2).max(2)
    }

    fn propose(&self, half: ActiveHalf<'_>) -> Proposed {
        let complement = half.complement();
        let nc = complement.len();
        let s = self.subset.unwrap_or(nc).min(nc);
        let scale = 1.0 / (s as f64 - 1.0).sqrt();
        let (mut idx, mut z) = (vec![0; nc], vec![0.0; s]);
        half.propose_each(|walker, rng, out| {
            for (k, i) in idx.iter_mut().enumerate() {
                *i = k;
            }
            if s < nc {
                // Partial Fisher–Yates: the first `s` entries become a uniform subset.
                for k in 0..s {
                    let r = rng.random_range(k..nc);
                    idx.swap(k, r);
                }
            }
            for zj in z.iter_mut() {
                *zj = rng.sample(StandardNormal);
            }
            let mean = z.iter().sum::<f64>() / s as f64;
            let x = walker.x;
            out.copy_from_slice(x);
            for (&zj, &i) in z.iter().zip(&idx) {
                let c = scale * (zj - mean);
                // Centred on `x` (allowed because Σ (Z_j − Z̄) = 0) to avoid cancellation
                // when the ensemble sits far from the origin.
                for ((o, &xj), &xi) in out.iter_mut().zip(complement.walker(i)).zip(x) {
                    *o += c * (xj - xi);
                }
            }
            Correction::SYMMETRIC
        })
    }
}
