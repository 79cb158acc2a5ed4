//! Simulation-based calibration (SBC, Talts et al. 2018) of the whole pipeline: draw the true
//! parameters and the data from the model's prior predictive distribution
//! ([`Posterior::draw_prior_predictive`]: the model file's priors, populations before their
//! members when parameters are pooled, each slide simulated at the design's times with the
//! noise of its σ), fit them with [`slipbayes::fit`], and record the rank of every true
//! parameter (and of the true peaks, a new contact's included) among L thinned posterior
//! draws. Calibrated posteriors give uniform ranks and intervals that cover the truth as often
//! as they claim. Any model whose runs are first slides and repeat slides that follow them
//! can be checked: one contact (`models/sbc.toml`) or a pooled campaign
//! (`models/sbc_pooled.toml`).
//!
//! Replication `i` depends only on (seed, i): its randomness is ChaCha8 stream `i` of the
//! seed, and the fit is bit-identical on any number of threads, so replications run in
//! parallel and a run can stop and continue. Each finished replication is appended at once to
//! one table, `DIR/replications.csv` ([`table`]); a re-run with the same settings skips the
//! replications it holds. Each fit runs in a scratch directory `DIR/fits/NNNNN/` whose chains
//! are deleted once ranked. [`SbcRun`] holds these parts apart so that the ranks of an MPI job
//! can share them (`ranks`, feature `mpi`).
//!
//! This part joins model, simulation and fit; it prints nothing (progress goes to a callback).
pub mod hard;
#[cfg(feature = "mpi")]
pub mod ranks;
mod report;
pub mod stats;
pub mod svg;
pub mod table;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use slipbayes::data::write_atomically;
use slipbayes::density::{QuantityKind, Target};
use slipbayes::fit::run_dir::{CHAINS_DIR, CHECKPOINT};
use slipbayes::fit::{run_fit, FitSettings};
use slipbayes::fit::{RunDir, SummarySpec};
use slipbayes::law::Scene;
use slipbayes::model::data::RunData;
use slipbayes::model::Posterior;
use slipbayes::run_file::RunFile;
use slipbayes::sampler::Move;
use slipbayes::sampler::{Parallelism, Silent, Steps};
use slipbayes::simulate::sample_times;
use slipbayes::IoError;

pub use report::{summarise, write_report, GrossLimits, QuantityCalibration, SbcReport};
pub use stats::{Coverage, Uniformity};

/// Sub-directory of the replications' fits (scratch: each fit's chains are deleted once
/// ranked).
pub const FITS_DIR: &str = "fits";
/// Sub-directory of the one-file-per-replication records of earlier versions, which opening
/// a run converts into the table.
const LEGACY_RECORDS_DIR: &str = "replications";
pub use table::REPLICATIONS_TABLE;
/// The settings of a validation run, which a continued run must match.
pub const SETTINGS_FILE: &str = "settings.json";
/// Prior draws in a row that the law rejects (stick-slip) before a replication gives up.
const MAX_REDRAWS: usize = 1000;

/// Errors of a validation run (a failing fit is not one: it is recorded in its replication).
#[derive(Debug, thiserror::Error)]
pub enum ValidateError {
    /// The model has a run SBC cannot simulate.
    #[error("{path}: {message}")]
    Model {
        /// The model file.
        path: PathBuf,
        /// What is wrong and what to do.
        message: String,
    },
    /// A setting is invalid.
    #[error("{name} = {value}: {expected}")]
    InvalidSetting {
        /// Setting name as on the command line.
        name: &'static str,
        /// Its value.
        value: String,
        /// What is expected.
        expected: &'static str,
    },
    /// The output directory holds a validation run with other settings.
    #[error("{dir} holds a validation run with other settings ({problem}); use another --out, or --overwrite to start again")]
    SettingsMismatch {
        /// The output directory.
        dir: PathBuf,
        /// The first difference.
        problem: String,
    },
    /// Reading or writing a file failed.
    #[error(transparent)]
    Io(#[from] IoError),
    /// The model file could not be loaded.
    #[error(transparent)]
    Spec(#[from] slipbayes::model::SpecError),
    /// The table of replications cannot be read or written.
    #[error(transparent)]
    Table(#[from] table::TableError),
    /// Replications were recorded through a run that was loaded, not opened (a bug).
    #[error("a validation run must be opened (SbcRun::open) before it records replications")]
    NotOpened,
}

/// The simulated design and the fit of every replication.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SbcSettings {
    /// Model file with its priors (e.g. `models/sbc.toml`); every run a first slide or a
    /// repeat slide that follows one.
    pub model: PathBuf,
    /// Replications.
    pub replications: usize,
    /// Seed; replication i uses ChaCha8 stream i of it.
    pub seed: u64,
    /// Length of each simulated first slide (s).
    pub first_duration_s: f64,
    /// Its sampling interval (s).
    pub first_interval_s: f64,
    /// Length of each simulated repeat slide (s).
    pub repeat_duration_s: f64,
    /// Its sampling interval (s).
    pub repeat_interval_s: f64,
    /// Walkers per ensemble of each fit.
    pub walkers: usize,
    /// Independent ensembles of each fit.
    pub ensembles: usize,
    /// Steps of each fit.
    pub steps: u64,
    /// L: posterior draws the truth is ranked among (ranks lie in 0..=L; L + 1 should be a
    /// multiple of 20, e.g. 99 or 199).
    pub rank_draws: usize,
}

impl Default for SbcSettings {
    /// The published design: 1 nm/s slides of 20 000 s every 100 s (first, 201 points) and
    /// 2 000 s every 40 s (repeat, 51 points); fits of 4 × 16 walkers × 1 000 steps; L = 99.
    fn default() -> Self {
        Self {
            model: PathBuf::from("models/sbc.toml"),
            replications: 200,
            seed: 1,
            first_duration_s: 20_000.0,
            first_interval_s: 100.0,
            repeat_duration_s: 2_000.0,
            repeat_interval_s: 40.0,
            walkers: 16,
            ensembles: 4,
            steps: 1_000,
            rank_draws: 99,
        }
    }
}

fn invalid(name: &'static str, value: impl ToString, expected: &'static str) -> ValidateError {
    ValidateError::InvalidSetting {
        name,
        value: value.to_string(),
        expected,
    }
}

impl SbcSettings {
    fn validate(&self) -> Result<(), ValidateError> {
        if self.replications == 0 {
            return Err(invalid("replications", 0, "at least 1 (200 to publish)"));
        }
        if self.rank_draws < 9 || (self.rank_draws + 1) % 10 != 0 {
            return Err(invalid(
                "rank-draws",
                self.rank_draws,
                "L with L + 1 a multiple of 10 (e.g. 99 or 199)",
            ));
        }
        for (name, v) in [
            ("first-duration", self.first_duration_s),
            ("first-interval", self.first_interval_s),
            ("repeat-duration", self.repeat_duration_s),
            ("repeat-interval", self.repeat_interval_s),
        ] {
            if !(v.is_finite() && v > 0.0) {
                return Err(invalid(name, v, "a time > 0 s"));
            }
        }
        Ok(())
    }
}

/// One reported column whose truth is ranked, and its index among the posterior's columns.
#[derive(Debug, Clone)]
struct Tracked {
    column: String,
    index: usize,
}

/// The model, checked, over the simulated design: a posterior whose data are placeholders at
/// the simulated times (its prior predictive draws make each replication's data), with the
/// quantities to rank.
#[derive(Debug, Clone)]
struct Design {
    posterior: Posterior,
    /// Each run's instrument times.
    times: Vec<Vec<f64>>,
    tracked: Vec<Tracked>,
}

impl Design {
    fn new(run: RunFile, settings: &SbcSettings) -> Result<Self, ValidateError> {
        let (spec, plan) = (&run.model, run.blocking());
        let bad = |message: String| ValidateError::Model {
            path: spec.source.clone(),
            message,
        };
        let runs = &spec.file.runs;
        for (i, r) in runs.iter().enumerate() {
            match r.scene {
                Scene::First => {}
                Scene::Repeat if spec.run_follows[i].is_some() => {}
                Scene::Repeat => {
                    return Err(bad(format!(
                        "run `{}`: SBC simulates a repeat slide after the first slide it `follows`; name it",
                        r.name
                    )))
                }
                Scene::StiffFast => {
                    return Err(bad(format!(
                        "run `{}`: SBC simulates `first` and `repeat` slides only",
                        r.name
                    )))
                }
            }
            if r.window_s.is_some() {
                return Err(bad(format!(
                    "run `{}`: drop `window_s`: the simulated record is the fitted one",
                    r.name
                )));
            }
        }
        let times_of = |scene| match scene {
            Scene::Repeat => sample_times(settings.repeat_duration_s, settings.repeat_interval_s),
            _ => sample_times(settings.first_duration_s, settings.first_interval_s),
        };
        let mut times = Vec::with_capacity(runs.len());
        let mut placeholders = Vec::with_capacity(runs.len());
        for (i, r) in runs.iter().enumerate() {
            let t = times_of(r.scene).map_err(|e| bad(e.to_string()))?;
            let series = slipbayes::data::Series {
                force_n: vec![0.0; t.len()],
                time_s: t.clone(),
                normal_force_n: None,
            };
            placeholders
                .push(RunData::for_series(spec, i, series).map_err(|e| bad(e.to_string()))?);
            times.push(t);
        }
        let posterior =
            Posterior::from_data(spec, plan, placeholders).map_err(|e| bad(e.to_string()))?;
        // Every parameter, the peak of every first slide and the peak of a new contact: the
        // other derived columns (where and when the peak is) follow from these.
        let tracked = posterior
            .quantities()
            .iter()
            .enumerate()
            .filter(|(_, c)| {
                c.kind == QuantityKind::Parameter || c.name == "F_peak" || c.name == "F_peak_new"
            })
            .map(|(index, c)| Tracked {
                column: c.column.clone(),
                index,
            })
            .collect();
        Ok(Self {
            posterior,
            times,
            tracked,
        })
    }
}

/// What one replication found.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Replication {
    /// Index i (stream i of the seed).
    pub index: usize,
    /// The true value of every ranked column.
    pub truth: BTreeMap<String, f64>,
    /// Prior draws rejected before this one because the law has no quasi-static path.
    pub redraws: usize,
    /// Seed of the fit.
    pub fit_seed: u64,
    /// Per tracked column: rank of the truth among the L thinned draws (0..=L).
    pub ranks: BTreeMap<String, usize>,
    /// Per tracked column: fraction of all post-burn-in draws below the truth.
    pub quantiles: BTreeMap<String, f64>,
    /// Whether the fit passed every convergence check.
    pub converged: bool,
    /// Largest R̂ between ensembles over the tracked quantities.
    pub r_hat_max: Option<f64>,
    /// τ_max of the fit (steps).
    pub tau_max: Option<f64>,
    /// Burn-in discarded (steps).
    pub burn_in: u64,
    /// Smallest step gap between two ranked draws of one walker, over τ_max.
    pub min_gap_over_tau: Option<f64>,
    /// Seconds this replication took.
    pub wall_s: f64,
    /// Why the fit failed, when it did (no ranks then).
    pub failure: Option<String>,
}

/// Runs replication `index` in `dir` (its fit is left there, minus the chains).
fn replicate(design: &Design, settings: &SbcSettings, index: usize, dir: &Path) -> Replication {
    let started = Instant::now();
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    rng.set_stream(index as u64);
    let fit_seed: u64 = rng.random();
    let failed = |truth, redraws, failure: String| Replication {
        index,
        truth,
        redraws,
        fit_seed,
        ranks: BTreeMap::new(),
        quantiles: BTreeMap::new(),
        converged: false,
        r_hat_max: None,
        tau_max: None,
        burn_in: 0,
        min_gap_over_tau: None,
        wall_s: started.elapsed().as_secs_f64(),
        failure: Some(failure),
    };
    let draw = match design
        .posterior
        .draw_prior_predictive(&mut rng, MAX_REDRAWS)
    {
        Ok(d) => d,
        Err(e) => return failed(BTreeMap::new(), MAX_REDRAWS, e.to_string()),
    };
    let truth: BTreeMap<String, f64> = design
        .tracked
        .iter()
        .map(|t| (t.column.clone(), draw.values[t.index]))
        .collect();
    match fit_and_rank(design, settings, dir, &truth, draw.forces_n, fit_seed) {
        Ok(mut rep) => {
            rep.index = index;
            rep.redraws = draw.redraws;
            rep.wall_s = started.elapsed().as_secs_f64();
            rep
        }
        Err(e) => failed(truth, draw.redraws, e),
    }
}

fn fit_and_rank(
    design: &Design,
    settings: &SbcSettings,
    dir: &Path,
    truth: &BTreeMap<String, f64>,
    forces_n: Vec<Vec<f64>>,
    fit_seed: u64,
) -> Result<Replication, String> {
    let spec = design.posterior.spec();
    std::fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    // The simulated slides are fitted from memory; only the chains go to disk.
    let data = forces_n
        .into_iter()
        .zip(&design.times)
        .enumerate()
        .map(|(run, (force_n, time_s))| {
            let series = slipbayes::data::Series {
                time_s: time_s.clone(),
                force_n,
                normal_force_n: None,
            };
            RunData::for_series(spec, run, series).map_err(|e| e.to_string())
        })
        .collect::<Result<Vec<_>, _>>()?;
    let posterior =
        Posterior::from_data(spec, design.posterior.blocking(), data).map_err(|e| e.to_string())?;
    let fit_dir = RunDir::new(dir.join("fit"));
    let outcome = quiet_fit(
        &posterior,
        settings.walkers,
        settings.ensembles,
        fit_seed,
        Steps::Fixed(settings.steps),
        None,
        &fit_dir,
    )?;
    let chains = fit_dir.chain_reader().map_err(|e| e.to_string())?;
    let s = &outcome.summary.sampler;
    let kept = slipbayes::fit::kept_rows(&chains, s, usize::MAX);
    if kept.len() < settings.rank_draws {
        return Err(format!(
            "{} draws after burn-in, fewer than L = {}",
            kept.len(),
            settings.rank_draws
        ));
    }
    // L draws evenly spread over the rows (step, then ensemble, then walker) after burn-in:
    // each walker gives about L / (ensembles · walkers) draws, far apart in steps.
    let chosen: Vec<usize> = (0..settings.rank_draws)
        .map(|j| kept[((2 * j + 1) * kept.len()) / (2 * settings.rank_draws)])
        .collect();
    let mut last_of_walker: BTreeMap<(usize, usize), u64> = BTreeMap::new();
    let mut min_gap: Option<u64> = None;
    for &i in &chosen {
        let (step, e, w) = chains.locate(i);
        if let Some(prev) = last_of_walker.insert((e, w), step) {
            let gap = step - prev;
            min_gap = Some(min_gap.map_or(gap, |g| g.min(gap)));
        }
    }
    let tracked = &design.tracked;
    let mut ranks = BTreeMap::new();
    let mut quantiles = BTreeMap::new();
    for t in tracked {
        let column = chains.column(&t.column).map_err(|e| e.to_string())?;
        let value = truth[&t.column];
        let thinned: Vec<f64> = chosen.iter().map(|&i| column[i]).collect();
        ranks.insert(t.column.clone(), stats::rank(value, &thinned));
        let all: Vec<f64> = kept.iter().map(|&i| column[i]).collect();
        quantiles.insert(
            t.column.clone(),
            stats::rank(value, &all) as f64 / all.len() as f64,
        );
    }
    let r_hat_max = outcome
        .summary
        .quantities()
        .filter(|q| tracked.iter().any(|t| t.column == q.column))
        .filter_map(|q| q.stats.r_hat)
        .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))));
    // The chains and the checkpoint (10 MB) have served; 200 replications of them would
    // fill the disk.
    let _ = std::fs::remove_dir_all(fit_dir.file(CHAINS_DIR));
    let _ = std::fs::remove_file(fit_dir.file(CHECKPOINT));
    Ok(Replication {
        index: 0,
        truth: truth.clone(),
        redraws: 0,
        fit_seed,
        ranks,
        quantiles,
        converged: s.converged,
        r_hat_max,
        tau_max: s.tau_max,
        burn_in: s.burn_in,
        min_gap_over_tau: match (min_gap, s.tau_max) {
            (Some(g), Some(t)) if t > 0.0 => Some(g as f64 / t),
            _ => None,
        },
        wall_s: 0.0,
        failure: None,
    })
}

/// An error with its chain of causes, for a replication's record.
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}

/// A fit of `posterior`'s quantities into `dir` for `steps`, replacing what is there,
/// printing nothing: one replication of `validate`, or one hard case. Errors as the full cause
/// chain.
pub(crate) fn quiet_fit(
    posterior: &Posterior,
    walkers: usize,
    ensembles: usize,
    seed: u64,
    steps: Steps,
    moves: Option<&[(Move, f64)]>,
    dir: &RunDir,
) -> Result<slipbayes::fit::FitOutcome, String> {
    let defaults = FitSettings::default();
    let settings = FitSettings {
        walkers,
        ensembles,
        seed,
        steps,
        checkpoint_every: None,
        quiet: true,
        overwrite: true,
        moves: moves.map_or(defaults.moves.clone(), <[_]>::to_vec),
        ..defaults
    };
    run_fit(
        Target::blocked(posterior),
        &SummarySpec::of(posterior.quantities().to_vec()),
        posterior.search_start(),
        &settings,
        dir,
        false,
        &mut Silent,
        Parallelism::default(),
    )
    .map_err(|e| error_chain(&e))
}

fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> ValidateError {
    let path = path.to_path_buf();
    move |source| IoError::new(action, path, source).into()
}

fn first_difference(a: &SbcSettings, b: &SbcSettings) -> String {
    let (a, b) = (
        serde_json::to_value(a).unwrap_or_default(),
        serde_json::to_value(b).unwrap_or_default(),
    );
    if let (Some(a), Some(b)) = (a.as_object(), b.as_object()) {
        for (k, v) in a {
            if k != "replications" && b.get(k) != Some(v) {
                return format!("{k} was {} and is now {}", v, b.get(k).unwrap_or_default());
            }
        }
    }
    "unknown".into()
}

/// Runs (or continues) the validation in `out` and returns every replication, in index order.
/// Finished replications of an earlier run with the same settings (the number of
/// replications may grow) are read back instead of re-run. `progress` is called after each
/// replication finishes, from whichever thread ran it.
///
/// # Errors
/// [`ValidateError`] for a model with a run SBC cannot simulate, invalid settings, an
/// output directory holding another run (unless `overwrite`), or files that cannot be
/// written. A failing fit is not an error: it is recorded in its replication.
pub fn run_sbc(
    settings: &SbcSettings,
    out: &Path,
    overwrite: bool,
    progress: &(dyn Fn(&Replication) + Sync),
) -> Result<Vec<Replication>, ValidateError> {
    let run = SbcRun::open(settings, out, overwrite)?;
    let mut finished = run.finished();
    let pending = run.pending(&finished);
    let fresh = run.run_share::<ValidateError>(&pending, &|rep| {
        run.record(rep)?;
        progress(rep);
        Ok(())
    })?;
    run.finish()?;
    finished.extend(fresh.into_iter().map(|r| (r.index, r)));
    Ok(finished.into_values().collect())
}

/// A validation run's output directory and model, ready to run replications: what
/// [`run_sbc`] does in one process, in parts that the ranks of an MPI job share (rank 0
/// opens the directory and records every replication; every rank runs its own).
#[derive(Debug)]
pub struct SbcRun {
    settings: SbcSettings,
    design: Design,
    out: PathBuf,
    /// The table, open for appending: `None` for a run [loaded](Self::load) to run
    /// replications that another process records.
    table: Option<table::Appender>,
    /// The replications the table held when the run was opened.
    earlier: BTreeMap<usize, Replication>,
}

impl SbcRun {
    /// Checks the settings and the model, and opens `out` for them: its replications are
    /// removed with `overwrite`, else an earlier run there must have the same settings (the
    /// number of replications may grow) and rank the same quantities; `settings.json` is
    /// (re)written, and the table of replications rewritten with the rows it holds whole
    /// (the records of an earlier version, one file per replication, are converted into it).
    ///
    /// # Errors
    /// [`ValidateError`] for invalid settings, a model with a run SBC cannot simulate, an
    /// output directory holding another run (unless `overwrite`), or files that cannot be
    /// written.
    pub fn open(
        settings: &SbcSettings,
        out: &Path,
        overwrite: bool,
    ) -> Result<Self, ValidateError> {
        let mut run = Self::load(settings, out)?;
        let settings_path = out.join(SETTINGS_FILE);
        let table_path = out.join(REPLICATIONS_TABLE);
        let legacy = out.join(LEGACY_RECORDS_DIR);
        if overwrite {
            remove(&table_path, false)?;
            remove(&legacy, true)?;
            remove(&out.join(FITS_DIR), true)?;
        } else if let Ok(text) = std::fs::read_to_string(&settings_path) {
            let earlier: SbcSettings =
                serde_json::from_str(&text).map_err(|e| ValidateError::SettingsMismatch {
                    dir: out.to_path_buf(),
                    problem: format!("{} does not parse: {e}", settings_path.display()),
                })?;
            let mut same = earlier.clone();
            same.replications = settings.replications;
            if &same != settings {
                return Err(ValidateError::SettingsMismatch {
                    dir: out.to_path_buf(),
                    problem: first_difference(&earlier, settings),
                });
            }
        }
        let quantities = run.quantities();
        let mut earlier = match table::read(&table_path)? {
            Some(t) if t.quantities == quantities || t.rows.is_empty() => t.rows,
            Some(t) => {
                return Err(ValidateError::SettingsMismatch {
                    dir: out.to_path_buf(),
                    problem: format!(
                        "its replications rank {:?}, the model file now gives {quantities:?}",
                        t.quantities
                    ),
                })
            }
            None => BTreeMap::new(),
        };
        let converted = legacy_records(&legacy);
        for rep in converted.iter().cloned() {
            earlier.entry(rep.index).or_insert(rep);
        }
        std::fs::create_dir_all(out).map_err(io("create", out))?;
        let json = serde_json::to_vec_pretty(settings).unwrap_or_default();
        write_atomically(&settings_path, &json).map_err(io("write", &settings_path))?;
        table::write(&table_path, &quantities, &earlier)?;
        if !converted.is_empty() {
            remove(&legacy, true)?;
        }
        run.table = Some(table::Appender::open(&table_path, &quantities)?);
        run.earlier = earlier;
        Ok(run)
    }

    /// Checks the settings and loads the model, touching nothing in `out`: for a rank that
    /// runs replications of a run that rank 0 opened.
    ///
    /// # Errors
    /// [`ValidateError`] for invalid settings or a model with a run SBC cannot simulate.
    pub fn load(settings: &SbcSettings, out: &Path) -> Result<Self, ValidateError> {
        settings.validate()?;
        let run = RunFile::load(&settings.model)?;
        Ok(Self {
            design: Design::new(run, settings)?,
            settings: settings.clone(),
            out: out.to_path_buf(),
            table: None,
            earlier: BTreeMap::new(),
        })
    }

    /// The columns whose truth is ranked, in the table's order.
    fn quantities(&self) -> Vec<String> {
        self.design
            .tracked
            .iter()
            .map(|t| t.column.clone())
            .collect()
    }

    /// The replications among `0..settings.replications` that the table held whole when the
    /// run was opened (a row cut short is not finished: it is run again).
    pub fn finished(&self) -> BTreeMap<usize, Replication> {
        self.earlier
            .range(..self.settings.replications)
            .map(|(&i, r)| (i, r.clone()))
            .collect()
    }

    /// The indices of the replications still to run, in order.
    pub fn pending(&self, finished: &BTreeMap<usize, Replication>) -> Vec<usize> {
        (0..self.settings.replications)
            .filter(|i| !finished.contains_key(i))
            .collect()
    }

    /// Runs replications `indices` (each fit in its own scratch directory `fits/NNNNN/`),
    /// as many at a time as there are threads, and hands each to `done` as it finishes, from
    /// whichever thread ran it; returns them in the order of `indices`. Stops after the
    /// replications in flight when `done` fails, with its error.
    ///
    /// # Errors
    /// The first error of `done`.
    pub fn run_share<E: Send>(
        &self,
        indices: &[usize],
        done: &(dyn Fn(&Replication) -> Result<(), E> + Sync),
    ) -> Result<Vec<Replication>, E> {
        // As many replications at a time as there are threads. A single parallel loop over
        // all of them lets a thread that waits inside one fit steal the next replication, so
        // that dozens were in flight at once, holding their memory, and none finished for
        // minutes.
        let at_once = rayon::current_num_threads().max(1);
        let fits = self.out.join(FITS_DIR);
        let mut reps = Vec::with_capacity(indices.len());
        for chunk in indices.chunks(at_once) {
            let ran: Vec<Result<Replication, E>> = chunk
                .par_iter()
                .with_max_len(1)
                .map(|&i| {
                    let rep = replicate(
                        &self.design,
                        &self.settings,
                        i,
                        &fits.join(format!("{i:05}")),
                    );
                    done(&rep)?;
                    Ok(rep)
                })
                .collect();
            for rep in ran {
                reps.push(rep?);
            }
        }
        Ok(reps)
    }

    /// Appends `rep`'s row to the table and flushes it to disk: a run stopped at any moment
    /// leaves whole rows, which a continued run reads back.
    ///
    /// # Errors
    /// [`ValidateError::Table`] when it cannot be written, [`ValidateError::NotOpened`] for a
    /// run that was [loaded](Self::load) rather than opened.
    pub fn record(&self, rep: &Replication) -> Result<(), ValidateError> {
        let table = self.table.as_ref().ok_or(ValidateError::NotOpened)?;
        Ok(table.append(rep)?)
    }

    /// Rewrites the table in index order, once every replication has run: the same
    /// replications give the same file whatever order they finished in.
    ///
    /// # Errors
    /// [`ValidateError::Table`] when it cannot be read or written.
    pub fn finish(&self) -> Result<(), ValidateError> {
        let path = self.out.join(REPLICATIONS_TABLE);
        if let Some(t) = table::read(&path)? {
            table::write(&path, &t.quantities, &t.rows)?;
        }
        Ok(())
    }

    /// The bytes of `rep` as one rank sends it to another.
    pub fn record_bytes(rep: &Replication) -> Vec<u8> {
        serde_json::to_vec(rep).unwrap_or_default()
    }
}

/// Removes a file (or, with `dir`, a directory and its contents) that may not exist.
fn remove(path: &Path, dir: bool) -> Result<(), ValidateError> {
    let removed = if dir {
        std::fs::remove_dir_all(path)
    } else {
        std::fs::remove_file(path)
    };
    match removed {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(io("remove", path)(e)),
        _ => Ok(()),
    }
}

/// The records an earlier version wrote, one JSON file per replication in `dir`
/// (`NNNNN.json`); records that do not parse were unfinished and are left out.
fn legacy_records(dir: &Path) -> Vec<Replication> {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return Vec::new();
    };
    let mut reps: Vec<Replication> = entries
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "json"))
        .filter_map(|e| serde_json::from_str(&std::fs::read_to_string(e.path()).ok()?).ok())
        .collect();
    reps.sort_by_key(|r| r.index);
    reps
}

/// The replications finished so far in `out`, in index order, to report on a run that is
/// still going or was stopped.
///
/// # Errors
/// [`ValidateError`] when `out` holds no table of replications (nor the records of an
/// earlier version) or it cannot be read.
pub fn finished_replications(out: &Path) -> Result<Vec<Replication>, ValidateError> {
    let path = out.join(REPLICATIONS_TABLE);
    match table::read(&path)? {
        Some(t) => Ok(t.rows.into_values().collect()),
        None => {
            let legacy = legacy_records(&out.join(LEGACY_RECORDS_DIR));
            if legacy.is_empty() {
                Err(io("read", &path)(std::io::Error::from(
                    std::io::ErrorKind::NotFound,
                )))
            } else {
                Ok(legacy)
            }
        }
    }
}
