//! Accuracy of slipbayes::special against 50-digit mpmath references
//! (tests/reference/make_ei_reference.py), plus property and edge-case checks.
//!
//! Errors are measured against the reference rounded to f64, in units of ε = 2^−52, and
//! grouped by region so a failure prints the whole picture:
//! `cargo test --release --no-default-features --test special -- --nocapture`.

use std::collections::BTreeMap;
use std::fs;
use std::path::PathBuf;

use proptest::prelude::*;
use slipbayes::prec::{EI_DIFF_REL_TOL, EI_REL_TOL, EI_ROOT_ABS_TOL, EI_ROOT_BAND, EPS};
use slipbayes::special::{ei, ei_scaled, ei_scaled_diff, ScaledEiDiff};

const ROOT: f64 = 0.372_507_410_781_366_6;

fn reference(name: &str) -> Vec<Vec<f64>> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/reference")
        .join(name);
    let text = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    text.lines()
        .skip(1)
        .map(|line| {
            line.split(',')
                .map(|v| {
                    v.parse::<f64>()
                        .unwrap_or_else(|e| panic!("{}: bad number {v:?}: {e}", path.display()))
                })
                .collect()
        })
        .collect()
}

/// Largest error seen per region, with the input where it happened.
#[derive(Default)]
struct Worst(BTreeMap<&'static str, (f64, f64, f64, usize)>);

impl Worst {
    fn add(&mut self, region: &'static str, err_eps: f64, x0: f64, x: f64) {
        let e = self.0.entry(region).or_insert((0.0, f64::NAN, f64::NAN, 0));
        e.3 += 1;
        if err_eps > e.0 || err_eps.is_nan() {
            e.0 = err_eps;
            e.1 = x0;
            e.2 = x;
        }
    }
    fn max(&self) -> f64 {
        self.0.values().map(|v| v.0).fold(0.0, f64::max)
    }
    fn table(&self, title: &str) -> String {
        let mut s = format!("{title}\n");
        for (region, (err, x0, x, n)) in &self.0 {
            s += &format!("  {region:<28} n={n:<5} max {err:>7.3} ε  at x0={x0:e} x={x:e}\n");
        }
        s
    }
}

fn rel_err_eps(got: f64, want: f64) -> f64 {
    if got.to_bits() == want.to_bits() {
        return 0.0;
    }
    ((got - want) / want).abs() / EPS
}

fn s_region(x: f64) -> &'static str {
    match x {
        x if x < 1e-300 => "a: x < 1e-300",
        x if x < 0.2 => "b: [1e-300, 0.2)",
        x if (x - ROOT).abs() < 0.1 => "c: root ± 0.1",
        x if x <= 6.0 => "d: (r+0.1, 6]",
        x if x <= 10.0 => "e: (6, 10]",
        x if x <= 20.0 => "f: (10, 20]",
        x if x <= 40.0 => "g: (20, 40]",
        x if x <= 700.0 => "h: (40, 700]",
        _ => "i: > 700",
    }
}

#[test]
fn ei_and_scaled_match_reference() {
    let rows = reference("ei_grid.csv");
    assert!(
        rows.len() > 5000,
        "reference grid too small: {}",
        rows.len()
    );
    let (mut w_s, mut w_ei, mut w_root_abs, mut w_root_rel) = (
        Worst::default(),
        Worst::default(),
        Worst::default(),
        Worst::default(),
    );
    let mut overflow_errors = Vec::new();
    for r in &rows {
        let (x, ei_ref, s_ref) = (r[0], r[1], r[2]);
        w_s.add(s_region(x), rel_err_eps(ei_scaled(x), s_ref), f64::NAN, x);
        let got = ei(x);
        if ei_ref.is_infinite() || got.is_infinite() {
            // Past overflow: must be +inf exactly when the true value exceeds f64::MAX.
            if !(got.is_infinite() && ei_ref.is_infinite() && got > 0.0) {
                overflow_errors.push((x, got, ei_ref));
            }
            continue;
        }
        if (x - ROOT).abs() < EI_ROOT_BAND {
            w_root_abs.add(
                "root band (absolute)",
                (got - ei_ref).abs() / EPS,
                f64::NAN,
                x,
            );
            w_root_rel.add(
                "root band (relative)",
                rel_err_eps(got, ei_ref),
                f64::NAN,
                x,
            );
        } else {
            w_ei.add(s_region(x), rel_err_eps(got, ei_ref), f64::NAN, x);
        }
    }
    let report = format!(
        "{}{}{}{}overflow mismatches: {overflow_errors:?}\n",
        w_s.table("S(x) = e^-x Ei(x), relative error"),
        w_ei.table("Ei(x), relative error (outside root band)"),
        w_root_abs.table("Ei(x) within 1e-3 of the root, absolute error"),
        w_root_rel.table("Ei(x) within 1e-3 of the root, relative error (information)"),
    );
    eprintln!("{report}");
    assert!(overflow_errors.is_empty(), "{report}");
    assert!(w_s.max() <= EI_REL_TOL / EPS, "{report}");
    assert!(w_ei.max() <= EI_REL_TOL / EPS, "{report}");
    assert!(w_root_abs.max() <= EI_ROOT_ABS_TOL / EPS, "{report}");
}

fn d_region(x0: f64, x: f64) -> &'static str {
    let h = x - x0;
    if h < 1.0 && x <= 2.0 {
        if x < 2.0 * x0 {
            "series, x < 2 x0"
        } else {
            "series, x >= 2 x0"
        }
    } else if h < 2.0 && x0 >= h {
        if x0 > 1e6 {
            "quadrature, x0 > 1e6"
        } else if h >= 1.0 {
            "quadrature, h in [1, 2)"
        } else {
            "quadrature, h < 1, x0 <= 1e6"
        }
    } else if x0 < 1e-3 {
        "subtract, x0 < 1e-3"
    } else if x0 <= 2.0 {
        "subtract, x0 in [1e-3, 2]"
    } else {
        "subtract, x0 > 2"
    }
}

#[test]
fn scaled_diff_matches_reference() {
    let rows = reference("ei_diff.csv");
    assert!(rows.len() > 2000, "reference pairs too few: {}", rows.len());
    let mut w = Worst::default();
    let mut zero_errors = Vec::new();
    for r in &rows {
        let (x0, x, d_ref) = (r[0], r[1], r[2]);
        let got = ei_scaled_diff(x, x0);
        if d_ref.abs() < f64::MIN_POSITIVE {
            // x = x0, or e^-x underflowing: the result must be (near) zero as well.
            if got.abs() > f64::MIN_POSITIVE {
                zero_errors.push((x0, x, got, d_ref));
            }
            continue;
        }
        w.add(d_region(x0, x), rel_err_eps(got, d_ref), x0, x);
    }
    let report = format!(
        "{}zero mismatches: {zero_errors:?}\n",
        w.table("D(x, x0) = e^-x [Ei(x) - Ei(x0)], relative error")
    );
    eprintln!("{report}");
    assert!(zero_errors.is_empty(), "{report}");
    assert!(w.max() <= EI_DIFF_REL_TOL / EPS, "{report}");
}

#[test]
fn friction_law_limits() {
    // αv → 0: e^(−x) [Ei(x) − Ei(x0)] → ln(x/x0) (pure logarithmic aging).
    for &av in &[1e-12, 1e-9] {
        for &(t0, tau) in &[(1e-3, 1e5), (1e-9, 1e8), (14.8, 18000.0)] {
            let (x0, x) = (av * t0, av * tau);
            let d = ei_scaled_diff(x, x0);
            let lg = (x / x0).ln();
            // Through second order: D = e^(−x) [ln(x/x0) + (x − x0) + (x² − x0²)/4 + O(x³)].
            let approx = (-x).exp() * (lg + (x - x0) + (x * x - x0 * x0) / 4.0);
            let tol = 4.0 * EPS + x.powi(3) / lg;
            assert!(
                ((d - approx) / d).abs() < tol,
                "av={av} t0={t0} tau={tau}: {d} vs {approx}"
            );
            assert!(
                ((d - lg) / lg).abs() < 2.0 * x,
                "not logarithmic aging: {d} vs {lg}"
            );
        }
    }
}

#[test]
fn edge_cases() {
    // x = x0 gives 0 everywhere, including at the branch points and the extremes.
    for &x in &[
        5e-324,
        1e-300,
        ROOT,
        1.0,
        2.0,
        6.0,
        700.0,
        1e12,
        1e300,
        f64::INFINITY,
    ] {
        assert!(
            ei_scaled_diff(x, x).abs() < f64::MIN_POSITIVE,
            "x = x0 = {x}"
        );
        assert!(ScaledEiDiff::new(x).eval(x).abs() < f64::MIN_POSITIVE);
    }
    // Subnormal inputs stay finite.
    for &x in &[5e-324, 1e-310, 2.2e-308] {
        assert!(ei(x).is_finite() && ei(x) < -700.0);
        assert!(ei_scaled(x).is_finite());
    }
    assert!(ei_scaled_diff(1.0, 5e-324).is_finite());
    assert!(ei_scaled_diff(1e-308, 5e-324).is_finite());
    // Huge x: S(x) ≈ 1/x, D → S(x).
    let s = ei_scaled(1e300);
    assert!((s * 1e300 - 1.0).abs() < 4.0 * EPS, "S(1e300) = {s}");
    assert!(ei_scaled(f64::MAX).is_finite());
    assert!(((ei_scaled_diff(1e300, 1.0) - s) / s).abs() < 4.0 * EPS);
    assert!(ei_scaled_diff(f64::INFINITY, 1.0).abs() < f64::MIN_POSITIVE);
    // Domain: NaN in, NaN out; x < x0 or x0 < 0 is outside; x0 = 0 gives +inf.
    for &(x, x0) in &[(f64::NAN, 1.0), (1.0, f64::NAN), (1.0, 2.0), (1.0, -1.0)] {
        assert!(ei_scaled_diff(x, x0).is_nan(), "D({x}, {x0})");
        assert!(ScaledEiDiff::new(x0).eval(x).is_nan());
    }
    assert!(ei_scaled_diff(1.0, 0.0).is_infinite() && ei_scaled_diff(1.0, 0.0) > 0.0);
    assert!(ei(f64::NAN).is_nan() && ei(-1e-300).is_nan() && ei_scaled(f64::NAN).is_nan());
    assert!(ei(0.0) < 0.0 && ei(0.0).is_infinite());
    // Ei overflows only where the true value leaves the double range (≈ 716.35).
    assert!(ei(709.9).is_finite() && ei(716.3).is_finite());
    assert!(ei(716.4).is_infinite() && ei(1e300).is_infinite() && ei(f64::INFINITY) > 0.0);
    let d = ScaledEiDiff::new(0.25);
    assert!((d.x0() - 0.25).abs() < f64::MIN_POSITIVE);
}

/// log-uniform positive doubles over [10^lo, 10^hi].
fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo..hi).prop_map(|e| 10f64.powf(e))
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 4000,
        failure_persistence: Some(Box::new(
            proptest::test_runner::FileFailurePersistence::WithSource("regressions"),
        )),
        ..ProptestConfig::default()
    })]

    /// The prepared form gives bit-identical results.
    #[test]
    fn prepared_is_identical(x0 in log_uniform(-300.0, 12.0), f in log_uniform(-16.0, 3.0)) {
        let x = x0 * (1.0 + f);
        let a = ei_scaled_diff(x, x0);
        let b = ScaledEiDiff::new(x0).eval(x);
        prop_assert_eq!(a.to_bits(), b.to_bits(), "x0={} x={}", x0, x);
    }

    /// Splitting the interval: D(x2, x0) = D(x2, x1) + e^-(x2-x1) D(x1, x0), all terms
    /// positive, so it must hold to a few times the single-call tolerance. x2 ≤ 2 x1 keeps
    /// x2 − x1 exact.
    #[test]
    fn interval_additivity(x0 in log_uniform(-300.0, 12.0), a in log_uniform(-16.0, 1.0),
                           b in log_uniform(-16.0, 0.0)) {
        let x1 = x0 * (1.0 + a);
        let x2 = x1 * (1.0 + b);
        prop_assume!(x0 < x1 && x1 < x2);
        let whole = ei_scaled_diff(x2, x0);
        let parts = ei_scaled_diff(x2, x1) + (-(x2 - x1)).exp() * ei_scaled_diff(x1, x0);
        let tol = 3.0 * EI_DIFF_REL_TOL + 2.0 * EPS;
        prop_assert!(((whole - parts) / whole).abs() <= tol,
            "x0={} x1={} x2={} whole={} parts={}", x0, x1, x2, whole, parts);
    }

    /// Where the subtraction S(x) − e^-h S(x0) is moderately conditioned (h between 0.3
    /// and 1, where the series and quadrature paths are used), both forms agree within the
    /// condition number times a few ε.
    #[test]
    fn agrees_with_subtraction(x0 in log_uniform(-3.0, 3.0), h in 0.3f64..1.0) {
        let x = x0 + h;
        let h = x - x0;
        let (sx, t) = (ei_scaled(x), (-h).exp() * ei_scaled(x0));
        let d = ei_scaled_diff(x, x0);
        let cond = (sx.abs() + t.abs()) / d.abs();
        prop_assume!(cond < 20.0);
        prop_assert!(((sx - t - d) / d).abs() <= cond * 8.0 * EPS + EI_DIFF_REL_TOL,
            "x0={} x={} d={} sub={} cond={}", x0, x, d, sx - t, cond);
    }

    /// D ≥ 0 and D decreases as x0 grows towards x (∂D/∂x0 = −e^(x0−x)/x0 < 0).
    #[test]
    fn positive_and_monotone_in_x0(x in log_uniform(-300.0, 12.0), u in 0.0f64..1.0,
                                   v in 0.0f64..1.0) {
        let (lo, hi) = if u < v { (u, v) } else { (v, u) };
        let (x0a, x0b) = (x * lo, x * hi);
        prop_assume!(x0a > 0.0 && x0a < x0b);
        let (da, db) = (ei_scaled_diff(x, x0a), ei_scaled_diff(x, x0b));
        prop_assert!(db >= 0.0);
        prop_assert!(da >= db * (1.0 - EI_DIFF_REL_TOL), "x={} x0a={} x0b={} {} {}", x, x0a, x0b, da, db);
    }

    /// dD/dx = 1/x − D (the law's ODE), checked by a central difference where D is smooth
    /// and the difference step is well resolved.
    #[test]
    fn derivative_matches_ode(x0 in log_uniform(-6.0, 4.0), f in log_uniform(-2.0, 2.0)) {
        let x = x0 * (1.0 + f);
        let step = 1e-4 * x.min(1.0);
        let dd = (ei_scaled_diff(x + step, x0) - ei_scaled_diff(x - step, x0)) / (2.0 * step);
        let ode = 1.0 / x - ei_scaled_diff(x, x0);
        let scale = 1.0 / x + ei_scaled_diff(x, x0).abs();
        prop_assert!(((dd - ode) / scale).abs() < 1e-6, "x0={} x={} fd={} ode={}", x0, x, dd, ode);
    }
}
