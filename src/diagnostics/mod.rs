//! Convergence diagnostics: autocorrelation time, R-hat, ESS, MCSE and credible intervals.
//!
//! Pure functions over draws already in memory: no printing, no randomness, no knowledge of
//! friction or of how the draws were produced.
//!
//! - [`autocorr`]: emcee's integrated autocorrelation time (what the sampler uses for burn-in,
//!   thinning and stopping).
//! - [`arviz`]: ArviZ's rank-normalised split R-hat, bulk/tail/mean ESS, MCSE, HDI and
//!   quantiles over independent chains, numerically identical to arviz 0.23.
pub mod arviz;
pub mod autocorr;
mod error;
mod special;

pub use arviz::{
    equal_tailed_interval, ess_bulk, ess_mean, ess_tail, hdi, mcse_mean, mcse_quantile, mcse_sd,
    quantile, rhat, MIN_CHAINS_RHAT, MIN_DRAWS, TAIL_PROBS,
};
pub use autocorr::{
    integrated_time, mean_acf, AutocorrTime, DEFAULT_WINDOW_FACTOR, MIN_STEPS_AUTOCORR,
    TAU_RELIABLE_FACTOR,
};
pub use error::DiagnosticsError;
