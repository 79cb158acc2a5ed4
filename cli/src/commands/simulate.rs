//! `slipbayes simulate`: write a synthetic data set and its true values.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::{Args, ValueEnum};
use serde::Serialize;

use slipbayes::data::write_atomically;
use slipbayes::law::{Elastic, LawKind, LawParams, Scene};
use slipbayes::output_dir::claim_files;
use slipbayes::simulate::{simulate, SimulationSpec};

use super::{law_name, positive};

#[derive(Debug, Clone, Copy, ValueEnum)]
enum SceneArg {
    /// First slide on a fresh contact (aging, rejuvenation, elastic correction).
    First,
    /// Repeat slide right after a first one: F = min(kvt, F_end).
    Repeat,
    /// Fast slide declared stiff (no elastic correction, τ = t).
    StiffFast,
}

/// Simulate a slide from known parameters.
///
/// Writes a CSV with header `time_s,force_N` (plus `normal_force_N` when --normal-force is
/// given) and, beside it with the extension `.json`, the true values and every setting used.
/// All values are SI: forces in N, times in s, velocity in m/s, α in 1/m, k in N/m.
///
/// Example (PTFE on glass at 1 nm/s, near the paper's Fig. 2 fit):
///   slipbayes simulate --scene first --alpha 0.92e6 --a 6.2e-3 --f-d 10e-3 --t0 14.8
///   --k 1.2e4 --velocity 1e-9 --duration 30000 --interval 10 --sigma 1e-4 --seed 1
///   --out data/ptfe-c1-first.csv
#[derive(Debug, Args)]
#[command(verbatim_doc_comment)]
pub(super) struct SimulateArgs {
    /// Kind of slide.
    #[arg(long, value_enum)]
    scene: SceneArg,
    /// The law of a first or fast slide: `aging-rejuvenation` (default) or `log-aging` (its
    /// α → 0 limit, F = a ln(τ/t0): give no --alpha).
    #[arg(long, value_parser = law_name, default_value = "aging-rejuvenation")]
    law: LawKind,
    /// Shear-rejuvenation constant α (1/m); required by the aging–rejuvenation law.
    #[arg(long, allow_hyphen_values = true)]
    alpha: Option<f64>,
    /// Logarithmic aging amplitude a (N).
    #[arg(long, allow_hyphen_values = true)]
    a: f64,
    /// Steady-state friction F_d (N); required by the aging–rejuvenation law, and the force a
    /// repeat slide slides at unless --f-end or --after-first says otherwise.
    #[arg(long = "f-d", allow_hyphen_values = true)]
    f_d: Option<f64>,
    /// Short-time cut-off t0 (s).
    #[arg(long, allow_hyphen_values = true)]
    t0: f64,
    /// Machine stiffness k (N/m); required for first and repeat slides unless --rigid.
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    k: Option<f64>,
    /// A rigid machine (k → ∞): τ = t, and a repeat slide is at F_end from its start.
    #[arg(long, conflicts_with = "k")]
    rigid: bool,
    /// Sliding velocity v (m/s).
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    velocity: f64,
    /// Length of the record (s).
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    duration: f64,
    /// Sampling interval (s).
    #[arg(long, allow_hyphen_values = true, value_parser = positive)]
    interval: f64,
    /// Standard deviation σ of the Gaussian force noise (N).
    #[arg(long, default_value_t = 1e-4)]
    sigma: f64,
    /// Seed of the noise; the same seed gives the same file.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Repeat slide: force where the previous slide stopped (N). Default: F_d.
    #[arg(long = "f-end")]
    f_end: Option<f64>,
    /// Repeat slide: take F_end as the recorded force at the end of a first slide of this
    /// duration (s) with the same parameters.
    #[arg(long = "after-first")]
    after_first: Option<f64>,
    /// Mean normal force (N); adds a `normal_force_N` column.
    #[arg(long = "normal-force")]
    normal_force: Option<f64>,
    /// Standard deviation of the normal-force noise (N).
    #[arg(long = "normal-sigma", default_value_t = 0.0)]
    normal_sigma: f64,
    /// Output CSV path; the true values go to the same path with extension `.json`.
    #[arg(long)]
    out: PathBuf,
    /// Replace the output CSV and its `.json` if they exist (nothing else is touched).
    #[arg(long)]
    overwrite: bool,
}

/// The true-values file written beside a simulated CSV.
#[derive(Debug, Serialize)]
struct Truth<'a> {
    generator: String,
    data_file: String,
    synthetic: bool,
    points: usize,
    spec: &'a SimulationSpec,
    f_end_n: Option<f64>,
    peak: Option<TruePeak>,
}

#[derive(Debug, Serialize)]
struct TruePeak {
    f_peak_n: f64,
    tau_peak_s: f64,
    s_peak_m: f64,
    t_peak_s: f64,
}

pub(super) fn run(args: &SimulateArgs) -> anyhow::Result<ExitCode> {
    let truth_path = args.out.with_extension("json");
    claim_files(&[&args.out, &truth_path], args.overwrite)?;
    let scene = match args.scene {
        SceneArg::First => Scene::First,
        SceneArg::Repeat => Scene::Repeat,
        SceneArg::StiffFast => Scene::StiffFast,
    };
    let params = match (args.law, args.alpha, args.f_d) {
        (LawKind::AgingRejuvenation, Some(alpha), Some(f_d)) => {
            LawParams::new(alpha, args.a, f_d, args.t0)?
        }
        (LawKind::AgingRejuvenation, ..) => {
            bail!("the aging-rejuvenation law needs --alpha (1/m) and --f-d (N)")
        }
        (LawKind::LogAging, Some(_), _) => {
            bail!("--law log-aging is the α → 0 limit: it has no α, drop --alpha")
        }
        (LawKind::RateState, ..) => {
            bail!(
                "simulate writes slides of the aging-rejuvenation law or its limits; a \
                 rate-and-state slide is simulated with slipbayes::law::SpringSlider (see \
                 tests/rate_state_model.rs)"
            )
        }
        (LawKind::LogAging, None, f_d) => {
            LawParams::log_aging(args.a, f_d.unwrap_or(0.0), args.t0)?
        }
    };
    let spec = SimulationSpec {
        scene,
        law: args.law,
        params,
        stiffness_n_per_m: args.k,
        rigid: args.rigid,
        velocity_m_per_s: args.velocity,
        duration_s: args.duration,
        interval_s: args.interval,
        noise_sd_n: args.sigma,
        seed: args.seed,
        f_end_n: args.f_end,
        after_first_s: args.after_first,
        normal_force_n: args.normal_force,
        normal_noise_sd_n: args.normal_sigma,
    };
    let simulated = simulate(&spec)?;
    let peak = match scene {
        Scene::Repeat => None,
        Scene::First | Scene::StiffFast => {
            let law = spec.interface_law()?;
            let kv = match spec.elastic()? {
                Elastic::Spring { kv } => Some(kv),
                Elastic::Stiff => None,
            };
            law.peak().interior().map(|p| TruePeak {
                f_peak_n: p.force_n,
                tau_peak_s: p.tau_s,
                s_peak_m: p.slip_m(args.velocity),
                t_peak_s: p.observed_time_s(kv),
            })
        }
    };
    simulated
        .series
        .write_csv(&args.out)
        .with_context(|| format!("writing the data set {}", args.out.display()))?;
    let truth = Truth {
        generator: format!("slipbayes {} simulate", env!("CARGO_PKG_VERSION")),
        data_file: args
            .out
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default(),
        synthetic: true,
        points: simulated.series.len(),
        spec: &spec,
        f_end_n: simulated.f_end_n,
        peak,
    };
    let json = serde_json::to_string_pretty(&truth)?;
    write_atomically(&truth_path, json.as_bytes())
        .with_context(|| format!("writing the true values {}", truth_path.display()))?;
    println!(
        "wrote {} points to {} and the true values to {}",
        simulated.series.len(),
        args.out.display(),
        truth_path.display()
    );
    Ok(ExitCode::SUCCESS)
}
