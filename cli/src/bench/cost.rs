//! The cost of the forward model per data point, scene by scene, with the cost of one `exp`
//! per point measured alongside in the same run (so that the ratios survive a busy machine).

use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

use serde::Serialize;

use super::{load_posterior, BenchError, BenchSettings};
use slipbayes::data::Series;
use slipbayes::density::LogDensity;
use slipbayes::law::{Elastic, Law, LawParams, ObservedSlide, RepeatSlide};

/// One row of the cost table.
#[derive(Debug, Clone, Serialize)]
pub struct CostRow {
    /// What was timed.
    pub what: String,
    /// Points per evaluation.
    pub points: usize,
    /// Median over the repetitions, ns per point.
    pub ns_per_point: f64,
    /// Ratio to the exp floor of the same run.
    pub ratio_to_exp: f64,
}

/// The cost table: the floor first.
#[derive(Debug, Clone, Serialize)]
pub struct CostTable {
    /// Rows, the exp floor first.
    pub rows: Vec<CostRow>,
}

impl CostTable {
    /// The row called `what`.
    pub fn row(&self, what: &str) -> Option<&CostRow> {
        self.rows.iter().find(|r| r.what == what)
    }
}

/// Name of the floor row.
pub const EXP_FLOOR: &str = "exp floor: one f64::exp per point";
/// Name of the one-contact log-density row.
pub const ONE_CONTACT_LOG_DENSITY: &str = "one-contact log-density (first slide, σ marginal)";

/// The true parameters written beside a simulated data file.
#[derive(Debug, Clone, Copy)]
pub struct Truth {
    /// α, a, F_d, t0.
    pub params: LawParams,
    /// Machine stiffness (N/m); none for a stiff slide.
    pub k_n_per_m: Option<f64>,
    /// Velocity (m/s).
    pub velocity_m_per_s: f64,
    /// Noise sd (N).
    pub sigma_n: f64,
    /// The peak force of a first slide, if recorded.
    pub f_peak_n: Option<f64>,
    /// Force where the slide before a repeat slide stopped.
    pub f_end_n: Option<f64>,
}

/// Reads the truth JSON beside a data CSV (`x.csv` → `x.json`).
///
/// # Errors
/// [`BenchError::Input`] naming the file and the missing key.
pub fn read_truth(csv: &Path) -> Result<Truth, BenchError> {
    let path = csv.with_extension("json");
    let input = |message: String| BenchError::Input {
        what: format!("truth file {}", path.display()),
        message,
    };
    let text = std::fs::read_to_string(&path).map_err(|e| input(e.to_string()))?;
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| input(e.to_string()))?;
    let num = |ptr: &str| -> Result<f64, BenchError> {
        v.pointer(ptr)
            .and_then(serde_json::Value::as_f64)
            .ok_or_else(|| input(format!("missing number at {ptr}")))
    };
    let params = LawParams::new(
        num("/spec/params/alpha_per_m")?,
        num("/spec/params/a_n")?,
        num("/spec/params/f_d_n")?,
        num("/spec/params/t0_s")?,
    )
    .map_err(|e| input(e.to_string()))?;
    Ok(Truth {
        params,
        k_n_per_m: num("/spec/stiffness_n_per_m").ok(),
        velocity_m_per_s: num("/spec/velocity_m_per_s")?,
        sigma_n: num("/spec/noise_sd_n")?,
        f_peak_n: num("/peak/f_peak_n").ok(),
        f_end_n: num("/f_end_n").ok(),
    })
}

pub(crate) fn read_series(csv: &Path) -> Result<Series, BenchError> {
    Series::read_csv(csv).map_err(|e| BenchError::Input {
        what: format!("data {}", csv.display()),
        message: e.to_string(),
    })
}

/// Median ns per point of `f` over `reps` repetitions, each at least ~2 ms long.
fn time_per_point(points: usize, reps: usize, mut f: impl FnMut()) -> f64 {
    // Calls per repetition so that one repetition is long enough for the clock.
    let start = Instant::now();
    f();
    let once = start.elapsed().as_secs_f64().max(1e-7);
    let calls = ((2e-3 / once).ceil() as usize).clamp(1, 10_000);
    let mut samples: Vec<f64> = (0..reps.max(1))
        .map(|_| {
            let start = Instant::now();
            for _ in 0..calls {
                f();
            }
            start.elapsed().as_secs_f64() * 1e9 / (calls * points) as f64
        })
        .collect();
    samples.sort_by(f64::total_cmp);
    samples[samples.len() / 2]
}

/// Measures every row of the cost table.
///
/// # Errors
/// [`BenchError`] when a data or truth file cannot be used.
pub fn measure(settings: &BenchSettings) -> Result<CostTable, BenchError> {
    let reps = settings.plan.cost_reps;
    let law_error = |what: &str| {
        let what = what.to_owned();
        move |e: slipbayes::law::LawError| BenchError::Input {
            what: what.clone(),
            message: e.to_string(),
        }
    };
    let first = read_series(&settings.first_csv)?;
    let truth = read_truth(&settings.first_csv)?;
    let repeat = read_series(&settings.repeat_csv)?;
    let repeat_truth = read_truth(&settings.repeat_csv)?;
    let fast = read_series(&settings.fast_csv)?;
    let fast_truth = read_truth(&settings.fast_csv)?;
    let n = first.len();

    let law = Law::new(&truth.params, truth.velocity_m_per_s).map_err(law_error("law"))?;
    let k = truth.k_n_per_m.ok_or_else(|| BenchError::Input {
        what: format!("truth file of {}", settings.first_csv.display()),
        message: "a first slide needs spec.stiffness_n_per_m".into(),
    })?;
    let elastic =
        Elastic::spring(k, truth.velocity_m_per_s).map_err(law_error("elastic correction"))?;
    let observed = ObservedSlide::new(law.clone(), elastic);
    let fast_law =
        Law::new(&fast_truth.params, fast_truth.velocity_m_per_s).map_err(law_error("fast law"))?;
    let stiff = ObservedSlide::new(fast_law, Elastic::Stiff);
    let f_end = repeat_truth
        .f_end_n
        .or(truth.f_peak_n)
        .unwrap_or(truth.params.f_d_n);
    let repeat_slide = RepeatSlide::from_elastic(elastic, f_end).map_err(law_error("repeat"))?;
    let (_, posterior) = load_posterior(&settings.one_contact_model)?;
    let start = posterior.start().to_vec();

    // The floor: exp of the same x = αvτ the law sees.
    let xs: Vec<f64> = first.time_s.iter().map(|&t| law.alpha_v() * t).collect();
    let mut out = vec![0.0; n];
    let floor = time_per_point(n, reps, || {
        let mut s = 0.0;
        for &x in &xs {
            s += black_box(-x).exp();
        }
        black_box(s);
    });
    let mut rows = vec![(EXP_FLOOR.to_owned(), n, floor)];
    rows.push((
        "law F(τ) alone (interface time)".into(),
        n,
        time_per_point(n, reps, || {
            let mut s = 0.0;
            for &t in &first.time_s {
                s += law.force(black_box(t));
            }
            black_box(s);
        }),
    ));
    rows.push((
        "scene first: F at instrument times (elastic correction solved)".into(),
        n,
        time_per_point(n, reps, || {
            observed
                .forces(&first.time_s, &mut out, None)
                .expect("the true parameters of the bundled slide give a valid law");
            black_box(&out);
        }),
    ));
    let mut out_repeat = vec![0.0; repeat.len()];
    rows.push((
        "scene repeat: min(kvt, F_end)".into(),
        repeat.len(),
        time_per_point(repeat.len(), reps, || {
            repeat_slide
                .forces(&repeat.time_s, &mut out_repeat)
                .expect("lengths match");
            black_box(&out_repeat);
        }),
    ));
    let mut out_fast = vec![0.0; fast.len()];
    rows.push((
        "scene stiff-fast: F(t), no elastic correction".into(),
        fast.len(),
        time_per_point(fast.len(), reps, || {
            stiff
                .forces(&fast.time_s, &mut out_fast, None)
                .expect("the true parameters of the bundled fast slide give a valid law");
            black_box(&out_fast);
        }),
    ));
    let mut sink = [0.0; 0];
    let lp = posterior.log_density(&start, &mut sink);
    if lp.is_err() {
        return Err(BenchError::Input {
            what: format!("model {}", settings.one_contact_model.display()),
            message: "the log-density is not finite at the start point".into(),
        });
    }
    rows.push((
        ONE_CONTACT_LOG_DENSITY.into(),
        n,
        time_per_point(n, reps, || {
            black_box(posterior.log_density(black_box(&start), &mut sink).ok());
        }),
    ));
    Ok(CostTable {
        rows: rows
            .into_iter()
            .map(|(what, points, ns)| CostRow {
                what,
                points,
                ns_per_point: ns,
                ratio_to_exp: ns / floor,
            })
            .collect(),
    })
}
