//! The rate-and-state spring-slider (src/law/rate_state.rs) against a high-precision reference
//! integration, its analytic steady state, the direct effect of a velocity step, and its
//! typed errors.
//!
//! `tests/reference/rate_state/reference.json` was written by
//! `tests/reference/rate_state/make_reference.py`: scipy's Radau at rtol = 1e−13 in the SI
//! variables (F, ln θ), each observation time an end point of its own integration.

use serde_json::Value;
use slipbayes::law::rate_state::LIKELIHOOD_TOLERANCE;
use slipbayes::law::{
    InitialState, LawError, RateStateError, RateStateParams, SliderState, SpringSlider, StateLaw,
};
use slipbayes::prec::{RATE_STATE_LIKELIHOOD_REL_TOL, RATE_STATE_REL_TOL};

fn reference() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/reference/rate_state/reference.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).expect("reference")).expect("json")
}

fn num(v: &Value, key: &str) -> f64 {
    v[key]
        .as_f64()
        .unwrap_or_else(|| panic!("{key} is a number"))
}

fn nums(v: &Value, key: &str) -> Vec<f64> {
    v[key]
        .as_array()
        .unwrap_or_else(|| panic!("{key} is an array"))
        .iter()
        .map(|x| x.as_f64().expect("number"))
        .collect()
}

/// The slide a reference case describes.
fn slider(case: &Value) -> SpringSlider {
    let params = RateStateParams::new(
        num(case, "a_n"),
        num(case, "b_n"),
        num(case, "dc_m"),
        num(case, "f0_n"),
    )
    .expect("valid parameters");
    let law = match case["state_law"].as_str() {
        Some("aging") => StateLaw::Aging,
        Some("slip") => StateLaw::Slip,
        other => panic!("unknown law {other:?}"),
    };
    let init = &case["initial"];
    let initial = match init["kind"].as_str() {
        Some("hold") => InitialState::Hold {
            hold_s: num(init, "hold_s"),
        },
        Some("steady") => InitialState::Steady {
            velocity_m_per_s: num(init, "velocity_m_per_s"),
        },
        other => panic!("unknown initial state {other:?}"),
    };
    SpringSlider::new(
        params,
        law,
        num(case, "k_n_per_m"),
        num(case, "v_m_per_s"),
        initial,
    )
    .expect("valid slide")
    .with_reference_velocity(num(case, "v_ref_m_per_s"))
    .expect("valid V0")
}

/// Worst errors over a case: force relative to max(|F|, a), θ and V relative.
fn worst_errors(case: &Value, states: &[SliderState]) -> (f64, f64, f64) {
    let a = num(case, "a_n");
    let forces = nums(case, "force_n");
    let thetas = nums(case, "theta_s");
    let velocities = nums(case, "velocity_m_per_s");
    assert_eq!(states.len(), forces.len());
    let mut worst = (0.0_f64, 0.0_f64, 0.0_f64);
    for (i, s) in states.iter().enumerate() {
        worst.0 = worst
            .0
            .max((s.force_n - forces[i]).abs() / forces[i].abs().max(a));
        worst.1 = worst.1.max((s.theta_s - thetas[i]).abs() / thetas[i]);
        worst.2 = worst
            .2
            .max((s.velocity_m_per_s - velocities[i]).abs() / velocities[i]);
    }
    worst
}

#[test]
fn forces_match_the_scipy_radau_reference() {
    let reference = reference();
    let cases = reference["cases"].as_array().expect("cases");
    assert_eq!(cases.len(), 6, "slow, stiff and step cases for both laws");
    let mut worst = Vec::new();
    for case in cases {
        let name = case["name"].as_str().expect("name");
        // The reference's own error (rtol 1e-13 against 1e-12) is far below what is tested.
        assert!(num(case, "reference_self_difference") < 1e-12, "{name}");
        let times = nums(case, "times_s");

        let slide = slider(case);
        // The measured errors at every tolerance, for the record (docs and prec.rs).
        for tolerance in [1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-11, 1e-12, 1e-13] {
            let at = slide
                .clone()
                .with_tolerance(tolerance)
                .expect("valid tolerance");
            let (force, theta, velocity) = worst_errors(case, &at.states(&times).expect(name));
            eprintln!(
                "{name}: tolerance {tolerance:.0e}: force {force:.2e}, theta {theta:.2e}, \
                 V {velocity:.2e}"
            );
        }
        let (force, theta, velocity) = worst_errors(case, &slide.states(&times).expect(name));
        worst.push((name, force, theta, velocity));
        // A fit's likelihood solves its slides to a looser tolerance.
        let fitted = slide
            .clone()
            .with_tolerance(LIKELIHOOD_TOLERANCE)
            .expect("valid tolerance");
        let (force, _, _) = worst_errors(case, &fitted.states(&times).expect(name));
        assert!(
            force <= RATE_STATE_LIKELIHOOD_REL_TOL,
            "{name}: force error {force:e} at the likelihood's tolerance"
        );

        // forces() gives the same numbers as states().
        let mut out = vec![0.0; times.len()];
        slider(case).forces(&times, &mut out).expect(name);
        let states = slider(case).states(&times).expect(name);
        for (f, s) in out.iter().zip(&states) {
            assert!((f - s.force_n).abs() <= f64::EPSILON * f.abs());
        }
    }
    // Asserted after every case has been measured, so that a failure shows them all.
    for (name, force, theta, velocity) in worst {
        assert!(force <= RATE_STATE_REL_TOL, "{name}: force error {force:e}");
        // θ and V are exponentials of the solved logarithms, whose absolute errors become
        // relative ones, amplified by b/a (V) and by the log-state's magnitude.
        assert!(
            theta <= 100.0 * RATE_STATE_REL_TOL,
            "{name}: θ error {theta:e}"
        );
        assert!(
            velocity <= 100.0 * RATE_STATE_REL_TOL,
            "{name}: V error {velocity:e}"
        );
    }
}

#[test]
fn a_slow_first_slide_peaks_above_its_steady_force() {
    let reference = reference();
    let case = &reference["cases"][0];
    assert_eq!(case["name"], "slow_first_aging");
    let slide = slider(case);
    let times = nums(case, "times_s");
    let states = slide.states(&times).expect("slide");
    assert!(
        states[0].force_n.abs() < 1e-300,
        "the spring starts unloaded"
    );
    let peak = states.iter().map(|s| s.force_n).fold(0.0, f64::max);
    let steady = slide.steady_force_n();
    // θ0 = 100 θ_ss: the peak stands about b ln 100 above F_ss.
    assert!(
        peak > steady + 0.5 * num(case, "b_n") * 100f64.ln(),
        "{peak} vs {steady}"
    );
}

/// A long slide (300 D_c) with V0 ≠ v ends at the analytic steady state.
fn steady_state_after(law: StateLaw, a_n: f64, b_n: f64) -> (SpringSlider, SliderState) {
    let params = RateStateParams::new(a_n, b_n, 2e-6, 0.02).expect("valid");
    let v = 3e-7;
    let slide = SpringSlider::new(params, law, 5e4, v, InitialState::Hold { hold_s: 500.0 })
        .expect("valid")
        .with_reference_velocity(1e-6)
        .expect("valid");
    let end_s = 300.0 * 2e-6 / v;
    let times: Vec<f64> = (1..=100).map(|i| end_s * f64::from(i) / 100.0).collect();
    let states = slide.states(&times).expect("stable slide");
    (slide, *states.last().expect("states"))
}

#[test]
fn long_slides_reach_the_analytic_steady_state() {
    for law in [StateLaw::Aging, StateLaw::Slip] {
        // Rate-weakening and rate-strengthening, both stable at this stiffness.
        for (a_n, b_n) in [(1e-3, 1.4e-3), (1.5e-3, 0.5e-3)] {
            let (slide, last) = steady_state_after(law, a_n, b_n);
            let expected_force = 0.02 + (a_n - b_n) * (3e-7_f64 / 1e-6).ln();
            assert!((slide.steady_force_n() - expected_force).abs() < 1e-15);
            let force_err = (last.force_n - expected_force).abs() / expected_force;
            let theta_err = (last.theta_s - 2e-6 / 3e-7).abs() / (2e-6 / 3e-7);
            let v_err = (last.velocity_m_per_s - 3e-7).abs() / 3e-7;
            eprintln!("{law} a={a_n} b={b_n}: F {force_err:.1e} θ {theta_err:.1e} V {v_err:.1e}");
            assert!(
                force_err < 1e-9,
                "{law}: F {} vs {expected_force}",
                last.force_n
            );
            assert!(theta_err < 1e-8, "{law}: θ {}", last.theta_s);
            assert!(v_err < 1e-8, "{law}: V {}", last.velocity_m_per_s);
        }
    }
}

#[test]
fn a_velocity_step_shows_the_direct_effect_then_the_steady_change() {
    let (a, b, dc) = (1e-3, 1.2e-3, 1e-6);
    let (v1, v2) = (1e-6, 1e-5);
    // κ = k D_c/a = 1e5: the spring loads over a slip of ~1e-5 D_c, so the state barely moves
    // while the force takes up the direct effect.
    let kappa = 1e5;
    let k = kappa * a / dc;
    let times: Vec<f64> = (0..=4000)
        .map(|i| 1e-8 * (1e9_f64).powf(f64::from(i) / 4000.0))
        .collect();
    for law in [StateLaw::Aging, StateLaw::Slip] {
        let params = RateStateParams::new(a, b, dc, 0.01).expect("valid");
        let slide = SpringSlider::new(
            params,
            law,
            k,
            v2,
            InitialState::Steady {
                velocity_m_per_s: v1,
            },
        )
        .expect("valid")
        .with_reference_velocity(v1)
        .expect("valid");
        let states = slide.states(&times).expect("stable");
        let before = 0.01; // F0 + (a − b) ln(v1/V0) with V0 = v1
        let peak = states.iter().map(|s| s.force_n).fold(0.0, f64::max);
        let direct = a * 10f64.ln();
        // The state's change during loading costs about b ln(10)/κ of the peak.
        let direct_err = (peak - before - direct).abs() / direct;
        assert!(
            direct_err < 2.0 * b / a * 10f64.ln() / 1e4,
            "{law}: {direct_err:e}"
        );
        let last = states.last().expect("states");
        let steady = before + (a - b) * 10f64.ln();
        assert!(
            (last.force_n - steady).abs() < 1e-9 * steady,
            "{law}: {}",
            last.force_n
        );
    }
}

#[test]
fn coefficients_and_a_normal_force_give_forces() {
    let p = RateStateParams::from_coefficients(0.01, 0.015, 1e-6, 0.6, 2.5).expect("valid");
    assert!((p.a_n - 0.025).abs() < 1e-15);
    assert!((p.b_n - 0.0375).abs() < 1e-15);
    assert!((p.f0_n - 1.5).abs() < 1e-15);
    assert!((p.dc_m - 1e-6).abs() < 1e-21);
}

fn invalid_name(err: LawError) -> &'static str {
    match err {
        LawError::InvalidParameter { name, .. } => name,
        other => panic!("expected an invalid parameter, got {other:?}"),
    }
}

#[test]
fn bad_parameters_are_named() {
    let good = RateStateParams::new(1e-3, 1e-3, 1e-6, 0.01).expect("valid");
    let hold = InitialState::Hold { hold_s: 10.0 };
    for (a, b, dc, f0, name) in [
        (0.0, 1e-3, 1e-6, 0.01, "a"),
        (f64::NAN, 1e-3, 1e-6, 0.01, "a"),
        (1e-3, -1e-3, 1e-6, 0.01, "b"),
        (1e-3, f64::INFINITY, 1e-6, 0.01, "b"),
        (1e-3, 1e-3, 0.0, 0.01, "D_c"),
        (1e-3, 1e-3, 1e-6, -0.01, "F0"),
    ] {
        let err = RateStateParams::new(a, b, dc, f0).expect_err(name);
        assert_eq!(invalid_name(err.clone()), name);
        assert!(err.to_string().contains(name), "{err}");
        // A hand-built value is checked by the slide too.
        let raw = RateStateParams {
            a_n: a,
            b_n: b,
            dc_m: dc,
            f0_n: f0,
        };
        let err = SpringSlider::new(raw, StateLaw::Aging, 1e4, 1e-6, hold).expect_err(name);
        assert_eq!(invalid_name(err), name);
    }
    for (f_n, mu0, name) in [(0.0, 0.6, "F_N"), (1.0, -0.6, "mu0")] {
        let err = RateStateParams::from_coefficients(0.01, 0.01, 1e-6, mu0, f_n).expect_err(name);
        assert_eq!(invalid_name(err), name);
    }
    let slide = |k: f64, v: f64, initial: InitialState| {
        SpringSlider::new(good, StateLaw::Slip, k, v, initial)
    };
    assert_eq!(invalid_name(slide(0.0, 1e-6, hold).unwrap_err()), "k");
    assert_eq!(invalid_name(slide(1e4, -1e-6, hold).unwrap_err()), "v");
    let no_hold = InitialState::Hold { hold_s: 0.0 };
    assert_eq!(
        invalid_name(slide(1e4, 1e-6, no_hold).unwrap_err()),
        "t_hold"
    );
    let nan_step = InitialState::Steady {
        velocity_m_per_s: f64::NAN,
    };
    assert_eq!(invalid_name(slide(1e4, 1e-6, nan_step).unwrap_err()), "v1");
    let long_dc = RateStateParams::new(1e-3, 1e-3, 1.0, 0.01).expect("valid");
    let err = SpringSlider::new(long_dc, StateLaw::Aging, 1e308, 1e-6, hold).unwrap_err();
    assert_eq!(invalid_name(err), "k*D_c/a");
    let ok = slide(1e4, 1e-6, hold).expect("valid");
    let err = ok.clone().with_reference_velocity(0.0).unwrap_err();
    assert_eq!(invalid_name(err), "V0");
    for tol in [0.0, 1e-20, 0.5, f64::NAN] {
        let err = ok.clone().with_tolerance(tol).unwrap_err();
        assert_eq!(invalid_name(err), "tolerance");
    }
}

#[test]
fn bad_times_and_outputs_are_typed_errors() {
    let params = RateStateParams::new(1e-3, 1e-3, 1e-6, 0.01).expect("valid");
    let slide = SpringSlider::new(
        params,
        StateLaw::Aging,
        1e4,
        1e-6,
        InitialState::Hold { hold_s: 10.0 },
    )
    .expect("valid");
    let mut out = [0.0; 3];
    assert!(matches!(
        slide.forces(&[0.0, 2.0, 1.0], &mut out),
        Err(RateStateError::Law(LawError::UnsortedTimes {
            index: 2,
            ..
        }))
    ));
    assert!(matches!(
        slide.forces(&[0.0, f64::NAN, 1.0], &mut out),
        Err(RateStateError::Law(LawError::UnsortedTimes {
            index: 1,
            ..
        }))
    ));
    assert!(matches!(
        slide.forces(&[-1.0, 0.0, 1.0], &mut out),
        Err(RateStateError::NegativeTime { index: 0, .. })
    ));
    assert!(matches!(
        slide.forces(&[0.0, 1.0], &mut out),
        Err(RateStateError::Law(LawError::LengthMismatch {
            expected: 2,
            got: 3
        }))
    ));
    // t = 0 alone is the initial state: an unloaded spring.
    let mut one = [1.0];
    slide.forces(&[0.0], &mut one).expect("initial state");
    assert!(one[0].abs() < 1e-300);
    slide.forces(&[], &mut []).expect("no times");
}

#[test]
fn extreme_parameters_give_numbers_or_errors_never_nan() {
    let times: Vec<f64> = (1..=50).map(|i| f64::from(i) * 20.0).collect();
    let mut failures = 0;
    for law in [StateLaw::Aging, StateLaw::Slip] {
        for (a, b) in [(1e-3, 1e-3), (1e-4, 1e-2), (1e-2, 1e-4), (1e-6, 1e-1)] {
            for k in [1e-2, 1e2, 1e6, 1e12] {
                for hold_s in [1e-6, 1e2, 1e8] {
                    let params = RateStateParams::new(a, b, 1e-6, 0.05).expect("valid");
                    let slide =
                        SpringSlider::new(params, law, k, 1e-7, InitialState::Hold { hold_s })
                            .expect("valid");
                    match slide.states(&times) {
                        Ok(states) => {
                            for s in states {
                                assert!(
                                    s.force_n.is_finite()
                                        && s.velocity_m_per_s.is_finite()
                                        && s.theta_s.is_finite(),
                                    "{law} a={a} b={b} k={k} hold={hold_s}: {s:?}"
                                );
                            }
                        }
                        Err(err) => {
                            failures += 1;
                            assert!(
                                matches!(
                                    err,
                                    RateStateError::Solver { .. }
                                        | RateStateError::Unbounded { .. }
                                ),
                                "{err}"
                            );
                        }
                    }
                }
            }
        }
    }
    eprintln!("{failures} of 96 extreme slides reported an error");
}
