//! `slipbayes fit` and `slipbayes demo`: a model file (or the one-contact quick path) in, a run
//! directory with chains, summaries and the exact model out.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::bail;
use clap::Args;

use slipbayes::diagnostics::problem_lines;
use slipbayes::fit::run_dir::RUN_OUTPUT;
use slipbayes::fit::{fit_model, FitError, FitOutcome, FitSettings, RunLock, SettingOverrides};
use slipbayes::law::LawKind;
use slipbayes::model::spec::ForwardModel;
use slipbayes::model::{ModelSpec, OneContact, Posterior};
use slipbayes::output_dir::OutputDir;
use slipbayes::run_file::RunFile;
use slipbayes::sampler::{CarryFit, Mixture, Parallelism, Updates};

use super::import::ImportArgs;
use super::{law_name, non_negative, positive, EXIT_NOT_CONVERGED};
use crate::interrupt::{self, EXIT_INTERRUPTED};
use crate::progress::{ProgressBarObserver, DEFAULT_LINE_EVERY};

/// Where `demo` writes by default: a user's results, ignored by git (`/runs/` in
/// `.gitignore`), so that the main command leaves a clone clean.
pub(crate) const DEMO_OUT: &str = "runs/demo";

fn parse_window(text: &str) -> Result<[f64; 2], String> {
    let parts: Vec<&str> = text.split(',').collect();
    match parts.as_slice() {
        [a, b] => match (a.trim().parse::<f64>(), b.trim().parse::<f64>()) {
            (Ok(a), Ok(b)) => Ok([a, b]),
            _ => Err(format!("`{text}`: give two numbers START,END in seconds")),
        },
        _ => Err(format!("`{text}`: give START,END in seconds, e.g. 0,20000")),
    }
}

/// Fit a model to friction data and write a run directory.
///
/// Either a model file (`slipbayes fit models/demo.toml --out runs/demo`) or the one-contact
/// quick path that needs no model file:
///   slipbayes fit --first FIRST.csv [--repeat REPEAT.csv] --velocity 1e-9 --out DIR
/// The run directory gets `summary.json`, `summary.csv`, `chains/` (Parquet), `model.toml`
/// (the exact model fitted), `settings.json` and `predictive.csv` (posterior and posterior
/// predictive bands at the data times). A killed fit continues with `--resume` and
/// ends with the same chains; Ctrl-C stops it after a checkpoint and prints that command.
/// Progress goes to stderr: a bar on a terminal, else a line every --progress-every seconds.
/// Exit codes: 0 done; 1 error; 2 invalid command line; 3 with --strict, results written but
/// the run has not converged (R̂ < 1.01, ESS > 400, τ trusted); 130 interrupted (Ctrl-C).
#[derive(Debug, Args)]
#[command(verbatim_doc_comment)]
pub(super) struct FitArgs {
    /// Model file (TOML); omit to use the quick path flags.
    model: Option<PathBuf>,
    /// Output (run) directory.
    #[arg(long)]
    out: PathBuf,
    /// Quick path: data of a first slide (CSV, Parquet or RheoCompass export).
    #[arg(long, conflicts_with = "model")]
    first: Option<PathBuf>,
    /// Quick path: CSV of the repeat slide that followed it.
    #[arg(long, requires = "first")]
    repeat: Option<PathBuf>,
    /// Quick path: sliding velocity (m/s).
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    velocity: Option<f64>,
    /// Quick path: the first slide is fast and declared stiff (no elastic correction).
    #[arg(long, requires = "first")]
    stiff: bool,
    /// Quick path: the law of the first slide, `aging-rejuvenation` (default) or `log-aging`
    /// (its α → 0 limit), as `law` in a model file.
    #[arg(long, value_parser = law_name, requires = "first")]
    law: Option<LawKind>,
    /// Quick path: the machine is rigid (k → ∞, no elastic correction; `elastic = false` in a
    /// model file).
    #[arg(long, requires = "first")]
    rigid: bool,
    /// Quick path: normal force (N), for μ_s.
    #[arg(long = "normal-force", allow_hyphen_values = true, value_parser = positive)]
    normal_force: Option<f64>,
    /// Quick path: fit the first slide only within START,END (s of instrument time).
    #[arg(long = "window-s", value_parser = parse_window, requires = "first")]
    window_s: Option<[f64; 2]>,
    /// Quick path: largest error of each long slide's log-likelihood when it is evaluated on
    /// sufficient statistics of bins of its points (0: every point exactly; default 0.01 for
    /// slides of more than 10,000 points).
    #[arg(long = "likelihood-tolerance", value_parser = non_negative, requires = "first")]
    likelihood_tolerance: Option<f64>,
    /// Quick path: how to read the data files.
    #[command(flatten)]
    import: ImportArgs,
    #[command(flatten)]
    run: RunArgs,
}

/// Settings shared by `fit` and `demo`.
#[derive(Debug, Args)]
pub(super) struct RunArgs {
    /// Seed (overrides the model file's).
    #[arg(long)]
    seed: Option<u64>,
    /// Walkers per ensemble (default: the model file's, else max(32, 4·d + 4, 2·f + 4), d the
    /// coordinates one update moves, f the most followers a hierarchical update carries).
    #[arg(long)]
    walkers: Option<usize>,
    /// Fixed number of steps (default: the model file's, else run until converged).
    #[arg(long)]
    steps: Option<u64>,
    /// Step cap when running until converged.
    #[arg(long = "max-steps")]
    max_steps: Option<u64>,
    /// Wall-time budget of the fit in seconds; a run that hits it writes its results and
    /// says what it would still need.
    #[arg(long = "max-time", allow_hyphen_values = true, value_parser = positive)]
    max_time: Option<f64>,
    /// Continue a killed fit in the output directory.
    #[arg(long)]
    resume: bool,
    /// Replace an earlier fit in the output directory.
    #[arg(long)]
    overwrite: bool,
    /// No progress bar or progress lines.
    #[arg(long)]
    quiet: bool,
    /// Seconds between progress lines when stderr is not a terminal (batch jobs, logs).
    #[arg(
        long = "progress-every",
        default_value_t = DEFAULT_LINE_EVERY.as_secs_f64(),
        allow_hyphen_values = true,
        value_parser = positive
    )]
    progress_every: f64,
    /// Exit with status 3 when the run has not converged (results are written either way).
    #[arg(long)]
    strict: bool,
    /// Proposal moves and weights, e.g. `student-t=0.8,stretch=0.2` (moves: stretch, de,
    /// walk, gaussian, student-t, snooker, kde, slice, slice-gaussian); default: the model
    /// file's, else the fit's default mixture.
    #[arg(long)]
    moves: Option<Mixture>,
    /// `joint` (every coordinate at once), `blocked` (one block after the other: a material's
    /// shared parameters, then each contact's own) or `hierarchical` (blocked, the shared
    /// parameters carrying their contacts along, each contact proposed given them); default:
    /// the model file's, else hierarchical.
    #[arg(long)]
    updates: Option<Updates>,
    /// How hierarchical updates carry a shared block's followers: `complement` (a regression
    /// fitted to the complementary half at every half-step), `tuned` (fitted to the
    /// ensembles' draws of the first 100 steps, then fixed) or `auto` (tuned where the
    /// complement is smaller than the followers); default: the model file's, else auto.
    #[arg(long)]
    carry: Option<CarryFit>,
}

/// Run the main job: fit `models/demo.toml` (the bundled data) into `runs/demo/`, your own
/// results (git-ignored), replacing an earlier demo there (unless --resume).
///
/// The committed example report `reports/demo/` is not touched. Regenerating it is a
/// maintainer's step of its own, run from the repository root:
///   slipbayes demo --out reports/demo
#[derive(Debug, Args)]
#[command(verbatim_doc_comment)]
pub(super) struct DemoArgs {
    /// The demo model file.
    #[arg(long, default_value = "models/demo.toml")]
    model: PathBuf,
    /// Output (run) directory; `reports/demo` regenerates the committed example report.
    #[arg(long, default_value = DEMO_OUT)]
    out: PathBuf,
    #[command(flatten)]
    run: RunArgs,
}

/// The ranks of an MPI job that share a fit's evaluations (`None`: this process alone).
#[cfg(feature = "mpi")]
pub(super) type Ranks<'c> = Option<&'c mut slipbayes::distributed::Cluster>;
/// Without MPI there are no ranks to share with.
#[cfg(not(feature = "mpi"))]
pub(super) type Ranks<'c> = Option<&'c mut std::convert::Infallible>;

/// Where a fit of `posterior` with `updates` evaluates: on `ranks`, told first which density to
/// build (where every update that reads data is a contact's own or splits by contact, each
/// holds only its own contacts' data; joint updates never split by contact, so that a rank
/// holding a share would idle), or in this process.
#[cfg(feature = "mpi")]
fn parallelism<'p>(
    ranks: &'p mut Ranks<'_>,
    posterior: &Posterior,
    updates: Updates,
) -> Parallelism<'p> {
    match ranks {
        Some(cluster) => {
            let share = match updates {
                Updates::Joint => None,
                Updates::Blocked | Updates::Hierarchical => posterior.data_share(),
            };
            cluster.share_density(share.as_ref());
            Parallelism::from(&mut **cluster)
        }
        None => Parallelism::default(),
    }
}

/// Without MPI, every fit evaluates in this process.
#[cfg(not(feature = "mpi"))]
fn parallelism<'p>(
    _ranks: &'p mut Ranks<'_>,
    _posterior: &Posterior,
    _updates: Updates,
) -> Parallelism<'p> {
    Parallelism::default()
}

/// `fit`, its evaluations shared by `ranks` when given (the ranks of an MPI job).
pub(super) fn run(args: &FitArgs, ranks: Ranks<'_>) -> anyhow::Result<ExitCode> {
    fit_and_report(&fit_run_file(args)?, &args.out, &args.run, false, ranks)
}

/// The run `fit` fits: the model file, or the quick path's one-contact model with the
/// default sampler settings.
pub(super) fn fit_run_file(args: &FitArgs) -> anyhow::Result<RunFile> {
    Ok(match (&args.model, &args.first) {
        (Some(path), None) => RunFile::load(path)?,
        (None, Some(first)) => quick_model(args, first)?,
        (None, None) => {
            bail!("give a model file, or --first FIRST.csv for the one-contact quick path")
        }
        (Some(_), Some(_)) => bail!("give either a model file or --first, not both"),
    })
}

/// `demo`, its evaluations shared by `ranks` when given.
pub(super) fn demo(args: &DemoArgs, ranks: Ranks<'_>) -> anyhow::Result<ExitCode> {
    let run_file = demo_run_file(args)?;
    // The main job is re-run as it is: it replaces its earlier results unless resuming.
    fit_and_report(&run_file, &args.out, &args.run, !args.run.resume, ranks)
}

/// The run `demo` fits.
pub(super) fn demo_run_file(args: &DemoArgs) -> anyhow::Result<RunFile> {
    if !args.model.exists() {
        bail!("{}", missing_demo_model(&args.model));
    }
    Ok(RunFile::load(&args.model)?)
}

/// Where `demo` looked for its model and how to point it at the one bundled with the source.
fn missing_demo_model(model: &Path) -> String {
    let looked = std::env::current_dir()
        .map(|cwd| cwd.join(model))
        .unwrap_or_else(|_| model.to_path_buf());
    // The repository this binary was built from, if it is still there.
    let bundled = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/demo.toml");
    let hint = match bundled.canonicalize() {
        Ok(path) => format!("--model {}", path.display()),
        Err(_) => "--model PATH/TO/slipbayes/models/demo.toml".to_owned(),
    };
    format!(
        "no demo model at {} (`demo` reads {} relative to the current directory): run it from \
         the root of the slipbayes repository, or point it at the bundled model with `slipbayes \
         demo {hint} --out DIR`",
        looked.display(),
        model.display()
    )
}

/// The one-contact model of the quick path: groups `first`, `repeat` (runs) and `contact`.
fn quick_model(args: &FitArgs, first: &Path) -> anyhow::Result<RunFile> {
    let Some(velocity_m_per_s) = args.velocity else {
        bail!("--velocity is required with --first (m/s, e.g. 1e-9 for 1 nm/s)");
    };
    let model = ModelSpec::one_contact(&OneContact {
        first: first.to_path_buf(),
        repeat: args.repeat.clone(),
        velocity_m_per_s,
        stiff: args.stiff,
        normal_force_n: args.normal_force,
        window_s: args.window_s,
        likelihood_tolerance: args.likelihood_tolerance,
        import: args.import.options(),
        forward: ForwardModel {
            law: args.law.unwrap_or_default(),
            elastic: !args.rigid,
            ..ForwardModel::default()
        },
    })?;
    Ok(RunFile::with_default_sampler(model))
}

impl RunArgs {
    fn overrides(&self, overwrite: bool) -> SettingOverrides {
        SettingOverrides {
            seed: self.seed,
            walkers: self.walkers,
            steps: self.steps,
            max_steps: self.max_steps,
            max_time_s: self.max_time,
            quiet: self.quiet,
            overwrite: self.overwrite || overwrite,
            moves: self.moves.as_ref().map(|m| m.moves().to_vec()),
            updates: self.updates,
            carry: self.carry,
        }
    }
}

fn fit_and_report(
    run_file: &RunFile,
    out: &Path,
    run: &RunArgs,
    replace_earlier: bool,
    mut ranks: Ranks<'_>,
) -> anyhow::Result<ExitCode> {
    let posterior = run_file.posterior()?;
    let settings = FitSettings::for_model(
        &posterior,
        &run_file.sampler,
        &run.overrides(replace_earlier),
    );
    // Locked first, so that a directory another fit holds is left as it is. Only --overwrite
    // lets a run into a directory that is not ours: `demo` replaces an earlier run of its
    // own, never a user's files. A refused directory keeps nothing (the lock goes with it).
    let lock = RunLock::acquire(out)?;
    OutputDir::claim(out, RUN_OUTPUT, run.overwrite)?;
    interrupt::install();
    let mut observer =
        ProgressBarObserver::new(run.quiet, Duration::from_secs_f64(run.progress_every))
            .stop_when(&interrupt::INTERRUPTED);
    let command: Vec<String> = std::env::args().collect();
    let outcome = match fit_model(
        run_file,
        &posterior,
        &settings,
        &lock,
        run.resume,
        command.clone(),
        &mut observer,
        parallelism(&mut ranks, &posterior, settings.updates),
    ) {
        Err(FitError::Interrupted { dir, step }) => {
            eprintln!(
                "interrupted at step {step}: the chains and checkpoint in {} are written; \
                 resume with:\n  {}",
                dir.display(),
                interrupt::resume_command(&command)
            );
            return Ok(ExitCode::from(EXIT_INTERRUPTED));
        }
        result => result?,
    };
    print_summary(&outcome);
    #[cfg(feature = "report")]
    super::report::write_and_print(&outcome.dir)?;
    let converged = outcome.summary.sampler.converged;
    if !converged {
        eprintln!(
            "warning: the run has not converged by every criterion (see the problems above); \
             its results are written but should not be trusted blindly"
        );
    }
    Ok(if converged || !run.strict {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_NOT_CONVERGED)
    })
}

fn print_summary(outcome: &FitOutcome) {
    let s = &outcome.summary;
    println!(
        "{:<32} {:>12} {:>12} {:>12} {:>7} {:>8} {:>8}",
        "quantity", "median", "ci_low", "ci_high", "r_hat", "ess_bulk", "ess_tail"
    );
    for q in s.parameters.iter().chain(&s.derived) {
        let st = &q.stats;
        println!(
            "{:<32} {:>12.4e} {:>12.4e} {:>12.4e} {:>7.4} {:>8.0} {:>8.0}",
            format!("{}[{}] ({})", q.name, q.group, q.unit),
            st.median,
            st.ci_low,
            st.ci_high,
            st.r_hat.unwrap_or(f64::NAN),
            st.ess_bulk,
            st.ess_tail
        );
    }
    for c in &s.comparisons {
        println!(
            "P({}[{}] > {}[{}]) = {:.3}",
            c.name, c.group_a, c.name, c.group_b, c.p_a_greater
        );
    }
    let m = &s.sampler;
    println!(
        "sampler: {} ensembles × {} walkers × {} steps (burn-in {}), acceptance {:.3}, τ_max {:.1}, {} evaluations, {:.1} s; converged: {}",
        m.ensembles, m.walkers, m.steps, m.burn_in, m.acceptance, m.tau_max.unwrap_or(f64::NAN), m.log_density_evals, m.wall_s, m.converged
    );
    for line in problem_lines(&m.problems, m.steps, m.burn_in, m.walkers * m.ensembles) {
        println!("  problem: {line}");
    }
    for d in &s.data {
        if let Some(b) = &d.binning {
            println!(
                "run `{}`: likelihood on sufficient statistics of {} bins (degree {}), {} model \
                 times per evaluation for {} points; |Δ log L| ≤ {:.2e} (tolerance {})",
                d.run, b.bins, b.degree, b.evaluations, d.points_used, b.bound, b.tolerance
            );
        }
    }
    if let Some(loo) = &s.loo {
        println!(
            "PSIS-LOO: elpd_loo {:.2} ± {:.2}, p_loo {:.2} ({} draws, r_eff {:.2}); {} of {} points \
             with Pareto k̂ > {:.2}{}",
            loo.elpd_loo,
            loo.se,
            loo.p_loo,
            loo.draws,
            loo.r_eff,
            loo.unreliable_points,
            loo.runs.iter().map(|r| r.points).sum::<usize>(),
            loo.good_k,
            if loo.unreliable_points > 0 {
                format!(
                    " (their elpd is unreliable: cross-validate with `slipbayes kfold {}` before \
                     comparing models)",
                    outcome.dir.path().display()
                )
            } else {
                String::new()
            }
        );
    }
    if let Some(reason) = &s.loo_not_computed {
        println!("PSIS-LOO not computed: {reason}");
    }
    for note in &s.notes {
        println!("  note: {note}");
    }
    if let Some(model) = s.model.as_ref().filter(|m| !m.unread.is_empty()) {
        println!(
            "  note: not read under law = \"{}\"{}: {} (their parameters are not sampled)",
            model.law,
            if model.elastic {
                ""
            } else {
                ", elastic = false"
            },
            model.unread.join(", ")
        );
    }
    println!("written to {}", outcome.dir.path().display());
}
