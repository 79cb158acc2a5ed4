//! `slipbayes validate`: simulation-based calibration of the whole pipeline on any model of first and repeat slides.

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::atomic::{AtomicUsize, Ordering};

use anyhow::Context;
use clap::Args;

use super::EXIT_MISCALIBRATED;
use crate::validate::{
    run_sbc, summarise, write_report, GrossLimits, Replication, SbcSettings, FITS_DIR,
    REPLICATIONS_TABLE, SETTINGS_FILE,
};
use slipbayes::output_dir::{OutputDir, OutputKind};
use slipbayes::sampler::Mixture;

/// The output directory of `validate` ([`OutputDir::claim`]): what it writes there (the
/// replications' table and scratch fits, the report, the hard cases, and the folder of
/// per-replication records of earlier versions, which it converts and removes).
const VALIDATION_OUTPUT: OutputKind = OutputKind {
    name: "validation",
    writes: &[
        SETTINGS_FILE,
        REPLICATIONS_TABLE,
        "replications",
        FITS_DIR,
        "validation.json",
        "validation.md",
        "rank_histograms.svg",
        "hard",
    ],
    writes_prefixed: &[],
    written_before_markers: holds_validation,
};

/// Whether `dir`, which carries no marker, was written by a `validate` of a release that
/// wrote none: its `settings.json` holds the settings of a validation, or it holds the hard
/// cases' results.
fn holds_validation(dir: &std::path::Path) -> bool {
    let settings = std::fs::read(dir.join(SETTINGS_FILE))
        .ok()
        .is_some_and(|bytes| serde_json::from_slice::<SbcSettings>(&bytes).is_ok());
    settings || dir.join("hard").join("hard_cases.json").is_file()
}

/// Simulation-based calibration (Talts et al. 2018): draw parameters from the model's priors,
/// simulate a first and a repeat slide, fit them, and rank the truth among the posterior draws.
///
/// Writes to --out: replications.csv (a row per replication, appended as each finishes;
/// re-running the same command continues where it stopped), validation.json,
/// rank_histograms.svg and validation.md (χ² uniformity test and 50 %/95 % coverage per
/// quantity). Exit code 4 ("miscalibrated") on gross miscalibration (95 % coverage below
/// --min-coverage95, 50 % coverage outside [20 %, 80 %], χ² p < 1e-4, or more than 5 % failed
/// fits), and with --hard when a case fails; 2 is an invalid command line, 1 an error.
///
/// Under mpirun (a build with the feature `mpi`) every rank runs a share of the
/// replications and rank 0 writes --out: the same results as one process (docs/mpi.md).
#[derive(Debug, Args)]
#[command(verbatim_doc_comment)]
pub(super) struct ValidateArgs {
    /// The model with the priors to draw from and fit with (every run a first slide or a
    /// repeat slide that follows one; `models/sbc_pooled.toml` is a pooled campaign).
    #[arg(long, default_value = "models/sbc.toml")]
    model: PathBuf,
    /// Output directory.
    #[arg(long, default_value = "reports/validation")]
    out: PathBuf,
    /// Replications.
    #[arg(long, default_value_t = 200)]
    replications: usize,
    /// Seed; replication i uses stream i of it.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Simulated first slide: length (s).
    #[arg(long, default_value_t = 20_000.0)]
    first_duration: f64,
    /// Simulated first slide: sampling interval (s).
    #[arg(long, default_value_t = 100.0)]
    first_interval: f64,
    /// Simulated repeat slide: length (s).
    #[arg(long, default_value_t = 2_000.0)]
    repeat_duration: f64,
    /// Simulated repeat slide: sampling interval (s).
    #[arg(long, default_value_t = 40.0)]
    repeat_interval: f64,
    /// Walkers per ensemble of each fit.
    #[arg(long, default_value_t = 16)]
    walkers: usize,
    /// Ensembles of each fit.
    #[arg(long, default_value_t = 4)]
    ensembles: usize,
    /// Steps of each fit.
    #[arg(long, default_value_t = 1_000)]
    steps: u64,
    /// L, the thinned posterior draws each truth is ranked among (L + 1 a multiple of 10).
    #[arg(long, default_value_t = 99)]
    rank_draws: usize,
    /// Smallest acceptable coverage of the 95 % intervals.
    #[arg(long, default_value_t = 0.8)]
    min_coverage95: f64,
    /// Discard the replications of an earlier run in --out and start again.
    #[arg(long)]
    overwrite: bool,
    /// No line per replication.
    #[arg(long)]
    quiet: bool,
    /// Only summarise the replications already finished in --out (e.g. of a run still going).
    #[arg(long)]
    report_only: bool,
    /// Run the hard cases instead (into OUT/hard/): peak beyond the record, a short record,
    /// k near stick-slip, t0 = 1e-6 s, large noise, a 10^6-point slide.
    #[arg(long)]
    hard: bool,
    /// With --hard: only this case (repeatable).
    #[arg(long = "case", requires = "hard")]
    cases: Vec<String>,
    /// With --hard: the fits' moves instead of the default mixture, as `fit --moves` writes
    /// them (e.g. `student-t=0.4,de=0.4,slice=0.2`).
    #[arg(long, requires = "hard")]
    moves: Option<Mixture>,
    /// With --hard: the step cap of the fits run until converged (default 20 000).
    #[arg(long, requires = "hard")]
    max_steps: Option<u64>,
}

pub(super) fn run(args: &ValidateArgs) -> anyhow::Result<ExitCode> {
    OutputDir::claim(&args.out, VALIDATION_OUTPUT, args.overwrite)?;
    if args.hard {
        return hard(args);
    }
    let settings = sbc_settings(args);
    let finished = AtomicUsize::new(0);
    let progress = progress_lines(args, &finished);
    let reps = if args.report_only {
        crate::validate::finished_replications(&args.out)?
    } else {
        run_sbc(&settings, &args.out, args.overwrite, &progress)
            .with_context(|| format!("validating into {}", args.out.display()))?
    };
    report(args, &settings, &reps)
}

/// Rank 0 of `mpirun -n R slipbayes validate`: opens the run, gives every rank the list of
/// replications still to run, runs its share, records every rank's replications and writes
/// the report (see `crate::validate::ranks`). The other ranks run [`run_rank`].
#[cfg(feature = "mpi")]
pub(super) fn run_root(
    args: &ValidateArgs,
    cluster: &mut slipbayes::distributed::Cluster,
) -> anyhow::Result<ExitCode> {
    use crate::validate::{ranks, SbcRun};
    if args.hard {
        anyhow::bail!("validate --hard runs its cases in one process; run it without mpirun");
    }
    let settings = sbc_settings(args);
    if let Err(e) = OutputDir::claim(&args.out, VALIDATION_OUTPUT, args.overwrite) {
        // Nothing for the other ranks to run: they wait for the release.
        cluster.broadcast_list(None);
        return Err(e.into());
    }
    let opened = if args.report_only {
        Ok(None)
    } else {
        SbcRun::open(&settings, &args.out, args.overwrite)
            .and_then(|run| Ok(Some((run, ranks::fingerprint(&settings)?))))
    };
    let (run, fingerprint) = match opened {
        Ok(Some(opened)) => opened,
        // Nothing for the other ranks to run: they wait for the release.
        Ok(None) => {
            cluster.broadcast_list(None);
            let reps = crate::validate::finished_replications(&args.out)?;
            return report(args, &settings, &reps);
        }
        Err(e) => {
            cluster.broadcast_list(None);
            return Err(e).with_context(|| format!("validating into {}", args.out.display()));
        }
    };
    let mut reps = run.finished();
    let pending = run.pending(&reps);
    let list: Vec<u64> = std::iter::once(fingerprint)
        .chain(pending.iter().map(|&i| i as u64))
        .collect();
    cluster.broadcast_list(Some(&list));
    let finished = AtomicUsize::new(0);
    let progress = progress_lines(args, &finished);
    match ranks::run_root(&run, &pending, cluster, &progress) {
        Ok(shared) => {
            if cluster.size() > 1 {
                eprintln!(
                    "MPI: {} ranks; rank 0 ran {} of the {} replications to run and received {} \
                     from the other ranks",
                    cluster.size(),
                    shared.replications.len() - shared.received,
                    pending.len(),
                    shared.received
                );
            }
            reps.extend(shared.replications.into_iter().map(|r| (r.index, r)));
        }
        Err(e) => {
            let err = anyhow::Error::new(e).context(format!(
                "validating into {} (the replications written are kept: the same command \
                 continues with the rest)",
                args.out.display()
            ));
            for line in super::error_lines(&err) {
                eprintln!("rank 0: {line}");
            }
            // The other ranks are running their shares: end the whole job.
            cluster.abort(1)
        }
    }
    let reps: Vec<Replication> = reps.into_values().collect();
    report(args, &settings, &reps)
}

/// A rank other than 0 of `mpirun -n R slipbayes validate`: runs its share of the
/// replications rank 0 lists and sends each to rank 0; nothing when rank 0 lists none (it
/// failed, or only reports).
#[cfg(feature = "mpi")]
pub(super) fn run_rank(
    args: &ValidateArgs,
    cluster: &mut slipbayes::distributed::Cluster,
) -> anyhow::Result<()> {
    use crate::validate::{ranks, SbcRun};
    if args.hard {
        return Ok(());
    }
    let Some(list) = cluster.broadcast_list(None) else {
        return Ok(());
    };
    let Some((&root_fingerprint, pending)) = list.split_first() else {
        anyhow::bail!("rank 0 sent an empty list of replications");
    };
    let pending: Vec<usize> = pending.iter().map(|&i| i as usize).collect();
    if ranks::share(&pending, cluster.size(), cluster.rank()).is_empty() {
        return Ok(());
    }
    let settings = sbc_settings(args);
    let run = SbcRun::load(&settings, &args.out)
        .with_context(|| format!("loading the model {}", args.model.display()))?;
    if ranks::fingerprint(&settings)? != root_fingerprint {
        anyhow::bail!(
            "the settings or the model file {} differ from rank 0's: every rank must run the \
             same command on the same model file",
            args.model.display()
        );
    }
    ranks::run_rank(&run, &pending, cluster);
    Ok(())
}

fn sbc_settings(args: &ValidateArgs) -> SbcSettings {
    SbcSettings {
        model: args.model.clone(),
        replications: args.replications,
        seed: args.seed,
        first_duration_s: args.first_duration,
        first_interval_s: args.first_interval,
        repeat_duration_s: args.repeat_duration,
        repeat_interval_s: args.repeat_interval,
        walkers: args.walkers,
        ensembles: args.ensembles,
        steps: args.steps,
        rank_draws: args.rank_draws,
    }
}

/// A line per finished replication on stderr (none with --quiet); `finished` counts them.
fn progress_lines<'a>(
    args: &'a ValidateArgs,
    finished: &'a AtomicUsize,
) -> impl Fn(&Replication) + Sync + 'a {
    let total = args.replications;
    move |rep: &Replication| {
        let n = finished.fetch_add(1, Ordering::Relaxed) + 1;
        if !args.quiet {
            match &rep.failure {
                None => eprintln!(
                    "replication {:>5} done ({n} this run of {total}): {:.1} s, τ_max {:.0}, converged {}",
                    rep.index,
                    rep.wall_s,
                    rep.tau_max.unwrap_or(f64::NAN),
                    rep.converged
                ),
                Some(f) => eprintln!("replication {:>5} failed: {f}", rep.index),
            }
        }
    }
}

/// Summarises `reps`, writes the report into --out and prints its table; exit code 4 on gross
/// miscalibration.
fn report(
    args: &ValidateArgs,
    settings: &SbcSettings,
    reps: &[Replication],
) -> anyhow::Result<ExitCode> {
    let report = summarise(settings, reps);
    let limits = GrossLimits {
        min_coverage95: args.min_coverage95,
        ..GrossLimits::default()
    };
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    write_report(&report, &limits, &args.out, &command)?;
    println!(
        "{:<24} {:>8} {:>8} {:>10} {:>10} {:>10}",
        "quantity", "chi2", "p", "p(quant)", "cover50", "cover95"
    );
    for q in &report.quantities {
        println!(
            "{:<24} {:>8.1} {:>8.3} {:>10.3} {:>10.3} {:>10.3}",
            q.column,
            q.uniformity.chi2,
            q.uniformity.p_value,
            q.quantile_uniformity
                .as_ref()
                .map_or(f64::NAN, |u| u.p_value),
            q.coverage50.rate,
            q.coverage95.rate
        );
    }
    println!(
        "{} replications with ranks, {} failed; written to {}",
        report.succeeded,
        report.failures.len(),
        args.out.display()
    );
    let problems = report.gross_problems(&limits);
    for p in &problems {
        eprintln!("miscalibrated: {p}");
    }
    Ok(if problems.is_empty() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_MISCALIBRATED)
    })
}

fn hard(args: &ValidateArgs) -> anyhow::Result<ExitCode> {
    let out = args.out.join("hard");
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let mut progress = |o: &crate::validate::hard::HardOutcome| {
        if !args.quiet {
            eprintln!(
                "{}: {} in {:.1} s{}",
                o.case.name,
                if o.passed { "passed" } else { "FAILED" },
                o.wall_s,
                o.error
                    .as_ref()
                    .map_or(String::new(), |e| format!(" ({e})"))
            );
        }
    };
    let outcomes = crate::validate::hard::run_hard_cases(
        &out,
        &args.cases,
        args.seed,
        crate::validate::hard::FitOverrides {
            moves: args.moves.as_ref().map(Mixture::moves),
            max_steps: args.max_steps,
        },
        &command,
        &mut progress,
    )
    .with_context(|| format!("writing the hard cases into {}", out.display()))?;
    println!("written to {}", out.join("hard_cases.md").display());
    Ok(if outcomes.iter().all(|o| o.passed) {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_MISCALIBRATED)
    })
}
