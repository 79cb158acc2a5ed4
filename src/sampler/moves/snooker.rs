//! The differential-evolution snooker update.

use super::complement::distinct;
use super::{ActiveHalf, Correction, MoveSpec, ProposalMove, Proposed};
use crate::sampler::SamplerError;

/// Differential-evolution snooker update (ter Braak & Vrugt 2008; emcee's `DESnookerMove`): a
/// step along the line from a complement walker `Z` through the walker, as long as the
/// difference of two more complement walkers projected on that line. It reaches along curved
/// and elongated regions where a straight difference move stalls. Not affine-invariant (the
/// projection is Euclidean); it needs three complement walkers.
///
/// # Formula
/// `Y = Z + (1 + γ p)(X − Z)`, `p = (X − Z)·(Z₁ − Z₂) / |X − Z|²` with `Z, Z₁, Z₂` distinct
/// complement walkers (so the step along the line is `γ e·(Z₁ − Z₂)`, `e` the line's unit
/// vector, symmetric in `Z₁ ↔ Z₂`); the log acceptance ratio gains
/// `(ndim − 1) ln |1 + γ p|`, the Jacobian of a move along a line through `Z`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Snooker {
    gamma: f64,
}

impl Snooker {
    /// The snooker update with step factor `gamma`.
    ///
    /// # Errors
    /// [`SamplerError::InvalidMove`] unless `gamma` is finite and > 0.
    pub fn new(gamma: f64) -> Result<Self, SamplerError> {
        if !(gamma.is_finite() && gamma > 0.0) {
            return Err(SamplerError::InvalidMove {
                detail: format!("snooker gamma = {gamma} must be finite and > 0"),
            });
        }
        Ok(Self { gamma })
    }

    /// The move a spec of kind `snooker` records.
    pub(super) fn from_spec(spec: &MoveSpec) -> Result<Self, SamplerError> {
        Self::new(spec.only(&["gamma"])?.required("gamma", MoveSpec::number)?)
    }
}

impl Default for Snooker {
    /// emcee's `γ = 1.7` (ter Braak & Vrugt draw it from U(1.2, 2.2)).
    fn default() -> Self {
        Self { gamma: 1.7 }
    }
}

impl ProposalMove for Snooker {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new("snooker").with("gamma", self.gamma)
    }

    fn min_complement(&self, _dim: usize) -> usize {
        3
    }

    fn propose(&self, half: ActiveHalf<'_>) -> Proposed {
        let (gamma, complement) = (self.gamma, half.complement());
        let n = half.dim() as u64 - 1;
        half.propose_each(|walker, rng, out| {
            let [z, z1, z2] = distinct::<3>(rng, complement.len()).map(|k| complement.walker(k));
            let x = walker.x;
            let (mut dot, mut norm2) = (0.0, 0.0);
            for ((&xi, &zi), (&ai, &bi)) in x.iter().zip(z).zip(z1.iter().zip(z2)) {
                dot += (xi - zi) * (ai - bi);
                norm2 += (xi - zi) * (xi - zi);
            }
            if norm2 == 0.0 {
                // The walker sits on Z: no line to move along.
                out.copy_from_slice(x);
                return Correction::SYMMETRIC;
            }
            let stretch = 1.0 + gamma * dot / norm2;
            for ((o, &xi), &zi) in out.iter_mut().zip(x).zip(z) {
                *o = zi + stretch * (xi - zi);
            }
            Correction::power(stretch.abs(), n)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::propose_one;
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn the_snooker_step_moves_along_the_line_through_z_with_its_jacobian() {
        // Complement of three walkers in 3-D: every draw uses all three, in some order.
        let positions = [0.0, 0.0, 0.0, 1.0, 2.0, 0.5, -1.0, 0.5, 2.0];
        let x = [0.4, -0.7, 1.1];
        let mv = Snooker::default();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let mut seen = std::collections::BTreeSet::new();
        for _ in 0..60 {
            let (y, c) = propose_one(&mv, &x, &positions, &mut rng);
            // Which walker was Z: the one for which Y − Z is parallel to X − Z with the
            // snooker's stretch for one of the other two orderings.
            let row = |i: usize| &positions[3 * i..3 * i + 3];
            let found = (0..3).find_map(|k| {
                let (zk, a, b) = (row(k), row((k + 1) % 3), row((k + 2) % 3));
                let d: Vec<f64> = (0..3).map(|i| x[i] - zk[i]).collect();
                let n2: f64 = d.iter().map(|v| v * v).sum();
                [1.0, -1.0].into_iter().find_map(|sign| {
                    let dot: f64 = (0..3).map(|i| d[i] * sign * (a[i] - b[i])).sum();
                    let s = 1.0 + 1.7 * dot / n2;
                    let expect: Vec<f64> = (0..3).map(|i| zk[i] + s * d[i]).collect();
                    (0..3)
                        .all(|i| (expect[i] - y[i]).abs() < 1e-12)
                        .then_some((k, s))
                })
            });
            let (k, s) = found.expect("the proposal lies on a snooker line");
            seen.insert(k);
            // (ndim − 1) ln |1 + γ p| with ndim = 3.
            assert!((c.factor - s * s).abs() < 1e-12 * (s * s).max(1.0));
        }
        assert_eq!(seen.len(), 3, "every complement walker serves as Z");
        assert!(crate::sampler::Move::snooker()
            .validate_complement(2, 3)
            .unwrap_err()
            .to_string()
            .contains("at least 3"));
    }
}
