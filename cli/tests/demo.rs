//! The README's first command: `slipbayes demo` writes the committed `reports/demo/`, and
//! `slipbayes report DIR` rebuilds a report from a run directory.
#![cfg(feature = "report")]

use std::fs;
use std::path::Path;
use std::process::Command;

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

fn figures_linked(md: &str) -> Vec<String> {
    md.lines()
        .filter_map(|l| l.strip_prefix("!["))
        .filter_map(|l| l.split("](figures/").nth(1))
        .map(|l| l.trim_end_matches(')').to_owned())
        .collect()
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
    // `slipbayes report` rebuilds the same report from the run directory alone.
    for file in ["report.html", "report.md"] {
        fs::remove_file(fresh.join(file)).unwrap();
    }
    let stdout = run_ok(slipbayes().arg("report").arg(&fresh));
    assert!(stdout.contains("report.html"), "{stdout}");
    assert_eq!(md, fs::read_to_string(fresh.join("report.md")).unwrap());
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

#[test]
fn report_of_a_directory_without_a_run_fails_naming_the_file() {
    let tmp = tempfile::tempdir().unwrap();
    let out = slipbayes().arg("report").arg(tmp.path()).output().unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("settings.json"), "{err}");
}
