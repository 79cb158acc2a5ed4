//! `speed-vs-error.md`, `results.json` and the plots, from the measured [`BenchResults`].

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use serde::Serialize;

use super::knobs::{Knob, KnobRun};
use super::nuts::{NutsComparison, NutsOutcome};
use super::peer::{LogDensityCheck, PeerComparison, PeerOutcome};
use super::plot::{error_vs_time, ErrorPoint};
use super::throughput::MovesRun;
use super::{BenchError, BenchResults};
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

/// The side-by-side section: every peer's checks, then one table of every sampler.
fn peer_section(
    s: &mut String,
    threads: usize,
    reference_steps: u64,
    p: &PeerComparison,
    fit_moves: Option<&MovesRun>,
    others: &[PeerOutcome],
    outcome: Option<&NutsOutcome>,
) {
    let nuts = match outcome {
        Some(NutsOutcome::Ran(n)) => Some(n),
        _ => None,
    };
    let extras: Vec<&PeerComparison> = ran_peers(p, others).into_iter().skip(1).collect();
    let _ = writeln!(s, "\n## Side by side with the Python peers\n");
    let _ = writeln!(
        s,
        "`{}` (versions: {}) fits the one-contact posterior (`benches/peer/one_contact.toml`) \
         with {}, `vectorize=True`, one process, from the same initial walkers, with the same \
         walkers and steps.",
        super::peer::PEER_SCRIPT,
        p.versions,
        p.sampler.description(),
    );
    for outcome in others {
        match outcome {
            PeerOutcome::Ran(c) => {
                let _ = writeln!(
                    s,
                    "The same script with `--sampler {}` (versions: {}) fits it with {}, \
                     vectorised too, from the same walkers, with the same walkers and steps.",
                    c.sampler.option(),
                    c.versions,
                    c.sampler.description(),
                );
            }
            PeerOutcome::Skipped { sampler, reason } => {
                let _ = writeln!(
                    s,
                    "The {} peer (`{} --sampler {}`) was skipped: {reason}",
                    sampler.label(),
                    super::peer::PEER_SCRIPT,
                    sampler.option(),
                );
            }
        }
    }
    match outcome {
        Some(NutsOutcome::Ran(n)) => {
            let _ = writeln!(
                s,
                "`{}` (versions: {}) fits the same posterior in the same coordinates with \
                 NumPyro's NUTS on JAX (CPU, float64), the gradient taken through the elastic \
                 solve (implicit derivative of its Newton root): {} warmup iterations (step \
                 size and {} mass matrix adapted, target acceptance {}, tree depth at most {}) \
                 and {} kept draws per chain, chains started from our initial walkers, several \
                 chains in parallel one per core. JAX's compile time is measured apart and \
                 left out of its times.",
                super::nuts::NUTS_SCRIPT,
                n.versions,
                n.plan.warmup,
                if n.plan.dense_mass {
                    "dense"
                } else {
                    "diagonal"
                },
                n.plan.target_accept,
                n.plan.max_tree_depth,
                n.plan.draws,
            );
        }
        Some(NutsOutcome::Skipped { reason }) => {
            let _ = writeln!(
                s,
                "The NUTS peer (`{}`) was skipped: {reason}",
                super::nuts::NUTS_SCRIPT
            );
        }
        None => {}
    }
    let _ = writeln!(
        s,
        "All chains go through the same estimator here (bulk ESS with every walker of every \
         ensemble, or every NUTS chain, as a chain). Log-density evaluations count every point \
         a sampler asked for, the initial walkers' included: ours as our sampler counts them, \
         the Python ensemble samplers' by a counter around the log-density they are given (a \
         vectorised call adds its number of points; zeus' slice moves make several calls per \
         step).\n"
    );
    if let Some(f) = fit_moves {
        let _ = writeln!(
            s,
            "slipbayes samples this problem twice, from {} initial walkers as the peers: \
             with the stretch move (emcee's, so that per evaluation only the implementations \
             differ) and with `slipbayes fit`'s default moves ({}; joint updates, as every run \
             of this bench).\n",
            if f.same_start {
                "the same"
            } else {
                "NOT the same"
            },
            f.moves,
        );
    }
    log_density_line(s, 1, "emcee peer", &p.log_density);
    let mut item = 2;
    for c in &extras {
        log_density_line(
            s,
            item,
            &format!("{} peer", c.sampler.label()),
            &c.log_density,
        );
        item += 1;
    }
    if let Some(n) = nuts {
        log_density_line(s, item, "NUTS peer", &n.log_density);
        let _ = writeln!(
            s,
            "{}. NUTS peer: its autodiff gradient (through the elastic solve) against central \
             differences of its log-density at {} posterior draws: largest difference {} of \
             the gradient's largest component (required ≤ {:e}) → **{}**.",
            item + 1,
            n.gradient.points,
            g(n.gradient.max_error),
            super::nuts::GRADIENT_RTOL,
            agree(n.gradient.agrees()),
        );
        item += 2;
    }
    let _ = writeln!(
        s,
        "{item}. Medians (log-coordinates) within {} MCSE of ours: emcee **{}**{}{}.\n",
        super::peer::MEDIAN_MCSE_FACTOR,
        agree(p.medians_agree),
        extras
            .iter()
            .map(|c| format!(", {} **{}**", c.sampler.label(), agree(c.medians_agree)))
            .collect::<String>(),
        nuts.map_or(String::new(), |n| n
            .runs
            .iter()
            .map(|run| format!(
                ", NUTS {} chain(s) **{}**",
                run.chains,
                agree(run.medians_agree)
            ))
            .collect()),
    );
    let mut header = "| coordinate | our median | emcee median | |Δ| / MCSE |".to_owned();
    let mut rule = "|---|---:|---:|---:|".to_owned();
    for c in &extras {
        let _ = write!(header, " {} median | |Δ| / MCSE |", c.sampler.label());
        rule.push_str("---:|---:|");
    }
    for run in nuts.iter().flat_map(|n| &n.runs) {
        let _ = write!(
            header,
            " NUTS {} chain(s) median | |Δ| / MCSE |",
            run.chains
        );
        rule.push_str("---:|---:|");
    }
    let _ = writeln!(s, "{header}\n{rule}");
    for (i, c) in p.medians.iter().enumerate() {
        let _ = write!(
            s,
            "| {} | {:.6} | {:.6} | {} |",
            c.name,
            c.ours,
            c.peer,
            g(c.z)
        );
        for other in &extras {
            let c = &other.medians[i];
            let _ = write!(s, " {:.6} | {} |", c.peer, g(c.z));
        }
        for run in nuts.iter().flat_map(|n| &n.runs) {
            let c = &run.medians[i];
            let _ = write!(s, " {:.6} | {} |", c.peer, g(c.z));
        }
        s.push('\n');
    }
    samplers_table(s, threads, p, fit_moves, &extras, nuts);
    let _ = writeln!(
        s,
        "\nAgainst the best Python ensemble sampler that passed the checks (by ESS per 1,000 \
         evaluations, and by ESS/s):\n"
    );
    best_peer_lines(s, p, fit_moves, others, threads);
    let _ = write!(
        s,
        "\nError of the medians against our long one-contact reference run ({} steps, \
         another seed), in reference sds (largest over coordinates): slipbayes {} after {} s, \
         emcee {} after {} s",
        reference_steps,
        g(p.ours_error),
        g(p.ours_sampling_s[1]),
        g(p.peer_error),
        g(p.peer_sampling_s),
    );
    for c in &extras {
        let _ = write!(
            s,
            ", {} {} after {} s",
            c.sampler.label(),
            g(c.peer_error),
            g(c.peer_sampling_s)
        );
    }
    for run in nuts.iter().flat_map(|n| &n.runs) {
        let _ = write!(
            s,
            ", NUTS ({} chain(s)) {} after {} s",
            run.chains,
            g(run.error),
            g(run.warmup_s + run.sampling_s)
        );
    }
    let _ = writeln!(
        s,
        ". At emcee's wall time slipbayes could have run about {}× more steps.",
        g(p.peer_sampling_s / p.ours_sampling_s[1]),
    );
    if let Some(n) = nuts {
        nuts_table(s, n, threads, p.ours_ess_per_s[1]);
    }
}

/// Every sampler in one table: cost of a density, evaluations, time, ESS, ESS per 1,000
/// evaluations, ESS/s and our stretch move's ratio to it. NUTS's script counts the gradients
/// of its kept draws only, not of its warmup, so its row has no evaluation count.
fn samplers_table(
    s: &mut String,
    threads: usize,
    p: &PeerComparison,
    fit_moves: Option<&MovesRun>,
    extras: &[&PeerComparison],
    nuts: Option<&NutsComparison>,
) {
    let ours = p.ours_ess_per_s[1];
    let _ = writeln!(
        s,
        "\n| sampler | draws for the ESS | time per log-density (µs) | log-density evaluations | \
         sampling s | min ESS | ESS per 1,000 evaluations | ESS/s | slipbayes stretch \
         ({threads} threads) ESS/s ÷ this |"
    );
    let _ = writeln!(s, "|---|---|---:|---:|---:|---:|---:|---:|---:|");
    let kept = p.steps - p.steps / 4;
    let ensemble_draws = format!(
        "{}×{} walkers × {} steps after {} burn-in",
        p.ensembles,
        p.walkers,
        kept,
        p.steps - kept
    );
    let mut rows = vec![
        (
            "slipbayes stretch, 1 thread".to_owned(),
            g(p.ours_us_per_eval),
            p.ours_evaluations,
            p.ours_sampling_s[0],
            p.ours_ess_min,
            p.ours_ess_per_s[0],
        ),
        (
            format!("slipbayes stretch, {threads} threads"),
            String::new(),
            p.ours_evaluations,
            p.ours_sampling_s[1],
            p.ours_ess_min,
            p.ours_ess_per_s[1],
        ),
    ];
    if let Some(f) = fit_moves {
        rows.push((
            format!(
                "slipbayes, `fit`'s default moves ({}), {} threads{}",
                f.moves,
                f.threads,
                if f.same_start {
                    ""
                } else {
                    " (NOT the same start)"
                }
            ),
            String::new(),
            f.evaluations,
            f.sampling_s,
            f.ess_min,
            f.ess_per_s,
        ));
    }
    for c in std::iter::once(p).chain(extras.iter().copied()) {
        rows.push((
            format!("{} + numpy/scipy", c.sampler.label()),
            format!(
                "{} vectorised, {} single",
                g(c.peer_us_per_eval_vectorised),
                g(c.peer_us_per_eval_single)
            ),
            c.peer_evaluations,
            c.peer_sampling_s,
            c.peer_ess_min,
            c.peer_ess_per_s,
        ));
    }
    for (who, cost, evaluations, secs, ess, per_s) in rows {
        let _ = writeln!(
            s,
            "| {who} | {ensemble_draws} | {cost} | {evaluations} | {} | {} | {} | {} | {} |",
            g(secs),
            g(ess),
            g(super::peer::ess_per_kilo_eval(ess, evaluations)),
            g(per_s),
            g(ours / per_s)
        );
    }
    for (n, run) in nuts
        .iter()
        .flat_map(|n| n.runs.iter().map(move |run| (n, run)))
    {
        let _ = writeln!(
            s,
            "| NumPyro NUTS, {} chain(s) | {}×{} draws after {} warmup | {} with gradient |  | {} \
             (warmup {} + draws {}) | {} |  | {} | {} |",
            run.chains,
            run.chains,
            n.plan.draws,
            n.plan.warmup,
            g(n.us_per_gradient),
            g(run.warmup_s + run.sampling_s),
            g(run.warmup_s),
            g(run.sampling_s),
            g(run.ess_min),
            g(run.ess_per_s),
            g(ours / run.ess_per_s)
        );
    }
}

/// What NUTS spent its time on.
fn nuts_table(s: &mut String, n: &NutsComparison, threads: usize, ours_ess_per_s: f64) {
    let _ = writeln!(
        s,
        "\nNUTS in detail (times without JAX's compiling, which is given apart; gradients are \
         the leapfrog steps of the kept draws):\n"
    );
    let _ = writeln!(
        s,
        "| chains | warmup s | draws s | compile s (warmup, draws) | gradients | per draw | \
         divergences | mean acceptance | step size | ESS/s of the draws alone | slipbayes ({threads} \
         threads) ÷ that |"
    );
    let _ = writeln!(s, "|---:|---:|---:|---|---:|---:|---:|---:|---|---:|---:|");
    for run in &n.runs {
        let draws = (run.chains as u64 * n.plan.draws).max(1);
        let _ = writeln!(
            s,
            "| {} | {} | {} | {}, {} | {} | {} | {} | {} | {} | {} | {} |",
            run.chains,
            g(run.warmup_s),
            g(run.sampling_s),
            g(run.warmup_compile_s),
            g(run.sampling_compile_s),
            run.gradients,
            g(run.gradients as f64 / draws as f64),
            run.divergences,
            g(run.accept_prob),
            run.step_size
                .iter()
                .map(|v| g(*v))
                .collect::<Vec<_>>()
                .join(", "),
            g(run.ess_per_s_draws),
            g(ours_ess_per_s / run.ess_per_s_draws),
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::nuts::{GradientCheck, NutsPlan, NutsRun};
    use crate::bench::peer::{EnsemblePeer, MedianCheck};

    fn medians() -> Vec<MedianCheck> {
        vec![MedianCheck {
            name: "ln_k[c]".into(),
            ours: 9.4,
            peer: 9.4,
            z: 0.5,
        }]
    }

    /// ESS 250 from 50,000 evaluations in 100 s (5 per 1,000 evaluations, 2.5 per second)
    /// against ours, 250 from 2,500 evaluations (100 per 1,000) in 1 s on 2 threads.
    fn emcee() -> PeerComparison {
        PeerComparison {
            sampler: EnsemblePeer::Stretch,
            versions: serde_json::json!({"emcee": "3"}),
            log_density: LogDensityCheck::new(&[Some(1.0)], &[Some(1.0)]),
            medians: medians(),
            medians_agree: true,
            walkers: 32,
            ensembles: 2,
            steps: 600,
            ours_us_per_eval: 40.0,
            peer_us_per_eval_single: 4000.0,
            peer_us_per_eval_vectorised: 3000.0,
            ours_sampling_s: [2.0, 1.0],
            peer_sampling_s: 100.0,
            ours_evaluations: 2_500,
            peer_evaluations: 50_000,
            ours_ess_min: 250.0,
            peer_ess_min: 250.0,
            ours_ess_per_kilo_eval: 100.0,
            peer_ess_per_kilo_eval: 5.0,
            ours_ess_per_s: [125.0, 250.0],
            peer_ess_per_s: 2.5,
            ours_error: 0.02,
            peer_error: 0.03,
            quoted: true,
        }
    }

    /// Another ensemble peer: `ess` from `evaluations` in `seconds`.
    fn other(sampler: EnsemblePeer, ess: f64, evaluations: u64, seconds: f64) -> PeerOutcome {
        PeerOutcome::Ran(Box::new(PeerComparison {
            sampler,
            peer_sampling_s: seconds,
            peer_evaluations: evaluations,
            peer_ess_min: ess,
            peer_ess_per_kilo_eval: crate::bench::peer::ess_per_kilo_eval(ess, evaluations),
            peer_ess_per_s: ess / seconds,
            ..emcee()
        }))
    }

    /// Two chains, 300 draws each, ESS 500 in 60 s of warmup and 40 s of draws.
    fn nuts(quoted: bool) -> NutsOutcome {
        NutsOutcome::Ran(NutsComparison {
            versions: serde_json::json!({"numpyro": "0.22.0"}),
            log_density: LogDensityCheck::new(&[Some(1.0)], &[Some(1.0)]),
            gradient: GradientCheck {
                points: 12,
                max_error: 1e-9,
            },
            plan: NutsPlan::default(),
            us_per_gradient: 2000.0,
            runs: vec![NutsRun {
                chains: 2,
                warmup_s: 60.0,
                warmup_compile_s: 20.0,
                sampling_s: 40.0,
                sampling_compile_s: 30.0,
                gradients: 30_000,
                divergences: 0,
                accept_prob: 0.9,
                step_size: vec![0.1, 0.2],
                ess_min: 500.0,
                ess_per_s: 5.0,
                ess_per_s_draws: 12.5,
                medians: medians(),
                medians_agree: quoted,
                error: 0.04,
            }],
            quoted,
        })
    }

    #[test]
    fn nuts_is_a_row_of_the_samplers_table_with_our_ratio_to_it() {
        let mut s = String::new();
        peer_section(&mut s, 2, 4000, &emcee(), None, &[], Some(&nuts(true)));
        // 250 ESS/s against emcee's 2.5 and NUTS's 5 (warmup + draws); 2×300 draws.
        assert!(s.contains("| emcee stretch + numpy/scipy |"), "{s}");
        assert!(
            s.contains("| 50000 | 100 | 250 | 5.000 | 2.500 | 100 |"),
            "{s}"
        );
        assert!(
            s.contains("| NumPyro NUTS, 2 chain(s) | 2×300 draws after 300 warmup |"),
            "{s}"
        );
        assert!(s.contains("| 500 |  | 5.000 | 50.000 |"), "{s}");
        // The detail table: per draw 30,000 / 600 gradients, 250 / 12.5 on the draws alone.
        assert!(s.contains("| 30000 | 50.000 | 0 |"), "{s}");
        assert!(s.contains("| 12.500 | 20.000 |"), "{s}");
        assert!(s.contains("NUTS peer: log-density at 1 points"), "{s}");
        assert!(s.contains("NUTS 2 chain(s) **agree**"), "{s}");
    }

    #[test]
    fn the_headline_quotes_nuts_only_when_it_passed_and_says_why_it_is_missing() {
        let line = |outcome: Option<&NutsOutcome>| {
            let mut s = String::new();
            nuts_headline(&mut s, outcome, 250.0, 2);
            s
        };
        assert!(line(Some(&nuts(true))).contains("ESS/s **50.000× NUTS's** on 2 threads"));
        assert!(line(Some(&nuts(true))).contains("20.000× against its kept draws alone"));
        assert!(line(Some(&nuts(false))).contains("did **not** pass"));
        let skipped = NutsOutcome::Skipped {
            reason: "pip install jax failed".into(),
        };
        assert!(line(Some(&skipped)).contains("**skipped**: pip install jax failed"));
        assert!(line(None).contains("`--no-nuts`"));
    }

    /// `slipbayes fit`'s moves: ESS 1,000 from 2,500 evaluations (400 per 1,000) in 2 s.
    fn fit_moves() -> MovesRun {
        MovesRun {
            moves: "student-t 0.5, de 0.5".into(),
            threads: 2,
            sampling_s: 2.0,
            evaluations: 2_500,
            ess_min: 1000.0,
            ess_per_s: 500.0,
            ess_per_kilo_eval: 400.0,
            same_start: true,
        }
    }

    fn others() -> [PeerOutcome; 2] {
        [
            // 40 per 1,000 evaluations, 1 per second.
            other(EnsemblePeer::DeSnooker, 200.0, 5_000, 200.0),
            // 10 per 1,000 evaluations, 4 per second.
            other(EnsemblePeer::Zeus, 400.0, 40_000, 100.0),
        ]
    }

    #[test]
    fn every_ensemble_peer_is_a_row_with_its_evaluations_and_our_ratios() {
        let mut s = String::new();
        peer_section(
            &mut s,
            2,
            4000,
            &emcee(),
            Some(&fit_moves()),
            &others(),
            None,
        );
        let rows = [
            "| emcee DE + snooker + numpy/scipy |",
            "| 5000 | 200 | 200 | 40.000 | 1.000 | 250 |",
            "| zeus + numpy/scipy |",
            "| 40000 | 100 | 400 | 10.000 | 4.000 | 62.500 |",
            // Our stretch move: 2,500 evaluations, 100 per 1,000.
            "| 2500 | 1.000 | 250 | 100 | 250 | 1.000 |",
            "| slipbayes, `fit`'s default moves (student-t 0.5, de 0.5), 2 threads |",
            "| 2500 | 2.000 | 1000 | 400 | 500 | 0.500 |",
        ];
        for row in rows {
            assert!(s.contains(row), "{row} in {s}");
        }
        assert!(s.contains("The same script with `--sampler zeus`"), "{s}");
        assert!(s.contains("3. zeus peer: log-density"), "{s}");
        assert!(
            s.contains("emcee DE + snooker **agree**, zeus **agree**"),
            "{s}"
        );
        assert!(
            s.contains(
                "| coordinate | our median | emcee median | |Δ| / MCSE | emcee DE + snooker median |"
            ),
            "{s}"
        );
        // The best by evaluations is DE + snooker (40), by time zeus (4 per second).
        assert!(
            s.contains(
                "default moves (student-t 0.5, de 0.5): ESS per 1,000 log-density evaluations \
                 400 against the best Python ensemble sampler's (emcee DE + snooker 40.000): \
                 **10.000×**; ESS/s on 2 threads **125×** the fastest's (zeus). Target ≥ 10× \
                 the best Python ensemble sampler's: **met**."
            ),
            "{s}"
        );
        assert!(
            s.contains(
                "- slipbayes with the stretch move: ESS per 1,000 log-density evaluations 100 \
                 against the best Python ensemble sampler's (emcee DE + snooker 40.000): \
                 **2.500×**; ESS/s on 2 threads **62.500×** the fastest's (zeus).\n"
            ),
            "{s}"
        );
    }

    #[test]
    fn the_headline_compares_with_the_best_peer_that_passed_and_names_the_skipped() {
        let line = |fit: Option<&MovesRun>, others: &[PeerOutcome]| {
            let mut s = String::new();
            best_peer_headline(&mut s, &emcee(), fit, others, 2);
            s
        };
        // Stretch alone, ours and the peer's: 100 against 5 per 1,000 evaluations; the target
        // is then judged on our stretch move.
        let alone = line(None, &[]);
        assert!(
            alone.contains(
                "(emcee stretch 5.000): **20.000×**; ESS/s on 2 threads **100×** the fastest's \
                 (emcee stretch). Target ≥ 10× the best Python ensemble sampler's: **met**."
            ),
            "{alone}"
        );

        let skipped = PeerOutcome::Skipped {
            sampler: EnsemblePeer::Zeus,
            reason: "pip install zeus-mcmc failed".into(),
        };
        let mut failed = other(EnsemblePeer::DeSnooker, 1e4, 1_000, 1.0);
        if let PeerOutcome::Ran(c) = &mut failed {
            c.quoted = false;
        }
        let s = line(Some(&fit_moves()), &[failed, skipped]);
        // The DE peer's figures would win, but it did not pass the checks.
        assert!(s.contains("(emcee stretch 5.000): **80.000×**"), "{s}");
        assert!(
            s.contains("The emcee DE + snooker peer did **not** pass"),
            "{s}"
        );
        assert!(
            s.contains("The zeus peer was **skipped**: pip install zeus-mcmc failed"),
            "{s}"
        );

        // 40 per 1,000 evaluations: our stretch move is 2.5×, a factor 4 short of the target,
        // which is judged on the fit's moves alone when they ran.
        let s = line(None, &[others()[0].clone()]);
        assert!(s.contains("(emcee DE + snooker 40.000): **2.500×**"), "{s}");
        assert!(s.contains("**missed** (a factor 4.000 short)"), "{s}");
        let s = line(Some(&fit_moves()), &[others()[0].clone()]);
        assert_eq!(s.matches("Target").count(), 1, "{s}");
        assert!(s.contains("**10.000×**") && s.contains("**met**"), "{s}");
    }
}
