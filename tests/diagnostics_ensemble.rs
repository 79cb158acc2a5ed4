//! The ensemble layer: exact reduction to ArviZ with one walker per ensemble, and the
//! behaviour on synthetic ensembles with known answers.

use rand::SeedableRng;
use rand_chacha::ChaCha20Rng;
use rand_distr::{Distribution, StandardNormal};
use serde::Deserialize;
use slipbayes::diagnostics::{ensemble_rhat, summarize, DiagnosticsError, EnsembleDraws};

/// Agreement with ArviZ required when the ensemble layer reduces to it (see
/// diagnostics_arviz.rs; achieved is ~1e-14).
const ARVIZ_REL_TOL: f64 = 1e-8;

#[derive(Deserialize)]
struct Reference {
    divisor: f64,
    hdi_prob: f64,
    cases: Vec<Case>,
}

#[derive(Deserialize)]
struct Case {
    name: String,
    draws: usize,
    draws_int: Vec<Vec<i64>>,
    r_hat: Option<f64>,
    ess_bulk: f64,
    ess_tail: f64,
    ess_mean: f64,
    mcse_mean: f64,
    mcse_sd: f64,
    hdi: Vec<f64>,
    eti: Vec<f64>,
    mean: f64,
    sd: f64,
    median: f64,
    summary: Option<ArvizSummary>,
}

/// `az.summary(..., round_to="none")` columns.
#[derive(Deserialize)]
struct ArvizSummary {
    mean: f64,
    sd: f64,
    #[serde(rename = "hdi_3%")]
    hdi_low: f64,
    #[serde(rename = "hdi_97%")]
    hdi_high: f64,
    mcse_mean: f64,
    mcse_sd: f64,
    ess_bulk: f64,
    ess_tail: f64,
    r_hat: f64,
}

fn close(case: &str, what: &str, got: f64, want: f64) {
    let d = (got - want).abs();
    let r = if want.abs() > 0.0 { d / want.abs() } else { d };
    assert!(r < ARVIZ_REL_TOL, "{case}: {what} {got} vs ArviZ {want}");
}

/// With one walker per ensemble, the summary is ArviZ's, ensemble by chain.
#[test]
fn one_walker_per_ensemble_is_arviz() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/reference/arviz_diagnostics.json"
    );
    let text = std::fs::read_to_string(path).expect("reference file is committed");
    let r: Reference = serde_json::from_str(&text).expect("reference file parses");
    for c in &r.cases {
        let nested: Vec<Vec<Vec<f64>>> = c
            .draws_int
            .iter()
            .map(|ch| vec![ch.iter().map(|&k| k as f64 / r.divisor).collect()])
            .collect();
        let x = EnsembleDraws::from_nested(&nested).expect("valid draws");
        assert_eq!(x.walkers(), 1);
        let s = summarize(&x, r.hdi_prob, r.hdi_prob).expect("valid summary");
        let n = c.name.as_str();
        match (s.r_hat, c.r_hat) {
            (Some(got), Some(want)) => close(n, "r_hat", got, want),
            (None, None) => {}
            (got, want) => panic!("{n}: r_hat {got:?} vs ArviZ {want:?}"),
        }
        close(n, "ess_bulk", s.ess_bulk, c.ess_bulk);
        close(n, "ess_tail", s.ess_tail, c.ess_tail);
        close(n, "ess_mean", s.ess_mean, c.ess_mean);
        close(n, "mcse_mean", s.mcse_mean, c.mcse_mean);
        close(n, "mcse_sd", s.mcse_sd, c.mcse_sd);
        close(n, "hdi_low", s.hdi_low, c.hdi[0]);
        close(n, "hdi_high", s.hdi_high, c.hdi[1]);
        close(n, "ci_low", s.ci_low, c.eti[0]);
        close(n, "ci_high", s.ci_high, c.eti[1]);
        close(n, "mean", s.mean, c.mean);
        close(n, "sd", s.sd, c.sd);
        close(n, "median", s.median, c.median);
        // az.summary folds about the median before splitting; identical to az.rhat when the
        // number of draws is even.
        if let Some(a) = &c.summary {
            close(n, "summary mean", s.mean, a.mean);
            close(n, "summary sd", s.sd, a.sd);
            close(n, "summary hdi_3%", s.hdi_low, a.hdi_low);
            close(n, "summary hdi_97%", s.hdi_high, a.hdi_high);
            close(n, "summary mcse_mean", s.mcse_mean, a.mcse_mean);
            close(n, "summary mcse_sd", s.mcse_sd, a.mcse_sd);
            close(n, "summary ess_bulk", s.ess_bulk, a.ess_bulk);
            close(n, "summary ess_tail", s.ess_tail, a.ess_tail);
            if c.draws % 2 == 0 {
                close(
                    n,
                    "summary r_hat",
                    s.r_hat.expect("several chains"),
                    a.r_hat,
                );
            }
        }
    }
}

/// `ensembles x walkers` independent stationary AR(1) walkers of `steps` steps, shifted by
/// `offset(e, w)`.
fn ar1_ensembles(
    ensembles: usize,
    walkers: usize,
    steps: usize,
    phi: f64,
    seed: u64,
    offset: impl Fn(usize, usize) -> f64,
) -> EnsembleDraws {
    let mut rng = ChaCha20Rng::seed_from_u64(seed);
    let mut data = Vec::with_capacity(ensembles * walkers * steps);
    for e in 0..ensembles {
        for w in 0..walkers {
            let z: f64 = StandardNormal.sample(&mut rng);
            let mut x = z / (1.0 - phi * phi).sqrt();
            for t in 0..steps {
                if t > 0 {
                    let z: f64 = StandardNormal.sample(&mut rng);
                    x = phi * x + z;
                }
                data.push(x + offset(e, w));
            }
        }
    }
    EnsembleDraws::new(data, ensembles, walkers, steps).expect("valid draws")
}

const E: usize = 4;
const W: usize = 32;
const STEPS: usize = 500;
const N: f64 = (E * W * STEPS) as f64;

/// Independent normal draws: ESS close to the number of draws, R-hat close to one.
/// Over 20 seeds ESS/N had standard deviation 0.01 and R-hat never exceeded 1.0001, so the
/// bounds below are more than 5 standard errors wide.
#[test]
fn iid_draws_have_full_ess_and_unit_rhat() {
    let x = ar1_ensembles(E, W, STEPS, 0.0, 7, |_, _| 0.0);
    let s = summarize(&x, 0.94, 0.94).expect("valid");
    for (what, ess) in [
        ("bulk", s.ess_bulk),
        ("tail", s.ess_tail),
        ("mean", s.ess_mean),
    ] {
        assert!((ess / N - 1.0).abs() < 0.06, "ESS {what} {ess} vs N {N}");
    }
    let r = s.r_hat.expect("several ensembles");
    assert!((r - 1.0).abs() < 1e-3, "R-hat {r}");
    // The intervals of a standard normal, to within their Monte-Carlo error.
    assert!(s.mean.abs() < 0.02 && (s.sd - 1.0).abs() < 0.02);
    assert!((s.ci_high - 1.881).abs() < 0.05 && (s.ci_low + 1.881).abs() < 0.05);
    assert!((s.hdi_high - 1.881).abs() < 0.06 && (s.hdi_low + 1.881).abs() < 0.06);
    // mcse_mean ~ sd / sqrt(N).
    assert!((s.mcse_mean * N.sqrt() - 1.0).abs() < 0.06);
    assert!(s.tau_reliable == Some(true));
}

/// Two ensembles in one mode, two in another: R-hat between ensembles is far above 1.01,
/// although the walkers inside any one ensemble agree perfectly with each other, which is
/// why R-hat must not be computed between walkers of one ensemble.
#[test]
fn ensembles_stuck_in_different_modes_have_large_rhat() {
    let x = ar1_ensembles(E, W, STEPS, 0.5, 8, |e, _| if e < 2 { -3.0 } else { 3.0 });
    let s = summarize(&x, 0.94, 0.94).expect("valid");
    let r = s.r_hat.expect("several ensembles");
    assert!(r > 1.5, "R-hat {r}");
    assert_eq!(ensemble_rhat(&x).ok(), s.r_hat);
    let walkers: Vec<&[f64]> = (0..W).map(|w| x.series(0, w)).collect();
    let within_one = slipbayes::diagnostics::rhat(&walkers).expect("valid");
    assert!(
        within_one < 1.01,
        "walkers of one ensemble: R-hat {within_one}"
    );
}

/// Walkers that never mix with one another (each stuck around its own offset) lower the
/// ESS, even though every ensemble has the same spread of walkers and so R-hat between
/// ensembles stays near one.
#[test]
fn walkers_that_do_not_mix_lower_ess() {
    let x = ar1_ensembles(E, W, STEPS, 0.0, 9, |_, w| (w as f64 - 15.5) / 9.0);
    let s = summarize(&x, 0.94, 0.94).expect("valid");
    assert!(s.ess_bulk < 0.1 * N, "ESS bulk {} of N {N}", s.ess_bulk);
    assert!(s.ess_mean < 0.1 * N, "ESS mean {} of N {N}", s.ess_mean);
    assert!(s.r_hat.expect("several ensembles") < 1.01);
}

/// AR(1) walkers with integrated autocorrelation time tau = (1 + phi) / (1 - phi): ESS is
/// N / tau. Over 20 seeds ESS tau / N was 1.02 +- 0.016 (phi 0.5, 500 steps) and
/// 1.00 +- 0.028 (phi 0.9, 2000 steps); 10% is at least 3.5 standard deviations.
#[test]
fn autocorrelated_walkers_have_ess_n_over_tau() {
    for (phi, steps, seed) in [(0.5, STEPS, 10), (0.9, 2000, 11)] {
        let x = ar1_ensembles(E, W, steps, phi, seed, |_, _| 0.0);
        let s = summarize(&x, 0.94, 0.94).expect("valid");
        let n = (E * W * steps) as f64;
        let tau = (1.0 + phi) / (1.0 - phi);
        for (what, ess) in [("bulk", s.ess_bulk), ("mean", s.ess_mean)] {
            let ratio = ess * tau / n;
            assert!(
                (ratio - 1.0).abs() < 0.10,
                "phi {phi}: ESS {what} tau / N = {ratio}"
            );
        }
    }
}

#[test]
fn one_ensemble_has_no_rhat() {
    let x = ar1_ensembles(1, 8, 100, 0.0, 12, |_, _| 0.0);
    let s = summarize(&x, 0.9, 0.9).expect("valid");
    assert!(s.r_hat.is_none());
    assert!(matches!(
        ensemble_rhat(&x),
        Err(DiagnosticsError::TooFewChains { have: 1, .. })
    ));
    let json = serde_json::to_string(&s).expect("serialises");
    assert!(json.contains("\"r_hat\":null") && json.contains("\"ess_bulk\""));
}

#[test]
fn invalid_ensembles_are_rejected_with_their_position() {
    let mut nested = vec![vec![vec![0.0, 1.0, 2.0, 3.0, 4.0]; 3]; 2];
    nested[1][2][3] = f64::NAN;
    assert!(matches!(
        EnsembleDraws::from_nested(&nested),
        Err(DiagnosticsError::NonFinite {
            chain: 5,
            index: 3,
            ..
        })
    ));
    nested[1][2] = vec![0.0; 4];
    assert!(matches!(
        EnsembleDraws::from_nested(&nested),
        Err(DiagnosticsError::RaggedChains {
            chain: 5,
            len: 4,
            expected: 5
        })
    ));
    assert!(matches!(
        EnsembleDraws::new(vec![0.0; 6], 1, 2, 3),
        Err(DiagnosticsError::TooFewDraws {
            have: 3,
            needed: 4,
            ..
        })
    ));
    assert!(EnsembleDraws::new(vec![0.0; 7], 1, 2, 4).is_err());
    assert!(EnsembleDraws::new(vec![], 0, 2, 4).is_err());
    let x = EnsembleDraws::from_fn(2, 2, 4, |e, w, t| (e + 2 * w + 3 * t) as f64).expect("valid");
    assert_eq!(x.series(1, 1), &[3.0, 6.0, 9.0, 12.0]);
    assert!(summarize(&x, 1.0, 1.0).is_err());
    assert!(summarize(&x, 0.0, 0.0).is_err());
}
