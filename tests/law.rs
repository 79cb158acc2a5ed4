//! The friction law, its elastic correction and its peak against 50-digit mpmath references
//! (tests/reference/make_law_reference.py), and on the hard cases of docs/model.md §8.

mod common;

use common::Table;
use proptest::prelude::*;
use slipbayes::law::{
    Elastic, InterfaceLaw, Law, LawError, LawParams, LogAging, ObservedSlide, PeakOutcome,
    RepeatSlide, Simd,
};

/// The bar for the law's value: 1e−13 relative, or 1e−13·(a + F_d) absolute where F is
/// tiny.
const LAW_REL: f64 = 1e-13;

fn law_row(t: &Table, row: &[String]) -> Law {
    Law::from_rate(
        t.f64(row, "alpha_v"),
        t.f64(row, "a"),
        t.f64(row, "f_d"),
        t.f64(row, "t0"),
    )
    .unwrap()
}

/// Error of `got` against `want`, in units of the bar (≤ 1 passes).
fn law_error(got: f64, want: f64, scale: f64) -> f64 {
    let abs = (got - want).abs();
    let rel = abs / want.abs();
    (rel / LAW_REL).min(abs / (LAW_REL * scale))
}

#[test]
fn law_matches_50_digit_reference_on_hard_cases() {
    let t = Table::load("law_mpmath.csv");
    let mut worst = (0.0, String::new());
    let mut worst_rel = 0.0_f64;
    for row in &t.rows {
        let law = law_row(&t, row);
        let tau = t.f64(row, "tau");
        let want = t.f64(row, "force");
        let got = law.force(tau);
        let err = law_error(got, want, law.a() + law.f_d());
        if want.abs() > 0.0 {
            worst_rel = worst_rel.max((got - want).abs() / want.abs());
        }
        if err > worst.0 {
            worst = (
                err,
                format!(
                    "{} tau={tau:e}: got {got:e} want {want:e}",
                    t.str(row, "case")
                ),
            );
        }
    }
    eprintln!(
        "law: worst error {:.3} of the bar ({}); worst relative {:.2} eps",
        worst.0,
        worst.1,
        worst_rel / f64::EPSILON
    );
    assert!(worst.0 <= 1.0, "law off the reference: {}", worst.1);
}

/// The law in lanes (a stiff slide, τ = t, through the batched kernel) against 50-digit
/// references on every instruction set this machine has: on `law_lanes_mpmath.csv`, whose τ
/// come in runs dense enough that whole batches lie in one regime of the vector law (series
/// and every piece of the subtraction), and on the hard-case grid of `law_mpmath.csv`, whose
/// sparse τ mix regimes within a batch (the scalar fallback).
#[test]
fn law_in_lanes_matches_50_digit_reference() {
    for (table, most_in_lanes) in [("law_lanes_mpmath.csv", true), ("law_mpmath.csv", false)] {
        let t = Table::load(table);
        let mut cases: Vec<(String, Law, Vec<f64>, Vec<f64>)> = Vec::new();
        for row in &t.rows {
            let name = t.str(row, "case");
            if cases.last().is_none_or(|c| c.0 != name) {
                cases.push((name.to_owned(), law_row(&t, row), Vec::new(), Vec::new()));
            }
            let case = cases.last_mut().unwrap();
            case.2.push(t.f64(row, "tau"));
            case.3.push(t.f64(row, "force"));
        }
        for simd in Simd::available() {
            let mut worst = (0.0, String::new());
            let (mut batches, mut scalar) = (0, 0);
            for (name, law, taus, want) in &cases {
                // A slide's times must increase: the case's τ in increasing order.
                let mut order: Vec<usize> = (0..taus.len()).collect();
                order.sort_by(|&i, &j| taus[i].total_cmp(&taus[j]));
                let times: Vec<f64> = order.iter().map(|&i| taus[i]).collect();
                let slide = ObservedSlide::new(law.clone(), Elastic::Stiff);
                slide
                    .for_each_force_with(simd, &times, |k, _, got| {
                        let i = order[k];
                        let err = law_error(got, want[i], law.a() + law.f_d());
                        if err > worst.0 {
                            worst = (
                                err,
                                format!("{name} tau={:e}: got {got:e} want {:e}", taus[i], want[i]),
                            );
                        }
                    })
                    .unwrap();
                let counts = slide.kernel_counts(simd, &times).unwrap();
                batches += counts.batches;
                scalar += counts.scalar_law_batches;
            }
            eprintln!(
                "{table}, law in lanes ({}): worst error {:.3} of the bar ({}); {scalar} of {batches} batches by the scalar law",
                simd.as_str(),
                worst.0,
                worst.1
            );
            assert!(worst.0 <= 1.0, "{table} ({}): {}", simd.as_str(), worst.1);
            if most_in_lanes {
                assert!(
                    scalar * 10 <= batches,
                    "{table}: {scalar} of {batches} batches scalar"
                );
            }
        }
    }
}

#[test]
fn rate_matches_reference() {
    let t = Table::load("law_mpmath.csv");
    for row in &t.rows {
        let law = law_row(&t, row);
        let tau = t.f64(row, "tau");
        let want = t.f64(row, "rate");
        let (f, got) = law.force_and_rate(tau);
        // dF/dτ is a difference of a/τ and αv(F − F_d): judge it on the size of its terms.
        let scale = law.a() / tau + law.alpha_v() * (f.abs() + law.f_d());
        assert!(
            (got - want).abs() <= 1e-13 * scale,
            "{} tau={tau:e}: rate {got:e} want {want:e}",
            t.str(row, "case")
        );
    }
}

#[test]
fn observed_time_model_matches_reference() {
    let t = Table::load("observed_mpmath.csv");
    let mut case = String::new();
    let mut times = Vec::new();
    let mut want_f = Vec::new();
    let mut want_tau = Vec::new();
    let mut slide: Option<ObservedSlide> = None;
    let check =
        |slide: &ObservedSlide, case: &str, times: &[f64], want_f: &[f64], want_tau: &[f64]| {
            let mut f = vec![0.0; times.len()];
            let mut tau = vec![0.0; times.len()];
            slide.forces(times, &mut f, Some(&mut tau)).unwrap();
            let law = slide.law().as_aging_rejuvenation().unwrap();
            for i in 0..times.len() {
                let err = law_error(f[i], want_f[i], law.a() + law.f_d());
                assert!(
                    err <= 1.0,
                    "{case} t={:e}: F {:e} want {:e}",
                    times[i],
                    f[i],
                    want_f[i]
                );
                assert!(
                    (tau[i] - want_tau[i]).abs() <= 1e-13 * want_tau[i],
                    "{case} t={:e}: tau {:e} want {:e}",
                    times[i],
                    tau[i],
                    want_tau[i]
                );
            }
        };
    for row in &t.rows {
        let name = t.str(row, "case").to_owned();
        if name != case {
            if let Some(s) = slide.take() {
                check(&s, &case, &times, &want_f, &want_tau);
            }
            times.clear();
            want_f.clear();
            want_tau.clear();
            let law = Law::from_rate(
                t.f64(row, "alpha_v"),
                t.f64(row, "a"),
                t.f64(row, "f_d"),
                t.f64(row, "t0"),
            )
            .unwrap();
            slide = Some(ObservedSlide::new(
                law,
                Elastic::Spring {
                    kv: t.f64(row, "kv"),
                },
            ));
            case = name;
        }
        times.push(t.f64(row, "t"));
        want_f.push(t.f64(row, "force"));
        want_tau.push(t.f64(row, "tau"));
    }
    check(&slide.unwrap(), &case, &times, &want_f, &want_tau);
}

/// Plain Newton from τ = t − F_d/(kv) with a generous fixed iteration budget, as a naive fit
/// would do it.
fn plain_newton(law: &Law, kv: f64, t: f64) -> Option<f64> {
    let mut tau = t - law.f_d() / kv;
    for _ in 0..100 {
        let (f, r) = law.force_and_rate(tau);
        let step = (tau + f / kv - t) / (1.0 + r / kv);
        tau -= step;
        if !tau.is_finite() {
            return None;
        }
        if step.abs() <= 1e-14 * tau.abs() {
            return Some(tau);
        }
    }
    None
}

#[test]
fn steep_rise_of_slow_first_slide_defeats_plain_newton_but_not_ours() {
    // PTFE near the paper's Fig. 2 fit at 1 nm/s, k = 1.2e4 N/m.
    let law = Law::new(&LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8).unwrap(), 1e-9).unwrap();
    let kv = 1.2e4 * 1e-9;
    let slide = ObservedSlide::new(law.clone(), Elastic::Spring { kv });
    let times: Vec<f64> = (1..=3000).map(|i| i as f64 * 10.0).collect();
    let mut f = vec![0.0; times.len()];
    let mut tau = vec![0.0; times.len()];
    slide.forces(&times, &mut f, Some(&mut tau)).unwrap();
    let mut plain_failures = 0;
    for (i, &t) in times.iter().enumerate() {
        if tau[i] <= law.t0() {
            // Elastic loading up to the law's jump at t0.
            continue;
        }
        // Ours solves the elastic equation at every point...
        let residual = tau[i] + law.force(tau[i]) / kv - t;
        assert!(residual.abs() <= 1e-12 * t, "t={t}: residual {residual:e}");
        // ...and is the unique solution, which plain Newton misses on the rise.
        match plain_newton(&law, kv, t) {
            Some(p) if (p - tau[i]).abs() <= 1e-9 * t => {}
            _ => plain_failures += 1,
        }
    }
    assert!(plain_failures > 0, "the case must be hard for plain Newton");
    eprintln!(
        "plain Newton failed at {plain_failures} of {} points",
        times.len()
    );
}

#[test]
fn peak_matches_reference() {
    let t = Table::load("peak_mpmath.csv");
    for row in &t.rows {
        let law = law_row(&t, row);
        let PeakOutcome::Interior(p) = law.peak() else {
            panic!("{}: no peak", t.str(row, "case"));
        };
        let want_f = t.f64(row, "force_peak");
        let want_tau = t.f64(row, "tau_peak");
        assert!(
            (p.force_n - want_f).abs() <= LAW_REL * want_f,
            "{}: F_peak {:e} want {want_f:e}",
            t.str(row, "case"),
            p.force_n
        );
        // F is flat at the peak, so τ_peak is determined to about √ε less than F_peak.
        assert!(
            (p.tau_s - want_tau).abs() <= 1e-7 * want_tau,
            "{}: tau_peak {:e} want {want_tau:e}",
            t.str(row, "case"),
            p.tau_s
        );
    }
}

#[test]
fn fig4_peak_rises_as_t0_falls_logarithmically() {
    let t = Table::load("peak_mpmath.csv");
    let rows: Vec<_> = t
        .rows
        .iter()
        .filter(|r| t.str(r, "case") == "fig4")
        .collect();
    assert!(rows.len() >= 5);
    let ln_t0: Vec<f64> = rows.iter().map(|r| t.f64(r, "t0").ln()).collect();
    let ours: Vec<f64> = rows
        .iter()
        .map(|r| law_row(&t, r).peak().interior().unwrap().force_n)
        .collect();
    let reference: Vec<f64> = rows.iter().map(|r| t.f64(r, "force_peak")).collect();
    // t0 falls along the table: the peak must rise at every step.
    for i in 1..ours.len() {
        assert!(ln_t0[i] < ln_t0[i - 1]);
        assert!(ours[i] > ours[i - 1], "peak must rise as t0 falls");
    }
    // Slopes dF_peak/d ln t0 and their change (the curvature the exact law gives) agree with
    // the reference's exact values.
    let slope = |f: &[f64], i: usize| (f[i] - f[i - 1]) / (ln_t0[i] - ln_t0[i - 1]);
    for i in 1..ours.len() {
        let (s, r) = (slope(&ours, i), slope(&reference, i));
        assert!((s - r).abs() <= 1e-11 * r.abs(), "slope {s} want {r}");
        assert!(s < 0.0);
    }
    for i in 2..ours.len() {
        let c = slope(&ours, i) - slope(&ours, i - 1);
        let r = slope(&reference, i) - slope(&reference, i - 1);
        assert!(
            (c - r).abs() <= 1e-10 * slope(&reference, i).abs(),
            "curvature {c} want {r}"
        );
    }
}

#[test]
fn no_aging_means_no_interior_peak() {
    let law = Law::from_rate(0.007, 0.0, 1.0, 0.1).unwrap();
    assert_eq!(law.peak(), PeakOutcome::NoInteriorPeak);
    // F rises monotonically to F_d.
    let f: Vec<f64> = [1.0, 10.0, 100.0, 1e3, 1e4]
        .iter()
        .map(|&t| law.force(t))
        .collect();
    assert!(f.windows(2).all(|w| w[1] > w[0]));
    assert!((f[4] - 1.0).abs() < 1e-15);
}

#[test]
fn vanishing_rejuvenation_is_pure_logarithmic_aging() {
    // αv = 1e−12 1/s: over τ ≤ 1e8 s, x ≤ 1e−4 and F = a ln(τ/t0) + O(x) corrections.
    let (a, f_d, t0) = (6.2e-3, 10e-3, 14.8);
    let law = Law::from_rate(1e-12, a, f_d, t0).unwrap();
    for &tau in &[15.0, 100.0, 1e4, 1e8] {
        let x = 1e-12 * tau;
        let bound = (a * (tau / t0).ln() + f_d) * x * 2.0;
        assert!((law.force(tau) - a * (tau / t0).ln()).abs() <= bound + 1e-18);
    }
}

/// Pure logarithmic aging against its closed form a ln(τ/t0), with t0 a power of two so that
/// τ/t0 is exact and the reference is one correctly rounded logarithm: to 1e−14 relative,
/// right from t0 (where ln(τ/t0) is tiny) to τ = 1e12 s.
#[test]
fn log_aging_is_its_closed_form() {
    let (a, t0) = (6.2e-3, 0.5);
    let law = LogAging::new(a, t0).unwrap();
    assert!(law.force(0.49).abs() < f64::MIN_POSITIVE);
    assert!(law.force(t0).abs() < f64::MIN_POSITIVE);
    let mut taus = vec![t0 * (1.0 + 2f64.powi(-40)), t0 * (1.0 + 1e-9), 0.75, 1.0];
    taus.extend((0..25).map(|i| 10f64.powf(i as f64 * 0.5)));
    for tau in taus {
        let (force, rate) = law.force_and_rate(tau);
        let exact = a * (tau / t0).ln();
        assert!(
            (force - exact).abs() <= 1e-14 * exact.abs(),
            "τ = {tau:e}: {force:e} against {exact:e}"
        );
        assert!((rate - a / tau).abs() <= f64::EPSILON * a / tau);
    }
    assert!(matches!(
        InterfaceLaw::from(law).peak(),
        PeakOutcome::NoInteriorPeak
    ));
}

/// The full law tends to pure logarithmic aging as αv → 0: the difference shrinks in
/// proportion to αv (it is of order αvτ (a ln(τ/t0) + F_d)).
#[test]
fn full_law_tends_to_log_aging_as_rejuvenation_vanishes() {
    let (a, f_d, t0) = (6.2e-3, 10e-3, 14.8);
    let log_aging = LogAging::new(a, t0).unwrap();
    for alpha_v in [1e-6, 1e-9, 1e-12] {
        let full = Law::from_rate(alpha_v, a, f_d, t0).unwrap();
        for tau in [15.0, 1e3, 1e5] {
            let bound = 2.0 * alpha_v * tau * (log_aging.force(tau) + f_d);
            let gap = (full.force(tau) - log_aging.force(tau)).abs();
            assert!(
                gap <= bound,
                "αv = {alpha_v:e}, τ = {tau}: {gap:e} > {bound:e}"
            );
        }
    }
}

/// Log-aging through a spring: each recorded point solves t = τ + F(τ)/(kv) to rounding,
/// with no loading line (F(t0) = 0) and no stick-slip (dF/dτ > 0).
#[test]
fn log_aging_through_a_spring_solves_the_elastic_correction() {
    let (a, t0, kv) = (6.2e-3, 14.8, 1.2e-5);
    let law = LogAging::new(a, t0).unwrap();
    let slide = ObservedSlide::new(law, Elastic::Spring { kv });
    let times: Vec<f64> = (0..400).map(|i| i as f64 * 50.0).collect();
    let mut forces = vec![0.0; times.len()];
    let mut taus = vec![0.0; times.len()];
    slide.forces(&times, &mut forces, Some(&mut taus)).unwrap();
    let mut serial = vec![0.0; times.len()];
    slide
        .for_each_force_serial(&times, |i, _, f| serial[i] = f)
        .unwrap();
    for i in 0..times.len() {
        assert!((forces[i] - serial[i]).abs() < f64::MIN_POSITIVE);
        if times[i] <= t0 {
            assert!(forces[i].abs() < f64::MIN_POSITIVE);
            continue;
        }
        let t = taus[i] + law.force(taus[i]) / kv;
        assert!((t - times[i]).abs() <= 1e-12 * times[i], "t = {}", times[i]);
        assert!((law.force(taus[i]) - forces[i]).abs() <= 1e-12 * forces[i]);
    }
}

#[test]
fn force_is_zero_before_t0_and_jumps_to_fd_term_at_t0() {
    let law = Law::from_rate(0.007, 0.3, 1.0, 0.5).unwrap();
    assert!(law.force(0.4999).abs() < f64::MIN_POSITIVE);
    let jump = -(-0.007_f64 * 0.5).exp_m1();
    assert!((law.force(0.5) - jump).abs() <= 4.0 * f64::EPSILON * jump);
}

#[test]
fn stiff_slide_is_the_law_in_instrument_time() {
    let law = Law::from_rate(3.68, 6.2e-3, 10e-3, 4e-3).unwrap();
    let slide = ObservedSlide::new(law.clone(), Elastic::Stiff);
    let times: Vec<f64> = (0..500).map(|i| i as f64 * 0.01).collect();
    let mut f = vec![0.0; times.len()];
    slide.forces(&times, &mut f, None).unwrap();
    for (t, f) in times.iter().zip(&f) {
        assert!((law.force(*t) - f).abs() <= 0.0_f64.max(f64::EPSILON * f.abs()));
    }
}

#[test]
fn stick_slip_is_a_typed_error_just_below_the_limit() {
    // Strong weakening after the peak: a ≫ F_d.
    let law = Law::from_rate(0.01, 5.0, 1.0, 0.1).unwrap();
    let times: Vec<f64> = (1..=2000).map(|i| i as f64).collect();
    // The steepest weakening on (roughly) the path decides the limit.
    let (_, min_rate) = law.min_rate_up_to(2000.0);
    assert!(min_rate < 0.0);
    let critical_kv = -min_rate;
    let mut f = vec![0.0; times.len()];
    let stable = ObservedSlide::new(
        law.clone(),
        Elastic::Spring {
            kv: critical_kv * 1.01,
        },
    );
    stable.forces(&times, &mut f, None).unwrap();
    let unstable = ObservedSlide::new(
        law,
        Elastic::Spring {
            kv: critical_kv * 0.99,
        },
    );
    match unstable.forces(&times, &mut f, None) {
        Err(LawError::StickSlip { rate, limit, .. }) => assert!(rate < limit),
        other => panic!("expected stick-slip, got {other:?}"),
    }
}

#[test]
fn unsorted_or_nan_times_are_rejected_with_their_index() {
    let law = Law::from_rate(0.007, 0.3, 1.0, 0.1).unwrap();
    let slide = ObservedSlide::new(law, Elastic::Spring { kv: 1.0 });
    let mut f = vec![0.0; 3];
    assert_eq!(
        slide.forces(&[1.0, 3.0, 2.0], &mut f, None),
        Err(LawError::UnsortedTimes {
            index: 2,
            time: 2.0
        })
    );
    assert!(matches!(
        slide.forces(&[1.0, f64::NAN, 2.0], &mut f, None),
        Err(LawError::UnsortedTimes { index: 1, .. })
    ));
}

#[test]
fn invalid_parameters_name_themselves() {
    let e = LawParams::new(0.92e6, 1e-3, 1e-2, -1.0).unwrap_err();
    assert!(e.to_string().contains("t0"), "{e}");
    let e = Elastic::spring(f64::NAN, 1e-9).unwrap_err();
    assert!(e.to_string().contains('k'), "{e}");
}

#[test]
fn repeat_slide_loads_elastically_then_slides_at_f_end() {
    let r = RepeatSlide::new(1.2e-5, 10e-3).unwrap();
    assert!(r.force(-1.0).abs() < f64::MIN_POSITIVE);
    assert!((r.force(100.0) - 1.2e-3).abs() < 1e-18);
    assert!((r.force(1e4) - 10e-3).abs() < 1e-18);
}

#[test]
fn rigid_repeat_slide_is_the_limit_of_stiffer_springs() {
    let rigid = RepeatSlide::from_elastic(Elastic::Stiff, 10e-3).unwrap();
    assert!(rigid.loading_ends().abs() < f64::MIN_POSITIVE);
    assert!(rigid.force(0.0).abs() < f64::MIN_POSITIVE);
    for t in [1e-3, 1.0, 1e4] {
        assert!((rigid.force(t) - 10e-3).abs() < 1e-18);
        // min(kvt, F_end) reaches F_end at any t > 0 once kv > F_end/t.
        let spring = RepeatSlide::new(1e3 * 10e-3 / t, 10e-3).unwrap();
        assert!((spring.force(t) - rigid.force(t)).abs() < 1e-18);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// Wherever the path is stable, every solved point satisfies the elastic equation, τ and
    /// the recorded force are consistent, and τ increases with t.
    #[test]
    fn solved_points_satisfy_the_elastic_equation(
        log_alpha_v in -6.0..1.0_f64,
        ratio in 0.0..3.0_f64,
        log_t0 in -6.0..2.0_f64,
        log_kv_scale in 0.3..3.0_f64,
    ) {
        let (alpha_v, f_d) = (10f64.powf(log_alpha_v), 1e-2);
        let t0 = 10f64.powf(log_t0);
        let law = Law::from_rate(alpha_v, ratio * f_d, f_d, t0).unwrap();
        let t_end = 20.0 / alpha_v + 10.0 * t0;
        let (_, min_rate) = law.min_rate_up_to(t_end);
        let kv = (-min_rate).max(f_d * alpha_v) * 10f64.powf(log_kv_scale);
        let slide = ObservedSlide::new(law.clone(), Elastic::Spring { kv });
        let times: Vec<f64> = (1..=400).map(|i| t_end * i as f64 / 400.0).collect();
        let mut f = vec![0.0; times.len()];
        let mut tau = vec![0.0; times.len()];
        slide.forces(&times, &mut f, Some(&mut tau)).unwrap();
        for i in 0..times.len() {
            if tau[i] > t0 {
                let lhs = tau[i] + law.force(tau[i]) / kv;
                prop_assert!((lhs - times[i]).abs() <= 1e-12 * times[i]);
                prop_assert!((law.force(tau[i]) - f[i]).abs() <= 1e-12 * (f[i].abs() + f_d));
            }
            if i > 0 {
                prop_assert!(tau[i] >= tau[i - 1]);
            }
        }
    }
}

/// A slow PTFE first slide (the paper's Fig. 2 parameters, k = 1.2e4 N/m, 1 nm/s) sampled
/// every `dt` seconds for `n` points.
fn slow_first_slide(dt: f64, n: usize) -> (ObservedSlide, Vec<f64>) {
    let law = Law::new(&LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8).unwrap(), 1e-9).unwrap();
    let slide = ObservedSlide::new(law, Elastic::spring(1.2e4, 1e-9).unwrap());
    (slide, (1..=n).map(|i| i as f64 * dt).collect())
}

/// Every instruction set gives the same bits: the kernel uses no fused multiply-add, so the
/// chains of a fit cannot depend on the machine's vector unit.
#[test]
fn every_instruction_set_gives_the_same_bits() {
    let (slide, times) = slow_first_slide(7.0, 4000);
    let stiff = ObservedSlide::new(slide.law().clone(), Elastic::Stiff);
    let run = |slide: &ObservedSlide, simd: Simd| {
        let mut out = Vec::new();
        slide
            .for_each_force_with(simd, &times, |_, tau, f| {
                out.push((tau.to_bits(), f.to_bits()))
            })
            .unwrap();
        out
    };
    let available = Simd::available();
    assert!(available.contains(&Simd::Baseline));
    for simd in &available[1..] {
        assert!(
            run(&slide, *simd) == run(&slide, Simd::Baseline),
            "{} differs from baseline",
            simd.as_str()
        );
        assert!(
            run(&stiff, *simd) == run(&stiff, Simd::Baseline),
            "stiff {} differs",
            simd.as_str()
        );
    }
}

/// On slides shaped like the bundled data, the kernel takes its fast paths: the law in lanes
/// for all but the first few batches, one Newton round for nearly every batch, one law
/// evaluation for nearly every anchor where the data are dense, no point left to the serial
/// iteration. (Without this, a kernel that silently fell back everywhere would
/// pass every accuracy test.)
#[test]
fn the_kernel_takes_its_fast_paths_on_a_typical_slide() {
    for (dt, n) in [(10.0, 3000), (5.0, 5000), (1.0, 30000)] {
        let (slide, times) = slow_first_slide(dt, n);
        let c = slide.kernel_counts(Simd::active(), &times).unwrap();
        eprintln!("dt {dt} s, {n} points: {c:?}");
        assert_eq!(c.serial_points, 0, "dt {dt}: {c:?}");
        // One evaluation of the law per batch: where the Newton step from the septic guess is
        // not final (on the steep rise at the start, 8 batches of the 5,000-point slide), the
        // step of third order from the same evaluation is (a second Newton round took 8
        // batches of that slide 8 more evaluations of the law, the quintic guesses 16).
        assert_eq!(c.rounds, c.batches, "dt {dt}: {c:?}");
        assert!(c.third_order_batches <= 20, "dt {dt}: {c:?}");
        assert!(
            c.scalar_law_batches as f64 <= 0.05 * c.rounds as f64,
            "dt {dt}: {c:?}"
        );
        // Anchors start from the previous chunk's interpolant extrapolated: on densely sampled
        // data one Newton step nearly always suffices.
        // And the chunks between anchors grow to their full length (513 points), so that
        // the serial anchors cost little per point: about 390 points per anchor on the
        // 30,000-point slide (at most 257 with chunks of 8 batches).
        if dt <= 1.0 {
            assert!(
                c.anchor_evaluations as f64 <= 1.25 * c.anchors as f64,
                "dt {dt}: {c:?}"
            );
            assert!(c.anchors * 350 <= n as u64, "dt {dt}: {c:?}");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// The batched kernel against the serial solve it replaces, over the parameter ranges of
    /// the solve's own property test and record lengths from a few points to many chunks:
    /// the same τ and force to the law's bar, the same error (stick-slip) where the path is
    /// unstable.
    #[test]
    fn kernel_agrees_with_the_serial_solve(
        log_alpha_v in -8.0..2.0_f64,
        ratio in 0.0..3.0_f64,
        log_t0 in -7.0..3.0_f64,
        log_kv_scale in -0.5..3.0_f64,
        n in 1_usize..700,
        span_factor in 0.1..40.0_f64,
    ) {
        let (alpha_v, f_d) = (10f64.powf(log_alpha_v), 1e-2);
        let t0 = 10f64.powf(log_t0);
        let law = Law::from_rate(alpha_v, ratio * f_d, f_d, t0).unwrap();
        let t_end = span_factor / alpha_v + 10.0 * t0;
        let (_, min_rate) = law.min_rate_up_to(t_end);
        let kv = (-min_rate).max(f_d * alpha_v) * 10f64.powf(log_kv_scale);
        let slide = ObservedSlide::new(law.clone(), Elastic::Spring { kv });
        let times: Vec<f64> = (1..=n).map(|i| t_end * i as f64 / n as f64).collect();
        let mut serial = Vec::new();
        let serial_result = slide.for_each_force_serial(&times, |_, tau, f| serial.push((tau, f)));
        let mut batched = Vec::new();
        let batched_result = slide.for_each_force(&times, |_, tau, f| batched.push((tau, f)));
        match (&serial_result, &batched_result) {
            (Ok(()), Ok(())) => {
                for (i, ((tau_s, f_s), (tau_b, f_b))) in serial.iter().zip(&batched).enumerate() {
                    prop_assert!((tau_b - tau_s).abs() <= LAW_REL * tau_s.abs(),
                        "point {i}: tau {tau_b:e} against {tau_s:e}");
                    prop_assert!(law_error(*f_b, *f_s, law.a() + law.f_d()) <= 1.0,
                        "point {i}: force {f_b:e} against {f_s:e}");
                }
            }
            (Err(LawError::StickSlip { .. }), Err(LawError::StickSlip { .. })) => {}
            _ => prop_assert!(false, "serial {serial_result:?}, batched {batched_result:?}"),
        }
    }
}

/// Parameter sets (α 1/m, a N, F_d N, t0 s, v m/s) of `tests/reference/law_rust_values.csv`.
const BINDING_PARAMS: [[f64; 5]; 4] = [
    [0.92e6, 6.2e-3, 10e-3, 14.8, 1e-9],
    [0.92e6, 6.2e-3, 10e-3, 14.8, 4e-6],
    [3.1e5, 1.5e-3, 4e-3, 0.02, 1e-8],
    [2e7, 0.0, 1e-2, 1e-6, 1e-9],
];

/// The law's exact bits on a grid of τ (s) for each of [`BINDING_PARAMS`], as CSV text:
/// what other bindings of the library (the Python package's `law`) are checked against.
fn binding_reference() -> String {
    let mut out =
        String::from("alpha_per_m,a_n,f_d_n,t0_s,velocity_m_per_s,tau_s,force_n,rate_n_per_s\n");
    for [alpha, a, f_d, t0, v] in BINDING_PARAMS {
        let law = Law::new(&LawParams::new(alpha, a, f_d, t0).unwrap(), v).unwrap();
        for i in 0..40 {
            // From before t0 to far past the peak, log-spaced.
            let tau = t0 * 0.5 * 10f64.powf(i as f64 * 0.2);
            let (force, rate) = law.force_and_rate(tau);
            out.push_str(&format!(
                "{alpha:?},{a:?},{f_d:?},{t0:?},{v:?},{tau:?},{force:?},{rate:?}\n"
            ));
        }
    }
    out
}

/// The committed table of the law's bits is current (`SLIPBAYES_WRITE_REFERENCE=1`
/// rewrites it): python/tests/test_law.py compares the Python binding with it bit for bit.
#[test]
fn law_bits_match_the_table_bindings_are_checked_against() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/reference/law_rust_values.csv");
    let text = binding_reference();
    if std::env::var_os("SLIPBAYES_WRITE_REFERENCE").is_some() {
        std::fs::write(&path, &text).unwrap();
    }
    let committed = std::fs::read_to_string(&path).unwrap();
    assert!(
        committed == text,
        "{} is stale: rerun with SLIPBAYES_WRITE_REFERENCE=1",
        path.display()
    );
}
