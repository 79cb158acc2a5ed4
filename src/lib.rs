//! slipbayes: Bayesian inference of how friction starts.
//!
//! A model file (`models/*.toml`) names the materials, contacts and slides of an experiment
//! and the data of each slide; slipbayes samples the joint posterior of the aging–rejuvenation
//! law's parameters with an affine-invariant ensemble sampler and writes everything it finds
//! into a run directory. The four sections below are the four ways into the library; each
//! example runs as a test.
//!
//! # Fit a model file into a run directory
//!
//! [`RunFile`] reads and validates the file; its posterior loads the data; the file's
//! `[sampler]` table, under the caller's [`SettingOverrides`], gives the [`FitSettings`]; a
//! [`RunLock`] claims the directory against a second fit; [`fit_model`] samples,
//! summarises and writes the run directory. Progress goes to an observer (here none).
//!
//! ```
//! use slipbayes::{
//!     fit_model, FitSettings, Parallelism, RunFile, RunLock, SettingOverrides, Silent,
//! };
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let data = concat!(env!("CARGO_MANIFEST_DIR"), "/data");
//! let dir = tempfile::tempdir()?;
//! // One PTFE contact on glass: a first slide at 1 nm/s and the repeat slide after it.
//! let model = format!(
//!     r#"
//! [[material]]
//! name = "PTFE"
//!
//! [[contact]]
//! name = "c1"
//! material = "PTFE"
//!
//! [[run]]
//! name = "first"
//! contact = "c1"
//! data = "{data}/ptfe-c1-first.csv"
//! velocity_m_per_s = 1e-9
//! scene = "first"
//!
//! [[run]]
//! name = "repeat"
//! contact = "c1"
//! data = "{data}/ptfe-c1-repeat.csv"
//! velocity_m_per_s = 1e-9
//! scene = "repeat"
//!
//! [sampler]
//! ensembles = 2
//! "#
//! );
//! let path = dir.path().join("ptfe.toml");
//! std::fs::write(&path, model)?;
//!
//! let run = RunFile::load(&path)?;
//! let posterior = run.posterior()?;
//! // A short fixed run for the example; without `steps` the fit runs until it converges.
//! let overrides = SettingOverrides {
//!     steps: Some(100),
//!     quiet: true,
//!     ..SettingOverrides::default()
//! };
//! let settings = FitSettings::for_model(&posterior, &run.sampler, &overrides);
//! let lock = RunLock::acquire(&dir.path().join("run"))?;
//! let outcome = fit_model(
//!     &run,
//!     &posterior,
//!     &settings,
//!     &lock,
//!     false,  // a fresh run, not resumed
//!     vec![], // the command line to record, if any
//!     &mut Silent,
//!     Parallelism::default(),
//! )?;
//! assert_eq!(outcome.summary.sampler.steps, 100);
//! assert!(outcome.dir.file("summary.json").exists());
//! # Ok(())
//! # }
//! ```
//!
//! # Build a posterior from data and evaluate it
//!
//! [`Posterior`] is a [`LogDensity`] over the sampled (log) parameters. It loads each run's
//! data file itself ([`RunFile::posterior`]), or takes data already in memory, one
//! [`RunData`] per run of the model in its order ([`Posterior::from_data`]).
//!
//! ```
//! use std::path::Path;
//!
//! use slipbayes::{LogDensity, Posterior, RunData, RunFile, Series};
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // A record from anywhere (an instrument's own reader, a notebook): here the bundled CSV.
//! let csv = std::fs::read_to_string(concat!(
//!     env!("CARGO_MANIFEST_DIR"),
//!     "/data/ptfe-c1-first.csv"
//! ))?;
//! let (mut time_s, mut force_n) = (Vec::new(), Vec::new());
//! for line in csv.lines().skip(1) {
//!     let mut fields = line.split(',');
//!     time_s.push(fields.next().unwrap_or_default().parse()?);
//!     force_n.push(fields.next().unwrap_or_default().parse()?);
//! }
//! let series = Series { time_s, force_n, normal_force_n: None };
//!
//! // The model: one first slide; its `data` is not read when the data are given.
//! let model = r#"
//! [[material]]
//! name = "PTFE"
//! [[contact]]
//! name = "c1"
//! material = "PTFE"
//! [[run]]
//! name = "first"
//! contact = "c1"
//! data = "in-memory.csv"
//! velocity_m_per_s = 1e-9
//! scene = "first"
//! "#;
//! let run = RunFile::parse(model, Path::new("ptfe.toml"))?;
//! let data = vec![RunData::for_series(&run.model, 0, series)?];
//! let posterior = Posterior::from_data(&run.model, run.blocking(), data)?;
//!
//! // The log-density at the posterior's rough start, and the derived values there.
//! let x = posterior.start().to_vec();
//! let mut derived = vec![0.0; posterior.derived_names().len()];
//! let log_density = posterior.log_density(&x, &mut derived)?;
//! assert!(log_density.is_finite());
//! assert_eq!(posterior.param_names().len(), posterior.dim());
//! # Ok(())
//! # }
//! ```
//!
//! # Run the sampler on your own density
//!
//! The sampler knows nothing of friction: any [`LogDensity`] will do. A point the density
//! refuses ([`LogDensityError::rejected`]) is a rejected proposal, counted by reason; draws
//! go to a [`ChainSink`] (here a [`MemorySink`]); progress to an [`Observer`] (here
//! [`Silent`]). [`SamplerConfig`] also takes a mixture of [`Move`]s, one's own among them
//! ([`ProposalMove`]), and a density that offers blocks ([`BlockedDensity`]) is updated
//! block by block when handed over as [`Target::blocked`].
//!
//! ```
//! use slipbayes::{
//!     EnsembleSampler, LogDensity, LogDensityError, MemorySink, SamplerConfig, Silent, Steps,
//! };
//!
//! /// A correlated Gaussian in two dimensions (correlation 0.8, unit variances).
//! struct Gaussian;
//! impl LogDensity for Gaussian {
//!     fn dim(&self) -> usize {
//!         2
//!     }
//!     fn log_density(&self, x: &[f64], _derived: &mut [f64]) -> Result<f64, LogDensityError> {
//!         let rho: f64 = 0.8;
//!         let q = (x[0] * x[0] - 2.0 * rho * x[0] * x[1] + x[1] * x[1]) / (1.0 - rho * rho);
//!         Ok(-0.5 * q)
//!     }
//! }
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! // 8 walkers in each of 2 ensembles, seed 42; each ensemble starts on a small circle about
//! // the origin (the walkers must span both dimensions).
//! let config = SamplerConfig::new(8, 2, 42)?;
//! let start: Vec<Vec<Vec<f64>>> = (0..2)
//!     .map(|e| {
//!         (0..8)
//!             .map(|w| {
//!                 let angle = (w as f64 + 0.5 * e as f64) * std::f64::consts::TAU / 8.0;
//!                 vec![0.1 * angle.cos(), 0.1 * angle.sin()]
//!             })
//!             .collect()
//!     })
//!     .collect();
//! let mut sampler = EnsembleSampler::new(&Gaussian, config, start)?;
//! let mut sink = MemorySink::new();
//! let report = sampler.run(Steps::Fixed(2000), &mut sink, &mut Silent)?;
//! assert_eq!(report.total_steps, 2000);
//!
//! // The mean of x0 over the second half of ensemble 0's chains.
//! let chain = &sink.chains[0];
//! let x0: Vec<f64> = (0..chain.walkers)
//!     .flat_map(|w| chain.walker_series(w, 0).split_off(1000))
//!     .collect();
//! let mean = x0.iter().sum::<f64>() / x0.len() as f64;
//! assert!(mean.abs() < 0.3, "mean of x0 {mean}");
//! # Ok(())
//! # }
//! ```
//!
//! # Read a run directory
//!
//! [`RunDir`] names, writes and reads every file of a run directory: the summary
//! ([`FitSummary`], `summary.json`), the chains (Parquet parts under `chains/`), the model
//! and the run record.
//!
//! ```
//! # use slipbayes::{
//! #     fit_model, FitSettings, Parallelism, RunFile, RunLock, SettingOverrides, Silent,
//! # };
//! use slipbayes::RunDir;
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! # let data = concat!(env!("CARGO_MANIFEST_DIR"), "/data");
//! # let tmp = tempfile::tempdir()?;
//! # let model = format!(
//! #     "[[material]]\nname = \"PTFE\"\n[[contact]]\nname = \"c1\"\nmaterial = \"PTFE\"\n\
//! #      [[run]]\nname = \"first\"\ncontact = \"c1\"\ndata = \"{data}/ptfe-c1-first.csv\"\n\
//! #      velocity_m_per_s = 1e-9\nscene = \"first\"\n[sampler]\nensembles = 2\n"
//! # );
//! # std::fs::write(tmp.path().join("ptfe.toml"), model)?;
//! # let run = RunFile::load(&tmp.path().join("ptfe.toml"))?;
//! # let posterior = run.posterior()?;
//! # let overrides = SettingOverrides { steps: Some(100), quiet: true, ..Default::default() };
//! # let settings = FitSettings::for_model(&posterior, &run.sampler, &overrides);
//! # let lock = RunLock::acquire(&tmp.path().join("run"))?;
//! # let (parallelism, observer) = (Parallelism::default(), &mut Silent);
//! # fit_model(&run, &posterior, &settings, &lock, false, vec![], observer, parallelism)?;
//! # drop(lock);
//! # let path = tmp.path().join("run");
//! // `path`: a directory `slipbayes fit` (or `fit_model`) wrote.
//! let dir = RunDir::new(&path);
//! let summary = dir.read_summary()?;
//! for q in &summary.parameters {
//!     println!("{} [{}]: {:.3} ± {:.3}", q.name, q.group, q.stats.mean, q.stats.sd);
//! }
//! // The chains: one column per parameter, the log-density and the derived quantities;
//! // one row per step, ensemble and walker.
//! let chains = dir.read_chains()?;
//! let log_density = chains.column("log_density")?;
//! assert_eq!(log_density.len(), chains.len());
//! assert_eq!(dir.read_model()?.model.file.runs.len(), 1);
//! # Ok(())
//! # }
//! ```
//!
//! # The layers
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
//! - [`output_dir`]: whose directory it is: every command writes only into a new, empty or
//!   marked directory of its own, or with `--overwrite`, and then only its own files.
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
pub mod output_dir;
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

// The names a user of the library needs, at the top: fit a model file, build a posterior from
// data, run the sampler on one's own density, read a run directory. Everything else stays in
// its module.
pub use data::Series;
pub use density::{BlockedDensity, LogDensity, LogDensityError, Target};
#[cfg(feature = "parquet")]
pub use fit::{
    fit_model, FitError, FitOutcome, FitSettings, FitSummary, RunDir, RunDirError, RunLock,
    SettingOverrides,
};
pub use io_error::IoError;
pub use model::data::RunData;
pub use model::{BlockSettings, ModelSpec, OneContact, Posterior, PosteriorError, SpecError};
pub use output_dir::{claim_files, ClaimError, OutputDir, OutputKind};
pub use run_file::RunFile;
pub use sampler::{
    ChainSink, EnsembleSampler, MemorySink, Move, Observer, Parallelism, ProposalMove, RunReport,
    SamplerConfig, SamplerError, Silent, Steps, StopRule, Updates,
};
