//! PSIS-LOO and model comparison against ArviZ 0.23 on the same pointwise log-likelihoods.
//!
//! The matrices are rebuilt here exactly as `tests/reference/loo/make_reference.py` built them
//! (a 64-bit linear congruential generator and Box–Muller), and `reference.json` holds what
//! ArviZ's `loo` and `compare` gave on them.

use serde_json::Value;
use slipbayes::diagnostics::loo::stacking_score;
use slipbayes::diagnostics::{compare, psis_loo, Loo, LooError};

const MODELS: [&str; 3] = ["normal_fixed", "normal", "student"];

struct Lcg(u64);

impl Lcg {
    fn uniform(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 11) as f64 + 0.5) / 9007199254740992.0
    }

    fn normal(&mut self) -> f64 {
        let (u1, u2) = (self.uniform(), self.uniform());
        (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
    }
}

fn reference() -> Value {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/reference/loo/reference.json"
    );
    serde_json::from_str(&std::fs::read_to_string(path).expect("reference")).expect("json")
}

fn data(points: usize) -> Vec<f64> {
    let mut rng = Lcg(1);
    let mut y: Vec<f64> = (0..points).map(|_| rng.normal()).collect();
    y[7] = 6.0;
    y[19] = -5.0;
    y
}

/// Point-major log-likelihood of `model` (as the Python script computes it).
fn matrix(model: &str, y: &[f64], seed: u64, draws: usize) -> Vec<f64> {
    let mut rng = Lcg(seed);
    let n = y.len() as f64;
    let mean = y.iter().sum::<f64>() / n;
    let mut out = vec![0.0; y.len() * draws];
    let ln_2pi = (2.0 * std::f64::consts::PI).ln();
    for s in 0..draws {
        let mu = mean + rng.normal() / n.sqrt();
        let sigma = if model == "normal_fixed" {
            1.0
        } else {
            (0.6 + 0.15 * rng.normal()).exp()
        };
        for (i, &yi) in y.iter().enumerate() {
            let z = (yi - mu) / sigma;
            out[i * draws + s] = if model == "student" {
                let pi = std::f64::consts::PI;
                -(pi.sqrt() / 2.0).ln()
                    - 0.5 * (3.0 * pi).ln()
                    - sigma.ln()
                    - 2.0 * (z * z / 3.0).ln_1p()
            } else {
                -0.5 * z * z - sigma.ln() - 0.5 * ln_2pi
            };
        }
    }
    out
}

fn loo_of(model: &str, r: &Value) -> (Loo, Vec<f64>) {
    let points = r["points"].as_u64().unwrap() as usize;
    let draws = r["draws"].as_u64().unwrap() as usize;
    let seed = r[model]["seed"].as_u64().unwrap();
    let log_lik = matrix(model, &data(points), seed, draws);
    let loo = psis_loo(&log_lik, draws, r["r_eff"].as_f64().unwrap()).expect("loo");
    (loo, log_lik)
}

fn close(what: &str, ours: f64, theirs: f64, tolerance: f64) {
    let scale = theirs.abs().max(1.0);
    assert!(
        (ours - theirs).abs() <= tolerance * scale,
        "{what}: ours {ours}, ArviZ {theirs} (difference {:e})",
        (ours - theirs).abs()
    );
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn loo_agrees_with_arviz_on_the_same_matrix() {
    let r = reference();
    for model in MODELS {
        let (loo, log_lik) = loo_of(model, &r);
        let expected = &r[model];
        // The same matrix on both sides.
        for (s, theirs) in numbers(&expected["first_row"]).into_iter().enumerate() {
            close("log-likelihood", log_lik[s], theirs, 1e-15);
        }
        close(
            "elpd_loo",
            loo.elpd,
            expected["elpd_loo"].as_f64().unwrap(),
            1e-9,
        );
        close("se", loo.se, expected["se"].as_f64().unwrap(), 1e-9);
        close(
            "p_loo",
            loo.p_loo,
            expected["p_loo"].as_f64().unwrap(),
            1e-9,
        );
        close(
            "good_k",
            loo.good_k,
            expected["good_k"].as_f64().unwrap(),
            1e-15,
        );
        for (i, (ours, theirs)) in loo
            .pointwise
            .iter()
            .zip(numbers(&expected["loo_i"]))
            .enumerate()
        {
            close(&format!("{model} loo_i[{i}]"), *ours, theirs, 1e-9);
        }
        for (i, (ours, theirs)) in loo
            .pareto_k
            .iter()
            .zip(numbers(&expected["pareto_k"]))
            .enumerate()
        {
            close(&format!("{model} pareto_k[{i}]"), *ours, theirs, 1e-9);
        }
        assert_eq!(
            !loo.unreliable_points().is_empty(),
            expected["warning"].as_bool().unwrap(),
            "{model}: the k-hat warning"
        );
    }
}

#[test]
fn an_outlier_is_flagged_where_a_light_tailed_model_cannot_predict_it() {
    let r = reference();
    let (normal, _) = loo_of("normal", &r);
    let (student, _) = loo_of("student", &r);
    // Point 7 is the outlier y = 6: the normal model's estimate for it is unreliable, the
    // Student-t model's is not.
    assert!(
        normal.unreliable_points().contains(&7),
        "{:?}",
        normal.pareto_k
    );
    assert!(
        student.unreliable_points().is_empty(),
        "{:?}",
        student.pareto_k
    );
}

#[test]
fn comparison_agrees_with_arviz_and_its_weights_score_at_least_as_well() {
    let r = reference();
    let loos: Vec<Loo> = MODELS.iter().map(|m| loo_of(m, &r).0).collect();
    let named: Vec<(&str, &Loo)> = MODELS.iter().copied().zip(&loos).collect();
    let table = compare(&named).expect("compare");
    let expected = r["compare"].as_array().unwrap();
    assert_eq!(table.len(), expected.len());
    let mut arviz_weights = vec![0.0; MODELS.len()];
    for (row, theirs) in table.iter().zip(expected) {
        assert_eq!(row.name, theirs["name"].as_str().unwrap());
        assert_eq!(row.rank as u64, theirs["rank"].as_u64().unwrap());
        close("elpd", row.elpd, theirs["elpd_loo"].as_f64().unwrap(), 1e-9);
        close(
            "elpd_diff",
            row.elpd_diff,
            theirs["elpd_diff"].as_f64().unwrap(),
            1e-9,
        );
        close("dse", row.dse, theirs["dse"].as_f64().unwrap(), 1e-9);
        // ArviZ's optimiser stops near the optimum; ours goes to 1e-12.
        close(
            "weight",
            row.weight,
            theirs["weight"].as_f64().unwrap(),
            1e-4,
        );
        let m = MODELS.iter().position(|&m| m == row.name).unwrap();
        arviz_weights[m] = theirs["weight"].as_f64().unwrap();
    }
    let ours: Vec<f64> = MODELS
        .iter()
        .map(|m| table.iter().find(|row| row.name == *m).unwrap().weight)
        .collect();
    let refs: Vec<&Loo> = loos.iter().collect();
    assert!((ours.iter().sum::<f64>() - 1.0).abs() < 1e-12);
    assert!(
        stacking_score(&refs, &ours) >= stacking_score(&refs, &arviz_weights) - 1e-12,
        "our weights {ours:?} score below ArviZ's {arviz_weights:?}"
    );
}

#[test]
fn bad_inputs_are_refused_with_what_to_fix() {
    let draws = 100;
    assert_eq!(
        psis_loo(&[0.0; 10], 10, 1.0),
        Err(LooError::TooFewDraws {
            draws: 10,
            needed: 25
        })
    );
    assert!(matches!(
        psis_loo(&vec![0.0; 250], draws, 1.0),
        Err(LooError::Shape { got: 250, .. })
    ));
    assert_eq!(
        psis_loo(&vec![0.0; 200], draws, 0.0),
        Err(LooError::REff(0.0))
    );
    let mut log_lik = vec![-1.0; 200];
    log_lik[150] = f64::NEG_INFINITY;
    let error = psis_loo(&log_lik, draws, 1.0).unwrap_err();
    assert_eq!(
        error,
        LooError::NonFinite {
            point: 1,
            draw: 50,
            value: f64::NEG_INFINITY
        }
    );
    assert!(error.to_string().contains("point 1 at draw 50"), "{error}");
    let one = psis_loo(&vec![-1.0; 200], draws, 1.0).unwrap();
    let three = psis_loo(&vec![-1.0; 300], draws, 1.0).unwrap();
    assert_eq!(compare(&[("a", &one)]), Err(LooError::TooFewModels(1)));
    assert!(matches!(
        compare(&[("a", &one), ("b", &three)]),
        Err(LooError::DifferentData {
            points: 3,
            expected: 2,
            ..
        })
    ));
}
