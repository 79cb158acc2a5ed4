//! Error against cost, knob by knob, on the first and repeat slide of one contact: data
//! decimation (every k-th point kept, built from the bundled files into the scratch
//! directory), walkers per ensemble, and chain length. Each setting is a complete
//! `run_fit` (start-point optimisation, sampling with chains streamed to Parquet, summary),
//! timed as a user would wait for it, and compared with a long reference run on the full data
//! and with the known truth.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::cost::{read_series, read_truth, Truth};
use super::{load_posterior, BenchError, BenchSettings, BENCH_SEED};
use slipbayes::data::{write_atomically, Series};
use slipbayes::density::LogDensity;
use slipbayes::density::Target;
use slipbayes::fit::{run_fit, FitSettings, FitSummary, QuantitySummary, RunDir, SummarySpec};
use slipbayes::sampler::{Parallelism, Silent, Steps, StopRule};

/// Which knob a run turns.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Knob {
    /// `slipbayes fit` as it comes: all data, default walkers, run until converged.
    Default,
    /// Every k-th data point.
    Decimation,
    /// Walkers per ensemble.
    Walkers,
    /// Steps.
    Length,
}

impl Knob {
    /// Label in tables and plots.
    pub fn label(self) -> &'static str {
        match self {
            Self::Default => "default (until converged)",
            Self::Decimation => "data decimation",
            Self::Walkers => "walkers",
            Self::Length => "chain length",
        }
    }
}

/// One fit of the study.
#[derive(Debug, Clone, Serialize)]
pub struct KnobRun {
    /// The knob turned.
    pub knob: Knob,
    /// Its value, in words.
    pub value: String,
    /// Data points fitted (both slides).
    pub points: usize,
    /// Walkers per ensemble.
    pub walkers: usize,
    /// Steps run.
    pub steps: u64,
    /// Wall time of the whole fit (s).
    pub wall_s: f64,
    /// Largest |median − reference median| / reference sd over the parameters.
    pub median_vs_reference: f64,
    /// Largest error of the F_peak 95 % interval ends, in reference sds of F_peak.
    pub f_peak_interval_vs_reference: f64,
    /// Largest |median − truth| / reference sd over the parameters with a known truth.
    pub median_vs_truth: f64,
    /// On the Pareto front of (wall time, `median_vs_reference`).
    pub pareto_median: bool,
    /// On the Pareto front of (wall time, `f_peak_interval_vs_reference`).
    pub pareto_f_peak: bool,
}

/// The whole study.
#[derive(Debug, Clone, Serialize)]
pub struct KnobStudy {
    /// Reference: steps and wall time.
    pub reference_steps: u64,
    /// Wall time of the reference fit (s).
    pub reference_wall_s: f64,
    /// Whether the reference run calls itself converged, and its τ_max (steps).
    pub reference_converged: bool,
    /// τ_max of the reference.
    pub reference_tau_max: Option<f64>,
    /// The reference's |median − truth| / sd: what even an exact posterior shows.
    pub reference_vs_truth: f64,
    /// Every run.
    pub runs: Vec<KnobRun>,
}

/// Indices not dominated by another point (smaller or equal in both, smaller in one).
pub fn pareto_front(points: &[(f64, f64)]) -> Vec<bool> {
    points
        .iter()
        .map(|&(t, e)| {
            !points
                .iter()
                .any(|&(t2, e2)| t2 <= t && e2 <= e && (t2 < t || e2 < e))
        })
        .collect()
}

/// Writes the first and repeat slides with every `k`-th point (and the last, where the first
/// slide stopped and the repeat slide takes over) and a model file for them.
pub(crate) fn decimated_model(
    settings: &BenchSettings,
    k: usize,
) -> Result<(PathBuf, usize), BenchError> {
    let dir = settings.scratch.join(format!("decimated-{k}"));
    std::fs::create_dir_all(&dir).map_err(BenchError::io(&dir))?;
    let mut points = 0;
    let mut files = Vec::new();
    for (name, source) in [
        ("first", &settings.first_csv),
        ("repeat", &settings.repeat_csv),
    ] {
        let s = read_series(source)?;
        let keep: Vec<usize> = (0..s.len())
            .filter(|&i| i % k == 0 || i + 1 == s.len())
            .collect();
        let kept = Series {
            time_s: keep.iter().map(|&i| s.time_s[i]).collect(),
            force_n: keep.iter().map(|&i| s.force_n[i]).collect(),
            normal_force_n: s
                .normal_force_n
                .as_ref()
                .map(|v| keep.iter().map(|&i| v[i]).collect()),
        };
        points += kept.len();
        let path = dir.join(format!("{name}.csv"));
        kept.write_csv(&path).map_err(|e| BenchError::Input {
            what: format!("decimated data {}", path.display()),
            message: e.to_string(),
        })?;
        files.push(path);
    }
    let v = settings.velocity_m_per_s;
    let toml = format!(
        "# First and repeat slide of one contact, every {k}-th point (slipbayes bench).\n\
         [[material]]\nname = \"PTFE\"\n\n[[contact]]\nname = \"c1\"\nmaterial = \"PTFE\"\n\n\
         [[run]]\nname = \"first\"\ncontact = \"c1\"\ndata = \"first.csv\"\n\
         velocity_m_per_s = {v:e}\nscene = \"first\"\n\n\
         [[run]]\nname = \"repeat\"\ncontact = \"c1\"\ndata = \"repeat.csv\"\n\
         velocity_m_per_s = {v:e}\nscene = \"repeat\"\nfollows = \"first\"\n"
    );
    let model = dir.join("model.toml");
    write_atomically(&model, toml.as_bytes()).map_err(BenchError::io(&model))?;
    Ok((model, points))
}

/// One complete fit into `out` (chains streamed to Parquet and left there).
pub(crate) fn fit_keeping(
    model: &Path,
    walkers: Option<usize>,
    steps: Steps,
    seed: u64,
    out: &Path,
    threads: usize,
) -> Result<(FitSummary, usize), BenchError> {
    let (_, posterior) = load_posterior(model)?;
    let walkers = walkers.unwrap_or_else(|| super::throughput::default_walkers(posterior.dim()));
    let settings = FitSettings {
        walkers,
        seed,
        steps,
        quiet: true,
        overwrite: true,
        ..FitSettings::default()
    };
    std::fs::create_dir_all(out).map_err(BenchError::io(out))?;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| BenchError::run("thread pool")(e.to_string()))?;
    let outcome = pool
        .install(|| {
            run_fit(
                Target::blocked(&posterior),
                &SummarySpec::of(posterior.quantities().to_vec()),
                posterior.search_start(),
                &settings,
                &RunDir::new(out),
                false,
                &mut Silent,
                Parallelism::default(),
            )
        })
        .map_err(|e| BenchError::run(format!("fit of {}", model.display()))(e.to_string()))?;
    Ok((outcome.summary, walkers))
}

fn find<'a>(s: &'a FitSummary, column: &str) -> Option<&'a QuantitySummary> {
    s.quantities().find(|q| q.column == column)
}

/// The true value of a reported parameter, where the data files give it.
fn truth_of(q: &QuantitySummary, first: &Truth, repeat: &Truth) -> Option<f64> {
    let p = &first.params;
    match (q.name.as_str(), q.group.as_str()) {
        ("alpha", _) => Some(p.alpha_per_m),
        ("a_over_F_d", _) => Some(p.a_n / p.f_d_n),
        ("F_d", _) => Some(p.f_d_n),
        ("t0", _) => Some(p.t0_s),
        ("k", _) => first.k_n_per_m,
        ("sigma", "first") => Some(first.sigma_n),
        ("sigma", "repeat") => Some(repeat.sigma_n),
        _ => None,
    }
}

fn errors(
    s: &FitSummary,
    reference: &FitSummary,
    first: &Truth,
    repeat: &Truth,
) -> (f64, f64, f64) {
    let mut vs_reference: f64 = 0.0;
    let mut vs_truth: f64 = 0.0;
    for r in &reference.parameters {
        let Some(q) = find(s, &r.column) else {
            continue;
        };
        vs_reference = vs_reference.max((q.stats.median - r.stats.median).abs() / r.stats.sd);
        if let Some(t) = truth_of(r, first, repeat) {
            vs_truth = vs_truth.max((q.stats.median - t).abs() / r.stats.sd);
        }
    }
    let peak = "F_peak[first]";
    let f_peak = match (find(s, peak), find(reference, peak)) {
        (Some(q), Some(r)) => {
            ((q.stats.ci_low - r.stats.ci_low).abs()).max((q.stats.ci_high - r.stats.ci_high).abs())
                / r.stats.sd
        }
        _ => f64::NAN,
    };
    (vs_reference, f_peak, vs_truth)
}

/// Runs the study.
///
/// # Errors
/// [`BenchError`] when data cannot be decimated or a fit fails.
pub fn study(
    settings: &BenchSettings,
    progress: &mut dyn FnMut(&str),
) -> Result<KnobStudy, BenchError> {
    let plan = &settings.plan;
    let threads = settings.threads;
    let first = read_truth(&settings.first_csv)?;
    let repeat = read_truth(&settings.repeat_csv)?;
    let (full, full_points) = decimated_model(settings, 1)?;
    let runs_dir = settings.scratch.join("runs");

    progress("  reference fit (full data, long chains)");
    let clock = std::time::Instant::now();
    let (reference, _) = fit_keeping(
        &full,
        None,
        Steps::Fixed(plan.reference_steps),
        BENCH_SEED + 1,
        &runs_dir.join("reference"),
        threads,
    )?;
    let reference_wall_s = clock.elapsed().as_secs_f64();

    // (knob, value, model, points, walkers, steps)
    let mut jobs: Vec<(Knob, String, PathBuf, usize, Option<usize>, Steps)> = vec![(
        Knob::Default,
        format!(
            "as `slipbayes fit` (at most {} steps)",
            plan.default_max_steps
        ),
        full.clone(),
        full_points,
        None,
        Steps::UntilConverged(StopRule::new(plan.default_max_steps)),
    )];
    for &n in &plan.lengths {
        jobs.push((
            Knob::Length,
            format!("{n} steps"),
            full.clone(),
            full_points,
            None,
            Steps::Fixed(n),
        ));
    }
    for &w in &plan.walkers {
        jobs.push((
            Knob::Walkers,
            format!("{w} walkers"),
            full.clone(),
            full_points,
            Some(w),
            Steps::Fixed(plan.knob_steps),
        ));
    }
    for &k in &plan.decimations {
        let (model, points) = decimated_model(settings, k)?;
        jobs.push((
            Knob::Decimation,
            format!("1 point in {k}"),
            model,
            points,
            None,
            Steps::Fixed(plan.knob_steps),
        ));
    }

    let mut runs = Vec::with_capacity(jobs.len());
    for (i, (knob, value, model, points, walkers, steps)) in jobs.into_iter().enumerate() {
        progress(&format!("  {}: {value}", knob.label()));
        let clock = std::time::Instant::now();
        let (summary, walkers) = fit_keeping(
            &model,
            walkers,
            steps,
            BENCH_SEED,
            &runs_dir.join(format!("run-{i}")),
            threads,
        )?;
        // Chains are not kept: the study needs only the summary.
        let _ = std::fs::remove_dir_all(&runs_dir);
        let wall_s = clock.elapsed().as_secs_f64();
        let (m, f, t) = errors(&summary, &reference, &first, &repeat);
        runs.push(KnobRun {
            knob,
            value,
            points,
            walkers,
            steps: summary.sampler.steps,
            wall_s,
            median_vs_reference: m,
            f_peak_interval_vs_reference: f,
            median_vs_truth: t,
            pareto_median: false,
            pareto_f_peak: false,
        });
    }
    let front = |f: fn(&KnobRun) -> f64| {
        pareto_front(&runs.iter().map(|r| (r.wall_s, f(r))).collect::<Vec<_>>())
    };
    let (pm, pf) = (
        front(|r| r.median_vs_reference),
        front(|r| r.f_peak_interval_vs_reference),
    );
    for (r, (m, f)) in runs.iter_mut().zip(pm.into_iter().zip(pf)) {
        r.pareto_median = m;
        r.pareto_f_peak = f;
    }
    let (_, _, reference_vs_truth) = errors(&reference, &reference, &first, &repeat);
    Ok(KnobStudy {
        reference_steps: plan.reference_steps,
        reference_wall_s,
        reference_converged: reference.sampler.converged,
        reference_tau_max: reference.sampler.tau_max,
        reference_vs_truth,
        runs,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::BenchSettings;

    /// The repository root: cargo runs this crate's tests from `cli/`.
    fn repo(path: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
    }

    fn settings(scratch: &Path) -> BenchSettings {
        let mut s = BenchSettings::bundled(true, 1, scratch.to_path_buf());
        s.first_csv = repo("data/ptfe-c1-first.csv");
        s.repeat_csv = repo("data/ptfe-c1-repeat.csv");
        s.fast_csv = repo("data/ptfe-c1-fast.csv");
        s
    }

    #[test]
    fn decimated_model_keeps_every_kth_point_and_the_last() {
        let dir = tempfile::tempdir().unwrap();
        let s = settings(dir.path());
        let first = read_series(&s.first_csv).unwrap();
        let repeat = read_series(&s.repeat_csv).unwrap();
        let k = 7;
        let expected: usize = [first.len(), repeat.len()]
            .iter()
            .map(|&n| n.div_ceil(k) + usize::from((n - 1) % k != 0))
            .sum();
        let (model, points) = decimated_model(&s, k).unwrap();
        assert_eq!(points, expected);
        let (spec, posterior) = load_posterior(&model).unwrap();
        assert_eq!(spec.file.runs.len(), 2);
        // The first slide still ends where the repeat slide takes over.
        let kept = read_series(&spec.data_path(0)).unwrap();
        let end = |s: &Series| s.time_s.last().copied().unwrap_or(f64::NAN);
        assert!((end(&kept) - end(&first)).abs() < 1e-9);
        assert!(posterior.dim() >= 5);
    }

    #[test]
    fn truth_of_the_bundled_contact_is_read() {
        let first = read_truth(&repo("data/ptfe-c1-first.csv")).unwrap();
        assert!((first.params.alpha_per_m - 0.92e6).abs() < 1.0);
        assert!(first.k_n_per_m.is_some() && first.f_peak_n.is_some());
        let fast = read_truth(&repo("data/ptfe-c1-fast.csv")).unwrap();
        assert!(fast.k_n_per_m.is_none());
        assert!(read_truth(&repo("data/absent.csv")).is_err());
    }

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let front = pareto_front(&[(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (2.0, 3.0)]);
        assert_eq!(front, vec![true, true, false, true, true]);
    }
}
