//! `slipbayes watch` on a slide replayed in real time: the bundled PTFE first slide (30,000 s
//! of record, its peak near 2,340 s) written into an export at 1000× speed, in bursts, each
//! burst's last row written in two halves, while `watch` follows it until the peak is inside
//! the record. Then the directory holds what it promises: a complete `latest/` refit with its
//! report, a forecast from the end of the record, one history row per refit, and each refit
//! after a converged one warm-started from it.

#![cfg(all(unix, feature = "report"))]

use std::fs::{self, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::Duration;

/// Instrument seconds per wall second.
const SPEED: f64 = 1000.0;
/// Rows per burst (10 s apart in the record: 100 instrument seconds, 0.1 s of replay).
const BURST: usize = 10;

fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// Writes the rows of `source` into `export` at [`SPEED`], until done or `stop` is set.
fn replay(source: &Path, export: &Path, stop: &AtomicBool) {
    let text = fs::read_to_string(source).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let rows: Vec<&str> = lines.collect();
    let mut file = OpenOptions::new()
        .create(true)
        .append(true)
        .open(export)
        .unwrap();
    writeln!(file, "{header}").unwrap();
    for burst in rows.chunks(BURST) {
        if stop.load(Ordering::SeqCst) {
            return;
        }
        let (last, complete) = burst.split_last().unwrap();
        for row in complete {
            writeln!(file, "{row}").unwrap();
        }
        // The burst's last row in two halves, as a writer caught mid-row leaves it.
        let half = last.len() / 2;
        write!(file, "{}", &last[..half]).unwrap();
        file.flush().unwrap();
        thread::sleep(Duration::from_secs_f64(10.0 * BURST as f64 / SPEED / 2.0));
        writeln!(file, "{}", &last[half..]).unwrap();
        file.flush().unwrap();
        thread::sleep(Duration::from_secs_f64(10.0 * BURST as f64 / SPEED / 2.0));
    }
}

fn column(header: &str, name: &str) -> usize {
    header.split(',').position(|c| c == name).unwrap()
}

#[test]
fn watch_follows_a_replayed_slide_until_its_peak_is_in_the_record() {
    let dir = tempfile::tempdir().unwrap();
    let export = dir.path().join("export.csv");
    let out = dir.path().join("live");
    let stop = Arc::new(AtomicBool::new(false));
    let writer = {
        let (stop, export) = (stop.clone(), export.clone());
        thread::spawn(move || replay(&repo().join("data/ptfe-c1-first.csv"), &export, &stop))
    };
    let output = Command::new(env!("CARGO_BIN_EXE_slipbayes"))
        .args([
            "watch",
            export.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .args([
            "--velocity",
            "1e-9",
            "--until-peak-observed",
            "--idle-s",
            "20",
        ])
        .args(["--poll-s", "0.2", "--seed", "5"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .output()
        .unwrap();
    stop.store(true, Ordering::SeqCst);
    writer.join().unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr),
    );
    assert!(
        output.status.success(),
        "watch failed ({:?}):\n{stdout}\n{stderr}",
        output.status
    );
    assert!(stdout.contains("criterion met"), "{stdout}\n{stderr}");

    // One history row per refit; the last meets the criterion, past the true peak.
    let history = fs::read_to_string(out.join("watch.csv")).unwrap();
    let mut lines = history.lines();
    let header = lines.next().unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    assert!(
        rows.len() >= 2,
        "at least a refit before the peak and one after:\n{history}"
    );
    let value = |row: &[&str], name: &str| -> f64 { row[column(header, name)].parse().unwrap() };
    let last = rows.last().unwrap();
    assert!(value(last, "p_peak_in_record") >= 0.95, "{history}");
    assert!(value(last, "record_end_s") > 2_300.0, "{history}");
    assert_eq!(last[column(header, "converged")], "true");
    let ends: Vec<f64> = rows.iter().map(|r| value(r, "record_end_s")).collect();
    assert!(
        ends.windows(2).all(|w| w[0] < w[1]),
        "each refit sees more rows: {ends:?}"
    );
    // A refit after a converged one starts from its posterior (after one that did not
    // converge, the start may be refused: its medians can lie where the longer record has no
    // quasi-static solution).
    for pair in rows.windows(2) {
        if pair[0][column(header, "converged")] == "true" {
            assert_eq!(pair[1][column(header, "warm_start")], "true", "{history}");
        }
    }
    // The simulation's F_peak (data/ptfe-c1-first.json) within about 4 posterior sd of the
    // median: the record at the stop depends on timing, so a 95 % interval would miss it in
    // one run of twenty.
    let truth = 0.019_750_769_463_131_618;
    let (low, high) = (value(last, "F_peak_low_N"), value(last, "F_peak_high_N"));
    let median = value(last, "F_peak_N");
    assert!(
        (median - truth).abs() <= high - low,
        "F_peak {median} [{low}, {high}]"
    );

    // `latest` is a complete run directory with its report; older refits are pruned.
    let latest = out.join("latest");
    for file in [
        "summary.json",
        "report.html",
        "predictive.csv",
        "settings.json",
    ] {
        assert!(latest.join(file).is_file(), "latest/{file} missing");
    }
    assert!(fs::read_dir(out.join("refits")).unwrap().count() <= 2);

    // The forecast starts at the end of the record and spans the horizon.
    let forecast = fs::read_to_string(out.join("forecast.csv")).unwrap();
    let times: Vec<f64> = forecast
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert_eq!(times.len(), 200);
    assert_eq!(times[0], value(last, "record_end_s"));
    assert!(times[199] >= 2.0 * times[0]);
}
