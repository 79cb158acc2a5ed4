//! Rival forward models chosen in the model file: `law = "log-aging"` (α → 0) and
//! `elastic = false` (k → ∞). The key parses and refuses unknown laws by name, each model
//! samples and reports only its own parameters, the default is the model of before bit for bit,
//! and a short fit of data simulated under each nested model converges to its truth.

mod common;

use std::path::{Path, PathBuf};

use slipbayes::density::LogDensity;
use slipbayes::law::{LawKind, Scene};
use slipbayes::model::spec::ForwardModel;
use slipbayes::run_file::RunFile;

/// PTFE near the paper's Fig. 2 fit (as `common::simulate_ptfe`).
const ALPHA: f64 = 0.92e6;
const F_D: f64 = 10e-3;
const T0: f64 = 14.8;
const K: f64 = 1.2e4;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// One contact with a first slide (`first.csv`) and a repeat slide (`repeat.csv`) following
/// it; `head` goes before the tables (top-level keys such as `law`).
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
velocity_m_per_s = 1e-9
scene = "first"
[[run]]
name = "repeat"
contact = "c"
data = "repeat.csv"
velocity_m_per_s = 1e-9
scene = "repeat"
[levels]
alpha = "contact"
a = "contact"
"#
    )
}

fn load(dir: &Path, head: &str) -> RunFile {
    RunFile::load(&write(dir, "model.toml", &model(head))).unwrap()
}

fn simulate_full(dir: &Path) {
    common::simulate_ptfe(dir, "first.csv", Scene::First, 20_000.0, 50.0, 1, 0.0);
    common::simulate_ptfe(dir, "repeat.csv", Scene::Repeat, 2_000.0, 10.0, 2, 20_000.0);
}

#[test]
fn law_key_parses_each_value_and_refuses_unknown_ones_by_name() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (head, expected) in [
        ("", ForwardModel::default()),
        (
            "law = \"aging-rejuvenation\"\nelastic = true",
            ForwardModel::default(),
        ),
        (
            "law = \"log-aging\"",
            ForwardModel {
                law: LawKind::LogAging,
                elastic: true,
                ..ForwardModel::default()
            },
        ),
        (
            "elastic = false",
            ForwardModel {
                law: LawKind::AgingRejuvenation,
                elastic: false,
                ..ForwardModel::default()
            },
        ),
        (
            "law = \"log-aging\"\nelastic = false",
            ForwardModel {
                law: LawKind::LogAging,
                elastic: false,
                ..ForwardModel::default()
            },
        ),
    ] {
        assert_eq!(load(d, head).model.forward(), expected, "{head}");
    }
    assert_eq!(
        ForwardModel::default(),
        ForwardModel {
            law: LawKind::AgingRejuvenation,
            elastic: true,
            state_law: slipbayes::law::StateLaw::Aging,
        }
    );
    let path = write(d, "bad.toml", &model("\nlaw = \"coulomb\""));
    let e = RunFile::load(&path).unwrap_err().to_string();
    for needed in [
        "bad.toml",
        "line 2",
        "column 7",
        "`law = \"coulomb\"`",
        "\"aging-rejuvenation\", \"log-aging\", \"rate-state\"",
    ] {
        assert!(e.contains(needed), "`{needed}` missing from: {e}");
    }
    let path = write(d, "bad.toml", &model("elastic = \"no\""));
    let e = RunFile::load(&path).unwrap_err().to_string();
    assert!(e.contains("bad.toml") && e.contains("line 1"), "{e}");
}

/// Each model samples and reports only the parameters it uses: log-aging has no α, no F_d
/// (the repeat slide follows the first) and no peak; the rigid machine has no k, and its peak
/// is seen at t_peak = τ_peak.
#[test]
fn each_model_samples_and_reports_only_its_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate_full(d);
    let post = |head: &str| load(d, head).posterior().unwrap();

    let full = post("");
    assert_eq!(
        full.param_names(),
        [
            "ln_alpha[c]",
            "ln_a_over_F_d[c]",
            "ln_F_d[c]",
            "ln_t0[first]",
            "ln_k[c]"
        ]
    );
    assert!(full.derived_names().contains(&"F_peak[first]".to_owned()));

    let log_aging = post("law = \"log-aging\"");
    assert_eq!(
        log_aging.param_names(),
        ["ln_a[c]", "ln_t0[first]", "ln_k[c]"]
    );
    let derived = log_aging.derived_names();
    assert!(
        !derived
            .iter()
            .any(|n| n.contains("peak") || n.contains("F_d")),
        "{derived:?}"
    );

    let rigid = post("elastic = false");
    assert_eq!(
        rigid.param_names(),
        [
            "ln_alpha[c]",
            "ln_a_over_F_d[c]",
            "ln_F_d[c]",
            "ln_t0[first]"
        ]
    );
    let names = rigid.derived_names();
    let mut values = vec![0.0; names.len()];
    rigid.log_density(rigid.start(), &mut values).unwrap();
    let value = |name: &str| values[names.iter().position(|n| n == name).unwrap()];
    assert!(value("tau_peak[first]").is_finite());
    assert!(
        (value("t_peak[first]") - value("tau_peak[first]")).abs()
            <= 4.0 * f64::EPSILON * value("tau_peak[first]")
    );

    // A repeat slide that follows no first slide slides at F_d, which log-aging keeps for it.
    let alone = model("law = \"log-aging\"")
        .replace("name = \"first\"", "name = \"other\"")
        .replace(
            "contact = \"c\"\ndata = \"first.csv\"",
            "contact = \"c2\"\ndata = \"first.csv\"",
        )
        + "[[contact]]\nname = \"c2\"\nmaterial = \"m\"\n";
    let spec = RunFile::load(&write(d, "alone.toml", &alone)).unwrap();
    let names = spec.posterior().unwrap().param_names();
    assert!(names.contains(&"ln_F_d[c]".to_owned()), "{names:?}");
    assert!(!names.contains(&"ln_F_d[c2]".to_owned()), "{names:?}");
}

/// Without the keys, and with the defaults written out, the posterior is the same: the same
/// coordinates, log-density, forces and derived values to the bit. That both are the model of
/// before `law` existed, bit for bit, is `cli/tests/demo.rs`: the demo's fit reproduces the
/// committed reports/demo (made before) byte for byte, chains and all.
#[test]
fn default_law_written_out_or_not_is_the_same_model_to_the_bit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    simulate_full(d);
    let implicit = load(d, "").posterior().unwrap();
    let explicit = load(d, "law = \"aging-rejuvenation\"\nelastic = true")
        .posterior()
        .unwrap();
    assert_eq!(implicit.param_names(), explicit.param_names());
    // A point off the mode, where every part of the model is exercised.
    let x: Vec<f64> = [ALPHA * 1.1, 0.55, F_D * 1.02, T0 * 0.9, K * 1.05]
        .iter()
        .map(|v| v.ln())
        .collect();
    let mut bits = Vec::new();
    for post in [&implicit, &explicit] {
        let mut derived = vec![0.0; post.derived_names().len()];
        let lp = post.log_density(&x, &mut derived).unwrap();
        let mut hash = lp.to_bits();
        for run in 0..2 {
            for f in post.run_forces(&x, run).unwrap() {
                hash = hash.rotate_left(5) ^ f.to_bits();
            }
        }
        for v in derived {
            hash = hash.rotate_left(5) ^ v.to_bits();
        }
        bits.push((lp.to_bits(), hash));
    }
    assert_eq!(bits[0], bits[1]);
}

/// Short fits of data simulated under each nested model (the chains need Parquet storage).
#[cfg(feature = "parquet")]
mod fits {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};
    use slipbayes::law::{Elastic, Law, LogAging, ObservedSlide, RepeatSlide};

    const VELOCITY: f64 = 1e-9;
    const A: f64 = 0.62 * 10e-3;
    const NOISE: f64 = 1e-4;

    /// Writes `forces` at `times` plus Gaussian noise of sd [`NOISE`] as a CSV.
    fn write_noisy(dir: &Path, name: &str, times: &[f64], forces: &[f64], seed: u64) {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, NOISE).unwrap();
        let mut text = String::from("time_s,force_N\n");
        for (t, f) in times.iter().zip(forces) {
            text += &format!("{t},{}\n", f + noise.sample(&mut rng));
        }
        write(dir, name, &text);
    }

    fn times(duration_s: f64, interval_s: f64) -> Vec<f64> {
        let n = (duration_s / interval_s).round() as usize;
        (0..=n).map(|i| i as f64 * interval_s).collect()
    }

    /// Fits `model` in `dir` for `steps` steps and returns the summary.
    fn fit(dir: &Path, spec: &RunFile, steps: u64) -> slipbayes::fit::FitSummary {
        use slipbayes::fit::{fit_model, FitSettings, RunLock};
        use slipbayes::sampler::Parallelism;
        use slipbayes::sampler::{Silent, Steps};
        let post = spec.posterior().unwrap();
        let settings = FitSettings {
            walkers: 24,
            ensembles: 4,
            seed: 3,
            steps: Steps::Fixed(steps),
            quiet: true,
            ..FitSettings::default()
        };
        fit_model(
            spec,
            &post,
            &settings,
            &RunLock::acquire(&dir.join("fit")).unwrap(),
            false,
            vec![],
            &mut Silent,
            Parallelism::default(),
        )
        .unwrap()
        .summary
    }

    /// Every parameter has R̂ below 1.05 and its 95 % interval holds the truth.
    fn assert_converged_on(s: &slipbayes::fit::FitSummary, truths: &[(&str, &str, f64)]) {
        common::assert_r_hat_below_1_05(s);
        common::assert_covers(s, truths);
    }

    /// Data simulated by pure logarithmic aging through the spring: the log-aging fit converges
    /// and covers a, t0 and k.
    #[test]
    fn log_aging_fit_of_log_aging_data_converges_to_the_truth() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let first_t = times(5_000.0, 25.0);
        let elastic = Elastic::spring(K, VELOCITY).unwrap();
        let slide = ObservedSlide::new(LogAging::new(A, T0).unwrap(), elastic);
        let mut first = vec![0.0; first_t.len()];
        slide.forces(&first_t, &mut first, None).unwrap();
        write_noisy(d, "first.csv", &first_t, &first, 5);
        // The repeat slide loads up to where the first one stopped.
        let repeat_t = times(1_000.0, 10.0);
        let repeat = RepeatSlide::from_elastic(elastic, *first.last().unwrap()).unwrap();
        let mut forces = vec![0.0; repeat_t.len()];
        repeat.forces(&repeat_t, &mut forces).unwrap();
        write_noisy(d, "repeat.csv", &repeat_t, &forces, 6);

        let s = fit(d, &load(d, "law = \"log-aging\""), 600);
        assert_converged_on(&s, &[("a", "c", A), ("t0", "first", T0), ("k", "c", K)]);
    }

    /// Data simulated on a rigid machine (τ = t, a repeat slide at F_end from its start): the
    /// `elastic = false` fit converges and covers α, a/F_d, F_d and t0.
    #[test]
    fn rigid_fit_of_rigid_data_converges_to_the_truth() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let first_t = times(20_000.0, 100.0);
        let law = Law::from_rate(ALPHA * VELOCITY, A, F_D, T0).unwrap();
        let slide = ObservedSlide::new(law, Elastic::Stiff);
        let mut first = vec![0.0; first_t.len()];
        slide.forces(&first_t, &mut first, None).unwrap();
        write_noisy(d, "first.csv", &first_t, &first, 7);
        let repeat_t = times(1_000.0, 20.0);
        let repeat = RepeatSlide::rigid(*first.last().unwrap()).unwrap();
        let mut forces = vec![0.0; repeat_t.len()];
        repeat.forces(&repeat_t, &mut forces).unwrap();
        write_noisy(d, "repeat.csv", &repeat_t, &forces, 8);

        let s = fit(d, &load(d, "elastic = false"), 600);
        assert_converged_on(
            &s,
            &[
                ("alpha", "c", ALPHA),
                ("a_over_F_d", "c", A / F_D),
                ("F_d", "c", F_D),
                ("t0", "first", T0),
            ],
        );
    }
}
