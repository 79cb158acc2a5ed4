//! The README's first command: `slipbayes demo`, run in a fresh copy of the repository,
//! writes `runs/demo/` and leaves the copy clean; what it writes is the committed example
//! report `reports/demo/`; `slipbayes report DIR` rebuilds a report from a run directory.
#![cfg(feature = "report")]

use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn slipbayes() -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_slipbayes"));
    cmd.current_dir(repo_root());
    cmd
}

fn git(dir: &Path, args: &[&str]) -> String {
    let out = Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(args)
        .output()
        .expect("git runs (the demo test checks a copy of the repository with it)");
    assert!(
        out.status.success(),
        "git {args:?} in {}: {}",
        dir.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// A fresh clone, as far as the demo can tell: the repository's tracked files that it reads
/// or that it might overwrite (`.gitignore`, `models/`, `data/`, `reports/demo/`) copied into
/// `dir`, there committed to a new git repository.
fn fresh_clone(dir: &Path) {
    let root = repo_root();
    let tracked = git(
        &root,
        &[
            "ls-files",
            "--",
            ".gitignore",
            "models",
            "data",
            "reports/demo",
        ],
    );
    for file in tracked.lines() {
        let to = dir.join(file);
        fs::create_dir_all(to.parent().unwrap()).unwrap();
        fs::copy(root.join(file), &to).unwrap();
    }
    git(dir, &["init", "--quiet"]);
    git(dir, &["add", "--all"]);
    git(
        dir,
        &[
            "-c",
            "user.name=slipbayes test",
            "-c",
            "user.email=test@slipbayes.invalid",
            "commit",
            "--quiet",
            "--no-gpg-sign",
            "--no-verify",
            "-m",
            "fresh clone",
        ],
    );
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

/// The README's main command, `slipbayes demo` from the root of a fresh clone, writes
/// `runs/demo/` and leaves the clone clean (it used to rewrite the tracked `reports/demo/`).
/// What it writes must be the committed `reports/demo/`: every deterministic output is
/// compared, byte for byte (the demo runs once, about a minute).
#[test]
fn demo_leaves_a_fresh_clone_clean_and_the_committed_report_is_current() {
    let committed = repo_root().join("reports/demo");
    let clone = tempfile::tempdir().unwrap();
    fresh_clone(clone.path());
    let out = Command::new(env!("CARGO_BIN_EXE_slipbayes"))
        .args(["demo", "--quiet"])
        .current_dir(clone.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "demo failed:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let fresh = clone.path().join("runs/demo");
    assert!(
        String::from_utf8_lossy(&out.stdout)
            .contains(&format!("written to {}", Path::new("runs/demo").display())),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let status = git(
        clone.path(),
        &["status", "--porcelain", "--untracked-files=all"],
    );
    assert!(
        status.is_empty(),
        "`slipbayes demo` left the clone dirty:\n{status}"
    );
    let stale = |file: &str| {
        format!(
            "reports/demo/{file} is stale: regenerate the committed report with \
             `cargo run --release -- demo --out reports/demo`"
        )
    };
    for file in [
        "summary.csv",
        "predictive.csv",
        "model.toml",
        "curves.json",
        "truth.json",
    ] {
        assert_eq!(
            fs::read_to_string(committed.join(file)).unwrap(),
            fs::read_to_string(fresh.join(file)).unwrap(),
            "{}",
            stale(file)
        );
    }
    for file in ["report.md", "report.html"] {
        let (a, b) = (
            fs::read_to_string(committed.join(file)).unwrap(),
            fs::read_to_string(fresh.join(file)).unwrap(),
        );
        assert!(deterministic(&a) == deterministic(&b), "{}", stale(file));
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
            "{}",
            stale(&format!("figures/{file}"))
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
