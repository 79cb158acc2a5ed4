#![cfg(feature = "report")]

//! A run directory is recognisably ours: every command that writes a directory or a set of
//! files writes only into one that is new, empty or marked as slipbayes', refuses any other
//! naming the files it would replace, and with --overwrite replaces only its own files.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use slipbayes::output_dir::MARKER;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

fn slipbayes() -> Command {
    Command::new(env!("CARGO_BIN_EXE_slipbayes"))
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// The one-contact quick path on the first 5,000 s of the bundled first slide: a fit of a
/// second or two at 200 steps.
fn quick_fit(out: &Path) -> Command {
    let mut cmd = slipbayes();
    cmd.arg("fit")
        .arg("--first")
        .arg(repo("data/ptfe-c1-first.csv"))
        .args(["--velocity", "1e-9", "--window-s", "0,5000", "--quiet"])
        .arg("--out")
        .arg(out);
    cmd
}

/// A paper's folder: the user's own `summary.json` and `report.html` (names a fit writes) and
/// `notes.txt` (a name it does not).
fn users_folder(dir: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    for name in ["summary.json", "report.html", "notes.txt"] {
        std::fs::write(dir.join(name), format!("the user's {name}")).unwrap();
    }
}

fn assert_untouched(dir: &Path, names: &[&str]) {
    for name in names {
        assert_eq!(
            std::fs::read_to_string(dir.join(name)).unwrap(),
            format!("the user's {name}"),
            "{name}"
        );
    }
}

/// The refusal names the directory and the files it would have replaced, and says what to do;
/// exit status 1, the command line's status of an error in what it was given.
fn assert_refused(out: &Output, dir: &Path, replaced: &[&str]) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains(&dir.display().to_string()), "{err}");
    for name in replaced {
        assert!(err.contains(name), "{name} not named in: {err}");
    }
    assert!(
        err.contains("--overwrite") && err.contains("another --out"),
        "{err}"
    );
}

#[test]
fn fit_into_a_folder_of_the_users_refuses_and_overwrite_replaces_only_its_own_files() {
    let tmp = tempfile::tempdir().unwrap();
    let paper = tmp.path().join("paper");
    users_folder(&paper);
    let out = quick_fit(&paper).args(["--steps", "200"]).output().unwrap();
    assert_refused(&out, &paper, &["summary.json", "report.html"]);
    assert_untouched(&paper, &["summary.json", "report.html", "notes.txt"]);
    assert!(!paper.join("chains").exists() && !paper.join(MARKER).exists());

    let out = quick_fit(&paper)
        .args(["--steps", "200", "--overwrite"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert_untouched(&paper, &["notes.txt"]);
    assert_ne!(
        std::fs::read_to_string(paper.join("summary.json")).unwrap(),
        "the user's summary.json"
    );
    assert!(paper.join(MARKER).is_file());
    // Now ours: fitting again is refused as an earlier run (not as a foreign directory), and
    // `report` rewrites its report.
    let out = quick_fit(&paper).args(["--steps", "200"]).output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("already holds a completed run"), "{err}");
    let out = slipbayes().arg("report").arg(&paper).output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert_untouched(&paper, &["notes.txt"]);
}

#[test]
fn a_run_written_before_markers_is_resumed_and_reported() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    // A killed fit of a release that wrote no marker: an unfinished run (its checkpoint and
    // chains) and nothing else of ours.
    let mut child = quick_fit(&run)
        .args(["--steps", "4000", "--seed", "3"])
        .spawn()
        .unwrap();
    let started = std::time::Instant::now();
    while !run.join("checkpoint.bin").exists() {
        assert!(started.elapsed().as_secs() < 120, "no checkpoint written");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    std::fs::remove_file(run.join(MARKER)).unwrap();
    let out = quick_fit(&run)
        .args(["--steps", "4000", "--seed", "3", "--resume"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(run.join(MARKER).is_file());
    // A finished run of that release: its report is rebuilt.
    std::fs::remove_file(run.join(MARKER)).unwrap();
    let out = slipbayes().arg("report").arg(&run).output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
}

#[test]
fn demo_into_a_folder_of_the_users_refuses() {
    let tmp = tempfile::tempdir().unwrap();
    let paper = tmp.path().join("paper");
    users_folder(&paper);
    let out = slipbayes()
        .arg("demo")
        .arg("--model")
        .arg(repo("models/demo.toml"))
        .arg("--out")
        .arg(&paper)
        .args(["--steps", "100", "--quiet"])
        .output()
        .unwrap();
    assert_refused(&out, &paper, &["summary.json", "report.html"]);
    assert_untouched(&paper, &["summary.json", "report.html", "notes.txt"]);
}

#[test]
fn report_of_a_folder_of_the_users_refuses() {
    let tmp = tempfile::tempdir().unwrap();
    users_folder(tmp.path());
    let out = slipbayes().arg("report").arg(tmp.path()).output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&tmp.path().display().to_string())
            && err.contains("not a run directory slipbayes wrote"),
        "{err}"
    );
    assert_untouched(tmp.path(), &["summary.json", "report.html", "notes.txt"]);
}

#[test]
fn validate_into_a_folder_of_the_users_refuses() {
    let tmp = tempfile::tempdir().unwrap();
    let paper = tmp.path().join("paper");
    std::fs::create_dir_all(&paper).unwrap();
    for name in ["validation.md", "notes.txt"] {
        std::fs::write(paper.join(name), format!("the user's {name}")).unwrap();
    }
    let out = slipbayes()
        .arg("validate")
        .arg("--model")
        .arg(repo("models/sbc.toml"))
        .arg("--out")
        .arg(&paper)
        .args(["--replications", "1", "--quiet"])
        .output()
        .unwrap();
    assert_refused(&out, &paper, &["validation.md"]);
    assert_untouched(&paper, &["validation.md", "notes.txt"]);
    // A run directory of a fit is not a validation's either.
    let run = tmp.path().join("run");
    let out = quick_fit(&run).args(["--steps", "200"]).output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let out = slipbayes()
        .arg("validate")
        .arg("--model")
        .arg(repo("models/sbc.toml"))
        .arg("--out")
        .arg(&run)
        .args(["--replications", "1", "--quiet"])
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("marks it as a slipbayes run directory"),
        "{err}"
    );
}

#[test]
fn import_does_not_replace_an_existing_file_without_overwrite() {
    let tmp = tempfile::tempdir().unwrap();
    let csv = tmp.path().join("slide.csv");
    std::fs::write(&csv, "the user's slide.csv").unwrap();
    let import = || {
        let mut cmd = slipbayes();
        cmd.arg("import")
            .arg(repo("data/ptfe-c1-first.csv"))
            .arg("--out")
            .arg(&csv);
        cmd
    };
    let out = import().output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&csv.display().to_string()) && err.contains("--overwrite"),
        "{err}"
    );
    assert_eq!(
        std::fs::read_to_string(&csv).unwrap(),
        "the user's slide.csv"
    );
    let out = import().arg("--overwrite").output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(std::fs::read_to_string(&csv)
        .unwrap()
        .starts_with("time_s,force_N"));
}
