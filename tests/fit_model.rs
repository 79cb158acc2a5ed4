//! End to end on simulated data with known truth: the one-contact posterior covers every true
//! value, and a short first slide alone leaves k wide rather than confidently wrong.
#![cfg(feature = "parquet")]

mod common;

use std::path::Path;

use slipbayes::fit::{run_fit, ComparisonSpec, FitSettings, FitSummary};
use slipbayes::law::{Law, LawParams, Scene};
use slipbayes::model::{ModelSpec, Posterior};
use slipbayes::sampler::{Silent, Steps};

const TRUTH: (f64, f64, f64, f64, f64) = (0.92e6, 0.62, 10e-3, 14.8, 1.2e4);

fn fit(dir: &Path, name: &str, model: &str, steps: u64) -> FitSummary {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, model).unwrap();
    let spec = ModelSpec::load(&path).unwrap();
    let post = Posterior::new(&spec).unwrap();
    let quantities = post.quantities();
    let settings = FitSettings {
        walkers: 20,
        ensembles: 4,
        seed: 7,
        steps: Steps::Fixed(steps),
        checkpoint_every: Some(500),
        quiet: true,
        ..FitSettings::default()
    };
    let out = dir.join(name);
    let comparisons = ComparisonSpec {
        names: vec![],
        groups: vec![],
    };
    run_fit(
        &post,
        &quantities,
        &comparisons,
        post.start(),
        &settings,
        &out,
        false,
        &mut Silent,
    )
    .unwrap()
    .summary
}

fn model(runs: &str) -> String {
    format!(
        "[[material]]\nname = \"m\"\n[[contact]]\nname = \"c\"\nmaterial = \"m\"\n{runs}\n\
         [levels]\nalpha = \"contact\"\na = \"contact\"\n"
    )
}

fn run(name: &str, file: &str, scene: &str) -> String {
    format!(
        "[[run]]\nname = \"{name}\"\ncontact = \"c\"\ndata = \"{file}\"\nvelocity_m_per_s = 1e-9\nscene = \"{scene}\"\n"
    )
}

fn get<'a>(s: &'a FitSummary, name: &str, group: &str) -> &'a slipbayes::fit::Stats {
    &s.parameters
        .iter()
        .chain(&s.derived)
        .find(|q| q.name == name && q.group == group)
        .unwrap_or_else(|| panic!("no {name}[{group}]"))
        .stats
}

#[test]
fn one_contact_posterior_covers_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::simulate_ptfe(d, "first.csv", Scene::First, 20_000.0, 50.0, 11, 0.0);
    common::simulate_ptfe(d, "repeat.csv", Scene::Repeat, 2_000.0, 10.0, 12, 20_000.0);
    let s = fit(
        d,
        "both",
        &model(&(run("first", "first.csv", "first") + &run("repeat", "repeat.csv", "repeat"))),
        1500,
    );
    let (alpha, ratio, f_d, t0, k) = TRUTH;
    let peak = Law::new(&LawParams::new(alpha, ratio * f_d, f_d, t0).unwrap(), 1e-9)
        .unwrap()
        .peak()
        .interior()
        .unwrap()
        .force_n;
    for (name, group, truth) in [
        ("alpha", "c", alpha),
        ("a_over_F_d", "c", ratio),
        ("F_d", "c", f_d),
        ("t0", "first", t0),
        ("k", "c", k),
        ("sigma", "first", 1e-4),
        ("sigma", "repeat", 1e-4),
        ("F_peak", "first", peak),
    ] {
        let st = get(&s, name, group);
        assert!(
            st.ci_low <= truth && truth <= st.ci_high,
            "{name}[{group}]: truth {truth:e} outside [{:e}, {:e}]",
            st.ci_low,
            st.ci_high
        );
    }
}

#[test]
fn short_first_slide_alone_leaves_k_wide() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 800 s of the rise, well before the peak (t_peak ≈ 2300 s).
    common::simulate_ptfe(d, "first.csv", Scene::First, 800.0, 5.0, 21, 0.0);
    common::simulate_ptfe(d, "repeat.csv", Scene::Repeat, 2_000.0, 10.0, 22, 800.0);
    let alone = fit(
        d,
        "alone",
        &model(&run("first", "first.csv", "first")),
        1500,
    );
    let k = get(&alone, "k", "c");
    // The data hardly pin k: its interval still holds the truth.
    assert!(
        k.ci_low <= TRUTH.4 && TRUTH.4 <= k.ci_high,
        "k [{:e}, {:e}]",
        k.ci_low,
        k.ci_high
    );
    let with_repeat = fit(
        d,
        "with-repeat",
        &model(&(run("first", "first.csv", "first") + &run("repeat", "repeat.csv", "repeat"))),
        1500,
    );
    let kr = get(&with_repeat, "k", "c");
    assert!(
        kr.ci_low <= TRUTH.4 && TRUTH.4 <= kr.ci_high,
        "k [{:e}, {:e}]",
        kr.ci_low,
        kr.ci_high
    );
    // A repeat slide pins k: its interval is many times narrower than without one.
    let width = |s: &slipbayes::fit::Stats| (s.ci_high / s.ci_low).ln();
    eprintln!(
        "ln-width of k: alone {:.4}, with repeat {:.4}",
        width(k),
        width(kr)
    );
    assert!(
        width(k) > 5.0 * width(kr),
        "alone [{:e}, {:e}], with repeat [{:e}, {:e}]",
        k.ci_low,
        k.ci_high,
        kr.ci_low,
        kr.ci_high
    );
}
