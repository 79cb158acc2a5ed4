//! The degree of the polynomial within a bin of sufficient statistics, against what one
//! likelihood evaluation costs: the PTFE first slide of docs/model.md §7 (20,000 s sampled
//! every `INTERVAL` s, noise 0.1 mN), its bins planned at the true parameters for the default
//! tolerance (0.01 in log-likelihood, bound stated at half the noise), then one evaluation of
//! the sum of squared residuals timed.
//!
//! `cargo run --release --example bin_degree [-- INTERVAL]` (default 0.02 s: 10⁶ points).
//! Cited by `BIN_DEGREE` (src/model/posterior/long_records.rs).

use std::time::Instant;

use slipbayes::law::{Elastic, Law, LawParams, ObservedSlide, Scene};
use slipbayes::model::sufficient::{
    log_likelihood_bound, max_error_for, plan_bins, PlanSettings, Reduction, ReferenceModel,
};
use slipbayes::simulate::{simulate, SimulationSpec};

const DURATION_S: f64 = 20_000.0;
const NOISE_N: f64 = 1e-4;
const TOLERANCE: f64 = 0.01;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let interval: f64 = std::env::args()
        .nth(1)
        .map(|a| a.parse())
        .transpose()?
        .unwrap_or(0.02);
    let params = LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8)?;
    let (k, v) = (1.2e4, 1e-9);
    let series = simulate(&SimulationSpec {
        scene: Scene::First,
        params,
        stiffness_n_per_m: Some(k),
        law: Default::default(),
        rigid: false,
        velocity_m_per_s: v,
        duration_s: DURATION_S,
        interval_s: interval,
        noise_sd_n: NOISE_N,
        seed: 1,
        f_end_n: None,
        after_first_s: None,
        normal_force_n: None,
        normal_noise_sd_n: 0.0,
    })?
    .series;
    let (times, forces) = (&series.time_s, &series.force_n);
    let n = times.len();
    let law = Law::from_rate(
        params.alpha_per_m * v,
        params.a_n,
        params.f_d_n,
        params.t0_s,
    )?;
    let slide = ObservedSlide::new(law, Elastic::spring(k, v)?);
    let model =
        |t: &[f64], out: &mut [f64]| slide.for_each_force_serial(t, |j, _, f| out[j] = f).is_ok();
    let t0 = slide.law().t0();
    let kinks = [t0, t0 + slide.law().force(t0) / (k * v)];
    let excluded = kinks.map(|k| (k, k));
    let noise = 0.5 * NOISE_N;
    let exact_started = Instant::now();
    let mut exact = 0.0;
    slide.for_each_force(times, |i, _, f| exact += (forces[i] - f).powi(2))?;
    let exact_s = exact_started.elapsed().as_secs_f64();
    println!("{n} points, one exact evaluation {:.2} ms", 1e3 * exact_s);
    println!("| degree | bins | exact points | evaluations | planning (s) | moments (s) | one evaluation (µs) | bound |");
    println!("|---|---|---|---|---|---|---|---|");
    for degree in [3, 5, 7, 9, 11] {
        let settings = PlanSettings {
            degree,
            max_error_n: max_error_for(TOLERANCE, n, noise, 1.0),
            min_points: 4 * (degree + 1),
            max_points: 1 << 14,
        };
        let started = Instant::now();
        let references: [&ReferenceModel; 1] = [&model];
        let planned = plan_bins(&times[..], &excluded, &settings, &references);
        let planning = started.elapsed().as_secs_f64();
        let started = Instant::now();
        let reduction = Reduction::new(times, forces, &[], degree, &planned);
        let moments = started.elapsed().as_secs_f64();
        let layout = reduction.layout(times, &kinks);
        let reps = 200;
        let started = Instant::now();
        let mut ssr = 0.0;
        for _ in 0..reps {
            let mut sum = reduction.accumulator(&layout, forces);
            slide.for_each_force(layout.times(), |_, _, f| sum.visit(f))?;
            ssr = sum.finish().0;
        }
        let per = started.elapsed().as_secs_f64() / reps as f64;
        let bound = log_likelihood_bound(n, reduction.sum_sq_error(), noise, 1.0);
        println!(
            "| {degree} | {} | {} | {} | {planning:.3} | {moments:.3} | {:.1} | {bound:.2e} (ΔSSR/SSR {:.1e}) |",
            reduction.bins(),
            n - reduction.binned_points(),
            reduction.evaluations(),
            1e6 * per,
            (ssr - exact) / exact
        );
        if std::env::var("SHOW_BINS").is_ok() {
            for (first, end, lo, hi) in reduction.bin_spans().iter().take(12) {
                println!("  bin {first}..{end}: {lo:.3} – {hi:.3} s");
            }
        }
    }
    Ok(())
}
