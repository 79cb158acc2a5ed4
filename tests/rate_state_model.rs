//! Rate-and-state friction as a fitted forward model (`law = "rate-state"`): the model file's
//! keys and their errors, the parameters it samples, the likelihood's forces against the
//! spring-slider solved directly, labelled rejection of unsolvable proposals, and a short fit
//! of simulated data that covers the truth.

mod common;

use std::path::{Path, PathBuf};

use slipbayes::density::{LogDensity, LogDensityError};
use slipbayes::law::rate_state::LIKELIHOOD_TOLERANCE;
use slipbayes::law::{InitialState, LawKind, RateStateParams, SpringSlider, StateLaw};
use slipbayes::model::posterior::REJECT_RATE_STATE;
use slipbayes::model::spec::ForwardModel;
use slipbayes::model::Posterior;
use slipbayes::run_file::RunFile;

/// A slow first slide with a peak and an undershoot under the slip law (docs/model.md §10).
const VELOCITY: f64 = 1e-6;
const A: f64 = 0.5e-3;
const B: f64 = 0.7e-3;
const D_C: f64 = 1e-6;
const F0: f64 = 10e-3;
const HOLD: f64 = 100.0;
const K: f64 = 2000.0;
const NOISE: f64 = 5e-5;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// One contact with a first slide (`first.csv`) and a repeat slide (`repeat.csv`); `head` goes
/// before the tables.
fn model(head: &str) -> String {
    format!(
        r#"{head}
[[material]]
name = "m"
[[contact]]
name = "c"
material = "m"
[[run]]
name = "first"
contact = "c"
data = "first.csv"
velocity_m_per_s = {VELOCITY:e}
scene = "first"
[[run]]
name = "repeat"
contact = "c"
data = "repeat.csv"
velocity_m_per_s = {VELOCITY:e}
scene = "repeat"
[levels]
a = "contact"
"#
    )
}

fn load(dir: &Path, head: &str) -> RunFile {
    RunFile::load(&write(dir, "model.toml", &model(head))).unwrap()
}

fn times(duration_s: f64, interval_s: f64) -> Vec<f64> {
    let n = (duration_s / interval_s).round() as usize;
    (0..=n).map(|i| i as f64 * interval_s).collect()
}

/// The slide of the true parameters from `initial`, solved at the default tolerance.
fn true_slide(law: StateLaw, initial: InitialState) -> SpringSlider {
    let params = RateStateParams::new(A, B, D_C, F0).unwrap();
    SpringSlider::new(params, law, K, VELOCITY, initial).unwrap()
}

/// Writes the first and repeat slides of the truth under `law`, with Gaussian noise of sd
/// [`NOISE`] from a 64-bit LCG and Box–Muller (the same data on every machine).
fn simulate(dir: &Path, law: StateLaw) {
    let mut state: u64 = 17;
    let mut normal = move || {
        let mut uniform = || {
            state = state
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            ((state >> 11) as f64 + 0.5) / (1u64 << 53) as f64
        };
        let (u1, u2) = (uniform(), uniform());
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    for (name, initial, duration) in [
        ("first.csv", InitialState::Hold { hold_s: HOLD }, 12.0),
        (
            "repeat.csv",
            InitialState::Hold {
                hold_s: D_C / VELOCITY,
            },
            8.0,
        ),
    ] {
        let t = times(duration, 0.05);
        let mut f = vec![0.0; t.len()];
        true_slide(law, initial).forces(&t, &mut f).unwrap();
        let mut text = String::from("time_s,force_N\n");
        for (t, f) in t.iter().zip(&f) {
            text += &format!("{t},{}\n", f + NOISE * normal());
        }
        write(dir, name, &text);
    }
}

#[test]
fn rate_state_keys_parse_and_refuse_what_does_not_apply_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (head, state_law) in [
        ("law = \"rate-state\"", StateLaw::Aging),
        (
            "law = \"rate-state\"\nstate_law = \"aging\"",
            StateLaw::Aging,
        ),
        ("law = \"rate-state\"\nstate_law = \"slip\"", StateLaw::Slip),
    ] {
        let expected = ForwardModel {
            law: LawKind::RateState,
            elastic: true,
            state_law,
        };
        assert_eq!(load(d, head).model.forward(), expected, "{head}");
    }
    assert_eq!(
        ForwardModel {
            law: LawKind::RateState,
            elastic: true,
            state_law: StateLaw::Slip,
        }
        .to_string(),
        "rate-state (slip law)"
    );

    let error = |head: &str| {
        let path = write(d, "bad.toml", &model(head));
        RunFile::load(&path).unwrap_err().to_string()
    };
    let e = error("law = \"rate-state\"\nstate_law = \"ruina\"");
    for needed in ["bad.toml", "line 2", "`state_law = \"ruina\"`", "\"slip\""] {
        assert!(e.contains(needed), "`{needed}` missing from: {e}");
    }
    let e = error("state_law = \"slip\"");
    assert!(
        e.contains("bad.toml: state_law:") && e.contains("law = \"rate-state\""),
        "{e}"
    );
    let e = error("reference_velocity_m_per_s = 1e-6");
    assert!(e.contains(": reference_velocity_m_per_s:"), "{e}");
    let e = error("law = \"rate-state\"\nreference_velocity_m_per_s = -1.0");
    assert!(
        e.contains(": reference_velocity_m_per_s:") && e.contains("-1"),
        "{e}"
    );
    let e = error("law = \"rate-state\"\nelastic = false");
    assert!(e.contains(": elastic:") && e.contains("spring"), "{e}");
    let stiff =
        model("law = \"rate-state\"").replace("scene = \"first\"", "scene = \"stiff-fast\"");
    let e = RunFile::load(&write(d, "bad.toml", &stiff))
        .unwrap_err()
        .to_string();
    assert!(e.contains(": run[0].scene:"), "{e}");
    let e = error(
        "law = \"rate-state\"\n[priors]\nD_c = { dist = \"log-uniform\", low = 0.0, high = 1e-3 }",
    );
    assert!(e.contains("priors.D_c"), "{e}");
}

/// The parameters of rate-and-state: a (contact level here), b and D_c (material), F_d as F0
/// (contact), the hold age t0 of the first slide alone (a repeat slide starts from steady
/// sliding) and k; no α and no peak columns.
#[test]
fn rate_state_samples_its_own_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate(d, StateLaw::Slip);
    let post = load(d, "law = \"rate-state\"\nstate_law = \"slip\"")
        .posterior()
        .unwrap();
    assert_eq!(
        post.param_names(),
        [
            "ln_a[c]",
            "ln_b[m]",
            "ln_D_c[m]",
            "ln_F_d[c]",
            "ln_t0[first]",
            "ln_k[c]"
        ]
    );
    let derived = post.derived_names();
    assert!(
        !derived
            .iter()
            .any(|n| n.contains("peak") || n.contains("alpha")),
        "{derived:?}"
    );
    // Levels and priors of the new parameters are set as the others'.
    let text = model(
        "law = \"rate-state\"\n[priors]\nD_c = { dist = \"log-normal\", median = 1e-6, sd_log = 2.0 }",
    )
    .replace("a = \"contact\"", "a = \"contact\"\nb = \"contact\"");
    let spec = RunFile::load(&write(d, "levels.toml", &text)).unwrap();
    let post = spec.posterior().unwrap();
    assert!(post.param_names().contains(&"ln_b[c]".to_owned()));
    let priors = post.prior_descriptions();
    let d_c = priors
        .iter()
        .find(|(n, _)| n.starts_with("ln_D_c"))
        .unwrap();
    assert!(d_c.1.contains("log-normal(median 1e-6"), "{d_c:?}");
}

/// The likelihood's forces of both runs at a point are the spring-slider's, solved directly
/// at the likelihood's tolerance: a first slide from θ(0) = t0, a repeat slide from θ(0) =
/// D_c/v; and the log-density is the Gaussian one of those residuals.
#[test]
fn likelihood_forces_are_the_spring_sliders() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate(d, StateLaw::Slip);
    for law in [StateLaw::Aging, StateLaw::Slip] {
        // σ sampled (a uniform prior, not integrated out), one per contact.
        let head = format!(
            "law = \"rate-state\"\nstate_law = \"{law}\"\n\
             [priors]\nsigma = {{ dist = \"uniform\", low = 0.0, high = 1.0 }}"
        );
        let text = model(&head).replace("a = \"contact\"", "a = \"contact\"\nsigma = \"contact\"");
        let spec = RunFile::load(&write(d, "model.toml", &text)).unwrap();
        let post = spec.posterior().unwrap();
        // Off the truth, so that nothing is at a special value.
        let (a, b, d_c, f0, t0, k, sigma) = (
            0.9 * A,
            1.1 * B,
            1.3 * D_C,
            1.01 * F0,
            0.7 * HOLD,
            1.2 * K,
            2.0 * NOISE,
        );
        let x: Vec<f64> = [a, b, d_c, f0, t0, k, sigma]
            .iter()
            .map(|v| v.ln())
            .collect();
        assert_eq!(post.param_names().len(), 7, "{:?}", post.param_names());
        // The values the posterior reads back from x, to the last bit.
        let [a, b, d_c, f0, t0, k, sigma] = [0, 1, 2, 3, 4, 5, 6].map(|i| x[i].exp());
        let params = RateStateParams::new(a, b, d_c, f0).unwrap();
        let mut log_likelihood = 0.0;
        for (run, initial, file) in [
            (0, InitialState::Hold { hold_s: t0 }, "first.csv"),
            (
                1,
                InitialState::Hold {
                    hold_s: d_c / VELOCITY,
                },
                "repeat.csv",
            ),
        ] {
            let (t, observed) = read_csv(&d.join(file));
            let direct = SpringSlider::new(params, law, k, VELOCITY, initial)
                .unwrap()
                .with_tolerance(LIKELIHOOD_TOLERANCE)
                .unwrap();
            let mut expected = vec![0.0; t.len()];
            direct.forces(&t, &mut expected).unwrap();
            let got = post.run_forces(&x, run).unwrap();
            assert_eq!(got.len(), t.len());
            for (g, e) in got.iter().zip(&expected) {
                assert!(
                    (g - e).abs() <= 4.0 * f64::EPSILON * e.abs(),
                    "{law} run {run}: {g} vs {e}"
                );
            }
            log_likelihood += gaussian_log_likelihood(&observed, &expected, sigma);
        }
        // The log-density minus the log prior at x is the log-likelihood: compare the
        // difference between two σ, where every prior but σ's cancels.
        let mut derived = vec![0.0; post.derived_names().len()];
        let lp = post.log_density(&x, &mut derived).unwrap();
        let mut y = x.clone();
        y[6] = (3.0 * NOISE).ln();
        let lp_y = post.log_density(&y, &mut derived).unwrap();
        let ll_y = log_likelihood_at(&post, &y, d);
        // Uniform on σ, sampled as ln σ: the Jacobian ln σ.
        let prior_sigma = |s: f64| s.ln();
        let expected = (log_likelihood - ll_y) + (prior_sigma(sigma) - prior_sigma(3.0 * NOISE));
        assert!(
            ((lp - lp_y) - expected).abs() <= 1e-9 * expected.abs().max(1.0),
            "{law}: {} vs {expected}",
            lp - lp_y
        );
    }
}

/// The Gaussian log-likelihood of both runs at `x` from the posterior's own forces.
fn log_likelihood_at(post: &Posterior, x: &[f64], d: &Path) -> f64 {
    let sigma = x[6].exp();
    let mut total = 0.0;
    for (run, file) in [(0, "first.csv"), (1, "repeat.csv")] {
        let (_, observed) = read_csv(&d.join(file));
        total += gaussian_log_likelihood(&observed, &post.run_forces(x, run).unwrap(), sigma);
    }
    total
}

/// Σ ln N(observed | model, σ²).
fn gaussian_log_likelihood(observed: &[f64], model: &[f64], sigma: f64) -> f64 {
    observed
        .iter()
        .zip(model)
        .map(|(o, e)| {
            let z = (o - e) / sigma;
            -0.5 * z * z - sigma.ln() - 0.5 * std::f64::consts::TAU.ln()
        })
        .sum()
}

/// (times, forces) of a CSV written by [`simulate`].
fn read_csv(path: &Path) -> (Vec<f64>, Vec<f64>) {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .skip(1)
        .map(|l| {
            let (t, f) = l.split_once(',').unwrap();
            (t.parse::<f64>().unwrap(), f.parse::<f64>().unwrap())
        })
        .unzip()
}

/// A proposal whose slide cannot be integrated (the slip law on a spring far softer than
/// (b − a)/D_c runs away into stick-slip) is a rejected proposal under its own label, not a
/// fatal error and not a NaN.
#[test]
fn an_unsolvable_slide_is_a_labelled_rejection() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate(d, StateLaw::Slip);
    let post = load(d, "law = \"rate-state\"\nstate_law = \"slip\"")
        .posterior()
        .unwrap();
    let x: Vec<f64> = [A, 2.0 * B, D_C, F0, HOLD, K]
        .iter()
        .map(|v| v.ln())
        .collect();
    let mut derived = vec![0.0; post.derived_names().len()];
    match post.log_density(&x, &mut derived) {
        Err(LogDensityError::Rejected { reason }) => assert_eq!(reason, REJECT_RATE_STATE),
        other => panic!("expected a rejection, got {other:?}"),
    }
    // The same point with a stiff spring is fine.
    let mut stiff = x.clone();
    stiff[5] = (20.0 * K).ln();
    assert!(post.log_density(&stiff, &mut derived).unwrap().is_finite());
}

/// The start search finds the mode's basin and a short fit of slip-law data covers the
/// truth (the chains need Parquet storage).
#[cfg(feature = "parquet")]
#[test]
fn a_short_fit_of_slip_law_data_covers_the_truth() {
    use slipbayes::fit::{fit_model, FitSettings, RunLock};
    use slipbayes::sampler::Parallelism;
    use slipbayes::sampler::{Silent, Steps};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate(d, StateLaw::Slip);
    let run = load(d, "law = \"rate-state\"\nstate_law = \"slip\"");
    let post = run.posterior().unwrap();
    let settings = FitSettings {
        walkers: 32,
        ensembles: 4,
        seed: 3,
        steps: Steps::Fixed(400),
        quiet: true,
        ..FitSettings::default()
    };
    let s = fit_model(
        &run,
        &post,
        &settings,
        &RunLock::acquire(&d.join("fit")).unwrap(),
        false,
        vec![],
        &mut Silent,
        Parallelism::default(),
    )
    .unwrap()
    .summary;
    common::assert_r_hat_below_1_05(&s);
    common::assert_covers(
        &s,
        &[
            ("a", "c", A),
            ("b", "m", B),
            ("D_c", "m", D_C),
            ("F_d", "c", F0),
            ("t0", "first", HOLD),
            ("k", "c", K),
            ("sigma", "first", NOISE),
        ],
    );
}

/// A file refitted under the default law with the `law` line removed keeps its priors and
/// levels of b and D_c: they are a rival law's leftovers, accepted and listed as unread.
#[test]
fn rate_state_settings_are_leftovers_under_the_default_law() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = model("[priors]\nD_c = { dist = \"log-uniform\", low = 1e-9, high = 1e-4 }")
        .replace("a = \"contact\"", "a = \"contact\"\nb = \"contact\"");
    let spec = RunFile::load(&write(d, "leftover.toml", &text)).unwrap();
    assert_eq!(spec.model.unread_settings(), ["levels.b", "priors.D_c"]);
}
