//! Hard cases: data sets at the edges of what the one-contact model can learn, each simulated
//! from known parameters, fitted with the documented default (weakly informative) priors, and
//! judged per quantity: does the 95 % interval cover the truth, and how much did the data
//! shrink the prior (contraction 1 − sd²_post / sd²_prior of ln θ; near 0 means the data do
//! not tell)? A hard case passes when the fit ends and no quantity is confidently wrong (truth
//! further outside its 95 % interval than the interval is wide); it fails on an error or a
//! confident wrong answer. A quantity the data leave near its prior is said to be so.

use std::path::{Path, PathBuf};
use std::time::Instant;

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use slipbayes::data::write_atomically;
use slipbayes::density::LogDensity;
use slipbayes::fit::run_dir::{CHAINS_DIR, CHECKPOINT};
use slipbayes::fit::{fit_stop_rule, kept_draws, peak_notes, RunDir, DEFAULT_MAX_STEPS};
use slipbayes::law::{Law, LawParams, Scene};
use slipbayes::model::data::RunData;
use slipbayes::model::Posterior;
use slipbayes::run_file::RunFile;
use slipbayes::sampler::{Move, Steps};
use slipbayes::simulate::{simulate, SimulationSpec};

/// Contraction below which a quantity counts as not identified by the data.
pub const IDENTIFIED_CONTRACTION: f64 = 0.5;
/// Distance of the truth outside a 95 % interval, in widths of the interval (log scale), beyond
/// which a miss is a confident wrong answer rather than the 1-in-20 miss of a calibrated
/// interval: about four posterior sds further out.
pub const CONFIDENTLY_WRONG_WIDTHS: f64 = 1.0;
/// Prior draws used to estimate the prior sd of ln θ.
const PRIOR_DRAWS: usize = 20_000;
/// Kept draws read back for the posterior sd of ln θ.
const POSTERIOR_DRAWS: usize = 4_000;

/// One hard case: the truth, the simulated design and the fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HardCase {
    /// Short name (also its directory).
    pub name: String,
    /// What makes it hard.
    pub description: String,
    /// The law's true parameters.
    pub params: LawParams,
    /// True stiffness (N/m).
    pub k_n_per_m: f64,
    /// True noise sd (N).
    pub sigma_n: f64,
    /// First slide: (duration, interval) in s.
    pub first: (f64, f64),
    /// Repeat slide, if any: (duration, interval) in s.
    pub repeat: Option<(f64, f64)>,
    /// Fit: walkers per ensemble, ensembles, steps (the cap when `until_converged`).
    pub fit: (usize, usize, u64),
    /// Whether the fit runs until converged (the fit's default), `fit.2` steps at most;
    /// otherwise exactly `fit.2` steps.
    #[serde(default)]
    pub until_converged: bool,
}

const VELOCITY: f64 = 1e-9;

/// The PTFE truth of docs/model.md §7 with plausible F_d, k and σ (as in the bundled data).
fn ptfe() -> (LawParams, f64, f64) {
    let f_d = 10e-3;
    (
        LawParams {
            alpha_per_m: 0.92e6,
            a_n: 0.62 * f_d,
            f_d_n: f_d,
            t0_s: 14.8,
        },
        1.2e4,
        1e-4,
    )
}

/// The stiffness at which the first slide's path first turns into stick-slip: −min dF/dτ / v
/// over the record.
///
/// # Errors
/// When the law rejects the parameters.
pub fn stick_slip_stiffness(
    params: &LawParams,
    duration_s: f64,
) -> Result<f64, slipbayes::law::LawError> {
    let law = Law::new(params, VELOCITY)?;
    let (_, rate) = law.min_rate_up_to(duration_s);
    Ok((-rate).max(0.0) / VELOCITY)
}

/// The cases of issue 8: peak beyond the record, a record too short for k and t0, k just
/// above the stick-slip limit, t0 = 1e−6 s, very large noise, and a first slide of 10⁶ points
/// with a repeat slide of 10⁵ (sampled every 0.02 s, as a rheometer logs; its likelihood on
/// sufficient statistics, the default for long records).
pub fn cases() -> Vec<HardCase> {
    let (p, k, sigma) = ptfe();
    let standard = |name: &str, description: &str| HardCase {
        name: name.into(),
        description: description.into(),
        params: p,
        k_n_per_m: k,
        sigma_n: sigma,
        first: (20_000.0, 50.0),
        repeat: Some((2_000.0, 10.0)),
        fit: (32, 4, DEFAULT_MAX_STEPS),
        until_converged: true,
    };
    let near = stick_slip_stiffness(&p, 20_000.0).unwrap_or(k);
    let tiny_t0_limit = stick_slip_stiffness(&LawParams { t0_s: 1e-6, ..p }, 20_000.0).unwrap_or(k);
    vec![
        HardCase {
            first: (1_500.0, 5.0),
            ..standard(
                "peak-beyond-record",
                "first slide stops at 1 500 s, before its peak (observed at about 2 340 s); repeat slide after it",
            )
        },
        HardCase {
            first: (600.0, 2.0),
            repeat: None,
            ..standard(
                "short-first-only",
                "600 s of first slide only (301 points, no repeat slide), far before the peak at about 2 340 s",
            )
        },
        HardCase {
            k_n_per_m: 1.05 * near,
            ..standard(
                "near-stick-slip",
                &format!("k = 1.05 × the stick-slip limit {near:.4e} N/m of this path"),
            )
        },
        HardCase {
            params: LawParams { t0_s: 1e-6, ..p },
            // The peak grows with ln(1/t0): at k = 1.2e4 N/m this slide would stick-slip.
            k_n_per_m: 2.0 * tiny_t0_limit,
            ..standard(
                "tiny-t0",
                &format!("t0 = 1e−6 s (αv·t0 ≈ 1e−9), k = 2 × its stick-slip limit {tiny_t0_limit:.4e} N/m"),
            )
        },
        HardCase {
            sigma_n: 5e-3,
            ..standard("large-noise", "σ = 5 mN, half of F_d and about a third of the peak's rise")
        },
        HardCase {
            first: (20_000.0, 0.02),
            repeat: Some((2_000.0, 0.02)),
            ..standard(
                "million-points",
                "first slide of 1 000 001 points and repeat slide of 100 001 (every 0.02 s), \
                 fitted on sufficient statistics (docs/model.md §5)",
            )
        },
    ]
}

/// How one quantity came out.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QuantityOutcome {
    /// Chain column.
    pub column: String,
    /// True value.
    pub truth: f64,
    /// Posterior median.
    pub median: f64,
    /// 95 % equal-tailed interval.
    pub ci95: [f64; 2],
    /// Whether it covers the truth.
    pub covered: bool,
    /// 1 − sd²(ln θ | data) / sd²(ln θ); `None` for derived quantities (no prior of their own).
    pub contraction: Option<f64>,
    /// The truth lies more than [`CONFIDENTLY_WRONG_WIDTHS`] interval widths outside it.
    pub confidently_wrong: bool,
    /// In words: identified, not identified, or missed.
    pub verdict: String,
}

/// The result of one hard case.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HardOutcome {
    /// The case.
    pub case: HardCase,
    /// Points in the first slide.
    pub first_points: usize,
    /// Per quantity, when the fit finished.
    pub quantities: Vec<QuantityOutcome>,
    /// The error, when it did not.
    pub error: Option<String>,
    /// Whether every convergence check passed.
    pub converged: bool,
    /// Largest R̂ over the reported quantities.
    pub r_hat_max: Option<f64>,
    /// Log-density evaluations (optimisation excluded).
    pub log_density_evals: u64,
    /// Steps the fit ran.
    #[serde(default)]
    pub steps_run: u64,
    /// Seconds of sampling.
    pub sampling_s: f64,
    /// Seconds in all (simulation, start, sampling, summary).
    pub wall_s: f64,
    /// Seconds per log-density evaluation at the start point.
    pub eval_s: f64,
    /// Whether the case passed (see the module documentation).
    pub passed: bool,
    /// What the fit says the data do not show (`summary.json`'s notes).
    #[serde(default)]
    pub notes: Vec<String>,
}

fn run_toml(name: &str, file: &str, scene: &str, follows: Option<&str>) -> String {
    let follows = follows.map_or(String::new(), |f| format!("follows = \"{f}\"\n"));
    format!(
        "[[run]]\nname = \"{name}\"\ncontact = \"c\"\ndata = \"{file}\"\nvelocity_m_per_s = {VELOCITY:e}\nscene = \"{scene}\"\n{follows}"
    )
}

/// What the command line changes in the hard cases' fits.
#[derive(Debug, Clone, Copy, Default)]
pub struct FitOverrides<'a> {
    /// Moves instead of the fit's default mixture.
    pub moves: Option<&'a [(Move, f64)]>,
    /// Step cap of the fits run until converged, instead of the case's.
    pub max_steps: Option<u64>,
}

/// Runs one case in `dir`, fitted with `moves` instead of the default mixture when given;
/// never panics on bad data: errors end up in the outcome.
pub fn run_case(
    case: &HardCase,
    dir: &Path,
    seed: u64,
    moves: Option<&[(Move, f64)]>,
) -> HardOutcome {
    let started = Instant::now();
    let mut outcome = HardOutcome {
        case: case.clone(),
        first_points: 0,
        quantities: vec![],
        error: None,
        converged: false,
        r_hat_max: None,
        log_density_evals: 0,
        steps_run: 0,
        sampling_s: 0.0,
        wall_s: 0.0,
        eval_s: f64::NAN,
        passed: false,
        notes: Vec::new(),
    };
    if let Err(e) = fit_case(case, dir, seed, moves, &mut outcome) {
        outcome.error = Some(e);
    }
    outcome.wall_s = started.elapsed().as_secs_f64();
    outcome.passed =
        outcome.error.is_none() && !outcome.quantities.iter().any(|q| q.confidently_wrong);
    outcome
}

fn fit_case(
    case: &HardCase,
    dir: &Path,
    seed: u64,
    moves: Option<&[(Move, f64)]>,
    outcome: &mut HardOutcome,
) -> Result<(), String> {
    std::fs::create_dir_all(dir).map_err(|e| format!("creating {}: {e}", dir.display()))?;
    let spec = |scene, (duration, interval): (f64, f64), noise_seed, after| SimulationSpec {
        scene,
        params: case.params,
        stiffness_n_per_m: Some(case.k_n_per_m),
        law: Default::default(),
        rigid: false,
        velocity_m_per_s: VELOCITY,
        duration_s: duration,
        interval_s: interval,
        noise_sd_n: case.sigma_n,
        seed: noise_seed,
        f_end_n: None,
        after_first_s: after,
        normal_force_n: None,
        normal_noise_sd_n: 0.0,
    };
    let first = simulate(&spec(Scene::First, case.first, seed, None))
        .map_err(|e| format!("simulating the first slide: {e}"))?
        .series;
    outcome.first_points = first.len();
    let mut slides = vec![first.clone()];
    let mut model = String::from(
        "# Hard case: default priors, one contact.\n[[material]]\nname = \"m\"\n[[contact]]\nname = \"c\"\nmaterial = \"m\"\n",
    );
    model += &run_toml("first", "first.csv", "first", None);
    if let Some(design) = case.repeat {
        let end = first.time_s.last().copied().unwrap_or(case.first.0);
        slides.push(
            simulate(&spec(Scene::Repeat, design, seed + 1, Some(end)))
                .map_err(|e| format!("simulating the repeat slide: {e}"))?
                .series,
        );
        model += &run_toml("repeat", "repeat.csv", "repeat", Some("first"));
    }
    // The model and its slides stay in memory; only the fit's chains go to disk.
    let run = RunFile::parse(&model, &dir.join("model.toml")).map_err(|e| e.to_string())?;
    let spec = &run.model;
    let data = slides
        .into_iter()
        .enumerate()
        .map(|(i, series)| RunData::for_series(spec, i, series))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let posterior = Posterior::from_data(spec, run.blocking(), data).map_err(|e| e.to_string())?;
    let timer = Instant::now();
    let at_start = posterior.log_density(posterior.start(), &mut []);
    outcome.eval_s = timer.elapsed().as_secs_f64();
    at_start.map_err(|e| format!("the posterior at its start point: {e}"))?;

    let (walkers, ensembles, steps) = case.fit;
    let steps = if case.until_converged {
        Steps::UntilConverged(fit_stop_rule(steps))
    } else {
        Steps::Fixed(steps)
    };
    let fit_dir = RunDir::new(dir.join("fit"));
    let fit = super::quiet_fit(&posterior, walkers, ensembles, seed, steps, moves, &fit_dir)?;
    let s = &fit.summary;
    outcome.notes = peak_notes(&posterior, s);
    outcome.converged = s.sampler.converged;
    outcome.log_density_evals = s.sampler.log_density_evals;
    outcome.steps_run = s.sampler.steps_run;
    outcome.sampling_s = s.sampler.wall_s;
    outcome.r_hat_max = s
        .quantities()
        .filter_map(|q| q.stats.r_hat)
        .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r))));

    let coords = posterior.param_names();
    let draws = kept_draws(&fit, &coords, POSTERIOR_DRAWS).map_err(|e| e.to_string())?;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let p = case.params;
    let truths = [
        ("alpha", "alpha", p.alpha_per_m),
        ("a_over_F_d", "a_over_F_d", p.a_n / p.f_d_n),
        ("F_d", "F_d", p.f_d_n),
        ("t0", "t0", p.t0_s),
        ("k", "k", case.k_n_per_m),
        // σ is integrated out: no coordinate, so no contraction; coverage still counts.
        ("sigma", "sigma", case.sigma_n),
    ];
    for q in s.parameters.iter().chain(&s.derived) {
        let (truth, contraction) = if q.name == "F_peak" {
            let peak = Law::new(&p, VELOCITY)
                .ok()
                .and_then(|l| l.peak().interior())
                .map_or(f64::NAN, |pk| pk.force_n);
            (peak, None)
        } else if let Some(&(_, prior_name, truth)) = truths.iter().find(|t| t.0 == q.name) {
            let coord = coords.iter().position(|c| c == &format!("ln_{}", q.column));
            let contraction = coord.map(|i| {
                let post: Vec<f64> = draws.iter().map(|d| d[i]).collect();
                let prior = spec.prior(prior_name);
                let prior_draws: Vec<f64> = (0..PRIOR_DRAWS)
                    .filter_map(|_| prior.sample(&mut rng).map(f64::ln))
                    .collect();
                1.0 - variance(&post) / variance(&prior_draws)
            });
            (truth, contraction)
        } else {
            continue;
        };
        let st = &q.stats;
        let covered = st.ci_low <= truth && truth <= st.ci_high;
        // On the log scale: how far outside its 95 % interval the truth lies, in widths of
        // that interval (one width is about four posterior sds).
        let (lo, hi, t) = (st.ci_low.ln(), st.ci_high.ln(), truth.ln());
        let miss_in_widths = (lo - t).max(t - hi).max(0.0) / (hi - lo);
        let spread = format!("95 % interval spans a factor {:.3}", st.ci_high / st.ci_low);
        let verdict = match (covered, contraction) {
            (true, Some(c)) if c < IDENTIFIED_CONTRACTION => format!(
                "not identified by these data: ln {} keeps {:.0} % of the prior's sd",
                q.name,
                100.0 * (1.0 - c).max(0.0).sqrt()
            ),
            (true, _) => format!("covers the truth; {spread}"),
            (false, _) if miss_in_widths <= CONFIDENTLY_WRONG_WIDTHS => format!(
                "misses the truth by {miss_in_widths:.2} interval widths (a 95 % interval misses 1 time in 20); {spread}"
            ),
            (false, _) => format!(
                "CONFIDENTLY WRONG: the truth lies {miss_in_widths:.2} interval widths outside; {spread}"
            ),
        };
        let confidently_wrong = !covered && miss_in_widths > CONFIDENTLY_WRONG_WIDTHS;
        outcome.quantities.push(QuantityOutcome {
            column: q.column.clone(),
            truth,
            median: st.median,
            ci95: [st.ci_low, st.ci_high],
            covered,
            contraction,
            confidently_wrong,
            verdict,
        });
    }
    let _ = std::fs::remove_dir_all(fit_dir.file(CHAINS_DIR));
    let _ = std::fs::remove_file(fit_dir.file(CHECKPOINT));
    Ok(())
}

fn variance(x: &[f64]) -> f64 {
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)
}

/// The outcomes as a Markdown section.
pub fn markdown(outcomes: &[HardOutcome], command: &str) -> String {
    use std::fmt::Write;
    let mut md = String::new();
    let _ = writeln!(md, "## Hard cases\n\nCommand: `{command}`. Default priors (log-uniform over many decades), one contact at 1 nm/s, PTFE truth of docs/model.md §7 (α = 0.92 µm⁻¹, a/F_d = 0.62, F_d = 10 mN, t0 = 14.8 s, k = 1.2e4 N/m, σ = 0.1 mN) except where the case changes it. Contraction = 1 − sd²(ln θ | data)/sd²(ln θ); below {IDENTIFIED_CONTRACTION} the data do not identify θ.\n");
    for o in outcomes {
        let c = &o.case;
        let _ = writeln!(
            md,
            "### `{}`: {}\n\n{} first-slide points{}; fit {} ensembles × {} walkers × {} steps{}; {} evaluations, {:.1} s sampling, {:.1} s in all, {:.2e} s per evaluation at the start; largest R̂ {}; converged by every check: {}; **{}**.\n",
            c.name,
            c.description,
            o.first_points,
            c.repeat.map_or(", no repeat slide".to_string(), |(d, i)| format!(", repeat slide {d} s every {i} s")),
            c.fit.1,
            c.fit.0,
            o.steps_run,
            if c.until_converged {
                format!(" (until converged, at most {})", c.fit.2)
            } else {
                String::new()
            },
            o.log_density_evals,
            o.sampling_s,
            o.wall_s,
            o.eval_s,
            o.r_hat_max.map_or("n/a".into(), |r| format!("{r:.3}")),
            o.converged,
            if o.passed { "passed" } else { "FAILED" }
        );
        if let Some(e) = &o.error {
            let _ = writeln!(md, "Error: {e}\n");
            continue;
        }
        let _ = writeln!(
            md,
            "| quantity | truth | median | 95 % interval | contraction | verdict |\n|---|---|---|---|---|---|"
        );
        for q in &o.quantities {
            let _ = writeln!(
                md,
                "| `{}` | {:.4e} | {:.4e} | [{:.3e}, {:.3e}] | {} | {} |",
                q.column,
                q.truth,
                q.median,
                q.ci95[0],
                q.ci95[1],
                q.contraction.map_or("–".into(), |c| format!("{c:.3}")),
                q.verdict
            );
        }
        let _ = writeln!(md);
        for note in &o.notes {
            let _ = writeln!(md, "The fit notes: {note}.\n");
        }
    }
    md
}

/// Runs the named cases (all when `only` is empty) into `out/<case>/`, writing
/// `out/hard_cases.json` and `out/hard_cases.md` after each case, the fits changed by
/// `overrides`.
///
/// # Errors
/// When the summary files cannot be written.
pub fn run_hard_cases(
    out: &Path,
    only: &[String],
    seed: u64,
    overrides: FitOverrides,
    command: &str,
    progress: &mut dyn FnMut(&HardOutcome),
) -> Result<Vec<HardOutcome>, std::io::Error> {
    let mut outcomes = Vec::new();
    for case in cases() {
        if !only.is_empty() && !only.contains(&case.name) {
            continue;
        }
        let dir: PathBuf = out.join(&case.name);
        // The cap goes into the case, so that its report states the cap the fit had.
        let (walkers, ensembles, _) = case.fit;
        let case = match overrides.max_steps {
            Some(cap) if case.until_converged => HardCase {
                fit: (walkers, ensembles, cap),
                ..case
            },
            _ => case,
        };
        let outcome = run_case(&case, &dir, seed, overrides.moves);
        progress(&outcome);
        outcomes.push(outcome);
        let json = serde_json::to_vec_pretty(&outcomes).unwrap_or_default();
        write_atomically(&out.join("hard_cases.json"), &json)?;
        write_atomically(
            &out.join("hard_cases.md"),
            markdown(&outcomes, command).as_bytes(),
        )?;
    }
    Ok(outcomes)
}
