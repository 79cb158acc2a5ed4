//! Optimisers and the Laplace approximation: finding the mode of a log-density, its curvature,
//! and walkers drawn around it, so that a sampler starts close to the posterior.
//!
//! - [`mod@lbfgs`]: limited-memory BFGS on central finite-difference gradients.
//! - [`mod@nelder_mead`]: the simplex method, for functions that refuse some points.
//! - [`by_blocks`](ArrowheadFactor): the same for a density of many independent blocks, at
//!   a cost linear in their number.
//! - [`laplace`]: the mode ([`find_mode`]), the covariance of the Laplace approximation
//!   ([`laplace_covariance`]) and walkers drawn from it ([`laplace_walkers`],
//!   [`initial_around_optimum`]).
//!
//! Like the sampler, this part sees a model only through [`crate::density::LogDensity`] (or
//! a plain function of `&[f64]`) and knows nothing of friction.

mod by_blocks;
pub mod laplace;
pub mod lbfgs;
pub mod nelder_mead;
mod probe;

pub use by_blocks::{ArrowheadFactor, BY_BLOCKS_FROM};
pub use laplace::{
    find_mode, initial_around_optimum, laplace_covariance, laplace_walkers, Covariance, Optimum,
    SearchMap, SearchStart, Start, FALLBACK_SPREAD, MAX_DRAW_ATTEMPTS,
};
pub use lbfgs::{lbfgs, LbfgsOptions, Objective};
pub use nelder_mead::{nelder_mead, NelderMeadOptions};

/// Why no mode, or no walkers around it, could be found; each names the point at fault.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum OptimizeError {
    /// The start does not have the density's dimension.
    #[error("the start has {got} coordinates, the density {expected}")]
    Shape {
        /// The density's dimension.
        expected: usize,
        /// The start's length.
        got: usize,
    },
    /// The density refuses the start.
    #[error(
        "the log-density at the start {} is not finite; start inside the support",
        shown(start)
    )]
    StartNotFinite {
        /// The start.
        start: Vec<f64>,
    },
    /// The search ended where the density is not finite.
    #[error("Nelder–Mead ended at {at:?} with log-density {log_density}")]
    NoFiniteMode {
        /// Where the search ended.
        at: Vec<f64>,
        /// The log-density there.
        log_density: f64,
    },
    /// No walker could be drawn inside the support around the mode.
    #[error(
        "could not draw walker {walker} of ensemble {ensemble} inside the support around the mode \
         {mode:?} in {attempts} attempts"
    )]
    NoWalkerInSupport {
        /// Ensemble index.
        ensemble: usize,
        /// Walker index.
        walker: usize,
        /// The mode.
        mode: Vec<f64>,
        /// Draws tried.
        attempts: usize,
    },
    /// The walkers drawn around the mode do not span the space.
    #[error(
        "walkers drawn around the mode {mode:?} are degenerate (condition number {condition:e})"
    )]
    DegenerateWalkers {
        /// The mode.
        mode: Vec<f64>,
        /// Condition number of the centred walker matrix.
        condition: f64,
    },
}

impl OptimizeError {
    /// What went wrong, in words, without the points (for a caller that names them itself).
    pub fn summary(&self) -> &'static str {
        match self {
            Self::Shape { .. } => "the start has the wrong number of coordinates",
            Self::StartNotFinite { .. } => "the log-density is not finite at the start",
            Self::NoFiniteMode { .. } => "the mode search ended where the density is not finite",
            Self::NoWalkerInSupport { .. } => {
                "no walker could be drawn inside the support around the mode"
            }
            Self::DegenerateWalkers { .. } => {
                "the walkers drawn around the mode coincide: the posterior there is narrower \
                 than its coordinates can resolve"
            }
        }
    }
}

/// A point for a message: every coordinate of a small one, the first few of a large one.
fn shown(x: &[f64]) -> String {
    const SHOWN: usize = 8;
    if x.len() <= SHOWN {
        format!("{x:?}")
    } else {
        format!("{:?} … ({} coordinates)", &x[..SHOWN], x.len())
    }
}
