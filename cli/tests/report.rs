//! Reports end to end: a real (short) fit writes report.html, report.md and figures;
//! `slipbayes report DIR` rebuilds them identically; the optional data provenance is rendered;
//! and the committed `reports/demo/` is what the current code produces on the bundled data.
#![cfg(feature = "report")]

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;

fn slipbayes() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_slipbayes"));
    cmd.current_dir(Path::new(env!("CARGO_MANIFEST_DIR")).join(".."));
    cmd
}

fn run_ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("slipbayes runs");
    assert!(
        out.status.success(),
        "{cmd:?} failed:\n{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// One short quick-path fit shared by the tests of this file (a fit costs seconds).
fn quick_fit() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = tempfile::tempdir().expect("temp dir");
        let out = dir.path().join("run");
        run_ok(
            slipbayes()
                .args([
                    "fit",
                    "--first",
                    "data/ptfe-c1-first.csv",
                    "--repeat",
                    "data/ptfe-c1-repeat.csv",
                    "--velocity",
                    "1e-9",
                    "--normal-force",
                    "0.05",
                    "--steps",
                    "160",
                    "--quiet",
                    "--out",
                ])
                .arg(&out),
        );
        dir
    })
    .path()
}

fn run_dir() -> PathBuf {
    quick_fit().join("run")
}

fn copy_dir(from: &Path, to: &Path) {
    fs::create_dir_all(to).unwrap();
    for entry in fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let target = to.join(entry.file_name());
        if entry.file_type().unwrap().is_dir() {
            copy_dir(&entry.path(), &target);
        } else {
            fs::copy(entry.path(), target).unwrap();
        }
    }
}

fn figures_linked(md: &str) -> Vec<String> {
    md.lines()
        .filter_map(|l| l.strip_prefix("!["))
        .filter_map(|l| l.split("](figures/").nth(1))
        .map(|l| l.trim_end_matches(')').to_owned())
        .collect()
}

#[test]
fn a_fit_writes_a_complete_self_contained_report() {
    let dir = run_dir();
    let html = fs::read_to_string(dir.join("report.html")).unwrap();
    let md = fs::read_to_string(dir.join("report.md")).unwrap();

    // Every figure the issue asks for, as a file linked from the Markdown and inline in HTML.
    let linked = figures_linked(&md);
    for expected in [
        "fit-first.svg",
        "fit-repeat.svg",
        "distance-contact.svg",
        "peak-density.svg",
        "peak-t0.svg",
        "forest.svg",
        "trace-1.svg",
        "corner-material.svg",
    ] {
        assert!(
            linked.iter().any(|f| f == expected),
            "{expected} not in {linked:?}"
        );
    }
    for file in &linked {
        let svg = fs::read_to_string(dir.join("figures").join(file)).unwrap();
        assert!(svg.starts_with("<svg"), "{file} is not SVG");
        // Inline in the HTML, byte for byte.
        assert!(html.contains(&svg), "{file} is not inline in report.html");
    }
    assert_eq!(html.matches("<figure id=\"fig-").count(), linked.len());

    // Self-contained: no scripts, no links or sources outside the page.
    assert!(!html.contains("<script"));
    assert!(!html.contains("src="));
    for href in html.split("href=\"").skip(1) {
        assert!(
            href.starts_with('#'),
            "external link {}",
            &href[..40.min(href.len())]
        );
    }

    // Axis labels carry units users think in.
    let fit = fs::read_to_string(dir.join("figures/fit-first.svg")).unwrap();
    for label in [
        "instrument time t (s)",
        "friction force F (mN)",
        "interface time τ = t − F/(kv) (s)",
        "95 % predictive",
        "50 % predictive",
        "posterior median",
    ] {
        assert!(fit.contains(label), "fit-first.svg lacks {label:?}");
    }
    let distance = fs::read_to_string(dir.join("figures/distance-contact.svg")).unwrap();
    assert!(distance.contains("sliding distance x = vτ (µm)"));
    let t0 = fs::read_to_string(dir.join("figures/peak-t0.svg")).unwrap();
    assert!(t0.contains("peak static friction F_peak (mN)"));

    // The answers at a glance, the provenance, the tables.
    for text in [
        "## At a glance",
        "inside the 95 % predictive band",
        "F_peak[first] = ",
        "- command: ",
        "- seed: 1",
        "- slipbayes version: ",
        "## Diagnostics",
        "| quantity | R̂ | ESS bulk | ESS tail | MCSE mean | τ (kept draws) |",
        "| quantity | unit | mean | sd | hdi_2.5% | hdi_97.5% | mcse_mean | mcse_sd | ess_bulk | ess_tail | r_hat |",
        "μ_s = F_peak/F_N",
    ] {
        assert!(md.contains(text), "report.md lacks {text:?}");
    }
    // α in µm⁻¹ (0.92 in the bundled data), not in 1/m.
    assert!(
        md.lines()
            .any(|l| l.contains("α[contact]") && l.contains("| µm⁻¹ | 0.9")),
        "no summary row of α in µm⁻¹"
    );
    // 160 steps cannot converge: the verdict says so at the top, before any figure.
    let warning = md.find("> **WARNING: ").expect("a warning verdict");
    assert!(warning < md.find("![").unwrap());
    // The quick path records how each file was read.
    let data = &md[md.find("## Data\n").expect("a Data section")..];
    assert!(
        data.contains("ptfe-c1-first.csv | csv | 3001 | 3001 | 0 |"),
        "{data}"
    );
}

#[test]
fn report_command_rebuilds_the_same_report() {
    let tmp = tempfile::tempdir().unwrap();
    let copy = tmp.path().join("moved-run");
    copy_dir(&run_dir(), &copy);
    for f in ["report.html", "report.md"] {
        fs::remove_file(copy.join(f)).unwrap();
    }
    fs::remove_dir_all(copy.join("figures")).unwrap();
    let stdout = run_ok(slipbayes().arg("report").arg(&copy));
    assert!(stdout.contains("report.html"), "{stdout}");
    // The title names the run directory; everything else is the same, byte for byte.
    let original = fs::read_to_string(run_dir().join("report.md")).unwrap();
    let rebuilt = fs::read_to_string(copy.join("report.md")).unwrap();
    assert_eq!(
        original.replace("slipbayes report: run", "slipbayes report: moved-run"),
        rebuilt
    );
    for file in figures_linked(&original) {
        assert_eq!(
            fs::read(run_dir().join("figures").join(&file)).unwrap(),
            fs::read(copy.join("figures").join(&file)).unwrap(),
            "{file} differs"
        );
    }
}

#[test]
fn data_provenance_is_rendered_when_present() {
    let tmp = tempfile::tempdir().unwrap();
    let copy = tmp.path().join("run");
    copy_dir(&run_dir(), &copy);
    let path = copy.join("summary.json");
    let mut summary: serde_json::Value =
        serde_json::from_str(&fs::read_to_string(&path).unwrap()).unwrap();
    summary["data"] = serde_json::json!([
        {"run": "first", "file": "data/ptfe-c1-first.txt", "format": "rheocompass",
         "points_read": 3012, "points_used": 3000, "dropped_invalid": 12,
         "window_s": [0.0, 30000.0], "binning": {"bins": 429, "points_per_bin": 6.99},
         "conversions": ["torque mN·m / 7 mm → force N", "decimal commas"]},
        {"run": "repeat", "file": "data/ptfe-c1-repeat.csv", "format": "csv",
         "points_read": 358, "points_used": 358, "dropped_invalid": 0,
         "window_s": null, "binning": null, "conversions": []}
    ]);
    fs::write(&path, serde_json::to_string_pretty(&summary).unwrap()).unwrap();
    run_ok(slipbayes().arg("report").arg(&copy));
    let md = fs::read_to_string(copy.join("report.md")).unwrap();
    assert!(md.contains("## Data\n"), "{md}");
    assert!(md.contains(
        "| **first** ⚠ | data/ptfe-c1-first.txt | rheocompass | 3012 | 3000 | 12 | 0 – 30000 s | 429 bins of 6.99 points | torque mN·m / 7 mm → force N; decimal commas |"
    ), "{md}");
    assert!(md.contains(
        "| repeat | data/ptfe-c1-repeat.csv | csv | 358 | 358 | 0 | all | none | none |"
    ));
    let html = fs::read_to_string(copy.join("report.html")).unwrap();
    assert!(html.contains("<h2 id=\"data\">Data</h2>"));

    // A malformed fragment is an error naming the file and the key.
    summary["data"] = serde_json::json!([{"run": 3}]);
    fs::write(&path, serde_json::to_string(&summary).unwrap()).unwrap();
    let out = slipbayes().arg("report").arg(&copy).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    // `data` is part of the summary's schema: the error names the file and the position.
    assert!(
        err.contains("summary.json") && err.contains("line 1, column"),
        "{err}"
    );
}

#[test]
fn report_of_a_directory_without_a_run_says_what_is_missing() {
    let tmp = tempfile::tempdir().unwrap();
    let out = slipbayes().arg("report").arg(tmp.path()).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("settings.json") && err.contains("finished run directory"),
        "{err}"
    );
}

/// Lines of a report that change between identical fits: the command line and the wall time.
fn deterministic(text: &str) -> String {
    text.lines()
        .map(|l| {
            let mut l = l.to_owned();
            for key in ["command: ", "wall time: "] {
                // In Markdown a whole list line; in HTML one <li> of a longer line.
                while let Some(start) = l.find(key) {
                    let end = l[start..].find("</li>").map_or(l.len(), |e| start + e);
                    l.replace_range(start..end, "");
                }
            }
            l
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The committed `reports/demo/` must be what `slipbayes demo` produces now: the demo is run
/// again (about 2 minutes) and every deterministic output compared, byte for byte.
#[test]
fn committed_demo_report_is_current() {
    let committed = Path::new(env!("CARGO_MANIFEST_DIR")).join("../reports/demo");
    let tmp = tempfile::tempdir().unwrap();
    let fresh = tmp.path().join("demo");
    run_ok(slipbayes().args(["demo", "--quiet", "--out"]).arg(&fresh));
    for file in ["summary.csv", "predictive.csv", "model.toml"] {
        assert_eq!(
            fs::read_to_string(committed.join(file)).unwrap(),
            fs::read_to_string(fresh.join(file)).unwrap(),
            "reports/demo/{file} is stale: regenerate with `cargo run --release -- demo`"
        );
    }
    for file in ["report.md", "report.html"] {
        let (a, b) = (
            fs::read_to_string(committed.join(file)).unwrap(),
            fs::read_to_string(fresh.join(file)).unwrap(),
        );
        assert!(
            deterministic(&a) == deterministic(&b),
            "reports/demo/{file} is stale: regenerate with `cargo run --release -- demo`"
        );
    }
    let md = fs::read_to_string(fresh.join("report.md")).unwrap();
    let linked = figures_linked(&md);
    assert!(linked.len() >= 20, "{linked:?}");
    let mut committed_figures: Vec<String> = fs::read_dir(committed.join("figures"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    committed_figures.sort();
    let mut fresh_figures = linked.clone();
    fresh_figures.sort();
    assert_eq!(
        committed_figures, fresh_figures,
        "figures/ holds stale files"
    );
    for file in linked {
        assert!(
            fs::read(committed.join("figures").join(&file)).unwrap()
                == fs::read(fresh.join("figures").join(&file)).unwrap(),
            "reports/demo/figures/{file} is stale: regenerate with `cargo run --release -- demo`"
        );
    }
}
