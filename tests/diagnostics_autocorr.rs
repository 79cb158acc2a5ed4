//! emcee's integrated autocorrelation time: exact agreement with emcee on committed chains
//! (tests/reference/emcee_autocorr.json, made by make_emcee_autocorr_reference.py) and
//! agreement with the analytic tau of long AR(1) ensembles.

use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Deserialize;
use slipbayes::diagnostics::{integrated_time, DEFAULT_WINDOW_FACTOR, TAU_FACTOR};

/// FFT rounding differs between numpy (pocketfft) and rustfft; everything else is the same
/// arithmetic, so the estimates agree to a few ulps of the ACF sums.
const EMCEE_REL_TOL: f64 = 1e-10;

#[derive(Deserialize)]
struct Reference {
    divisor: f64,
    c: f64,
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Case {
    name: String,
    steps: usize,
    tau_emcee: f64,
    window_emcee: usize,
    reliable_emcee: bool,
    draws_int: Vec<Vec<i64>>,
}

fn load() -> Reference {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/reference/emcee_autocorr.json"
    );
    let text = std::fs::read_to_string(path).expect("reference file is committed");
    serde_json::from_str(&text).expect("reference file parses")
}

#[test]
fn matches_emcee_integrated_time() {
    let r = load();
    assert!((r.c - DEFAULT_WINDOW_FACTOR).abs() < f64::EPSILON);
    assert!(r.cases.len() >= 5);
    let mut worst = 0.0_f64;
    for case in &r.cases {
        let walkers: Vec<Vec<f64>> = case
            .draws_int
            .iter()
            .map(|w| w.iter().map(|&k| k as f64 / r.divisor).collect())
            .collect();
        assert!(walkers.iter().all(|w| w.len() == case.steps));
        let refs: Vec<&[f64]> = walkers.iter().map(Vec::as_slice).collect();
        let got = integrated_time(&refs, r.c).expect("valid chains");
        let rel = (got.tau - case.tau_emcee).abs() / case.tau_emcee;
        worst = worst.max(rel);
        assert!(
            rel < EMCEE_REL_TOL,
            "{}: tau {} vs emcee {} (rel {rel:e})",
            case.name,
            got.tau,
            case.tau_emcee
        );
        assert_eq!(got.window, case.window_emcee, "{}: window", case.name);
        assert_eq!(got.reliable, case.reliable_emcee, "{}: reliable", case.name);
    }
    eprintln!("worst relative difference from emcee: {worst:e}");
}

/// `walkers` independent stationary AR(1) series of length `steps`.
fn ar1(phi: f64, walkers: usize, steps: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha20Rng::seed_from_u64(seed);
    (0..walkers)
        .map(|_| {
            let z: f64 = StandardNormal.sample(&mut rng);
            let mut x = z / (1.0 - phi * phi).sqrt();
            (0..steps)
                .map(|t| {
                    if t > 0 {
                        let e: f64 = StandardNormal.sample(&mut rng);
                        x = phi * x + e;
                    }
                    x
                })
                .collect()
        })
        .collect()
}

/// On long runs the estimate is within 10% of the analytic `(1 + phi) / (1 - phi)`.
/// Sokal's variance formula, var(tau)/tau^2 ~ 2 (2M + 1) / N with M ~ 5 tau and N = 640 000
/// draws, gives a relative standard error of at most 2.4% (phi = 0.9), so 10% is > 4 sigma;
/// the truncation bias 2 phi^M / (1 - phi) is negligible at M ~ 5 tau.
#[test]
fn long_ar1_matches_analytic_tau() {
    for (phi, seed) in [(0.0, 1), (0.5, 2), (0.9, 3)] {
        let walkers = ar1(phi, 32, 20_000, seed);
        let refs: Vec<&[f64]> = walkers.iter().map(Vec::as_slice).collect();
        let got = integrated_time(&refs, DEFAULT_WINDOW_FACTOR).expect("valid chains");
        let analytic = (1.0 + phi) / (1.0 - phi);
        let rel = (got.tau - analytic).abs() / analytic;
        eprintln!(
            "phi {phi}: tau {} analytic {analytic} rel {rel:.3}",
            got.tau
        );
        assert!(
            rel < 0.10,
            "phi {phi}: tau {} vs analytic {analytic}",
            got.tau
        );
        assert!(got.reliable);
        assert!(got.window as f64 >= DEFAULT_WINDOW_FACTOR * got.tau);
    }
}

/// A run shorter than 50 tau is flagged unreliable.
#[test]
fn short_run_is_unreliable() {
    let walkers = ar1(0.95, 8, 300, 4);
    let refs: Vec<&[f64]> = walkers.iter().map(Vec::as_slice).collect();
    let got = integrated_time(&refs, DEFAULT_WINDOW_FACTOR).expect("valid chains");
    assert!(!got.reliable, "tau {} from 300 steps", got.tau);
    assert!(TAU_FACTOR * got.tau > 300.0);
}
