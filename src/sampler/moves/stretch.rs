//! The Goodman–Weare stretch move.

use rand::Rng;

use super::{ActiveHalf, Correction, MoveSpec, ProposalMove, Proposed};
use crate::sampler::SamplerError;

/// Goodman–Weare stretch move (emcee's `StretchMove`): along the line through the walker and
/// a complement walker.
///
/// # Formula
/// `Y = X_j + z (X − X_j)`, `X_j` from the complement, `z = ((a−1)u + 1)² / a`,
/// `u ~ U(0, 1)` (so `g(z) ∝ 1/√z` on `[1/a, a]`); the log acceptance ratio gains
/// `(ndim − 1) ln z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stretch {
    a: f64,
}

impl Stretch {
    /// The stretch move with scale `a`.
    ///
    /// # Errors
    /// [`SamplerError::InvalidMove`] unless `a` is finite and > 1.
    pub fn new(a: f64) -> Result<Self, SamplerError> {
        if !(a.is_finite() && a > 1.0) {
            return Err(SamplerError::InvalidMove {
                detail: format!("stretch scale a = {a} must be finite and > 1"),
            });
        }
        Ok(Self { a })
    }

    /// The scale `a`.
    pub fn a(&self) -> f64 {
        self.a
    }

    /// The move a spec of kind `stretch` records.
    pub(super) fn from_spec(spec: &MoveSpec) -> Result<Self, SamplerError> {
        Self::new(spec.only(&["a"])?.required("a", MoveSpec::number)?)
    }
}

impl Default for Stretch {
    /// `a = 2`, the usual choice.
    fn default() -> Self {
        Self { a: 2.0 }
    }
}

impl ProposalMove for Stretch {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new("stretch").with("a", self.a)
    }

    fn min_complement(&self, _dim: usize) -> usize {
        1
    }

    fn propose(&self, half: ActiveHalf<'_>) -> Proposed {
        let (a, complement) = (self.a, half.complement());
        let n = half.dim() as u64 - 1;
        half.propose_each(|walker, rng, out| {
            let j = complement.pick(rng);
            let u: f64 = rng.random();
            let z = ((a - 1.0) * u + 1.0).powi(2) / a;
            for ((o, &xi), &xj) in out.iter_mut().zip(walker.x).zip(j) {
                *o = xj + z * (xi - xj);
            }
            // z^(ndim−1) by multiplication: the acceptance test then needs no logarithm.
            Correction::power(z, n)
        })
    }
}
