//! The stopping rule is honest on every configuration a model file allows: the one-contact
//! quick path, the demo's two materials, the demo with `aging = "absolute"`, the demo with t0
//! pooled, and a campaign. Fits stopped by the rule from two seeds have every parameter's mean
//! within 4 combined MCSE of a run of the same model ten times as long as the longer of them,
//! and the τ_max the rule trusted agrees with that run's (on its second half). `benches/stopping.py` measures the
//! same with ArviZ and more seeds (`reports/stopping.md`).
#![cfg(feature = "parquet")]

#[path = "../../tests/common/reference_tau.rs"]
mod reference_tau;

use std::path::{Path, PathBuf};
use std::process::Command;

use reference_tau::reference_tau;
use serde_json::Value;

const SEEDS: [u64; 2] = [1, 2];
/// Combined Monte-Carlo standard errors a mean may differ by.
const K_MCSE: f64 = 4.0;
/// The rule's τ_max over that of a run ten times longer: the pooled estimate on chains of
/// 12.5 τ is 0.92 of the long-run value in median, 0.73–1.10 over windows
/// (`reports/fit-defaults.md`).
const TAU_RATIO: (f64, f64) = (0.6, 1.4);

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

/// Runs `slipbayes fit ARGS --out OUT --quiet EXTRA` and returns its summary.json.
fn fit(args: &[String], out: &Path, extra: &[String]) -> Value {
    let status = Command::new(env!("CARGO_BIN_EXE_slipbayes"))
        .arg("fit")
        .args(args)
        .arg("--out")
        .arg(out)
        .arg("--quiet")
        .args(extra)
        .output()
        .expect("slipbayes runs");
    assert!(
        status.status.success(),
        "slipbayes fit {args:?} {extra:?}: {}",
        String::from_utf8_lossy(&status.stderr)
    );
    serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap()
}

/// The demo's model file with its data paths made absolute, `before` above it and `after`
/// below it, written to `dir/name.toml`.
fn demo_variant(dir: &Path, name: &str, before: &str, after: &str) -> String {
    let text = std::fs::read_to_string(repo("models/demo.toml")).unwrap();
    let data = repo("data").display().to_string();
    let text = format!("{before}{}{after}", text.replace("../data", &data));
    let path = dir.join(format!("{name}.toml"));
    std::fs::write(&path, text).unwrap();
    path.display().to_string()
}

/// A 4-contact campaign made by `data/make_campaign.py` with this build.
fn campaign(dir: &Path) -> String {
    let out = dir.join("campaign");
    let status = Command::new("python3")
        .arg(repo("data/make_campaign.py"))
        .args([
            "--contacts",
            "4",
            "--binary",
            env!("CARGO_BIN_EXE_slipbayes"),
            "--out",
        ])
        .arg(&out)
        .current_dir(repo(""))
        .output()
        .expect("python3 runs data/make_campaign.py");
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    out.join("campaign.toml").display().to_string()
}

/// Fits `args` from every seed until converged and once for ten times as long; returns what
/// fails the standard.
fn honesty(label: &str, args: &[String], dir: &Path) -> Vec<String> {
    let mut failures = Vec::new();
    let stopped: Vec<(u64, Value)> = SEEDS
        .iter()
        .map(|&seed| {
            let out = dir.join(format!("{label}-{seed}"));
            (seed, fit(args, &out, &["--seed".into(), seed.to_string()]))
        })
        .collect();
    let steps = |s: &Value| s["sampler"]["steps"].as_u64().unwrap();
    let longest = stopped.iter().map(|(_, s)| steps(s)).max().unwrap();
    let reference_dir = dir.join(format!("{label}-reference"));
    let reference = fit(
        args,
        &reference_dir,
        &[
            "--seed".into(),
            "1000".into(),
            "--steps".into(),
            (10 * longest).to_string(),
        ],
    );
    let tau_ref = reference_tau(&reference_dir);
    let number = |q: &Value, key: &str| q[key].as_f64().unwrap_or(f64::NAN);
    for (seed, s) in &stopped {
        let sampler = &s["sampler"];
        if !(sampler["converged"] == true && sampler["stopped_by"] == "Converged") {
            failures.push(format!(
                "{label} seed {seed}: not converged: {}",
                sampler["problems"]
            ));
        }
        let ours = s["parameters"].as_array().unwrap();
        let theirs = reference["parameters"].as_array().unwrap();
        for (q, r) in ours.iter().zip(theirs) {
            let z = (number(q, "mean") - number(r, "mean"))
                / number(q, "mcse_mean").hypot(number(r, "mcse_mean"));
            if z.is_nan() || z.abs() > K_MCSE {
                failures.push(format!(
                    "{label} seed {seed}: mean of {} is {z:+.2} MCSE from the reference's",
                    q["column"]
                ));
            }
        }
        let tau = sampler["tau_max"].as_f64().unwrap();
        eprintln!(
            "{label} seed {seed}: {} steps, τ_max {tau:.2}; reference {} steps, τ_max {tau_ref:.2}",
            steps(s),
            10 * longest
        );
        if !(TAU_RATIO.0..=TAU_RATIO.1).contains(&(tau / tau_ref)) {
            failures.push(format!(
                "{label} seed {seed}: τ_max {tau:.2} trusted after {} steps, {tau_ref:.2} on {} \
                 steps",
                steps(s),
                10 * longest
            ));
        }
    }
    failures
}

#[test]
fn the_stopping_rule_is_honest_on_every_model_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let one_contact = [
        "--first",
        &repo("data/ptfe-c1-first.csv").display().to_string(),
        "--repeat",
        &repo("data/ptfe-c1-repeat.csv").display().to_string(),
        "--velocity",
        "1e-9",
    ]
    .map(String::from)
    .to_vec();
    let configurations = [
        ("one-contact", one_contact),
        ("demo", vec![demo_variant(d, "demo", "", "")]),
        (
            "absolute",
            vec![demo_variant(d, "absolute", "aging = \"absolute\"\n", "")],
        ),
        (
            "pooled",
            vec![demo_variant(d, "pooled", "", "\n[pooling]\nt0 = true\n")],
        ),
        ("campaign", vec![campaign(d)]),
    ];
    let failures: Vec<String> = configurations
        .iter()
        .flat_map(|(label, args)| honesty(label, args, d))
        .collect();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
