//! `slipbayes watch`: follows a first slide's export while the instrument writes it, refits it
//! as rows arrive, and says what the peak is so far and whether to let the slide run on.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use anyhow::Context;
use clap::Args;

use slipbayes::data::follow::Follower;
use slipbayes::data::write_atomically;
use slipbayes::fit::run_dir::RUN_OUTPUT;
use slipbayes::fit::watch::{forecast, forecast_csv, warm_point, Criterion, Interval, PeakSoFar};
use slipbayes::fit::{fit_model, FitError, FitSettings, FitSummary, RunLock, SettingOverrides};
use slipbayes::law::LawKind;
use slipbayes::model::spec::ForwardModel;
use slipbayes::model::{ModelSpec, OneContact};
use slipbayes::output_dir::{OutputDir, OutputKind};
use slipbayes::run_file::RunFile;
use slipbayes::sampler::Parallelism;

use super::import::ImportArgs;
use super::{law_name, positive, EXIT_NOT_CONVERGED};
use crate::interrupt::{self, EXIT_INTERRUPTED};
use crate::progress::ProgressBarObserver;

/// What `watch` writes into its directory.
const WATCH_OUTPUT: OutputKind = OutputKind {
    name: "watch",
    writes: &[DATA, REFITS, LATEST, HISTORY, FORECAST],
    writes_prefixed: &[],
    written_before_markers: |_| false,
};
const DATA: &str = "data";
const REFITS: &str = "refits";
const LATEST: &str = "latest";
const HISTORY: &str = "watch.csv";
const FORECAST: &str = "forecast.csv";
/// The quick path's name for the first slide.
const RUN: &str = "first";
/// Refits kept on disk: the latest and the one before (which a reader may still hold open).
const KEPT_REFITS: usize = 2;
/// Points of the forecast.
const FORECAST_POINTS: usize = 200;

/// Follow a first slide's export while the instrument writes it: refit it as rows arrive and
/// say what the peak is so far.
///
///   slipbayes watch EXPORT.txt --velocity 1e-9 --out runs/live --until-width 0.01
///
/// Reads the export's complete rows (a half-written last row waits for the next read; an
/// export the software rewrites or rotates starts the record over), refits the slide with the
/// one-contact quick path whenever rows have arrived, each refit starting from the last one's
/// posterior, and prints, per refit, F_peak, τ_peak, t_peak and μ_s with their 95 % intervals
/// and whether the peak is already inside the record or extrapolated by the law.
///
/// The directory holds `latest/` (the last complete refit: a run directory with its report,
/// switched atomically), `forecast.csv` (the posterior predictive of the rest of the slide,
/// from the end of the record to --horizon-s), `watch.csv` (one row per refit) and `data/`
/// (the rows fitted last). Stops when the criterion is met (--until-width, --until-peak-observed;
/// exit 0, printing the time it was met), when the export has not grown for --idle-s seconds
/// (exit 3 when a criterion was given and not met), or on Ctrl-C (exit 130; `latest/` stays the
/// last complete refit).
#[derive(Debug, Args)]
#[command(verbatim_doc_comment)]
pub(super) struct WatchArgs {
    /// The export being written (CSV, RheoCompass, TRIOS or rSpace text).
    export: PathBuf,
    /// Output directory.
    #[arg(long)]
    out: PathBuf,
    /// Sliding velocity (m/s).
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    velocity: f64,
    /// Normal force (N), for μ_s (default: the export's normal-force column, if any).
    #[arg(long = "normal-force", allow_hyphen_values = true, value_parser = positive)]
    normal_force: Option<f64>,
    /// The law, `aging-rejuvenation` (default) or `log-aging`.
    #[arg(long, value_parser = law_name)]
    law: Option<LawKind>,
    /// The machine is rigid (no elastic correction).
    #[arg(long)]
    rigid: bool,
    /// Stop once F_peak's 95 % interval is narrower than this fraction of its median
    /// (e.g. 0.01), in a converged refit.
    #[arg(long = "until-width", allow_hyphen_values = true, value_parser = positive)]
    until_width: Option<f64>,
    /// Stop once the peak is inside the record (probability ≥ 0.95), in a converged refit.
    #[arg(long = "until-peak-observed", conflicts_with = "until_width")]
    until_peak_observed: bool,
    /// Stop when the export has not grown for this many seconds (default: never).
    #[arg(long = "idle-s", allow_hyphen_values = true, value_parser = positive)]
    idle_s: Option<f64>,
    /// Seconds between reads of the export.
    #[arg(long = "poll-s", default_value_t = 1.0, allow_hyphen_values = true, value_parser = positive)]
    poll_s: f64,
    /// Instrument time (s) the forecast reaches (default: the larger of twice the record's end
    /// and 1.5 × t_peak's upper end).
    #[arg(long = "horizon-s", allow_hyphen_values = true, value_parser = positive)]
    horizon_s: Option<f64>,
    /// Wall-time budget of each refit in seconds (default: none, each refit runs until
    /// converged). A refit that hits it reports what it has, marked not converged: before the
    /// peak a record is hard to fit, and a cap keeps the refits in step with the instrument.
    #[arg(long = "refit-max-s", allow_hyphen_values = true, value_parser = positive)]
    refit_max_s: Option<f64>,
    /// Seed of every refit.
    #[arg(long)]
    seed: Option<u64>,
    /// Replace an earlier watch in the output directory.
    #[arg(long)]
    overwrite: bool,
    /// Print nothing but the line that says the criterion was met.
    #[arg(long)]
    quiet: bool,
    /// How to read the export.
    #[command(flatten)]
    import: ImportArgs,
}

/// One row of `watch.csv`.
struct Row {
    refit: usize,
    watch_s: f64,
    points: usize,
    peak: PeakSoFar,
    converged: bool,
    refit_s: f64,
    warm: bool,
}

const HISTORY_HEADER: &str = "refit,watch_s,points,record_end_s,\
F_peak_N,F_peak_low_N,F_peak_high_N,tau_peak_s,tau_peak_low_s,tau_peak_high_s,\
t_peak_s,t_peak_low_s,t_peak_high_s,mu_s,mu_s_low,mu_s_high,\
p_peak_in_record,converged,refit_s,warm_start";

impl Row {
    fn csv(&self) -> String {
        let i = |v: &Interval| format!("{:?},{:?},{:?}", v.median, v.low, v.high);
        let p = &self.peak;
        format!(
            "{},{:.3},{},{:?},{},{},{},{},{:.4},{},{:.3},{}",
            self.refit,
            self.watch_s,
            self.points,
            p.record_end_s,
            i(&p.f_peak),
            i(&p.tau_peak),
            i(&p.t_peak),
            p.mu_s.as_ref().map_or(",,".to_owned(), i),
            p.p_in_record,
            self.converged,
            self.refit_s,
            self.warm
        )
    }
}

pub(super) fn run(args: &WatchArgs) -> anyhow::Result<ExitCode> {
    let criterion = match (args.until_width, args.until_peak_observed) {
        (Some(w), _) => Some(Criterion::Width(w)),
        (None, true) => Some(Criterion::PeakObserved),
        (None, false) => None,
    };
    let file_name = args
        .export
        .file_name()
        .with_context(|| format!("{} does not name a file", args.export.display()))?;
    // Held until the watch ends: a second watch or fit cannot write here meanwhile.
    let _lock = RunLock::acquire(&args.out)?;
    OutputDir::claim(&args.out, WATCH_OUTPUT, args.overwrite)?;
    for dir in [DATA, REFITS] {
        std::fs::create_dir_all(args.out.join(dir))
            .with_context(|| format!("creating {}", args.out.join(dir).display()))?;
    }
    let snapshot_path = args.out.join(DATA).join(file_name);
    interrupt::install();
    let say = |line: String| {
        if !args.quiet {
            eprintln!("{line}");
        }
    };
    say(format!(
        "watching {} (every {} s){}",
        args.export.display(),
        args.poll_s,
        criterion.map_or(String::new(), |c| format!(" until {}", c.describe()))
    ));
    let began = Instant::now();
    let mut follower = Follower::new(&args.export);
    let mut rows: Vec<Row> = Vec::new();
    let mut warm: Option<FitSummary> = None;
    let mut last_change = Instant::now();
    let mut last_error = String::new();
    loop {
        if interrupt::INTERRUPTED.load(Ordering::SeqCst) {
            say(interrupted(&args.out));
            return Ok(ExitCode::from(EXIT_INTERRUPTED));
        }
        let polled = follower
            .poll()
            .with_context(|| format!("reading {}", args.export.display()))?;
        let Some(snapshot) = polled else {
            if let Some(idle) = args.idle_s {
                if last_change.elapsed().as_secs_f64() >= idle {
                    return Ok(idle_exit(args, criterion, &rows, idle));
                }
            }
            std::thread::sleep(Duration::from_secs_f64(args.poll_s));
            continue;
        };
        last_change = Instant::now();
        if snapshot.rewritten {
            say(format!(
                "{} was rewritten: the record starts over",
                args.export.display()
            ));
            warm = None;
        }
        write_atomically(&snapshot_path, &snapshot.bytes)
            .with_context(|| format!("writing {}", snapshot_path.display()))?;
        let refit = rows.last().map_or(1, |r| r.refit + 1);
        let started = Instant::now();
        match refit_once(args, &snapshot_path, refit, warm.as_ref()) {
            Ok(Refit::Done {
                summary,
                peak,
                warm_started,
            }) => {
                last_error.clear();
                let row = Row {
                    refit,
                    watch_s: began.elapsed().as_secs_f64(),
                    points: summary.data.first().map_or(0, |d| d.points_used),
                    converged: summary.sampler.converged,
                    peak,
                    refit_s: started.elapsed().as_secs_f64(),
                    warm: warm_started,
                };
                say(describe(&row));
                rows.push(row);
                write_history(&args.out, &rows)?;
                let row = rows.last().expect("pushed");
                if let Some(c) = criterion.filter(|c| c.met(&row.peak, row.converged)) {
                    println!(
                        "criterion met ({}) at refit {}: the record to t = {:.6e} s of \
                         instrument time, {:.1} s after watching began; F_peak {}; results in {}",
                        c.describe(),
                        row.refit,
                        row.peak.record_end_s,
                        row.watch_s,
                        interval_text(&row.peak.f_peak, 1e3, "mN"),
                        args.out.join(LATEST).display()
                    );
                    return Ok(ExitCode::SUCCESS);
                }
                warm = Some(*summary);
            }
            Ok(Refit::Interrupted) => {
                say(interrupted(&args.out));
                return Ok(ExitCode::from(EXIT_INTERRUPTED));
            }
            // Too few rows yet, or a row the importer refuses: said once, then the next rows
            // are waited for (a bad file stays bad, and the message says why).
            Err(e) => {
                let text = super::error_lines(&e).join("\n  ");
                if text != last_error {
                    say(format!("refit {refit} not made yet: {text}"));
                    last_error = text;
                }
            }
        }
        drop_old_refits(&args.out)?;
    }
}

enum Refit {
    Done {
        /// The refit's summary: its verdict, and the start of the next refit.
        summary: Box<FitSummary>,
        peak: PeakSoFar,
        warm_started: bool,
    },
    Interrupted,
}

/// Fits the rows in `snapshot` into `refits/NNNNNN`, writes its report and forecast, and
/// points `latest` at it.
fn refit_once(
    args: &WatchArgs,
    snapshot: &Path,
    refit: usize,
    warm: Option<&FitSummary>,
) -> anyhow::Result<Refit> {
    let model = ModelSpec::one_contact(&OneContact {
        first: snapshot.to_path_buf(),
        repeat: None,
        velocity_m_per_s: args.velocity,
        stiff: false,
        normal_force_n: args.normal_force,
        window_s: None,
        likelihood_tolerance: None,
        import: args.import.options(),
        forward: ForwardModel {
            law: args.law.unwrap_or_default(),
            elastic: !args.rigid,
            ..ForwardModel::default()
        },
    })?;
    let run_file = RunFile::with_default_sampler(model);
    let posterior = run_file.posterior()?;
    let warm_started = warm
        .and_then(|s| warm_point(&posterior, s))
        .is_some_and(|p| posterior.warm_start(p));
    let settings = FitSettings::for_model(
        &posterior,
        &run_file.sampler,
        &SettingOverrides {
            seed: args.seed,
            max_time_s: args.refit_max_s,
            quiet: true,
            // A refit that failed after sampling (its number is tried again) leaves a run.
            overwrite: true,
            ..SettingOverrides::default()
        },
    );
    let dir = args.out.join(REFITS).join(format!("{refit:06}"));
    let lock = RunLock::acquire(&dir)?;
    OutputDir::claim(&dir, RUN_OUTPUT, true)?;
    let mut observer =
        ProgressBarObserver::new(true, Duration::from_secs(1)).stop_when(&interrupt::INTERRUPTED);
    let command: Vec<String> = std::env::args().collect();
    let outcome = match fit_model(
        &run_file,
        &posterior,
        &settings,
        &lock,
        false,
        command,
        &mut observer,
        Parallelism::default(),
    ) {
        Err(FitError::Interrupted { .. }) => {
            drop(lock);
            let _ = std::fs::remove_dir_all(&dir);
            return Ok(Refit::Interrupted);
        }
        result => result?,
    };
    #[cfg(feature = "report")]
    slipbayes::report::write_report(&outcome.dir)
        .with_context(|| format!("writing the report of {}", dir.display()))?;
    let peak = PeakSoFar::of(&outcome, &posterior, RUN)?;
    let horizon = args
        .horizon_s
        .unwrap_or((2.0 * peak.record_end_s).max(1.5 * peak.t_peak.high));
    let band = forecast(
        &outcome,
        &posterior,
        RUN,
        horizon,
        FORECAST_POINTS,
        settings.seed,
    )?;
    drop(lock);
    switch_latest(&args.out, &dir)?;
    let path = args.out.join(FORECAST);
    write_atomically(&path, forecast_csv(&band).as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(Refit::Done {
        summary: Box::new(outcome.summary),
        peak,
        warm_started,
    })
}

/// Points `out/latest` at `dir` in one rename, so that a reader finds the last complete refit
/// or the one before, never a refit being written.
fn switch_latest(out: &Path, dir: &Path) -> anyhow::Result<()> {
    let latest = out.join(LATEST);
    let target = Path::new(REFITS).join(dir.file_name().expect("a refit's name"));
    let tmp = out.join(".latest.tmp");
    let _ = std::fs::remove_file(&tmp);
    #[cfg(unix)]
    std::os::unix::fs::symlink(&target, &tmp)
        .with_context(|| format!("linking {}", tmp.display()))?;
    #[cfg(not(unix))]
    return Err(anyhow::anyhow!(
        "watch needs symbolic links (Unix) for `latest`"
    ));
    std::fs::rename(&tmp, &latest).with_context(|| format!("replacing {}", latest.display()))
}

/// Removes all but the newest [`KEPT_REFITS`] refits.
fn drop_old_refits(out: &Path) -> anyhow::Result<()> {
    let dir = out.join(REFITS);
    let mut refits: Vec<PathBuf> = std::fs::read_dir(&dir)
        .with_context(|| format!("listing {}", dir.display()))?
        .flatten()
        .map(|e| e.path())
        .collect();
    refits.sort();
    let current = std::fs::read_link(out.join(LATEST)).ok();
    for old in refits.iter().rev().skip(KEPT_REFITS) {
        if current.as_deref().and_then(Path::file_name) != old.file_name() {
            std::fs::remove_dir_all(old).with_context(|| format!("removing {}", old.display()))?;
        }
    }
    Ok(())
}

fn write_history(out: &Path, rows: &[Row]) -> anyhow::Result<()> {
    let mut csv = format!("{HISTORY_HEADER}\n");
    for r in rows {
        csv.push_str(&r.csv());
        csv.push('\n');
    }
    let path = out.join(HISTORY);
    write_atomically(&path, csv.as_bytes()).with_context(|| format!("writing {}", path.display()))
}

fn interval_text(v: &Interval, scale: f64, unit: &str) -> String {
    format!(
        "{:.4} [{:.4}, {:.4}]{}{unit}",
        v.median * scale,
        v.low * scale,
        v.high * scale,
        if unit.is_empty() { "" } else { " " }
    )
}

/// The line printed after a refit.
fn describe(row: &Row) -> String {
    let p = &row.peak;
    let mu = p.mu_s.as_ref().map_or(String::new(), |m| {
        format!(", μ_s {}", interval_text(m, 1.0, ""))
    });
    format!(
        "refit {} ({} points to t = {:.0} s; {:.1} s{}{}): F_peak {} (width {:.2} %), τ_peak {}, \
         t_peak {}{mu}; {}",
        row.refit,
        row.points,
        p.record_end_s,
        row.refit_s,
        if row.warm { ", warm start" } else { "" },
        if row.converged { "" } else { ", not converged" },
        interval_text(&p.f_peak, 1e3, "mN"),
        100.0 * p.f_peak.relative_width(),
        interval_text(&p.tau_peak, 1.0, "s"),
        interval_text(&p.t_peak, 1.0, "s"),
        p.statement()
    )
}

fn interrupted(out: &Path) -> String {
    format!(
        "interrupted: {} is the last complete refit",
        out.join(LATEST).display()
    )
}

fn idle_exit(args: &WatchArgs, criterion: Option<Criterion>, rows: &[Row], idle: f64) -> ExitCode {
    let last = rows.last().map_or("no refit was made".to_owned(), |r| {
        format!("the last refit is {}", r.refit)
    });
    match criterion {
        Some(c) => {
            eprintln!(
                "{} has not grown for {idle} s; {last}, and the criterion ({}) was not met",
                args.export.display(),
                c.describe()
            );
            ExitCode::from(EXIT_NOT_CONVERGED)
        }
        None => {
            eprintln!(
                "{} has not grown for {idle} s; {last}",
                args.export.display()
            );
            ExitCode::SUCCESS
        }
    }
}
