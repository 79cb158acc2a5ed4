//! Runs as a batch job or a user at a terminal sees them: progress in logs, Ctrl-C, a run
//! directory locked while a fit writes it, exit codes, and the messages of everyday mistakes.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..").join(path)
}

fn slipbayes() -> Command {
    Command::new(env!("CARGO_BIN_EXE_slipbayes"))
}

/// The one-contact quick path on the first 5,000 s of the bundled first slide (501 points,
/// the peak and the start of the decay): a fit of seconds, whose R̂ is shown by step 600 (on
/// the first 1,000 s alone the walkers accept 4 % and R̂ is never shown in 3,000 steps).
fn quick_fit(out: &Path) -> Command {
    let mut cmd = slipbayes();
    cmd.arg("fit")
        .arg("--first")
        .arg(repo("data/ptfe-c1-first.csv"))
        .args(["--velocity", "1e-9", "--window-s", "0,5000", "--out"])
        .arg(out);
    cmd
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[cfg(feature = "parquet")]
#[test]
fn a_fit_in_a_batch_job_prints_progress_lines_with_tau_and_r_hat() {
    let dir = tempfile::tempdir().unwrap();
    // stderr is a pipe here, as under nohup or SLURM.
    let out = quick_fit(&dir.path().join("fit"))
        .args(["--max-steps", "3000", "--progress-every", "0.05"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| l.starts_with("progress: "))
        .collect();
    assert!(lines.len() >= 2, "{err}");
    let last = lines.last().unwrap();
    assert!(
        last.contains("/3000 (cap), ") && last.contains("acc 0."),
        "{last}"
    );
    // The stopping rule's checks give τ and R̂; the last line is the step the run stopped at,
    // after the check that stopped it.
    assert!(
        lines
            .iter()
            .any(|l| l.contains("τ_max ") && !l.contains("τ_max ?")),
        "{err}"
    );
    assert!(
        lines
            .iter()
            .any(|l| l.contains("R̂ 1.") || l.contains("R̂ 0.")),
        "{err}"
    );
}

#[cfg(feature = "parquet")]
#[test]
fn quiet_batch_jobs_print_no_progress() {
    let dir = tempfile::tempdir().unwrap();
    let out = quick_fit(&dir.path().join("fit"))
        .args(["--steps", "200", "--progress-every", "0.01", "--quiet"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(!stderr(&out).contains("progress:"), "{}", stderr(&out));
}

#[cfg(all(feature = "parquet", unix))]
#[test]
fn ctrl_c_stops_after_a_checkpoint_and_the_printed_command_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("fit");
    let mut child = quick_fit(&run)
        .args(["--steps", "4000", "--progress-every", "0.05", "--seed", "7"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(child.stderr.take().unwrap()).lines();
    // Interrupted once sampling runs (its first progress line).
    let mut seen = Vec::new();
    for line in lines.by_ref() {
        let line = line.unwrap();
        let sampling = line.starts_with("progress: ");
        seen.push(line);
        if sampling {
            break;
        }
    }
    let status = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    seen.extend(lines.map(Result::unwrap));
    let code = child.wait().unwrap().code();
    let err = seen.join("\n");
    assert_eq!(code, Some(130), "{err}");
    assert!(err.contains("interrupted at step"), "{err}");
    assert!(run.join("checkpoint.bin").exists(), "{err}");
    assert!(!run.join("summary.json").exists(), "{err}");
    // The line after "resume with:" is the command that continues the run.
    let resume = seen
        .iter()
        .skip_while(|l| !l.contains("resume with:"))
        .nth(1)
        .unwrap_or_else(|| panic!("no resume command in:\n{err}"))
        .trim()
        .to_owned();
    assert!(resume.ends_with("--resume"), "{resume}");
    assert!(resume.contains("--steps 4000"), "{resume}");
    let out = Command::new("sh").args(["-c", &resume]).output().unwrap();
    assert!(out.status.success(), "{resume}:\n{}", stderr(&out));
    let summary: serde_json::Value =
        serde_json::from_slice(&std::fs::read(run.join("summary.json")).unwrap()).unwrap();
    assert_eq!(summary["sampler"]["steps"], 4000, "{summary}");
}

#[cfg(feature = "parquet")]
#[test]
fn a_second_fit_into_a_locked_run_directory_names_the_holder() {
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("fit");
    std::fs::create_dir_all(&run).unwrap();
    // A live process holds the lock, as a running fit would.
    let mut holder = Command::new("sleep").arg("60").spawn().unwrap();
    let lock = run.join(slipbayes::fit::run_dir::LOCK_FILE);
    std::fs::write(&lock, format!("{}\nsleep 60\n", holder.id())).unwrap();
    let out = quick_fit(&run)
        .args(["--steps", "200", "--quiet"])
        .output()
        .unwrap();
    holder.kill().unwrap();
    holder.wait().unwrap();
    assert_eq!(out.status.code(), Some(1));
    let err = stderr(&out);
    assert!(
        err.contains(&format!("process {} (`sleep 60`)", holder.id())),
        "{err}"
    );
    assert!(!run.join("chains").exists(), "{err}");
    // Its holder gone, the lock is stale and the next fit takes it over, then releases it.
    let out = quick_fit(&run)
        .args(["--steps", "200", "--quiet"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(!lock.exists());
}

#[cfg(feature = "parquet")]
#[test]
fn strict_not_converged_has_its_own_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    // 40 steps cannot trust a τ of several steps (12.5 τ after the burn-in).
    let out = quick_fit(&dir.path().join("fit"))
        .args(["--steps", "40", "--quiet", "--strict"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    assert!(dir.path().join("fit/summary.json").exists());
    // 2 stays clap's: an invalid command line.
    let out = slipbayes()
        .args(["fit", "--no-such-flag"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let help = slipbayes().arg("--help").output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(
        help.contains("Exit codes:") && help.contains("3 "),
        "{help}"
    );
}

#[test]
fn negative_numbers_are_refused_for_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let out = slipbayes()
        .arg("fit")
        .arg("--first")
        .arg(repo("data/ptfe-c1-first.csv"))
        .args(["--velocity", "-1e-9", "--out"])
        .arg(dir.path().join("fit"))
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(!err.contains("-- -1"), "{err}");
    assert!(
        err.contains("'--velocity <VELOCITY>'") && err.contains("must be a number > 0"),
        "{err}"
    );
    // Where the library judges the value, its reason names the parameter.
    let out = slipbayes()
        .args([
            "simulate", "--scene", "first", "--alpha", "-1", "--a", "6e-3",
        ])
        .args([
            "--f-d",
            "1e-2",
            "--t0",
            "15",
            "--k",
            "1e4",
            "--velocity",
            "1e-9",
        ])
        .args(["--duration", "100", "--interval", "10", "--out"])
        .arg(dir.path().join("s.csv"))
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("alpha") && err.contains("> 0"), "{err}");
}

#[cfg(feature = "parquet")]
#[test]
fn demo_outside_the_repository_says_where_it_looked_and_what_to_do() {
    let dir = tempfile::tempdir().unwrap();
    let out = slipbayes()
        .arg("demo")
        .current_dir(dir.path())
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    let looked = dir.path().canonicalize().unwrap().join("models/demo.toml");
    assert!(err.contains(&looked.display().to_string()), "{err}");
    let bundled = repo("models/demo.toml").canonicalize().unwrap();
    assert!(
        err.contains(&format!("--model {}", bundled.display())),
        "{err}"
    );
}

#[cfg(feature = "report")]
#[test]
fn report_of_a_run_without_its_chains_says_how_to_regenerate_them() {
    // A fresh clone: the committed demo report without its git-ignored chains.
    let dir = tempfile::tempdir().unwrap();
    for file in [
        "settings.json",
        "summary.json",
        "model.toml",
        "predictive.csv",
    ] {
        std::fs::copy(repo("reports/demo").join(file), dir.path().join(file)).unwrap();
    }
    let out = slipbayes().arg("report").arg(dir.path()).output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("chains") && err.contains("missing"), "{err}");
    assert!(err.contains("slipbayes demo"), "{err}");
    // The command names the directory (a `demo` recorded without --out wrote to the default
    // of its day, which is no longer demo's default).
    assert!(err.contains("demo") && err.contains(" --out "), "{err}");
    assert!(!err.contains("no checkpoint"), "{err}");
}

#[test]
fn simulate_says_what_it_wrote_and_does_not_overwrite() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("first.csv");
    let simulate = || {
        let mut cmd = slipbayes();
        cmd.args([
            "simulate", "--scene", "first", "--alpha", "0.92e6", "--a", "6.2e-3",
        ])
        .args([
            "--f-d",
            "10e-3",
            "--t0",
            "14.8",
            "--k",
            "1.2e4",
            "--velocity",
            "1e-9",
        ])
        .args(["--duration", "300", "--interval", "10", "--out"])
        .arg(&csv);
        cmd
    };
    let out = simulate().output().unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    let said = String::from_utf8_lossy(&out.stdout);
    assert!(
        said.contains("wrote 31 points to") && said.contains("first.json"),
        "{said}"
    );
    let before = std::fs::read(&csv).unwrap();
    let out = simulate().args(["--seed", "2"]).output().unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains(&csv.display().to_string()) && err.contains("--overwrite"),
        "{err}"
    );
    assert_eq!(std::fs::read(&csv).unwrap(), before);
    let out = simulate()
        .args(["--seed", "2", "--overwrite"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr(&out));
    assert_ne!(std::fs::read(&csv).unwrap(), before);
}

#[test]
fn an_io_error_prints_its_cause_once() {
    let dir = tempfile::tempdir().unwrap();
    let out = slipbayes()
        .arg("fit")
        .arg(dir.path().join("missing.toml"))
        .arg("--out")
        .arg(dir.path().join("fit"))
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.matches("No such file or directory").count(), 1, "{err}");
}

/// A model file asking for an interval of a table that has none: it used to be ignored and
/// the whole table fitted (exit 0); now nothing is fitted and the message names the model
/// file, the run, the interval asked and what the file holds.
#[cfg(feature = "parquet")]
#[test]
fn an_interval_the_data_do_not_have_is_an_error_naming_the_model_and_run() {
    let dir = tempfile::tempdir().unwrap();
    let model = dir.path().join("m.toml");
    std::fs::write(
        &model,
        format!(
            "[[material]]\nname = \"PTFE\"\n[[contact]]\nname = \"c1\"\nmaterial = \"PTFE\"\n\
             [[run]]\nname = \"c1-first\"\ncontact = \"c1\"\ndata = \"{}\"\n\
             velocity_m_per_s = 1e-9\nscene = \"first\"\ninterval = 4\n",
            repo("data/ptfe-c1-first.csv").display()
        ),
    )
    .unwrap();
    let out = slipbayes()
        .arg("fit")
        .arg(&model)
        .args(["--steps", "100", "--quiet", "--out"])
        .arg(dir.path().join("fit"))
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    for part in [
        &format!("{}: run `c1-first`:", model.display()),
        "no interval 4",
        "csv table of 3001 data rows without intervals",
        "remove `interval`",
    ] {
        assert!(err.contains(part), "`{part}` not in:\n{err}");
    }
    assert!(!dir.path().join("fit/chains").exists(), "{err}");
}

/// `validate` finding miscalibration exits with 4, not clap's 2 for an invalid command line.
#[cfg(feature = "parquet")]
#[test]
fn validate_miscalibrated_has_its_own_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    // No coverage reaches 101 %: two short replications are judged miscalibrated.
    let out = slipbayes()
        .arg("validate")
        .arg("--model")
        .arg(repo("models/sbc.toml"))
        .args([
            "--replications",
            "2",
            "--steps",
            "60",
            "--min-coverage95",
            "1.01",
            "--quiet",
            "--out",
        ])
        .arg(dir.path().join("sbc"))
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(4), "{err}");
    assert!(err.contains("miscalibrated: "), "{err}");
    assert!(dir.path().join("sbc/validation.md").exists(), "{err}");
    for args in [&["--help"][..], &["validate", "--help"]] {
        let help = slipbayes().args(args).output().unwrap();
        let help = String::from_utf8_lossy(&help.stdout);
        assert!(help.contains("4") && help.contains("miscalibrat"), "{help}");
    }
}

/// When no start can be found, the error names the run and contact, the parameter, the value
/// the data give and the prior that excludes it, and what to change in the model file, instead
/// of a vector of log-coordinates; an absurd data value is refused where it is written.
#[cfg(feature = "parquet")]
#[test]
fn no_start_names_the_run_the_parameter_and_the_prior_or_value_at_fault() {
    let dir = tempfile::tempdir().unwrap();
    let model = |priors: &str| {
        let path = dir.path().join("m.toml");
        std::fs::write(
            &path,
            format!(
                "[[material]]\nname = \"PTFE\"\n[[contact]]\nname = \"c1\"\nmaterial = \"PTFE\"\n\
                 [[run]]\nname = \"c1-first\"\ncontact = \"c1\"\ndata = \"{}\"\n\
                 velocity_m_per_s = 1e-9\nscene = \"first\"\n\
                 [[run]]\nname = \"c1-repeat\"\ncontact = \"c1\"\ndata = \"{}\"\n\
                 velocity_m_per_s = 1e-9\nscene = \"repeat\"\n\
                 [priors]\n{priors}\n",
                repo("data/ptfe-c1-first.csv").display(),
                repo("data/ptfe-c1-repeat.csv").display()
            ),
        )
        .unwrap();
        path
    };
    let fit = |model: &Path| {
        slipbayes()
            .arg("fit")
            .arg(model)
            .args(["--steps", "50", "--quiet", "--overwrite", "--out"])
            .arg(dir.path().join("fit"))
            .output()
            .unwrap()
    };
    let check = |err: &str, parts: &[&str]| {
        for part in parts {
            assert!(err.contains(part), "`{part}` not in:\n{err}");
        }
        // No vector of coordinates, no second line repeating the optimiser's error.
        assert!(!err.contains("start [") && !err.contains("mode ["), "{err}");
        assert_eq!(err.trim_end().lines().count(), 1, "{err}");
    };
    // The noise of the data (about 1e-4 N) is what a σ prior of 1e-20 N excludes: the
    // posterior is too narrow to draw walkers in.
    let m = model("sigma = { dist = \"log-uniform\", low = 1e-20, high = 2e-20 }");
    let out = fit(&m);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    check(
        &err,
        &[
            "the noise of run c1-first of contact c1 is about ",
            "log-uniform on [1e-20, 2e-20] N, excludes",
            &format!(
                "in {}, change the prior of `sigma` under `[priors]`",
                m.display()
            ),
        ],
    );
    // A σ sampled explicitly whose prior has no density where the data put it.
    let m = model("sigma = { dist = \"half-normal\", sd = 1e-200 }");
    let out = fit(&m);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    check(
        &err,
        &[
            "sigma[c1-repeat] (run c1-repeat of contact c1) = ",
            "is outside its prior, half-normal(sd 1e-200) N (the data say about ",
            "change the prior of `sigma`",
        ],
    );
    // A force of 1e308 N in the data: refused at its line and column.
    let text = std::fs::read_to_string(repo("data/ptfe-c1-first.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_owned).collect();
    let mut cells: Vec<&str> = lines[10].split(',').collect();
    cells[1] = "1e308";
    lines[10] = cells.join(",");
    let huge = dir.path().join("huge.csv");
    std::fs::write(&huge, lines.join("\n")).unwrap();
    let out = slipbayes()
        .arg("fit")
        .arg("--first")
        .arg(&huge)
        .args(["--velocity", "1e-9", "--quiet", "--out"])
        .arg(dir.path().join("huge"))
        .output()
        .unwrap();
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(1), "{err}");
    check(
        &err,
        &[
            &format!("{}:11:2: column `force_N` (force): 1e308", huge.display()),
            "beyond ±1e100",
        ],
    );
}
