//! ArviZ's diagnostics reproduced: every function against arviz 0.23 on committed seeded
//! chains (tests/reference/arviz_diagnostics.json, made by make_arviz_reference.py).

use serde::Deserialize;
use slipbayes::diagnostics::{
    equal_tailed_interval, ess_bulk, ess_mean, ess_tail, hdi, mcse_mean, mcse_quantile, mcse_sd,
    quantile, rhat, DiagnosticsError,
};

/// Required agreement with ArviZ. The arithmetic is the same operation for operation except
/// the FFT (pocketfft vs rustfft), numpy's pairwise summation and the normal quantile
/// (scipy ndtri vs Boost erfc_inv), each a few ulps; the achieved worst case is printed.
const ARVIZ_REL_TOL: f64 = 1e-8;

#[derive(Deserialize)]
pub struct Reference {
    pub divisor: f64,
    pub hdi_prob: f64,
    pub quantile_probs: Vec<f64>,
    pub plain_quantiles: Vec<f64>,
    pub cases: Vec<Case>,
}

#[derive(Deserialize)]
pub struct Case {
    pub name: String,
    pub draws_int: Vec<Vec<i64>>,
    pub r_hat: Option<f64>,
    pub ess_bulk: f64,
    pub ess_tail: f64,
    pub ess_mean: f64,
    pub mcse_mean: f64,
    pub mcse_sd: f64,
    pub mcse_quantile: Vec<f64>,
    pub hdi: Vec<f64>,
    pub eti: Vec<f64>,
    pub quantiles: Vec<f64>,
}

fn load() -> (Reference, Vec<Vec<Vec<f64>>>) {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/reference/arviz_diagnostics.json"
    );
    let text = std::fs::read_to_string(path).expect("reference file is committed");
    let r: Reference = serde_json::from_str(&text).expect("reference file parses");
    let chains = r
        .cases
        .iter()
        .map(|c| {
            c.draws_int
                .iter()
                .map(|ch| ch.iter().map(|&k| k as f64 / r.divisor).collect())
                .collect()
        })
        .collect();
    (r, chains)
}

/// Relative difference, absolute when the reference is zero (an MCSE of tied draws).
fn rel(got: f64, want: f64) -> f64 {
    let d = (got - want).abs();
    if want.abs() > 0.0 {
        d / want.abs()
    } else {
        d
    }
}

struct Worst(f64, String);

impl Worst {
    fn check(&mut self, case: &str, what: &str, got: f64, want: f64) {
        let r = rel(got, want);
        assert!(
            r < ARVIZ_REL_TOL,
            "{case}: {what} = {got} but ArviZ gives {want} (rel {r:e})"
        );
        if r > self.0 {
            self.0 = r;
            self.1 = format!("{case} {what}");
        }
    }
}

#[test]
fn matches_arviz_on_reference_chains() {
    let (r, all) = load();
    assert!(r.cases.len() >= 8);
    let mut worst = Worst(0.0, String::new());
    for (case, chains) in r.cases.iter().zip(&all) {
        let refs: Vec<&[f64]> = chains.iter().map(Vec::as_slice).collect();
        let n = &case.name;
        match case.r_hat {
            Some(want) => worst.check(n, "r_hat", rhat(&refs).expect("valid"), want),
            None => assert!(matches!(
                rhat(&refs),
                Err(DiagnosticsError::TooFewChains {
                    have: 1,
                    needed: 2,
                    ..
                })
            )),
        }
        worst.check(
            n,
            "ess_bulk",
            ess_bulk(&refs).expect("valid"),
            case.ess_bulk,
        );
        worst.check(
            n,
            "ess_tail",
            ess_tail(&refs).expect("valid"),
            case.ess_tail,
        );
        worst.check(
            n,
            "ess_mean",
            ess_mean(&refs).expect("valid"),
            case.ess_mean,
        );
        worst.check(
            n,
            "mcse_mean",
            mcse_mean(&refs).expect("valid"),
            case.mcse_mean,
        );
        worst.check(n, "mcse_sd", mcse_sd(&refs).expect("valid"), case.mcse_sd);
        for (&p, &want) in r.quantile_probs.iter().zip(&case.mcse_quantile) {
            let got = mcse_quantile(&refs, p).expect("valid");
            worst.check(n, &format!("mcse_quantile({p})"), got, want);
        }
        let flat: Vec<f64> = chains.iter().flatten().copied().collect();
        let (lo, hi) = hdi(&flat, r.hdi_prob).expect("valid");
        worst.check(n, "hdi low", lo, case.hdi[0]);
        worst.check(n, "hdi high", hi, case.hdi[1]);
        let (lo, hi) = equal_tailed_interval(&flat, r.hdi_prob).expect("valid");
        worst.check(n, "eti low", lo, case.eti[0]);
        worst.check(n, "eti high", hi, case.eti[1]);
        for (&p, &want) in r.plain_quantiles.iter().zip(&case.quantiles) {
            let got = quantile(&flat, p).expect("valid");
            worst.check(n, &format!("quantile({p})"), got, want);
        }
    }
    eprintln!(
        "worst relative difference from ArviZ: {:e} ({})",
        worst.0, worst.1
    );
}

/// The diagnostics see what they should: a shifted chain gives a high R-hat and a low ESS,
/// autocorrelation lowers the ESS. (Guards against a test that passes because both sides
/// are wrong in the same trivial way.)
#[test]
fn reference_cases_are_discriminating() {
    let (r, all) = load();
    let by_name = |name: &str| {
        let i = r
            .cases
            .iter()
            .position(|c| c.name == name)
            .expect("case exists");
        all[i].clone()
    };
    let shifted = by_name("one_chain_shifted");
    let refs: Vec<&[f64]> = shifted.iter().map(Vec::as_slice).collect();
    assert!(rhat(&refs).expect("valid") > 1.1);
    let iid = by_name("normal_iid");
    let refs: Vec<&[f64]> = iid.iter().map(Vec::as_slice).collect();
    assert!(rhat(&refs).expect("valid") < 1.01);
    assert!(ess_bulk(&refs).expect("valid") > 1500.0);
    let ar = by_name("ar1_phi0.9");
    let refs: Vec<&[f64]> = ar.iter().map(Vec::as_slice).collect();
    assert!(ess_bulk(&refs).expect("valid") < 200.0);
}

#[test]
fn input_errors_say_what_is_wrong() {
    let a = [0.1, 0.5, 0.2, 0.9, 0.3];
    let short = [0.1, 0.2, 0.3];
    assert!(matches!(
        ess_bulk(&[&short]),
        Err(DiagnosticsError::TooFewDraws {
            have: 3,
            needed: 4,
            ..
        })
    ));
    assert!(matches!(rhat(&[]), Err(DiagnosticsError::NoChains { .. })));
    assert!(matches!(
        rhat(&[&a, &a[..4]]),
        Err(DiagnosticsError::RaggedChains { chain: 1, .. })
    ));
    let bad = [0.1, 0.5, f64::INFINITY, 0.9, 0.3];
    let err = ess_mean(&[&a, &bad]).expect_err("infinite draw");
    assert!(matches!(
        err,
        DiagnosticsError::NonFinite {
            chain: 1,
            index: 2,
            ..
        }
    ));
    assert!(err.to_string().contains("chain 1 at index 2"), "{err}");
    assert!(mcse_quantile(&[&a], 1.0).is_err());
    assert!(hdi(&a, 1.0).is_err());
    assert!(quantile(&a, -0.1).is_err());
    assert!(quantile(&[], 0.5).is_err());
}
