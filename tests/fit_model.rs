//! End to end on simulated data with known truth: the one-contact posterior covers every true
//! value, and a short first slide alone leaves k wide rather than confidently wrong.
#![cfg(feature = "parquet")]

mod common;

use std::path::Path;

use slipbayes::density::{BlockedDensity, LogDensity};
use slipbayes::fit::{fit_model, kept_draws, FitOutcome, FitSettings, FitSummary, RunLock};
use slipbayes::law::{Law, LawParams, Scene};
use slipbayes::model::Posterior;
use slipbayes::run_file::RunFile;
use slipbayes::sampler::{Parallelism, Silent, Steps};
use slipbayes::storage::ColumnKind;

const TRUTH: (f64, f64, f64, f64, f64) = (0.92e6, 0.62, 10e-3, 14.8, 1.2e4);

fn fit(dir: &Path, name: &str, model: &str, steps: u64) -> FitSummary {
    fit_full(dir, name, model, steps).0
}

fn fit_full(
    dir: &Path,
    name: &str,
    model: &str,
    steps: u64,
) -> (FitSummary, FitOutcome, Posterior) {
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, model).unwrap();
    let spec = RunFile::load(&path).unwrap();
    let post = spec.posterior().unwrap();
    // 24: the default Student-t proposal in a block of 10 needs 11 walkers per half.
    let settings = FitSettings {
        walkers: 24,
        ensembles: 4,
        seed: 7,
        steps: Steps::Fixed(steps),
        checkpoint_every: Some(500),
        quiet: true,
        ..FitSettings::default()
    };
    let outcome = fit_model(
        &spec,
        &post,
        &settings,
        &RunLock::acquire(&dir.join(name)).unwrap(),
        false,
        vec![],
        &mut Silent,
        Parallelism::default(),
    )
    .unwrap();
    (outcome.summary.clone(), outcome, post)
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

fn get<'a>(s: &'a FitSummary, name: &str, group: &str) -> &'a slipbayes::diagnostics::Summary {
    common::stats(s, name, group)
}

#[test]
fn one_contact_posterior_covers_the_truth() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::simulate_ptfe(d, "first.csv", Scene::First, 20_000.0, 50.0, 11, 0.0);
    common::simulate_ptfe(d, "repeat.csv", Scene::Repeat, 2_000.0, 10.0, 12, 20_000.0);
    let (s, outcome, post) = fit_full(
        d,
        "both",
        &model(&(run("first", "first.csv", "first") + &run("repeat", "repeat.csv", "repeat"))),
        1500,
    );
    // The record reaches well past the peak: nothing to say about it.
    assert!(s.notes.is_empty(), "{:?}", s.notes);
    // The chains describe themselves: the units and scale of the sampled ln θ and of the
    // reported values, the seed and shape, and the burn-in the summary used.
    let meta = outcome
        .dir
        .chain_reader()
        .unwrap()
        .metadata()
        .unwrap()
        .expect("the chain parts carry metadata");
    assert_eq!(meta.burn_in, Some(s.sampler.burn_in));
    assert_eq!(
        (
            meta.seed,
            meta.ensembles,
            meta.walkers,
            meta.thin,
            meta.steps.clone()
        ),
        (Some(7), Some(4), Some(24), Some(1), 0..1500)
    );
    for (column, kind, unit, log) in [
        ("ln_alpha[c]", ColumnKind::Parameter, "1/m", true),
        ("ln_k[c]", ColumnKind::Parameter, "N/m", true),
        ("ln_a_over_F_d[c]", ColumnKind::Parameter, "1", true),
        ("k[c]", ColumnKind::Derived, "N/m", false),
        ("F_peak[first]", ColumnKind::Derived, "N", false),
        ("log_density", ColumnKind::LogDensity, "1", true),
    ] {
        let c = meta
            .column(column)
            .unwrap_or_else(|| panic!("{column}: {meta:?}"));
        assert_eq!(
            (c.kind, c.unit.as_str(), c.log),
            (kind, unit, log),
            "{column}"
        );
    }
    // The 95 % posterior predictive band holds about 95 % of the observations.
    let draws = kept_draws(&outcome, &post.param_names(), 200).unwrap();
    let bands = post.predictive_bands(&draws, 1, 3).unwrap();
    let (mut inside, mut total) = (0, 0);
    for b in &bands {
        for j in 0..b.time_s.len() {
            total += 1;
            let (lo, hi) = (b.predictive_n[0][j], b.predictive_n[3][j]);
            inside += usize::from(lo <= b.observed_n[j] && b.observed_n[j] <= hi);
        }
    }
    let coverage = inside as f64 / total as f64;
    // Binomial spread over ~600 points is ±0.9 %; the bands' own quantile error adds a little.
    assert!(
        (0.91..=0.985).contains(&coverage),
        "95 % predictive coverage {coverage}"
    );
    let (alpha, ratio, f_d, t0, k) = TRUTH;
    let peak = Law::new(&LawParams::new(alpha, ratio * f_d, f_d, t0).unwrap(), 1e-9)
        .unwrap()
        .peak()
        .interior()
        .unwrap()
        .force_n;
    common::assert_covers(
        &s,
        &[
            ("alpha", "c", alpha),
            ("a_over_F_d", "c", ratio),
            ("F_d", "c", f_d),
            ("t0", "first", t0),
            ("k", "c", k),
            ("sigma", "first", 1e-4),
            ("sigma", "repeat", 1e-4),
            ("F_peak", "first", peak),
        ],
    );
}

#[test]
fn short_first_slide_alone_leaves_k_wide() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // 800 s of the rise, well before the peak (t_peak ≈ 2300 s).
    common::simulate_ptfe(d, "first.csv", Scene::First, 800.0, 5.0, 21, 0.0);
    common::simulate_ptfe(d, "repeat.csv", Scene::Repeat, 2_000.0, 10.0, 22, 800.0);
    // Without a repeat slide the posterior is far from Gaussian (τ ≈ 140 steps): 1,500
    // steps leave k's upper tail under-explored whatever the moves, so run 6,000.
    let alone = fit(
        d,
        "alone",
        &model(&run("first", "first.csv", "first")),
        6000,
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
    // Both records end before the peak: each fit says so, once, for the first slide.
    for s in [&alone, &with_repeat] {
        assert_eq!(s.notes.len(), 1, "{:?}", s.notes);
        assert!(
            s.notes[0].contains("run `first` lies after the end of its record")
                && s.notes[0].contains("8.0000e2 s"),
            "{}",
            s.notes[0]
        );
    }
    let kr = get(&with_repeat, "k", "c");
    assert!(
        kr.ci_low <= TRUTH.4 && TRUTH.4 <= kr.ci_high,
        "k [{:e}, {:e}]",
        kr.ci_low,
        kr.ci_high
    );
    // A repeat slide pins k: its interval is many times narrower than without one.
    let width = |s: &slipbayes::diagnostics::Summary| (s.ci_high / s.ci_low).ln();
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

/// Two materials, one contact each, simulated with known truth: the joint posterior covers
/// every true value and tells the materials apart.
#[test]
fn two_material_joint_posterior_covers_the_truth() {
    use slipbayes::law::{LawParams, Scene};
    use slipbayes::simulate::{simulate, SimulationSpec};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // (material, alpha, a/F_d, F_d, t0, k)
    let truth = [
        ("A", 0.92e6, 0.62, 10e-3, 14.8, 1.2e4),
        ("B", 1.5e6, 0.40, 8e-3, 30.0, 1.0e4),
    ];
    let mut text = String::new();
    for (m, alpha, ratio, f_d, t0, k) in truth {
        for (scene, dur, dt, seed) in [
            (Scene::First, 20_000.0, 50.0, 31),
            (Scene::Repeat, 2_000.0, 10.0, 32),
        ] {
            let spec = SimulationSpec {
                scene,
                params: LawParams::new(alpha, ratio * f_d, f_d, t0).unwrap(),
                stiffness_n_per_m: Some(k),
                law: Default::default(),
                rigid: false,
                velocity_m_per_s: 1e-9,
                duration_s: dur,
                interval_s: dt,
                noise_sd_n: 1e-4,
                seed: if m == "A" { seed } else { seed + 100 },
                f_end_n: None,
                after_first_s: (scene == Scene::Repeat).then_some(20_000.0),
                normal_force_n: None,
                normal_noise_sd_n: 0.0,
            };
            let file = format!("{m}-{scene}.csv");
            simulate(&spec)
                .unwrap()
                .series
                .write_csv(&d.join(&file))
                .unwrap();
            text += &format!(
                "[[run]]\nname = \"{m}-{scene}\"\ncontact = \"c{m}\"\ndata = \"{file}\"\nvelocity_m_per_s = 1e-9\nscene = \"{scene}\"\n"
            );
        }
        text = format!(
            "[[material]]\nname = \"{m}\"\n[[contact]]\nname = \"c{m}\"\nmaterial = \"{m}\"\n"
        ) + &text;
    }
    let s = fit(d, "joint", &text, 1500);
    for (m, alpha, ratio, f_d, t0, k) in truth {
        let c = format!("c{m}");
        let first = format!("{m}-first");
        for (name, group, value) in [
            ("alpha", m, alpha),
            ("a_over_F_d", m, ratio),
            ("F_d", c.as_str(), f_d),
            ("k", c.as_str(), k),
            ("t0", first.as_str(), t0),
        ] {
            let st = get(&s, name, group);
            assert!(
                st.ci_low <= value && value <= st.ci_high,
                "{name}[{group}]: {value:e} outside [{:e}, {:e}]",
                st.ci_low,
                st.ci_high
            );
        }
    }
    // α_A = 0.92e6 < α_B = 1.5e6, whichever material the file lists first.
    let alpha = s
        .comparisons
        .iter()
        .find(|c| c.name == "alpha")
        .expect("alpha compared");
    let p_a_over_b = if alpha.group_a == "A" {
        alpha.p_a_greater
    } else {
        1.0 - alpha.p_a_greater
    };
    assert!(p_a_over_b < 0.01, "P(alpha_A > alpha_B) = {p_a_over_b}");
}

/// More data, closer medians: the same contact sampled 20 times more densely.
#[test]
fn medians_approach_the_truth_as_data_grow() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (alpha, ratio, f_d, t0, k) = TRUTH;
    let mut errors = Vec::new();
    let mut widths = Vec::new();
    for (name, dt_first, dt_repeat) in [("coarse", 400.0, 100.0), ("fine", 20.0, 5.0)] {
        let first = format!("{name}-first.csv");
        let repeat = format!("{name}-repeat.csv");
        common::simulate_ptfe(d, &first, Scene::First, 20_000.0, dt_first, 41, 0.0);
        common::simulate_ptfe(d, &repeat, Scene::Repeat, 2_000.0, dt_repeat, 42, 20_000.0);
        let s = fit(
            d,
            name,
            &model(&(run("first", &first, "first") + &run("repeat", &repeat, "repeat"))),
            1500,
        );
        let mut err = 0.0;
        let mut w = Vec::new();
        for (p, g, truth) in [
            ("alpha", "c", alpha),
            ("a_over_F_d", "c", ratio),
            ("F_d", "c", f_d),
            ("t0", "first", t0),
            ("k", "c", k),
        ] {
            let st = get(&s, p, g);
            err += (st.median / truth).ln().abs();
            w.push((st.ci_high / st.ci_low).ln());
        }
        errors.push(err);
        widths.push(w);
    }
    eprintln!(
        "sum |ln(median/truth)|: coarse {:.4}, fine {:.4}",
        errors[0], errors[1]
    );
    assert!(
        errors[1] < errors[0],
        "medians did not approach the truth: {errors:?}"
    );
    for (coarse, fine) in widths[0].iter().zip(&widths[1]) {
        assert!(fine < coarse, "an interval did not shrink: {widths:?}");
    }
}

/// Pooling t0 within a material adds the population and the new-contact peak prediction.
#[test]
fn pooled_t0_predicts_a_new_contact() {
    use slipbayes::density::LogDensity;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::simulate_ptfe(d, "f1.csv", Scene::First, 20_000.0, 100.0, 51, 0.0);
    common::simulate_ptfe(d, "f2.csv", Scene::First, 20_000.0, 100.0, 52, 0.0);
    let text = "[[material]]\nname = \"m\"\n[[contact]]\nname = \"c1\"\nmaterial = \"m\"\n\
                [[contact]]\nname = \"c2\"\nmaterial = \"m\"\n"
        .to_string()
        + &run("r1", "f1.csv", "first").replace("contact = \"c\"", "contact = \"c1\"")
        + &run("r2", "f2.csv", "first").replace("contact = \"c\"", "contact = \"c2\"")
        + "[pooling]\nt0 = true\n";
    let path = d.join("pooled.toml");
    std::fs::write(&path, &text).unwrap();
    let post = RunFile::load(&path).unwrap().posterior().unwrap();
    let names = post.param_names();
    for n in [
        "ln_t0_pop_median[m]",
        "ln_t0_pop_log_sd[m]",
        "ln_t0[r1]",
        "ln_t0[r2]",
    ] {
        assert!(names.contains(&n.to_string()), "{n} missing from {names:?}");
    }
    let derived = post.derived_names();
    let k = derived
        .iter()
        .position(|n| n == "F_peak_new[m]")
        .expect("new-contact peak");
    let mut values = vec![0.0; derived.len()];
    post.log_density(post.start(), &mut values).unwrap();
    assert!(
        values[k].is_finite() && values[k] > 0.0,
        "F_peak_new = {}",
        values[k]
    );
    let s = fit(d, "pooled", &text, 800);
    let t0 = get(&s, "t0", "r1");
    assert!(
        t0.ci_low <= TRUTH.3 && TRUTH.3 <= t0.ci_high,
        "t0 [{:e}, {:e}]",
        t0.ci_low,
        t0.ci_high
    );
    assert!(get(&s, "F_peak_new", "m").median.is_finite());
}

/// Default walkers: max(32, 4·d + 4), and 2·f + 4 more when the followers' regressions are
/// fitted to the complement. The demo's largest block has 3 coordinates and its shared blocks
/// carry 7 and 6 followers: 32. A material of 15 contacts (first + repeat slide each) carries
/// 45 followers under hierarchical updates: its regressions fitted to the complement get 94
/// walkers, tuned ones (the default for so many followers) need no more than 32; blocked
/// updates carry none and keep 32.
#[test]
fn default_walkers_grow_with_the_followers_of_a_shared_block() {
    use slipbayes::fit::{SamplerSpec, SettingOverrides};
    use slipbayes::sampler::{CarryFit, Updates};
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = tempfile::tempdir().unwrap();
    let demo_text = std::fs::read_to_string(root.join("models/demo.toml"))
        .unwrap()
        .replace("../data/", &format!("{}/", root.join("data").display()));
    let demo_path = dir.path().join("demo.toml");
    std::fs::write(&demo_path, demo_text).unwrap();
    let demo = RunFile::load(&demo_path).unwrap().posterior().unwrap();
    let walkers_with = |post: &Posterior, updates: Option<Updates>, carry: Option<CarryFit>| {
        let overrides = SettingOverrides {
            updates,
            carry,
            ..SettingOverrides::default()
        };
        FitSettings::for_model(post, &SamplerSpec::default(), &overrides).walkers
    };
    let walkers = |post: &Posterior, updates: Option<Updates>| walkers_with(post, updates, None);
    assert_eq!(walkers(&demo, None), 32);

    let data = root.join("data");
    let mut text = String::from("[[material]]\nname = \"PTFE\"\n");
    for c in 0..15 {
        text += &format!(
            "[[contact]]\nname = \"c{c}\"\nmaterial = \"PTFE\"\n\
             [[run]]\nname = \"c{c}-first\"\ncontact = \"c{c}\"\ndata = \"{d}/ptfe-c1-first.csv\"\n\
             velocity_m_per_s = 1e-9\nscene = \"first\"\n\
             [[run]]\nname = \"c{c}-repeat\"\ncontact = \"c{c}\"\ndata = \"{d}/ptfe-c1-repeat.csv\"\n\
             velocity_m_per_s = 1e-9\nscene = \"repeat\"\nfollows = \"c{c}-first\"\n",
            d = data.display()
        );
    }
    let path = dir.path().join("campaign.toml");
    std::fs::write(&path, text).unwrap();
    let campaign = RunFile::load(&path).unwrap().posterior().unwrap();
    let followers = campaign
        .block_plan()
        .blocks
        .iter()
        .map(|b| b.links.followers.len())
        .max()
        .unwrap();
    assert_eq!(followers, 45);
    assert_eq!(walkers(&campaign, None), 32);
    assert!(CarryFit::Auto.tunes(followers, 32));
    assert!(!CarryFit::Auto.tunes(7, 32));
    // Five contacts' followers tune; three contacts' (the pooled SBC model, 16 walkers) do not.
    assert!(CarryFit::Auto.tunes(15, 32));
    assert!(!CarryFit::Auto.tunes(9, 16));
    assert_eq!(
        walkers_with(&campaign, None, Some(CarryFit::Complement)),
        94
    );
    assert_eq!(walkers(&campaign, Some(Updates::Blocked)), 32);
}
