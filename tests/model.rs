//! Model files and data fail before sampling with errors that name the key, file or line; the
//! posterior of simulated data covers the truth.

mod common;

use std::path::{Path, PathBuf};

use slipbayes::density::LogDensity;
use slipbayes::law::Scene;
use slipbayes::run_file::RunFile;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn one_run_model(data: &str, velocity: &str, scene: &str) -> String {
    format!(
        r#"
[[material]]
name = "PTFE"
[[contact]]
name = "c1"
material = "PTFE"
[[run]]
name = "r1"
contact = "c1"
data = "{data}"
velocity_m_per_s = {velocity}
scene = "{scene}"
"#
    )
}

fn load_err(dir: &Path, model: &str) -> String {
    let path = write(dir, "model.toml", model);
    match RunFile::load(&path) {
        Err(e) => e.to_string(),
        Ok(spec) => match spec.posterior() {
            Err(e) => e.to_string(),
            Ok(_) => panic!("model should have been refused:\n{model}"),
        },
    }
}

#[test]
fn bad_models_and_data_fail_before_sampling_naming_the_culprit() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    write(
        d,
        "ok.csv",
        &(0..20)
            .map(|i| format!("{i},{}\n", i as f64 * 1e-4))
            .fold("time_s,force_N\n".to_string(), |a, b| a + &b),
    );
    // Missing data file.
    let e = load_err(d, &one_run_model("missing.csv", "1e-9", "first"));
    assert!(e.contains("missing.csv"), "{e}");
    // Unknown scene: the TOML error names the key.
    let e = load_err(d, &one_run_model("ok.csv", "1e-9", "sideways"));
    assert!(e.contains("scene") || e.contains("sideways"), "{e}");
    // Negative velocity names the key.
    let e = load_err(d, &one_run_model("ok.csv", "-1e-9", "first"));
    assert!(e.contains("run[0].velocity_m_per_s"), "{e}");
    // Unsorted times name file and line.
    write(
        d,
        "unsorted.csv",
        "time_s,force_N\n0,0\n2,1e-3\n1,2e-3\n3,3e-3\n4,4e-3\n5,5e-3\n6,6e-3\n7,7e-3\n",
    );
    let e = load_err(d, &one_run_model("unsorted.csv", "1e-9", "first"));
    assert!(e.contains("unsorted.csv:4"), "{e}");
    // NaN names file and line.
    write(
        d,
        "nan.csv",
        "time_s,force_N\n0,0\n1,NaN\n2,1e-3\n3,3e-3\n4,4e-3\n5,5e-3\n6,6e-3\n7,7e-3\n",
    );
    let e = load_err(d, &one_run_model("nan.csv", "1e-9", "first"));
    assert!(e.contains("nan.csv:3"), "{e}");
    // Too few points.
    write(d, "short.csv", "time_s,force_N\n0,0\n1,1e-3\n2,2e-3\n");
    let e = load_err(d, &one_run_model("short.csv", "1e-9", "first"));
    assert!(e.contains("at least"), "{e}");
    // Unknown contact, unknown key, bad prior.
    let e = load_err(
        d,
        &one_run_model("ok.csv", "1e-9", "first")
            .replace("contact = \"c1\"\ndata", "contact = \"c9\"\ndata"),
    );
    assert!(e.contains("run[0].contact"), "{e}");
    let e = load_err(
        d,
        &(one_run_model("ok.csv", "1e-9", "first")
            + "\n[priors]\nalpha = { dist = \"log-uniform\", low = -1.0, high = 1e9 }\n"),
    );
    assert!(e.contains("priors.alpha"), "{e}");
    let e = load_err(
        d,
        &(one_run_model("ok.csv", "1e-9", "first") + "\n[levels]\nalpha = \"galaxy\"\n"),
    );
    assert!(e.contains("galaxy") || e.contains("levels"), "{e}");
    let e = load_err(
        d,
        &(one_run_model("ok.csv", "1e-9", "first") + "\n[sampler]\nmoves = \"stretch=1,hmc=2\"\n"),
    );
    assert!(
        e.contains("unknown move `hmc`") && e.contains("moves") && e.contains("line"),
        "{e}"
    );
}

/// A prior, level or pooling of a parameter that no forward model samples is refused by its
/// key (a/F_d sampled in place of a, a pooled t0's own prior); one of a parameter only the
/// chosen rival law drops (`priors.alpha` under log-aging, `priors.k` on a rigid machine) is
/// accepted, so a model file can be refitted under a rival law with one line changed, and is
/// listed as unread.
#[test]
fn settings_no_model_reads_are_refused_and_rival_leftovers_listed() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let base = one_run_model("ok.csv", "1e-9", "first");
    let load = |extra: &str| RunFile::load(&write(d, "model.toml", &format!("{extra}\n{base}")));
    let prior = "{ dist = \"log-uniform\", low = 1e3, high = 1e9 }";
    for (extra, key) in [
        (format!("[priors]\na = {prior}"), "priors.a"),
        (
            format!("[levels]\nt0 = \"contact\"\n[pooling]\nt0 = true\n[priors]\nt0 = {prior}"),
            "priors.t0",
        ),
        (
            format!("law = \"log-aging\"\naging = \"absolute\"\n[priors]\na_over_F_d = {prior}"),
            "priors.a_over_F_d",
        ),
    ] {
        let e = load(&extra).unwrap_err().to_string();
        assert!(
            e.contains(key) && e.contains("would have no effect"),
            "{extra}: {e}"
        );
    }
    for (extra, unread) in [
        (format!("aging = \"absolute\"\n[priors]\na = {prior}"), vec![]),
        (format!("[pooling]\nF_d = true\n[levels]\nF_d = \"contact\"\n[priors]\nF_d = {prior}"), vec![]),
        (
            format!("law = \"log-aging\"\n[levels]\nalpha = \"contact\"\n[priors]\nalpha = {prior}\na_over_F_d = {prior}"),
            vec!["levels.alpha", "priors.a_over_F_d", "priors.alpha"],
        ),
        (
            format!("elastic = false\n[levels]\nk = \"run\"\n[pooling]\nk = true\n[priors]\nk_pop_median = {prior}"),
            vec!["levels.k", "pooling.k", "priors.k_pop_median"],
        ),
    ] {
        let spec = load(&extra).unwrap_or_else(|e| panic!("{extra}: {e}"));
        assert_eq!(spec.model.unread_settings(), unread, "{extra}");
    }
}

/// Every model file the repository ships loads.
#[test]
fn committed_model_files_load() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for file in ["models", "benches/peer"]
        .iter()
        .flat_map(|d| std::fs::read_dir(root.join(d)).unwrap())
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
    {
        RunFile::load(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    }
}

/// Only parameters a scene uses are sampled; σ (log-uniform) is integrated out.
#[test]
fn layout_samples_only_what_scenes_use() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::simulate_ptfe(d, "first.csv", Scene::First, 20_000.0, 50.0, 1, 20_000.0);
    common::simulate_ptfe(d, "repeat.csv", Scene::Repeat, 2_000.0, 10.0, 2, 20_000.0);
    let spec = RunFile::load(&write(
        d,
        "m.toml",
        &one_run_model("repeat.csv", "1e-9", "repeat"),
    ))
    .unwrap();
    let post = spec.posterior().unwrap();
    // A repeat slide alone needs only F_d and k.
    assert_eq!(post.param_names(), vec!["ln_F_d[c1]", "ln_k[c1]"]);
    let spec = RunFile::load(&write(
        d,
        "m.toml",
        &one_run_model("first.csv", "1e-9", "stiff-fast"),
    ))
    .unwrap();
    let post = spec.posterior().unwrap();
    assert!(!post.param_names().iter().any(|n| n.starts_with("ln_k")));
    assert!(post.derived_names().contains(&"sigma[r1]".to_string()));
}

/// A σ with a prior other than log-uniform is sampled, and starts at the noise of the data.
#[test]
fn explicit_sigma_starts_at_the_noise_level() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    common::simulate_ptfe(d, "first.csv", Scene::First, 20_000.0, 50.0, 1, 0.0);
    let text = one_run_model("first.csv", "1e-9", "first")
        + "\n[priors]\nsigma = { dist = \"half-normal\", sd = 1e-3 }\n";
    let spec = RunFile::load(&write(d, "m.toml", &text)).unwrap();
    let post = spec.posterior().unwrap();
    let i = post
        .param_names()
        .iter()
        .position(|n| n == "ln_sigma[r1]")
        .expect("σ sampled");
    // Simulated with σ = 1e−4 N.
    let start = post.start()[i].exp();
    assert!((start / 1e-4 - 1.0).abs() < 0.2, "start σ = {start:e}");
}

/// The pointwise log-likelihood is ln N(F_i | model, σ²) at every observation, with σ the
/// reported `sigma` column (sampled, or drawn from its conditional where it is integrated
/// out), the model the run's forces at the data times, and a repeat slide loading up to where
/// its first slide stopped.
#[test]
fn pointwise_log_likelihood_is_each_observations_gaussian_term() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let first = data.join("ptfe-c1-first.csv");
    let model = one_run_model(&first.display().to_string(), "1e-9", "first")
        + &format!(
            r#"
[[run]]
name = "r2"
contact = "c1"
data = "{}"
velocity_m_per_s = 1e-9
scene = "repeat"
follows = "r1"
"#,
            data.join("ptfe-c1-repeat.csv").display()
        );
    let dir = tempfile::tempdir().unwrap();
    for priors in [
        "",
        "\n[priors]\nsigma = { dist = \"half-normal\", sd = 1e-3 }\n",
    ] {
        let spec = RunFile::load(&write(dir.path(), "m.toml", &(model.clone() + priors))).unwrap();
        let post = spec.posterior().unwrap();
        let x = post.start().to_vec();
        let mut derived = vec![0.0; post.derived_names().len()];
        post.log_density(&x, &mut derived).unwrap();
        let pointwise = post.pointwise_log_likelihood(&x).unwrap();
        assert_eq!(pointwise.len(), 2);
        for (run, name) in ["r1", "r2"].into_iter().enumerate() {
            let sigma_column = post
                .derived_names()
                .iter()
                .position(|n| *n == format!("sigma[{name}]"))
                .unwrap();
            let sigma = derived[sigma_column];
            let observed = slipbayes::model::data::RunData::for_run(&spec.model, run).unwrap();
            let model = post.run_forces(&x, run).unwrap();
            assert_eq!(pointwise[run].len(), observed.n_obs, "{name}");
            for (i, ll) in pointwise[run].iter().enumerate() {
                let r = observed.force[i] - model[i];
                let want =
                    -0.5 * (r / sigma).powi(2) - (sigma * (2.0 * std::f64::consts::PI).sqrt()).ln();
                assert!(
                    (ll - want).abs() < 1e-12 * want.abs().max(1.0),
                    "{name}[{i}]: {ll} {want}"
                );
            }
        }
    }
}
