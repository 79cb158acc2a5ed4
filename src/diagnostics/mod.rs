//! Convergence diagnostics: autocorrelation time, R-hat, ESS, MCSE and credible intervals.
//!
//! Pure functions over draws already in memory: no printing, no randomness, no knowledge of
//! friction or of how the draws were produced.
//!
//! - [`autocorr`]: the integrated autocorrelation time: emcee's, and the pooled form over
//!   walkers that the sampler (burn-in, thinning, stopping) and the summary use.
//! - [`arviz`]: ArviZ's rank-normalised split R-hat, bulk/tail/mean ESS, MCSE, HDI and
//!   quantiles over independent chains, numerically identical to arviz 0.23.
//! - [`summary`]: the summary of an ensemble run: R-hat *between independent ensembles*, ESS
//!   over walkers, intervals over all draws (the design is argued in its documentation); one
//!   engine, in memory for a short run and through working files (an external sort) for a
//!   long one, with the same numbers to the bit.
//! - [`loo`]: PSIS-LOO cross-validation from pointwise log-likelihoods, and the comparison of
//!   models by it (elpd differences with standard errors, stacking weights), as ArviZ's `loo`
//!   and `compare`.
//!
//! Inputs are validated once, at the entry of each function: empty, ragged, too short or
//! non-finite draws give a [`DiagnosticsError`] naming the chain and index at fault.
//!
//! ```
//! use slipbayes::diagnostics::{integrated_time, summarize, EnsembleDraws, DEFAULT_WINDOW_FACTOR};
//!
//! // 2 ensembles x 3 walkers x 100 steps of one parameter, walker-major.
//! let draws = EnsembleDraws::from_fn(2, 3, 100, |e, w, t| {
//!     (t as f64 / 10.0 + w as f64).sin() + 0.1 * e as f64
//! })?;
//! let s = summarize(&draws, 0.94, 0.94)?;
//! assert!(s.r_hat.is_some() && s.ess_bulk > 0.0 && s.hdi_low <= s.median);
//!
//! // The sampler's view: emcee's tau over the walkers of one ensemble.
//! let walkers: Vec<&[f64]> = (0..3).map(|w| draws.series(0, w)).collect();
//! let tau = integrated_time(&walkers, DEFAULT_WINDOW_FACTOR)?;
//! assert!(tau.tau > 0.0);
//! # Ok::<(), slipbayes::diagnostics::DiagnosticsError>(())
//! ```
pub mod arviz;
pub mod autocorr;
mod error;
pub mod loo;
pub mod summary;
pub mod verdict;
mod walkers;

pub use arviz::{
    equal_tailed_interval, ess_bulk, ess_mean, ess_tail, hdi, mcse_mean, mcse_quantile, mcse_sd,
    quantile, rhat, MIN_CHAINS_RHAT, MIN_DRAWS, TAIL_PROBS,
};
pub(crate) use arviz::{pointwise_quantiles, rhat_by};
pub use autocorr::{
    integrated_time, mean_acf, pooled_integrated_time, tau_trusted_length, AutocorrTime,
    DEFAULT_WINDOW_FACTOR, MIN_STEPS_AUTOCORR, TAU_MIN_FACTOR, TAU_REFERENCE_WALKERS,
};
pub use error::DiagnosticsError;
pub use loo::{compare, psis_loo, Compared, Loo, LooError, MIN_LOO_DRAWS};
pub use summary::{
    ensemble_rhat, summarize, summarize_draws, DrawsWriter, EnsembleDraws, Limits, Summary,
    WalkerDraws, Workspace,
};
pub(crate) use verdict::stuck_walkers;
pub use verdict::{
    problem_lines, quantity_problems, EssKind, Problem, ESS_MIN, RHAT_MAX, TAU_FACTOR,
};
pub(crate) use walkers::blockwise_condition_number;
pub use walkers::WALKER_CONDITION_LIMIT;
