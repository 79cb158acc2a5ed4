//! Cost per point of the special function, the law and the observed-time model, with one
//! `f64::exp` per point measured in the same run as the floor they are judged against.
//!
//! Run: `cargo bench --bench law`, then `python3 benches/report_performance.py` turns
//! criterion's estimates into the table of `reports/performance.md`.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use slipbayes::law::rate_state::{DEFAULT_TOLERANCE, LIKELIHOOD_TOLERANCE};
use slipbayes::law::{
    Elastic, InitialState, Law, LawParams, ObservedSlide, RateStateParams, Simd, SpringSlider,
    StateLaw,
};
use slipbayes::special::ei_scaled;

/// Points per slide, as in a slow first slide of a few hours sampled every few seconds.
const POINTS: usize = 5000;

/// A slow PTFE first slide near the paper's Fig. 2 fit: 1 nm/s, 7 h, k = 1.2e4 N/m.
fn slow_first_slide() -> (ObservedSlide, Vec<f64>) {
    let params = LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8).expect("valid parameters");
    let law = Law::new(&params, 1e-9).expect("valid law");
    let elastic = Elastic::spring(1.2e4, 1e-9).expect("valid spring");
    let times = (1..=POINTS).map(|i| i as f64 * 5.0).collect();
    (ObservedSlide::new(law, elastic), times)
}

/// A rate-and-state slide on the same times and machine: 1 nm/s, k = 1.2e4 N/m, a 10^4 s hold
/// (θ0 = 10 θ_ss with D_c = 1 µm, so a peak), slip 25 D_c.
fn rate_state_slide(law: StateLaw) -> SpringSlider {
    let params = RateStateParams::new(1e-3, 1.2e-3, 1e-6, 10e-3).expect("valid parameters");
    SpringSlider::new(params, law, 1.2e4, 1e-9, InitialState::Hold { hold_s: 1e4 })
        .expect("valid slide")
}

fn per_point(c: &mut Criterion) {
    let (slide, times) = slow_first_slide();
    let law = slide
        .law()
        .as_aging_rejuvenation()
        .expect("the aging–rejuvenation law")
        .clone();
    // The arguments each function sees along that slide: x = αvτ for S, τ for the law.
    let xs: Vec<f64> = times.iter().map(|t| law.alpha_v() * t).collect();
    let mut group = c.benchmark_group("per_point");
    group.throughput(Throughput::Elements(POINTS as u64));

    group.bench_function("exp_floor", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for &x in black_box(&xs) {
                acc += (-x).exp();
            }
            acc
        })
    });
    group.bench_function("scaled_ei", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for &x in black_box(&xs) {
                acc += ei_scaled(x);
            }
            acc
        })
    });
    group.bench_function("law_force", |b| {
        b.iter(|| {
            let mut acc = 0.0;
            for &t in black_box(&times) {
                acc += law.force(t);
            }
            acc
        })
    });
    let mut forces = vec![0.0; POINTS];
    group.bench_function("observed_model", |b| {
        b.iter(|| {
            slide
                .forces(black_box(&times), &mut forces, None)
                .expect("stable slide");
            forces[POINTS - 1]
        })
    });
    group.bench_function("observed_model_serial", |b| {
        b.iter(|| {
            let mut last = 0.0;
            slide
                .for_each_force_serial(black_box(&times), |_, _, f| last = f)
                .expect("stable slide");
            last
        })
    });
    // At the default tolerance (the reference's), and at the looser one a fit's likelihood
    // solves its slides to.
    for (name, state_law, tolerance) in [
        ("rate_state_aging", StateLaw::Aging, DEFAULT_TOLERANCE),
        ("rate_state_slip", StateLaw::Slip, DEFAULT_TOLERANCE),
        (
            "rate_state_aging_fit",
            StateLaw::Aging,
            LIKELIHOOD_TOLERANCE,
        ),
        ("rate_state_slip_fit", StateLaw::Slip, LIKELIHOOD_TOLERANCE),
    ] {
        let rate_state = rate_state_slide(state_law)
            .with_tolerance(tolerance)
            .expect("valid tolerance");
        group.bench_function(name, |b| {
            b.iter(|| {
                rate_state
                    .forces(black_box(&times), &mut forces)
                    .expect("stable slide");
                forces[POINTS - 1]
            })
        });
    }
    let stiff = ObservedSlide::new(law.clone(), Elastic::Stiff);
    for simd in Simd::available() {
        group.bench_function(format!("observed_model_{}", simd.as_str()), |b| {
            b.iter(|| {
                let mut last = 0.0;
                slide
                    .for_each_force_with(simd, black_box(&times), |_, _, f| last += f)
                    .expect("stable slide");
                last
            })
        });
        group.bench_function(format!("law_lanes_{}", simd.as_str()), |b| {
            b.iter(|| {
                let mut last = 0.0;
                stiff
                    .for_each_force_with(simd, black_box(&times), |_, _, f| last += f)
                    .expect("stiff slide");
                last
            })
        });
    }
    group.finish();
}

criterion_group!(benches, per_point);
criterion_main!(benches);
