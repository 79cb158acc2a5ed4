//! The incomplete gamma and beta functions and the normal quantile of slipbayes::special
//! against 50-digit mpmath references (tests/reference/make_special_reference.py).
//!
//! Errors are relative, in units of ε = 2^−52 times the size of the logarithm that limits
//! them, and grouped by function and region so that a failure prints the whole picture:
//! `cargo test --release --test special_gamma_beta -- --nocapture`.
//!
//! A tail probability t far from the bulk is the exponential of a logarithm L = ln t of size
//! |L|, and rounding L costs ε|L| relative in t. So:
//! - P, Q and I_x are judged in units of ε·max(1, |ln v|), v the value itself (in the bulk,
//!   plain ε; at P = 1e−300, ε·691);
//! - ln t of a tail probability t ≤ ½ by plain relative error, which is the same measure
//!   (ε|L| absolute in L is ε relative);
//! - ln v of a value close to 1 (ln v ≈ −t, t = 1 − v) is as accurate as t, so in units of
//!   ε·max(1, |ln t|);
//! - the quantiles by plain relative error.

mod common;

use std::collections::BTreeMap;

use common::Table;
use slipbayes::prec::{
    BETA_PPF_REL_TOL, BETA_REL_TOL, EPS, GAMMA_REL_TOL, LN_GAMMA_DIFF_REL_TOL, LN_GAMMA_REL_TOL,
    NORM_PPF_REL_TOL,
};
use slipbayes::special::{
    beta_ppf, beta_reg, gamma_p, gamma_q, ln_gamma_p, ln_gamma_p_diff, ln_gamma_q, norm_ppf,
};

const REFERENCE: &str = "special_gamma_beta.csv";

/// Largest error seen per (function, region), with where it happened and how many points.
#[derive(Default)]
struct Worst(BTreeMap<(&'static str, &'static str), (f64, String, usize)>);

impl Worst {
    fn add(&mut self, function: &'static str, region: &'static str, err_eps: f64, at: String) {
        let e = self
            .0
            .entry((function, region))
            .or_insert((0.0, String::new(), 0));
        e.2 += 1;
        if err_eps > e.0 || err_eps.is_nan() {
            e.0 = err_eps;
            e.1 = at;
        }
    }

    fn max(&self, function: &str) -> f64 {
        self.0
            .iter()
            .filter(|((f, _), _)| *f == function)
            .map(|(_, v)| v.0)
            .fold(0.0, f64::max)
    }

    fn table(&self) -> String {
        let mut s = String::from(
            "error against mpmath: relative, in ε (times max(1, |ln t|) for probabilities)\n",
        );
        for ((function, region), (err, at, n)) in &self.0 {
            s += &format!("  {function:<16} {region:<26} n={n:<5} max {err:>8.2} ε  at {at}\n");
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

/// Error of a probability in units of ε·max(1, |ln v|) (module documentation).
fn probability_err(got: f64, want: f64) -> f64 {
    rel_err_eps(got, want) / want.ln().abs().max(1.0)
}

/// Error of the logarithm of a probability (module documentation).
fn log_probability_err(got: f64, want: f64) -> f64 {
    let scale = if want < -std::f64::consts::LN_2 {
        1.0
    } else {
        (-want.exp_m1()).ln().abs().max(1.0)
    };
    rel_err_eps(got, want) / scale
}

fn shape_region(s: f64) -> &'static str {
    match s {
        s if s < 1.0 => "s < 1",
        s if s < 10.0 => "1 <= s < 10",
        s if s < 1000.0 => "10 <= s < 1000",
        _ => "s >= 1000",
    }
}

fn beta_region(a: f64, b: f64) -> &'static str {
    match (a.min(b), a.max(b)) {
        (_, big) if big < 10.0 => "a, b < 10",
        (small, _) if small < 10.0 => "min < 10 <= max",
        (_, big) if big < 1000.0 => "10 <= a, b < 1000",
        _ => "a, b >= 10, max >= 1000",
    }
}

/// Every row of the reference, checked; the report and the worst errors per function.
fn measure() -> (Worst, Vec<String>) {
    let t = Table::load(REFERENCE);
    let mut worst = Worst::default();
    let mut mismatches = Vec::new();
    for row in &t.rows {
        let function = t.str(row, "function");
        let arg = |name: &str| t.f64(row, name);
        let want = t.f64(row, "value");
        match function {
            "gamma_p" | "gamma_q" => {
                let (s, x) = (arg("arg1"), arg("arg2"));
                let (name, got) = if function == "gamma_p" {
                    ("gamma_p", gamma_p(s, x))
                } else {
                    ("gamma_q", gamma_q(s, x))
                };
                if want < f64::MIN_POSITIVE {
                    // Underflowing (or subnormal) tail: only the logarithm carries the value.
                    if got >= f64::MIN_POSITIVE {
                        mismatches.push(format!("{name}({s:e}, {x:e}) = {got:e}, want {want:e}"));
                    }
                } else {
                    worst.add(
                        name,
                        shape_region(s),
                        probability_err(got, want),
                        format!("s={s:e} x={x:e}"),
                    );
                }
            }
            "ln_gamma_p" | "ln_gamma_q" => {
                let (s, x) = (arg("arg1"), arg("arg2"));
                let (name, got) = if function == "ln_gamma_p" {
                    ("ln_gamma_p", ln_gamma_p(s, x))
                } else {
                    ("ln_gamma_q", ln_gamma_q(s, x))
                };
                worst.add(
                    name,
                    shape_region(s),
                    log_probability_err(got, want),
                    format!("s={s:e} x={x:e}"),
                );
            }
            "ln_gamma_p_diff" => {
                let (s, x_lo, x_hi) = (arg("arg1"), arg("arg2"), arg("arg3"));
                let got = ln_gamma_p_diff(s, x_lo, x_hi);
                worst.add(
                    "ln_gamma_p_diff",
                    shape_region(s),
                    log_probability_err(got, want),
                    format!("s={s:e} x_lo={x_lo:e} x_hi={x_hi:e}"),
                );
            }
            "beta_reg" => {
                let (a, b, x) = (arg("arg1"), arg("arg2"), arg("arg3"));
                let got = beta_reg(a, b, x);
                let at = format!("a={a:e} b={b:e} x={x:e}");
                if want < 1e-300 {
                    if got > 1e-290 {
                        mismatches.push(format!("beta_reg({at}) = {got:e}, want {want:e}"));
                    }
                } else {
                    worst.add(
                        "beta_reg",
                        beta_region(a, b),
                        probability_err(got, want),
                        at,
                    );
                }
            }
            "beta_ppf" => {
                let (q, a, b) = (arg("arg1"), arg("arg2"), arg("arg3"));
                let got = beta_ppf(q, a, b);
                worst.add(
                    "beta_ppf",
                    beta_region(a, b),
                    rel_err_eps(got, want),
                    format!("q={q:e} a={a:e} b={b:e}"),
                );
            }
            "norm_ppf" => {
                let p = arg("arg1");
                let got = norm_ppf(p);
                let region = if p < 1e-10 {
                    "p < 1e-10"
                } else if p > 1.0 - 1e-10 {
                    "p > 1 - 1e-10"
                } else {
                    "1e-10 <= p <= 1 - 1e-10"
                };
                // Φ⁻¹(½) = 0 exactly: judged absolutely.
                let err = if want == 0.0 {
                    got.abs() / EPS
                } else {
                    rel_err_eps(got, want)
                };
                worst.add("norm_ppf", region, err, format!("p={p:e}"));
            }
            other => panic!("unknown function {other} in {REFERENCE}"),
        }
    }
    (worst, mismatches)
}

#[test]
fn special_functions_match_mpmath() {
    let (worst, mismatches) = measure();
    let report = format!("{}underflow mismatches: {mismatches:?}\n", worst.table());
    eprintln!("{report}");
    assert!(mismatches.is_empty(), "{report}");
    for (function, tol) in [
        ("gamma_p", GAMMA_REL_TOL),
        ("gamma_q", GAMMA_REL_TOL),
        ("ln_gamma_p", LN_GAMMA_REL_TOL),
        ("ln_gamma_q", LN_GAMMA_REL_TOL),
        ("ln_gamma_p_diff", LN_GAMMA_DIFF_REL_TOL),
        ("beta_reg", BETA_REL_TOL),
        ("beta_ppf", BETA_PPF_REL_TOL),
        ("norm_ppf", NORM_PPF_REL_TOL),
    ] {
        assert!(
            worst.max(function) <= tol / EPS,
            "{function} beyond {} ε\n{report}",
            tol / EPS
        );
    }
}
