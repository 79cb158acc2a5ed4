//! A whole fit: start the walkers, sample into a run directory (with checkpoints, resumable
//! after a kill), summarise the chains, and write every file of the run directory.
//!
//! - [`run_fit`] fits any [`LogDensity`]: it knows the names of the chain columns and how the
//!   caller wants each reported ([`SummarySpec`]: quantities, means over several columns,
//!   comparisons between groups), never what they mean.
//! - [`fit_model`] fits a friction [`Posterior`](crate::model::Posterior): it reports every
//!   parameter and derived quantity, compares the materials, and adds the model, the run
//!   record and the posterior predictive bands to the run directory.
//! - [`run_dir`] names, writes and reads every file of a run directory.
//!
//! Neither prints: progress goes to the caller's [`Observer`], and the caller prints what the
//! returned [`FitOutcome`] holds.
//!
//! # What [`run_fit`] does
//! 1. Validates the settings and the summary spec against the density's columns, before
//!    anything expensive.
//! 2. Fresh run: claims the run directory's chain store (refusing one that holds a run unless
//!    `overwrite`), finds the mode from the given start and draws the initial walkers around
//!    it ([`initial_around_optimum`], stream [`INIT_STREAM`] of the seed), and samples.
//!    Resumed run: reopens the store at its last checkpoint and continues the sampler from the
//!    saved state, so the chains end identical to an uninterrupted run with the same seed.
//!    A run killed before its first checkpoint starts over; one killed after its chains were
//!    complete (while its summaries or report were written) samples no more and only redoes
//!    what follows.
//!    [`Steps::Fixed`] counts the *total* steps of the run, resumed or not.
//! 3. Reads the chains back, discards the burn-in the [`RunReport`] suggests (at least
//!    ⌈2 τ_max⌉ and the steps spent tuning; clamped to half the run only when τ is not
//!    trusted), keeps every later step, summarises every quantity,
//!    aggregate and comparison ([`crate::diagnostics::summarize`]), and judges convergence
//!    with [`crate::diagnostics::verdict`]: R̂ between ensembles below
//!    [`RHAT_MAX`](crate::diagnostics::RHAT_MAX), bulk and tail ESS above
//!    [`ESS_MIN`](crate::diagnostics::ESS_MIN), τ reliable, no stuck walkers.
//! 4. Writes `summary.json` and `summary.csv` atomically.
mod curves;
mod error;
pub mod kfold;
mod model;
pub mod run_dir;
mod sampling;
mod summarise;
pub mod watch;

use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use crate::data::Provenance;
use crate::density::{ColumnUnit, LogDensity, Quantity, Target};
use crate::optimize::{initial_around_optimum, SearchStart};
use crate::sampler::{
    CarryFit, EnsembleSampler, Move, Observer, Parallelism, RunReport, SamplerConfig, SamplerState,
    Steps, StopRule, Updates, DEFAULT_ENSEMBLES, DEFAULT_SEED,
};
use crate::storage::{ChainDescription, ChainReader, ParquetSink, SinkOptions, StorageError};
use sampling::{kept_rows_of, Sampling};

pub use crate::run_file::{RunFile, SamplerSpec};
pub use error::FitError;
pub use model::{fit_model, peak_notes, summary_spec, SettingOverrides};
pub use run_dir::{
    AggregateSummary, Comparison, FitSummary, ForwardModelRecord, LockError, QuantitySummary,
    RunDir, RunDirError, RunLock, RunRecord, SamplerSummary,
};

/// Default checkpoint interval, in steps.
pub const DEFAULT_CHECKPOINT_EVERY: u64 = 200;
/// Default walkers per ensemble (must still be at least twice the dimension).
pub const DEFAULT_WALKERS: usize = 32;
/// Default step cap of the stopping rule.
pub const DEFAULT_MAX_STEPS: u64 = 20_000;
/// Default probability of the equal-tailed interval and of the HDI.
pub const DEFAULT_INTERVAL_PROB: f64 = 0.95;
/// ChaCha8 stream of the seed used to draw the initial walkers; the sampler's streams are
/// `(ensemble << 32) | walker`, far from this one.
pub const INIT_STREAM: u64 = u64::MAX;
/// First ChaCha8 stream of the seed for the replicated observations of a finished run's draws
/// (the Python package's `posterior_predictive`): see [`replicate_rng`]. Disjoint from the
/// sampler's `(ensemble << 32) | walker` while there are fewer than 2³¹ ensembles.
pub const REPLICATE_STREAMS: u64 = 1 << 63;

/// The random stream of the replicated observations of the draw at chain row `row` (step ×
/// chains + chain, as the chains are stored) of a run sampled with `seed`: one stream per
/// draw, so that a draw's replicate is the same bits whichever other draws are replicated,
/// in whatever order or on however many threads.
pub fn replicate_rng(seed: u64, row: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(REPLICATE_STREAMS | row);
    rng
}

/// The default mixture of moves of a fit: nine tenths the Student-t independence proposal
/// fitted to the complementary half, which mixes in a few steps where the posterior is near
/// normal (several times faster than the stretch move on one contact; under hierarchical
/// updates every block is small enough for it), one tenth differential evolution, which
/// explores along differences between walkers and keeps the chains moving where the
/// complement is too small or too curved to fit a proposal to. The measurements behind the
/// choice are in `reports/fit-defaults.md`.
pub fn default_moves() -> Vec<(Move, f64)> {
    vec![
        (Move::student_t(), 0.9),
        (Move::differential_evolution(), 0.1),
    ]
}

/// The stopping rule of a fit run until converged: the sampler's rule (τ_max trusted, R̂ <
/// 1.01 on its history) with τ settled to 10 % between checks rather than emcee's 1 %,
/// which on short chains waits for the τ estimate's own noise to die down, hundreds of τ
/// after the chains are long enough (`reports/fit-defaults.md`). The fit then checks the
/// summary itself, on every post-burn-in draw of every reported quantity, and samples on
/// until that passes.
pub fn fit_stop_rule(max_steps: u64) -> StopRule {
    StopRule {
        tau_rel_change: 0.1,
        ..StopRule::new(max_steps)
    }
}

/// The default updates of a fit: hierarchical, over the default blocks (a material's shared
/// parameters, each contact's own), so that a sweep costs two evaluations of the runs and τ
/// (in sweeps) does not grow from one contact to a campaign (`reports/fit-defaults.md`).
pub fn default_updates() -> Updates {
    Updates::Hierarchical
}

/// The default walkers per ensemble of a fit of `density` with `updates` and `carry`:
/// max(32, 4·d + 4), where d is the number of coordinates one update moves (the dimension, or
/// the largest block when the updates are blocked and the density has two blocks or more, as
/// the sampler decides): the independence proposals are fitted to half the walkers, and a fit
/// of d dimensions from barely d + 1 points proposes poorly. With hierarchical updates whose
/// followers are carried by regressions fitted to the complement
/// ([`CarryFit::Complement`]), also at least 2·f + 4, f the largest number of followers a
/// block carries: the errors of all f coefficients add up in the acceptance ratio of the
/// shared block, so τ grows as f over the walkers. Under the default ([`CarryFit::Auto`]) a
/// block with that many followers is carried by a tuned regression instead, fitted to every
/// ensemble's draws of its tuning steps rather than to half the walkers of one step, so no
/// bound on the walkers is taken from it. Its error still grows as f over those draws, and
/// the shared block of a campaign does mix more slowly as contacts are added (the τ_max of
/// `reports/campaign-fit.md`). The measurements behind both bounds are in
/// `reports/fit-defaults.md`.
pub fn default_walkers<'d, D: LogDensity + ?Sized + 'd>(
    target: impl Into<Target<'d, D>>,
    updates: Updates,
    carry: CarryFit,
) -> usize {
    let target = target.into();
    let plan = match (updates, target.blocked_density()) {
        (Updates::Blocked | Updates::Hierarchical, Some(blocked)) => Some(blocked.block_plan()),
        _ => None,
    };
    let blocks = plan.as_ref().map_or(&[][..], |p| &p.blocks[..]);
    // One block (or none) is the whole space: the sampler updates jointly.
    let (span, followers) = if blocks.len() <= 1 {
        (target.density().dim(), 0)
    } else {
        let followers = match updates {
            // A tuned regression is fitted to many more draws (see above).
            Updates::Hierarchical if carry == CarryFit::Complement => blocks
                .iter()
                .map(|b| b.links.followers.len())
                .max()
                .unwrap_or(0),
            Updates::Joint | Updates::Blocked | Updates::Hierarchical => 0,
        };
        let span = blocks.iter().map(|b| b.coords.len()).max().unwrap_or(0);
        (span, followers)
    };
    (4 * span + 4).max(2 * followers + 4).max(DEFAULT_WALKERS)
}

/// A mean over several columns per draw, reported like a quantity (e.g. the F_d of a material
/// as the mean of its contacts').
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Aggregate {
    /// Reported name.
    pub name: String,
    /// Group.
    pub group: String,
    /// Unit (that of every column averaged).
    pub unit: String,
    /// The columns averaged.
    pub of: Vec<String>,
    /// What the mean is over, in words (e.g. "mean of the material's contacts").
    pub note: String,
}

/// Group comparison: for each `name` in `names`, and each ordered pair (A, B) of `groups`
/// (A before B in the list), the posterior of A − B and A / B, with intervals and P(A > B).
/// A and B are found among the quantities, then among the aggregates. Draws are paired by
/// (ensemble, walker, step). Pairs where A or B lacks the quantity are skipped; every name
/// must exist in at least two of the groups.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct ComparisonSpec {
    /// Quantity names to compare.
    pub names: Vec<String>,
    /// Groups, in the order that decides A and B.
    pub groups: Vec<String>,
}

/// What a fit's summary reports.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SummarySpec {
    /// The reported quantities.
    pub quantities: Vec<Quantity>,
    /// Means over several columns.
    pub aggregates: Vec<Aggregate>,
    /// Comparisons between groups.
    pub comparisons: ComparisonSpec,
    /// Where the data came from, recorded as they are.
    pub data: Vec<Provenance>,
    /// The forward model, recorded as it is.
    pub model: Option<ForwardModelRecord>,
}

impl SummarySpec {
    /// Reports `quantities`, nothing else.
    pub fn of(quantities: Vec<Quantity>) -> Self {
        Self {
            quantities,
            ..Self::default()
        }
    }
}

/// How to run and summarise a fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSettings {
    /// Walkers per ensemble (even, ≥ 4, ≥ 2·dim).
    pub walkers: usize,
    /// Independent ensembles (≥ 2 for R̂).
    pub ensembles: usize,
    /// Seed of every random stream; must be the original one when resuming.
    pub seed: u64,
    /// Run length. [`Steps::Fixed`] is the total number of steps (a resumed run runs the
    /// rest); [`Steps::UntilConverged`] caps the total at `max_steps`.
    pub steps: Steps,
    /// Steps between checkpoints; `None` checkpoints only at the end (a kill loses the run).
    pub checkpoint_every: Option<u64>,
    /// Probability of the equal-tailed credible interval, in (0, 1).
    pub ci_prob: f64,
    /// Probability of the highest-density interval, in (0, 1).
    pub hdi_prob: f64,
    /// Do not forward progress to the observer.
    pub quiet: bool,
    /// Replace the chains and checkpoint of an earlier run in the directory (fresh runs).
    pub overwrite: bool,
    /// Proposal moves and their weights; one is drawn per step and ensemble.
    pub moves: Vec<(Move, f64)>,
    /// Joint or blocked updates (settings written before blocked updates existed: joint).
    #[serde(default)]
    pub updates: Updates,
    /// How hierarchical updates carry a block's followers (settings written before this
    /// choice existed: fitted to the complement, as then).
    #[serde(default = "complement_carry")]
    pub carry: CarryFit,
    /// Wall-time budget of the fit (s), from its start; none by default. A run that hits it
    /// keeps what it sampled and reports `stopped_by: TimeCap`.
    #[serde(default)]
    pub max_time_s: Option<f64>,
}

impl Default for FitSettings {
    /// 32 walkers × 4 ensembles, the default seed, until converged (cap 20 000 steps),
    /// checkpoints every 200 steps, 95 % intervals.
    fn default() -> Self {
        Self {
            walkers: DEFAULT_WALKERS,
            ensembles: DEFAULT_ENSEMBLES,
            seed: DEFAULT_SEED,
            steps: Steps::UntilConverged(fit_stop_rule(DEFAULT_MAX_STEPS)),
            checkpoint_every: Some(DEFAULT_CHECKPOINT_EVERY),
            ci_prob: DEFAULT_INTERVAL_PROB,
            hdi_prob: DEFAULT_INTERVAL_PROB,
            quiet: false,
            overwrite: false,
            moves: default_moves(),
            updates: default_updates(),
            carry: CarryFit::default(),
            max_time_s: None,
        }
    }
}

fn complement_carry() -> CarryFit {
    CarryFit::Complement
}

fn invalid(name: &'static str, value: impl std::fmt::Display, req: &str) -> FitError {
    FitError::InvalidSetting {
        name,
        value: value.to_string(),
        requirement: req.to_owned(),
    }
}

impl FitSettings {
    fn validate(&self, resume: bool) -> Result<(), FitError> {
        for (name, p) in [("ci_prob", self.ci_prob), ("hdi_prob", self.hdi_prob)] {
            if !(p > 0.0 && p < 1.0) {
                return Err(invalid(name, p, "must lie strictly between 0 and 1"));
            }
        }
        if let Some(t) = self.max_time_s {
            if !(t.is_finite() && t > 0.0) {
                return Err(invalid(
                    "max_time_s",
                    t,
                    "must be a finite number of seconds > 0",
                ));
            }
        }
        if resume && self.overwrite {
            return Err(invalid(
                "overwrite",
                true,
                "cannot be combined with resume: resume continues the run, overwrite replaces it",
            ));
        }
        if !resume && matches!(self.steps, Steps::Fixed(0)) {
            return Err(invalid("steps", 0, "a new run needs at least one step"));
        }
        Ok(())
    }

    fn sampler_config(&self) -> Result<SamplerConfig, FitError> {
        SamplerConfig::new(self.walkers, self.ensembles, self.seed)
            .and_then(|c| c.with_checkpoint_every(self.checkpoint_every))
            .and_then(|c| c.with_moves(self.moves.clone()))
            .map(|c| c.with_updates(self.updates).with_carry(self.carry))
            .map_err(FitError::Config)
    }
}

/// The result of a fit.
#[derive(Debug, Clone)]
pub struct FitOutcome {
    /// The sampler's report of the whole run (τ, R̂ of the parameters, acceptance, ...).
    pub report: RunReport,
    /// What `summary.json` holds.
    pub summary: FitSummary,
    /// Where the outputs are.
    pub dir: RunDir,
}

/// Up to `max_draws` kept draws (after the burn-in) of the columns `names`, spread
/// evenly over the chains of a finished fit: one `Vec` per draw, in the order of `names`.
///
/// # Errors
/// [`FitError::RunDir`] when the chains cannot be read, [`FitError::Storage`] when they lack
/// a column.
pub fn kept_draws(
    outcome: &FitOutcome,
    names: &[String],
    max_draws: usize,
) -> Result<Vec<Vec<f64>>, FitError> {
    draws_from(&outcome.dir, &outcome.summary.sampler, names, max_draws)
}

/// [`kept_draws`] of the finished fit in `dir`, whose summary's sampler section is `sampler`.
///
/// # Errors
/// As [`kept_draws`].
pub(crate) fn draws_from(
    dir: &RunDir,
    sampler: &SamplerSummary,
    names: &[String],
    max_draws: usize,
) -> Result<Vec<Vec<f64>>, FitError> {
    let chains = dir.chain_reader()?;
    let rows = kept_rows(&chains, sampler, max_draws);
    let mut draws = vec![Vec::with_capacity(names.len()); rows.len()];
    // The rows asked for, one column at a time, read one row group at a time.
    for name in names {
        let column = chains
            .rows_of(name, &rows)
            .map_err(|source| FitError::Storage {
                context: format!("reading kept draws from {}", dir.path().display()),
                source,
            })?;
        for (draw, v) in draws.iter_mut().zip(column) {
            draw.push(v);
        }
    }
    Ok(draws)
}

/// Rows of `chains` kept after the burn-in recorded in `sampler`, at most
/// `max_draws` of them spread evenly over the chains, in row order.
pub fn kept_rows(
    chains: &crate::storage::ChainReader,
    sampler: &SamplerSummary,
    max_draws: usize,
) -> Vec<usize> {
    let first = chains.row(sampler.burn_in.min(chains.steps()), 0, 0);
    let kept = chains.rows() - first;
    let every = kept.div_ceil(max_draws.max(1)).max(1);
    (first..chains.rows()).step_by(every).collect()
}

/// Runs (or resumes) a fit of `target`'s density into `dir` and writes its summaries; see
/// the [module documentation](self). `start` is where the optimiser starts (ignored when
/// resuming, unless the run is started over because it was killed before its first
/// checkpoint). `observer` receives the sampler's progress unless `settings.quiet`. The
/// sampler evaluates as `parallelism` says (in this process by default); the chains and every
/// file are the same either way.
///
/// # Errors
/// [`FitError::InvalidSetting`], [`FitError::InvalidSpec`], [`FitError::Config`] before any
/// work; [`FitError::Storage`] when the directory holds another run (fresh) or no resumable
/// one (resume) or the chains cannot be written; [`FitError::ResumeMismatch`] when the
/// checkpoint belongs to other settings; [`FitError::Start`] when no starting walkers are
/// found; [`FitError::Sampler`] when sampling fails (the last checkpoint stays resumable);
/// [`FitError::TooFewDraws`], [`FitError::Diagnostics`] when the chains are too short to
/// summarise; [`FitError::RunDir`] when the chains cannot be read back or a summary cannot be
/// written.
#[allow(clippy::too_many_arguments)]
pub fn run_fit<'a, D: LogDensity + ?Sized + 'a>(
    target: impl Into<Target<'a, D>>,
    spec: &SummarySpec,
    start: impl Into<SearchStart<'a>>,
    settings: &FitSettings,
    dir: &RunDir,
    resume: bool,
    observer: &mut impl Observer,
    parallelism: Parallelism<'a>,
) -> Result<FitOutcome, FitError> {
    let (target, start) = (target.into(), start.into());
    let density = target.density();
    let started = Instant::now();
    settings.validate(resume)?;
    let param_names = density.param_names();
    let derived_names = density.derived_names();
    let plan = summarise::SummaryPlan::new(&param_names, &derived_names, spec)?;
    let (mut sampler, mut sink, steps, finished) = if resume {
        match resumed_sampler(target, settings, dir) {
            Err(FitError::Storage {
                source: StorageError::NoCheckpoint { .. },
                ..
            }) if dir.file(run_dir::CHAINS_DIR).is_dir() => {
                // Killed before its first checkpoint: nothing was saved to continue from, and
                // whatever parts it left hold the first steps of this very run. Starting over
                // with the same seed is what the uninterrupted run did.
                let restart = FitSettings {
                    overwrite: true,
                    ..settings.clone()
                };
                let (sampler, sink, steps) = fresh_sampler(target, start, &restart, dir)?;
                (sampler, sink, steps, false)
            }
            resumed => resumed?,
        }
    } else {
        let (sampler, sink, steps) = fresh_sampler(target, start, settings, dir)?;
        (sampler, sink, steps, false)
    };
    sampler.set_parallelism(parallelism);
    sink.describe(chain_description(density, spec, settings));
    dir.remove_summaries()?;
    // Quiet hides progress, but a request to stop must still reach the sampler.
    let mut stop_only = StopOnly(observer);
    let observer: &mut dyn Observer = if settings.quiet {
        &mut stop_only
    } else {
        stop_only.0
    };
    sampler.set_deadline(
        settings
            .max_time_s
            .map(|t| started + std::time::Duration::from_secs_f64(t)),
    );
    let first_step = sampler.step();
    let mut fit = Sampling {
        sampler,
        sink,
        plan,
        settings,
        dir,
        started,
        param_names: &param_names,
    };
    let (mut report, mut summary) = fit.run(steps, finished, observer)?;
    report.steps_run = fit.sampler.step() - first_step;
    summary.sampler.steps_run = report.steps_run;
    summary.sampler.stopped_by = report.stopped_by;
    let shown = dir.path().display();
    let storage = |context: String| move |source| FitError::Storage { context, source };
    // The parts' footers get the burn-in the summary used, now that it is final.
    fit.sink.set_burn_in(summary.sampler.burn_in);
    fit.sink
        .finish()
        .map_err(storage(format!("finishing the chains in {shown}")))?;
    dir.write_summary(&summary)?;
    Ok(FitOutcome {
        report,
        summary,
        dir: dir.clone(),
    })
}

/// A sampler, its sink, the steps to run, and whether the run had finished sampling, resumed
/// from the checkpoint in `dir`. A finished run (killed while its summaries or report were
/// written) runs no more steps: its chains are complete and only what follows is redone.
fn resumed_sampler<'a, D: LogDensity + ?Sized>(
    target: Target<'a, D>,
    settings: &FitSettings,
    dir: &RunDir,
) -> Result<(EnsembleSampler<'a, D>, ParquetSink, Steps, bool), FitError> {
    let config = settings.sampler_config()?;
    let param_names = target.density().param_names();
    let derived_names = target.density().derived_names();
    let shown = dir.path().display();
    let files = dir.chain_files();
    let storage = |context: String| move |source| FitError::Storage { context, source };
    let (sink, state, finished): (ParquetSink, SamplerState, bool) =
        ParquetSink::resume_finished(&files).map_err(storage(format!("resuming from {shown}")))?;
    sink.check_columns(&param_names, &derived_names)
        .map_err(storage(format!("resuming from {shown}")))?;
    let mismatch = |problem: String| FitError::ResumeMismatch {
        dir: dir.path().to_path_buf(),
        problem,
    };
    if state.seed != settings.seed {
        return Err(mismatch(format!(
            "the run was started with seed {} but seed {} was given; resume with the original seed",
            state.seed, settings.seed
        )));
    }
    if state.step != sink.steps() {
        return Err(FitError::Inconsistent {
            dir: dir.path().to_path_buf(),
            problem: format!(
                "the checkpoint's sampler state is at step {} but its chains end at step {}",
                state.step,
                sink.steps()
            ),
        });
    }
    // The checkpoint leaves out the sampler's thinned history; the chains hold it.
    let mut state = state;
    let chains = ChainReader::open(&files.chains)
        .map_err(storage(format!("reading the chains of {shown}")))?;
    let step = state.step;
    state
        .rebuild_history_rows(&config, kept_rows_of(&chains, &param_names, step))
        .map_err(|source| FitError::Sampler {
            context: format!("restoring the sampler's history from the chains of {shown}"),
            source,
        })?;
    drop(chains);
    let steps = match settings.steps {
        _ if finished => Steps::Fixed(0),
        Steps::Fixed(total) if total < state.step => {
            return Err(mismatch(format!(
                "the chains already hold {} steps, more than the {total} steps asked for",
                state.step
            )))
        }
        Steps::Fixed(total) => Steps::Fixed(total - state.step),
        rule @ Steps::UntilConverged(_) => rule,
    };
    let sampler =
        EnsembleSampler::from_state(target, config, state).map_err(|source| FitError::Sampler {
            context: format!("resuming the sampler from {shown}"),
            source,
        })?;
    Ok((sampler, sink, steps, finished))
}

/// A sampler started around the mode found from `start`, with a fresh sink in `dir`, and the
/// steps to run.
fn fresh_sampler<'a, D: LogDensity + ?Sized>(
    target: Target<'a, D>,
    start: SearchStart<'a>,
    settings: &FitSettings,
    dir: &RunDir,
) -> Result<(EnsembleSampler<'a, D>, ParquetSink, Steps), FitError> {
    let config = settings.sampler_config()?;
    let density = target.density();
    let shown = dir.path().display();
    let storage = |context: String| move |source| FitError::Storage { context, source };
    // The directory is claimed first: refusing an occupied one costs nothing, the
    // optimisation may cost a lot.
    let options = SinkOptions {
        overwrite: settings.overwrite,
        ..SinkOptions::default()
    };
    let sink = ParquetSink::create(
        &dir.chain_files(),
        &density.param_names(),
        &density.derived_names(),
        options,
    )
    .map_err(storage(format!("starting a run in {shown}")))?;
    let mut rng = ChaCha8Rng::seed_from_u64(settings.seed);
    rng.set_stream(INIT_STREAM);
    let initial = initial_around_optimum(
        target,
        start,
        settings.walkers,
        settings.ensembles,
        &mut rng,
    )
    .map_err(|optimizer| FitError::Start {
        start: start.point.to_vec(),
        why: density.explain(start.point),
        optimizer,
    })?;
    let sampler = EnsembleSampler::new(target, config, initial.walkers).map_err(|source| {
        FitError::Sampler {
            context: format!("starting the sampler for {shown}"),
            source,
        }
    })?;
    Ok((sampler, sink, settings.steps))
}

/// What the chain parts' footers say about a fit: seed, shape, and the units of every value
/// column (the density's own for its coordinates, else those of the quantity reported from a
/// column).
fn chain_description<D: LogDensity + ?Sized>(
    density: &D,
    spec: &SummarySpec,
    settings: &FitSettings,
) -> ChainDescription {
    let reported = |name: &String| {
        spec.quantities
            .iter()
            .find(|q| q.column == *name)
            .map(|q| ColumnUnit {
                unit: q.unit.clone(),
                log: false,
            })
            .unwrap_or_default()
    };
    // A column whose unit the density leaves undeclared gets the unit of the quantity reported
    // from it, if any.
    let declared = density.param_units();
    let param_units = density
        .param_names()
        .iter()
        .enumerate()
        .map(|(i, name)| {
            declared
                .get(i)
                .filter(|u| !u.unit.is_empty() || u.log)
                .cloned()
                .unwrap_or_else(|| reported(name))
        })
        .collect();
    ChainDescription {
        seed: settings.seed,
        ensembles: settings.ensembles,
        walkers: settings.walkers,
        // The sink records every step; only the sampler's in-memory history is thinned.
        thin: 1,
        param_units,
        derived_units: density.derived_names().iter().map(reported).collect(),
    }
}

/// Forwards only [`Observer::stop_requested`]: the observer of a quiet fit.
struct StopOnly<'a, O: Observer + ?Sized>(&'a mut O);

impl<O: Observer + ?Sized> Observer for StopOnly<'_, O> {
    fn stop_requested(&mut self) -> bool {
        self.0.stop_requested()
    }

    fn shows_progress(&self) -> bool {
        false
    }
}
