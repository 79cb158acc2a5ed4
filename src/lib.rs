//! slipbayes: Bayesian inference of how friction starts.
//!
//! The crate is layered so that each part knows only what it must:
//!
//! - [`special`]: the special functions, to (nearly) full double precision: the exponential
//!   integral Ei and its scaled forms, the incomplete gamma and beta functions, the normal
//!   quantile.
//! - [`law`]: the aging-rejuvenation friction law of Farain and Bonn, its elastic correction,
//!   the repeat-slide model and the static friction peak. Knows nothing of files or sampling.
//! - [`data`]: reading and writing data sets (`time_s,force_N` CSV) and their true values.
//! - [`simulate`]: synthetic data sets from known parameters.
//! - [`sampler`]: an affine-invariant ensemble MCMC sampler over any log-density. Knows nothing
//!   of friction.
//! - [`diagnostics`]: autocorrelation time, R-hat, ESS, MCSE and credible intervals.
//! - [`storage`]: chains streamed to Parquet and checkpoints for resuming (feature `parquet`).
//! - [`fit`]: a whole fit over any log-density: sample into a run directory (resumable),
//!   summarise, write `summary.json` and `summary.csv` (feature `parquet`).
//! - [`report`]: `report.html` and `report.md` with SVG figures, built from a finished run
//!   directory (feature `report`).

#![deny(clippy::float_cmp)]

pub mod data;
pub mod density;
pub mod diagnostics;
#[cfg(feature = "parquet")]
pub mod fit;
pub mod law;
pub mod model;
pub mod optimize;
pub mod prec;
#[cfg(feature = "report")]
pub mod report;
pub mod sampler;
pub mod simulate;
pub mod special;
#[cfg(feature = "parquet")]
pub mod storage;
