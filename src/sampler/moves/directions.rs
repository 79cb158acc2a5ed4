//! The slice move's directions: differences of two complement walkers, or draws from the
//! Gaussian fitted to the complement.

use std::sync::Arc;

use super::complement::ComplementFit;
use super::{Complement, DirectionDraw, MoveSpec, SliceDirection, WalkerRng};
use crate::sampler::SamplerError;

/// The kind of both directions' spec; `gaussian` tells them apart.
const KIND: &str = "slice";

/// zeus's differential direction: `η = μ (X_j − X_k)`, `j ≠ k` from the complement.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DifferentialDirection;

/// zeus's Gaussian direction: `η = μ √2 L Z` with `L Lᵀ = Ĉ` the complement's sample
/// covariance and `Z ~ N(0, I)`, the differential direction's covariance; differences of two
/// walkers where the complement has no full-rank covariance.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct GaussianDirection;

impl SliceDirection for DifferentialDirection {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new(KIND).with("gaussian", false)
    }

    fn min_complement(&self, _dim: usize) -> usize {
        2
    }

    fn fit(&self, _complement: Complement<'_>) -> Box<dyn DirectionDraw> {
        Box::new(Differences)
    }
}

impl SliceDirection for GaussianDirection {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new(KIND).with("gaussian", true)
    }

    fn min_complement(&self, _dim: usize) -> usize {
        // Two walkers for a difference, which it falls back to.
        2
    }

    fn fit(&self, complement: Complement<'_>) -> Box<dyn DirectionDraw> {
        let dim = complement.dim();
        let fit = (complement.len() > dim)
            .then(|| {
                let (_, cov) = complement.moments();
                ComplementFit::from_moments(vec![0.0; dim], cov, None)
            })
            .flatten();
        match fit {
            Some(fit) => Box::new(Gaussian(fit)),
            None => Box::new(Differences),
        }
    }
}

/// The slice move's directions a spec of kind `slice` records.
pub(super) fn from_spec(spec: &MoveSpec) -> Result<Arc<dyn SliceDirection>, SamplerError> {
    let gaussian = spec
        .only(&["gaussian"])?
        .required("gaussian", MoveSpec::flag)?;
    Ok(if gaussian {
        Arc::new(GaussianDirection)
    } else {
        Arc::new(DifferentialDirection)
    })
}

/// Differences of two complement walkers.
#[derive(Debug)]
struct Differences;

impl DirectionDraw for Differences {
    fn draw(&self, complement: Complement<'_>, mu: f64, rng: &mut WalkerRng, out: &mut [f64]) {
        let (a, b) = complement.pick_two(rng);
        for ((o, &ai), &bi) in out.iter_mut().zip(a).zip(b) {
            *o = mu * (ai - bi);
        }
    }
}

/// Draws from the complement's Gaussian, centred on zero.
#[derive(Debug)]
struct Gaussian(ComplementFit);

impl DirectionDraw for Gaussian {
    fn draw(&self, _complement: Complement<'_>, mu: f64, rng: &mut WalkerRng, out: &mut [f64]) {
        let mut z = vec![0.0; out.len()];
        self.0.draw_centred(rng, &mut z, out);
        // √2: the covariance of a difference of two walkers, so that one μ suits either
        // direction.
        let scale = mu * std::f64::consts::SQRT_2;
        for o in out.iter_mut() {
            *o *= scale;
        }
    }
}
