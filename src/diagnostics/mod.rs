//! Convergence diagnostics: autocorrelation time, R-hat, ESS, MCSE and credible intervals.
//!
//! Pure functions over draws already in memory: no printing, no randomness, no knowledge of
//! friction or of how the draws were produced.
//!
//! - [`autocorr`]: emcee's integrated autocorrelation time (what the sampler uses for burn-in,
//!   thinning and stopping).
pub mod autocorr;
mod error;

pub use autocorr::{
    integrated_time, mean_acf, AutocorrTime, DEFAULT_WINDOW_FACTOR, MIN_STEPS_AUTOCORR,
    TAU_RELIABLE_FACTOR,
};
pub use error::DiagnosticsError;
