//! slipbayes: Bayesian inference of how friction starts.
//!
//! The crate is layered so that each part knows only what it must:
//!
//! - [`special`]: the special functions, to (nearly) full double precision: the exponential
//!   integral Ei and its scaled forms, the incomplete gamma and beta functions, the normal
//!   quantile.
//! - [`law`]: the aging-rejuvenation friction law of Farain and Bonn, its elastic correction,
//!   the repeat-slide model and the static friction peak. Knows nothing of files or sampling.
//! - [`density`]: the log-density contract ([`density::LogDensity`]) shared by the sampler,
//!   the optimisers and the model, and the names and units of reported quantities.
//! - [`optimize`]: L-BFGS, Nelder–Mead and the Laplace approximation that places starting
//!   walkers around a mode.
//! - [`sampler`]: an affine-invariant ensemble MCMC sampler over any log-density. Knows nothing
//!   of friction.
//! - [`diagnostics`]: autocorrelation time, R-hat, ESS, MCSE, credible intervals, and the
//!   verdicts ([`diagnostics::Problem`]) that decide whether a run has converged.
//! - [`IoError`]: the one shape of a failed file operation (what, which path, why), carried by
//!   every error that touches files.
//! - [`data`]: reading data sets (`time_s,force_N` CSV) and instrument exports, their true
//!   values, and writing files atomically.
//! - [`simulate`]: synthetic data sets from known parameters.
//! - [`model`]: model specifications, priors and the joint posterior of many runs, contacts
//!   and materials. Knows nothing of how it is sampled.
//! - [`run_file`]: the run file a user writes (`models/*.toml`), parsed once at the edge into
//!   the model specification and the sampler settings.
//! - [`storage`]: chains streamed to Parquet and checkpoints for resuming (feature `parquet`).
//! - [`fit`]: a whole fit over any log-density: sample into a run directory (resumable) and
//!   summarise; [`fit::run_dir`] names, writes and reads every file of a run directory
//!   (feature `parquet`).
//! - [`plot`]: the one plotting layer (SVG written by the crate) of reports, `bench` and
//!   `validate`: figures, charts, axes and ticks, lines, markers, bands, bars, legends, one
//!   palette.
//! - [`distributed`]: fits over several processes behind the sampler's one seam for
//!   parallelism: the ranks of an MPI job (feature `mpi`), every rank updating a share of the
//!   contacts and evaluating a share of each half-step's proposals.
//! - [`report`]: `report.html` and `report.md` with SVG figures, built from a finished run
//!   directory (feature `report`).
//!
//! The command line, `bench` and `validate` live in the workspace's `cli/` crate, which only
//! parses, prints and calls this library.

#![deny(clippy::float_cmp)]
#![warn(missing_docs)]

pub mod data;
pub mod density;
pub mod diagnostics;
pub mod distributed;
#[cfg(feature = "parquet")]
pub mod fit;
mod io_error;
pub mod law;
pub mod model;
pub mod optimize;
pub mod plot;
pub mod prec;
#[cfg(feature = "report")]
pub mod report;
pub mod run_file;
pub mod sampler;
pub mod simulate;
pub mod special;
#[cfg(feature = "parquet")]
pub mod storage;

pub use io_error::IoError;
