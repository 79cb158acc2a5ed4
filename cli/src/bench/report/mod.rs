//! `speed-vs-error.md`, `results.json` and the plots, from the measured [`BenchResults`].

mod side_by_side;

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::knobs::{Knob, KnobRun};
use super::nuts::NutsOutcome;
use super::peer::{LogDensityCheck, PeerComparison, PeerOutcome};
use super::plot::{error_vs_time, ErrorPoint};
use super::throughput::MovesRun;
use super::{BenchError, BenchResults};
use side_by_side::peer_section;
use slipbayes::data::write_atomically;

/// The machine and its load while the bench ran.
#[derive(Debug, Clone, Serialize)]
pub struct Machine {
    /// UTC date and time of the start.
    pub started: String,
    /// CPU model.
    pub cpu: String,
    /// Logical CPUs.
    pub cpus: usize,
    /// Threads of the "all threads" runs.
    pub threads: usize,
    /// `/proc/loadavg` at the start.
    pub load_start: String,
    /// `/proc/loadavg` at the end.
    pub load_end: String,
    /// Wall time of the whole bench (s).
    pub total_s: f64,
    #[serde(skip)]
    clock: Option<std::time::Instant>,
}

fn load() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

impl Machine {
    /// The machine now.
    pub fn now(threads: usize) -> Self {
        let started = std::process::Command::new("date")
            .args(["-u", "+%Y-%m-%d %H:%M UTC"])
            .output()
            .ok()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
            .unwrap_or_default();
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find_map(|l| l.strip_prefix("model name"))
                    .map(|v| v.trim_start_matches([' ', '\t', ':']).to_owned())
            })
            .unwrap_or_else(|| "unknown".into());
        Self {
            started,
            cpu,
            cpus: std::thread::available_parallelism().map_or(1, |n| n.get()),
            threads,
            load_start: load(),
            load_end: String::new(),
            total_s: 0.0,
            clock: Some(std::time::Instant::now()),
        }
    }

    /// Records the load and the elapsed time at the end.
    pub fn finish(&mut self) {
        self.load_end = load();
        self.total_s = self.clock.map_or(0.0, |c| c.elapsed().as_secs_f64());
    }
}

/// Paths written by [`fn@write`].
#[derive(Debug, Clone)]
pub struct Written {
    /// The markdown report.
    pub markdown: PathBuf,
    /// Plots and `results.json`.
    pub files: Vec<PathBuf>,
}

fn g(v: f64) -> String {
    if !v.is_finite() {
        "—".into()
    } else if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.2e}")
    } else if v.abs() >= 100.0 {
        format!("{v:.0}")
    } else {
        format!("{v:.3}")
    }
}

fn points(
    runs: &[KnobRun],
    error: fn(&KnobRun) -> f64,
    pareto: fn(&KnobRun) -> bool,
) -> Vec<ErrorPoint> {
    runs.iter()
        .map(|r| ErrorPoint {
            series: r.knob.label(),
            wall_s: r.wall_s,
            error: error(r),
            pareto: pareto(r),
            default: r.knob == Knob::Default,
        })
        .collect()
}

/// Writes `<out>/speed-vs-error.md` and, in `<out>/speed-vs-error/`, the plots and
/// `results.json`. `command` is the command line that reproduces the run.
///
/// # Errors
/// [`BenchError::Io`] when a file cannot be written.
pub fn write(results: &BenchResults, out: &Path, command: &str) -> Result<Written, BenchError> {
    let dir = out.join("speed-vs-error");
    std::fs::create_dir_all(&dir).map_err(BenchError::io(&dir))?;
    let mut files = Vec::new();
    let json_path = dir.join("results.json");
    let json = serde_json::to_vec_pretty(results).map_err(|e| BenchError::Run {
        what: "results.json".into(),
        message: e.to_string(),
    })?;
    write_atomically(&json_path, &json).map_err(BenchError::io(&json_path))?;
    files.push(json_path);
    let runs = &results.knobs.runs;
    let plots: [(&str, &str, &str, Vec<ErrorPoint>); 3] = [
        (
            "median-vs-reference.svg",
            "Posterior medians against the reference run",
            "max |median - ref| / ref sd",
            points(runs, |r| r.median_vs_reference, |r| r.pareto_median),
        ),
        (
            "f-peak-interval-vs-reference.svg",
            "F_peak 95% interval ends against the reference run",
            "max end error / ref sd of F_peak",
            points(
                runs,
                |r| r.f_peak_interval_vs_reference,
                |r| r.pareto_f_peak,
            ),
        ),
        (
            "median-vs-truth.svg",
            "Posterior medians against the known truth",
            "max |median - truth| / ref sd",
            points(runs, |r| r.median_vs_truth, |_| false),
        ),
    ];
    for (name, title, y, pts) in &plots {
        let path = dir.join(name);
        error_vs_time(&path, title, y, pts)?;
        files.push(path);
    }
    let markdown = out.join("speed-vs-error.md");
    let text = markdown_text(results, command);
    write_atomically(&markdown, text.as_bytes()).map_err(BenchError::io(&markdown))?;
    Ok(Written { markdown, files })
}

fn markdown_text(r: &BenchResults, command: &str) -> String {
    let mut s = String::new();
    let m = &r.machine;
    let _ = writeln!(s, "# Speed against error\n");
    let _ = writeln!(
        s,
        "Written by `{command}` ({}), {}. Machine: {} logical CPUs ({}); \"all threads\" = {} \
         threads. Load average (1, 5, 15 min) at the start {} and at the end {}; the bench took \
         {:.0} s. Every figure below comes from this one run; baselines (the exp floor, the \
         peer) were measured in the same run, so ratios are steadier than absolute times on a \
         shared machine. Seed {}; `results.json` beside the plots holds every number.\n",
        if r.quick { "quick sizes" } else { "full sizes" },
        m.started,
        m.cpus,
        m.cpu,
        m.threads,
        m.load_start,
        m.load_end,
        m.total_s,
        super::BENCH_SEED,
    );

    // Headline.
    let _ = writeln!(s, "## Headline\n");
    if let Some(p) = &r.peer {
        if p.quoted {
            let _ = writeln!(
                s,
                "- One-contact posterior, same walkers ({}×{}) and steps ({}): ESS/s **{}× the \
                 peer's** on {} threads ({}× on one thread). Time per log-density: {} µs against \
                 the peer's {} µs vectorised ({}×) and {} µs one point per call ({}×).",
                p.ensembles,
                p.walkers,
                p.steps,
                g(p.ours_ess_per_s[1] / p.peer_ess_per_s),
                m.threads,
                g(p.ours_ess_per_s[0] / p.peer_ess_per_s),
                g(p.ours_us_per_eval),
                g(p.peer_us_per_eval_vectorised),
                g(p.peer_us_per_eval_vectorised / p.ours_us_per_eval),
                g(p.peer_us_per_eval_single),
                g(p.peer_us_per_eval_single / p.ours_us_per_eval),
            );
            let target = p.ours_ess_per_s[1] / p.peer_ess_per_s;
            let _ = writeln!(
                s,
                "- Target ESS/s ≥ 100× the peer's on both cores: {}.",
                if target >= 100.0 {
                    "**met**".to_owned()
                } else {
                    format!(
                        "**missed** ({}×, a factor {} short)",
                        g(target),
                        g(100.0 / target)
                    )
                }
            );
        } else {
            let _ = writeln!(
                s,
                "- The peer's posterior did **not** pass the checks below, so no speed ratio is \
                 quoted."
            );
        }
        best_peer_headline(
            &mut s,
            p,
            r.fit_moves.as_ref(),
            &r.ensemble_peers,
            m.threads,
        );
        nuts_headline(&mut s, r.nuts.as_ref(), p.ours_ess_per_s[1], m.threads);
    } else {
        let _ = writeln!(s, "- The peers were not run (`--no-peer`).");
    }
    if let Some(mem) = &r.memory {
        let mb = |kb: u64| g(kb as f64 / 1024.0);
        let _ = writeln!(
            s,
            "- Peak resident memory ({}, {} walkers; VmHWM of one process per reading) at {} and \
             {} steps ({}× longer chains; {} MB and {} MB of Parquet written): the sampler \
             streaming its chains to Parquet {} MB and {} MB; a whole fit, whose summary reads \
             the chains back, {} MB and {} MB.",
            mem.model,
            mem.walkers_total,
            mem.steps[0],
            mem.steps[1],
            mem.steps[1] / mem.steps[0].max(1),
            g(mem.chain_bytes[0] as f64 / 1048576.0),
            g(mem.chain_bytes[1] as f64 / 1048576.0),
            mb(mem.sample_peak_kb[0]),
            mb(mem.sample_peak_kb[1]),
            mb(mem.peak_kb[0]),
            mb(mem.peak_kb[1]),
        );
    }
    let _ = writeln!(
        s,
        "- Forward-model approximation (coarse τ grid with interpolation): **not offered**; the \
         law is always evaluated exactly.\n"
    );

    // Cost.
    let _ = writeln!(s, "## Cost of the model per data point\n");
    let _ = writeln!(
        s,
        "The true parameters of the bundled PTFE contact 1 (first slide 1 nm/s, 3,001 points; \
         its repeat slide; the 4 µm/s stiff-fast slide). Median of {} repetitions.\n",
        r.plan.cost_reps
    );
    let _ = writeln!(s, "| what | points | ns per point | ratio to exp floor |");
    let _ = writeln!(s, "|---|---:|---:|---:|");
    for row in &r.cost.rows {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} |",
            row.what,
            row.points,
            g(row.ns_per_point),
            g(row.ratio_to_exp)
        );
    }

    // Throughput.
    let _ = writeln!(s, "\n## Sampler throughput\n");
    let _ = writeln!(
        s,
        "Stretch moves, {} independent ensembles, walkers as `slipbayes fit` chooses them, \
         fixed steps; the start-point optimisation is not timed. ESS is the smallest bulk ESS \
         over the sampled coordinates after dropping the first quarter of the steps (walkers \
         as chains; they are not independent, so take it as a relative measure). Both runs use \
         the same seed.\n",
        slipbayes::sampler::DEFAULT_ENSEMBLES
    );
    let _ = writeln!(
        s,
        "| posterior | dim | walkers | steps | threads | sampling s | steps/s | evals/s | min ESS | ESS/s | scaling efficiency | chains identical |"
    );
    let _ = writeln!(
        s,
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|"
    );
    for t in &r.throughput {
        for (i, run) in t.runs.iter().enumerate() {
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                t.posterior,
                t.dim,
                t.walkers,
                t.steps,
                run.threads,
                g(run.sampling_s),
                g(run.steps_per_s),
                g(run.evals_per_s),
                g(run.ess_min),
                g(run.ess_per_s),
                if i == 0 {
                    String::new()
                } else {
                    g(t.scaling_efficiency)
                },
                if i == 0 {
                    String::new()
                } else {
                    (if t.identical_chains { "yes" } else { "NO" }).into()
                },
            );
        }
    }

    if let Some(p) = &r.peer {
        peer_section(
            &mut s,
            m.threads,
            r.plan.one_contact_reference_steps,
            p,
            r.fit_moves.as_ref(),
            &r.ensemble_peers,
            r.nuts.as_ref(),
        );
    }

    // Knobs.
    let k = &r.knobs;
    let _ = writeln!(s, "\n## Error against cost\n");
    let _ = writeln!(
        s,
        "First and repeat slide of PTFE contact 1 (`data/ptfe-c1-{{first,repeat}}.csv`). \
         Each row is a complete fit as `slipbayes fit` runs it (start-point optimisation, \
         sampling on {} threads with the chains streamed to Parquet, summary), timed from \
         start to end. Errors are the largest over the model's parameters, in posterior sds of \
         a reference fit on the full data with {} steps (wall time {} s, converged by its own \
         criteria: {}, τ_max {} steps). Against the truth even the reference is {} sd off \
         (one noisy data set). The default fit runs until converged. Decimation changes the \
         posterior itself, so its error against the reference includes the information lost.\n",
        r.machine.threads,
        k.reference_steps,
        g(k.reference_wall_s),
        k.reference_converged,
        k.reference_tau_max.map_or("—".into(), g),
        g(k.reference_vs_truth),
    );
    let _ = writeln!(
        s,
        "| knob | value | points | walkers | steps | wall s | medians vs ref | F_peak 95% ends vs ref | medians vs truth | Pareto (medians / F_peak) |"
    );
    let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|---:|---|");
    for run in &k.runs {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} / {} |",
            run.knob.label(),
            run.value,
            run.points,
            run.walkers,
            run.steps,
            g(run.wall_s),
            g(run.median_vs_reference),
            g(run.f_peak_interval_vs_reference),
            g(run.median_vs_truth),
            if run.pareto_median { "yes" } else { "" },
            if run.pareto_f_peak { "yes" } else { "" },
        );
    }
    let _ = writeln!(
        s,
        "\n![medians against the reference](speed-vs-error/median-vs-reference.svg)\n\n\
         ![F_peak interval ends against the reference](speed-vs-error/f-peak-interval-vs-reference.svg)\n\n\
         ![medians against the truth](speed-vs-error/median-vs-truth.svg)\n"
    );
    s
}

/// The bar: our ESS per 1,000 log-density evaluations at least this many times the
/// best Python ensemble sampler's.
pub const EVALUATIONS_TARGET: f64 = 10.0;

/// The Python ensemble peers that ran: the stretch peer, then the optional ones.
fn ran_peers<'a>(
    stretch: &'a PeerComparison,
    others: &'a [PeerOutcome],
) -> Vec<&'a PeerComparison> {
    std::iter::once(stretch)
        .chain(others.iter().filter_map(|o| match o {
            PeerOutcome::Ran(c) => Some(c.as_ref()),
            PeerOutcome::Skipped { .. } => None,
        }))
        .collect()
}

/// The best Python ensemble peers that passed the checks: by ESS per 1,000 evaluations, and by
/// ESS/s (not always the same one).
fn best_peers<'a>(
    stretch: &'a PeerComparison,
    others: &'a [PeerOutcome],
) -> Option<(&'a PeerComparison, &'a PeerComparison)> {
    let quoted: Vec<&PeerComparison> = ran_peers(stretch, others)
        .into_iter()
        .filter(|c| c.quoted)
        .collect();
    let by = |key: fn(&PeerComparison) -> f64| {
        quoted
            .iter()
            .copied()
            .max_by(|a, b| key(a).total_cmp(&key(b)))
    };
    Some((by(|c| c.peer_ess_per_kilo_eval)?, by(|c| c.peer_ess_per_s)?))
}

/// Our ratios to the best Python ensemble samplers, one line per configuration of ours:
/// `slipbayes fit`'s default moves (the configuration the target is about) and the stretch
/// move (emcee's own, so the ESS per evaluation isolates the moves).
fn best_peer_lines(
    s: &mut String,
    stretch: &PeerComparison,
    fit_moves: Option<&MovesRun>,
    others: &[PeerOutcome],
    threads: usize,
) {
    let Some((by_evals, by_time)) = best_peers(stretch, others) else {
        let _ = writeln!(
            s,
            "- No Python ensemble sampler passed the checks below, so no ratio of ESS per \
             1,000 evaluations is quoted."
        );
        return;
    };
    let mut ours = Vec::new();
    if let Some(f) = fit_moves {
        ours.push((
            format!("`slipbayes fit`'s default moves ({})", f.moves),
            f.ess_per_kilo_eval,
            f.ess_per_s,
            true,
        ));
    }
    ours.push((
        "the stretch move".to_owned(),
        stretch.ours_ess_per_kilo_eval,
        stretch.ours_ess_per_s[1],
        fit_moves.is_none(),
    ));
    for (label, per_kilo, per_s, target) in ours {
        let ratio = per_kilo / by_evals.peer_ess_per_kilo_eval;
        let verdict = if !target {
            String::new()
        } else if ratio >= EVALUATIONS_TARGET {
            format!(" Target ≥ {EVALUATIONS_TARGET}× the best Python ensemble sampler's: **met**.")
        } else {
            format!(
                " Target ≥ {EVALUATIONS_TARGET}× the best Python ensemble sampler's: **missed** \
                 (a factor {} short).",
                g(EVALUATIONS_TARGET / ratio)
            )
        };
        let _ = writeln!(
            s,
            "- slipbayes with {label}: ESS per 1,000 log-density evaluations {} against the best \
             Python ensemble sampler's ({} {}): **{}×**; ESS/s on {threads} threads **{}×** the \
             fastest's ({}).{verdict}",
            g(per_kilo),
            by_evals.sampler.label(),
            g(by_evals.peer_ess_per_kilo_eval),
            g(ratio),
            g(per_s / by_time.peer_ess_per_s),
            by_time.sampler.label(),
        );
    }
}

/// The headline's lines on the Python ensemble samplers: our ratios to the best, then why any
/// optional peer is missing.
fn best_peer_headline(
    s: &mut String,
    stretch: &PeerComparison,
    fit_moves: Option<&MovesRun>,
    others: &[PeerOutcome],
    threads: usize,
) {
    best_peer_lines(s, stretch, fit_moves, others, threads);
    for outcome in others {
        match outcome {
            PeerOutcome::Ran(c) if !c.quoted => {
                let _ = writeln!(
                    s,
                    "- The {} peer did **not** pass the checks below, so no ratio is quoted \
                     against it.",
                    c.sampler.label()
                );
            }
            PeerOutcome::Ran(_) => {}
            PeerOutcome::Skipped { sampler, reason } => {
                let _ = writeln!(
                    s,
                    "- The {} peer was **skipped**: {reason}",
                    sampler.label()
                );
            }
        }
    }
}

/// The headline's NUTS line(s): our ESS/s over NUTS's, or why there is no ratio.
fn nuts_headline(s: &mut String, nuts: Option<&NutsOutcome>, ours_ess_per_s: f64, threads: usize) {
    match nuts {
        Some(NutsOutcome::Ran(n)) if n.quoted => {
            for run in &n.runs {
                let _ = writeln!(
                    s,
                    "- Against NumPyro's NUTS ({} chain{}, gradients through the elastic \
                     solve): ESS/s **{}× NUTS's** on {} threads, counting its warmup (JIT \
                     compile excluded); {}× against its kept draws alone.",
                    run.chains,
                    if run.chains == 1 { "" } else { "s in parallel" },
                    g(ours_ess_per_s / run.ess_per_s),
                    threads,
                    g(ours_ess_per_s / run.ess_per_s_draws),
                );
            }
        }
        Some(NutsOutcome::Ran(_)) => {
            let _ = writeln!(
                s,
                "- The NUTS peer did **not** pass the checks below, so no speed ratio is \
                 quoted against it."
            );
        }
        Some(NutsOutcome::Skipped { reason }) => {
            let _ = writeln!(s, "- The NUTS peer was **skipped**: {reason}");
        }
        None => {
            let _ = writeln!(s, "- The NUTS peer was not run (`--no-nuts`).");
        }
    }
}

fn log_density_line(s: &mut String, item: usize, who: &str, c: &LogDensityCheck) {
    let _ = writeln!(
        s,
        "{item}. {who}: log-density at {} points (posterior draws and draws pushed ±5 sd): \
         largest relative difference {} (required ≤ {:e}), {} finiteness mismatches → **{}**.",
        c.points_compared,
        g(c.max_rel_diff),
        super::peer::LOG_DENSITY_RTOL,
        c.finiteness_mismatches,
        if c.log_density_agrees {
            "agree"
        } else {
            "DISAGREE"
        }
    );
}

fn agree(ok: bool) -> &'static str {
    if ok {
        "agree"
    } else {
        "DISAGREE"
    }
}

#[cfg(test)]
mod tests;
