//! Faults at any instant: a fit killed (SIGKILL) at 100 instants spread over its whole life, a
//! fit whose disk fills up, and a fit whose output directory turns read-only. After each fault
//! no file of the run directory is half written (every file is absent, a complete earlier
//! version or the complete final one, and nothing a reader would take for a file of the run is
//! a temporary), and `--resume` takes the directory over and ends with the chains of an
//! uninterrupted run, bit for bit, and its summaries.
//!
//! The disk tests mount small tmpfs file systems, which needs root (as CI runs): without it
//! they fail, saying so, rather than pass without testing anything.
//!
//! Counts are printed (`cargo test --release -p slipbayes-cli --test faults -- --nocapture`).

#![cfg(all(unix, feature = "report"))]

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde_json::Value;

use slipbayes::fit::run_dir::{
    CHAINS_DIR, CHECKPOINT, CSV_COLUMNS, CURVES_JSON, FIGURES_DIR, LOCK_FILE, LOO_CSV, MODEL_TOML,
    PREDICTIVE_CSV, REPORT_HTML, REPORT_MD, SETTINGS_JSON, SUMMARY_CSV, SUMMARY_JSON, TRUTH_JSON,
};
use slipbayes::fit::RunDir;
use slipbayes::output_dir::MARKER;
use slipbayes::sampler::SamplerState;
use slipbayes::storage::{read_chains, Chains, ParquetSink};

/// Steps of the test fit, and its checkpoint interval: twenty checkpoints in a second's run.
const STEPS: u64 = 200;
const CHECKPOINT_EVERY: u64 = 10;
/// Kills, and how many run at once (the machine's two cores).
const KILLS: usize = 100;
const AT_ONCE: usize = 2;
/// Sizes of the disks that fill up, spread from one part to nine tenths of the run, and the
/// fits whose directory turns read-only while they write.
const DISK_SIZES: u64 = 12;
const READ_ONLY_FITS: usize = 4;

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(path)
        .canonicalize()
        .expect("a file of the repository")
}

/// A one-contact model of the bundled first slide's first 5,000 s (501 points), 16 walkers ×
/// 4 ensembles, a fixed number of steps: every phase of a fit (start, sampling, checkpoints,
/// summaries, report) in about a second.
fn write_model(dir: &Path) -> PathBuf {
    let data = repo("data/ptfe-c1-first.csv");
    let path = dir.join("model.toml");
    fs::write(
        &path,
        format!(
            r#"[[material]]
name = "PTFE"

[[contact]]
name = "c1"
material = "PTFE"

[[run]]
name = "c1-first"
contact = "c1"
data = "{}"
velocity_m_per_s = 1e-9
scene = "first"
window_s = [0.0, 5000.0]

[sampler]
walkers = 16
steps = {STEPS}
checkpoint_every = {CHECKPOINT_EVERY}
seed = 7
"#,
            data.display()
        ),
    )
    .expect("write the model");
    path
}

fn fit(model: &Path, out: &Path, resume: bool) -> Command {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_slipbayes"));
    cmd.arg("fit")
        .arg(model)
        .arg("--out")
        .arg(out)
        .arg("--quiet")
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    if resume {
        cmd.arg("--resume");
    }
    cmd
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// An uninterrupted run: its chains, summary (less what describes one invocation), the bytes
/// of the files that do not depend on where or when it ran, and the names of its files.
struct Reference {
    chains: Chains,
    summary: Value,
    fixed: BTreeMap<String, Vec<u8>>,
    names: BTreeSet<String>,
}

impl Reference {
    /// Two uninterrupted runs at once (as the kills run), which must agree; the files equal in
    /// both are what every run must write byte for byte.
    fn new(model: &Path, tmp: &Path) -> (Self, Timeline) {
        let (a, b) = (tmp.join("reference-a"), tmp.join("reference-b"));
        let other = fit(model, &b, false).spawn().expect("spawn");
        let timeline = Timeline::watch(fit(model, &a, false), &a);
        let out = other.wait_with_output().expect("wait");
        assert!(out.status.success(), "{}", stderr(&out));
        let reference = Self {
            chains: read_chains(&a.join(CHAINS_DIR)).expect("the reference chains"),
            summary: summary_of(&a),
            fixed: BTreeMap::new(),
            names: files_of(&a).into_keys().collect(),
        };
        reference.check_resumed(&b, "a second uninterrupted run");
        let (files_a, files_b) = (files_of(&a), files_of(&b));
        let fixed = files_a
            .into_iter()
            .filter(|(name, bytes)| files_b.get(name) == Some(bytes))
            .collect::<BTreeMap<_, _>>();
        for name in [
            PREDICTIVE_CSV,
            CURVES_JSON,
            LOO_CSV,
            SUMMARY_CSV,
            CHECKPOINT,
        ] {
            assert!(fixed.contains_key(name), "{name} differs between two runs");
        }
        (Self { fixed, ..reference }, timeline)
    }

    /// What a finished run (fresh or resumed) must hold: the chains bit for bit, the summary,
    /// every file of the reference and nothing else (no temporary, no lock).
    fn check_resumed(&self, dir: &Path, what: &str) {
        let chains = read_chains(&dir.join(CHAINS_DIR)).expect("the chains");
        assert!(
            same_bits(&self.chains, &chains, self.chains.len()),
            "{what}: the chains differ from an uninterrupted run's"
        );
        assert_eq!(chains.len(), self.chains.len(), "{what}");
        assert_eq!(
            summary_of(dir),
            self.summary,
            "{what}: summary.json differs"
        );
        let files = files_of(dir);
        let names: BTreeSet<String> = files.keys().cloned().collect();
        assert_eq!(names, self.names, "{what}: other files than a run's");
        for (name, bytes) in &self.fixed {
            assert!(&files[name] == bytes, "{what}: {name} differs");
        }
    }
}

/// Whether a fit writes the file `name` more than once (each time whole): the checkpoint at
/// every checkpoint, the summaries before and after PSIS-LOO.
fn rewritten(name: &str) -> bool {
    [CHECKPOINT, SUMMARY_JSON, SUMMARY_CSV].contains(&name)
}

/// Every file under `dir` by its path relative to it, with its bytes (none when `dir` does not
/// exist: a fit killed before it made it).
fn files_of(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    let mut files = BTreeMap::new();
    if !dir.exists() {
        return files;
    }
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in fs::read_dir(&d).expect("list") {
            let path = entry.expect("entry").path();
            if path.is_dir() {
                stack.push(path);
            } else {
                let name = path
                    .strip_prefix(dir)
                    .expect("inside")
                    .display()
                    .to_string();
                files.insert(name, fs::read(&path).expect("read"));
            }
        }
    }
    files
}

/// `summary.json` without what describes one invocation (its wall time, the steps it ran) and
/// its checksum, which covers them.
fn summary_of(dir: &Path) -> Value {
    let mut v: Value =
        serde_json::from_slice(&fs::read(dir.join(SUMMARY_JSON)).expect("summary.json"))
            .expect("summary.json parses");
    v.as_object_mut().expect("an object").remove("checksum");
    let sampler = v["sampler"].as_object_mut().expect("sampler");
    sampler.remove("wall_s");
    sampler.remove("steps_run");
    v
}

/// Whether the first `rows` rows of two chain tables agree bit for bit (indices and every
/// column).
fn same_bits(a: &Chains, b: &Chains, rows: usize) -> bool {
    let bits = |v: &[f64]| v[..rows].iter().map(|x| x.to_bits()).collect::<Vec<u64>>();
    a.len() >= rows
        && b.len() >= rows
        && a.column_names() == b.column_names()
        && a.ensemble[..rows] == b.ensemble[..rows]
        && a.walker[..rows] == b.walker[..rows]
        && a.step[..rows] == b.step[..rows]
        && a.columns
            .iter()
            .zip(&b.columns)
            .all(|(x, y)| bits(x) == bits(y))
}

/// When, in an uninterrupted run, each phase begins (from the spawn): the first checkpoint,
/// the summaries (once the last part is written), the report (once PSIS-LOO, the last of the
/// run files, is written), and the exit.
#[derive(Debug)]
struct Timeline {
    checkpoint: Duration,
    summaries: Duration,
    report: Duration,
    exit: Duration,
}

impl Timeline {
    fn watch(mut cmd: Command, dir: &Path) -> Self {
        let started = Instant::now();
        let mut child = cmd.spawn().expect("spawn");
        let (mut checkpoint, mut summaries, mut report) = (None, None, None);
        let last_part = last_part();
        loop {
            let now = started.elapsed();
            let seen = |slot: &mut Option<Duration>, path: PathBuf| {
                if slot.is_none() && path.exists() {
                    *slot = Some(now);
                }
            };
            seen(&mut checkpoint, dir.join(CHECKPOINT));
            seen(&mut summaries, dir.join(CHAINS_DIR).join(&last_part));
            seen(&mut report, dir.join(LOO_CSV));
            if let Some(status) = child.try_wait().expect("wait") {
                assert!(status.success(), "the reference run failed");
                break;
            }
            thread::sleep(Duration::from_micros(500));
        }
        let exit = started.elapsed();
        let phase = |t: Option<Duration>, what| t.unwrap_or_else(|| panic!("no {what} seen"));
        Self {
            checkpoint: phase(checkpoint, "checkpoint"),
            summaries: phase(summaries, "last part"),
            report: phase(report, "loo.csv"),
            exit,
        }
    }

    /// `n` instants drawn from `rng`, each as a delay after the file that opens its phase
    /// appears in the killed run's own directory (so that a run slower or faster than this
    /// one, on a busy machine, is still killed in the phase drawn): a fifth in the start, three
    /// tenths while sampling, a tenth right after a part is renamed into `chains/` (while its
    /// checkpoint is written), a fifth in the summaries and run files, a fifth in the report
    /// (but for its last tenth, which a run a little faster than this one would not reach).
    fn instants(&self, n: usize, rng: &mut ChaCha8Rng) -> Vec<KillAt> {
        let checkpoint = Some(CHECKPOINT.to_owned());
        let last_part = Some(format!("{CHAINS_DIR}/{}", last_part()));
        let spans = [
            (None, self.checkpoint, n / 5),
            (
                checkpoint,
                self.summaries - self.checkpoint,
                n - 3 * (n / 5) - n / 10,
            ),
            (last_part, self.report - self.summaries, n / 5),
            (
                Some(LOO_CSV.to_owned()),
                (self.exit - self.report).mul_f64(0.9),
                n / 5,
            ),
        ];
        let mut instants: Vec<KillAt> = spans
            .into_iter()
            .flat_map(|(after, span, k)| {
                (0..k)
                    .map(|_| KillAt {
                        after: after.clone(),
                        delay: span.mul_f64(rng.random::<f64>()),
                    })
                    .collect::<Vec<_>>()
            })
            .collect();
        // A tenth within a millisecond of a part's rename into `chains/`: while its checkpoint
        // is written. That window is a few milliseconds long, so instants spread over the
        // sampling alone would land in it by chance only, and less often the faster the
        // machine.
        let parts = STEPS / CHECKPOINT_EVERY;
        instants.extend((0..n / 10).map(|_| KillAt {
            after: Some(format!(
                "{CHAINS_DIR}/part-{:06}.parquet",
                rng.random_range(1..parts - 1)
            )),
            delay: Duration::from_micros(rng.random_range(0..1000)),
        }));
        instants
    }
}

/// The last part of the test fit's chains.
fn last_part() -> String {
    format!("part-{:06}.parquet", STEPS / CHECKPOINT_EVERY - 1)
}

/// When to kill a fit: `delay` after the file `after` (relative to the run directory)
/// appears, or after the spawn.
#[derive(Debug, Clone)]
struct KillAt {
    after: Option<String>,
    delay: Duration,
}

/// Where a fault found the run, by what its directory held.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Phase {
    /// No checkpoint yet: the lock, the data, the mode search, the first steps.
    Start,
    /// Between checkpoints.
    Sampling,
    /// A checkpoint half done: its part renamed into `chains/` but the checkpoint file not yet
    /// replaced, or the new checkpoint still a temporary.
    CheckpointWrite,
    /// Every step sampled: the summaries, the footers, the run files.
    Summaries,
    /// The report: every run file written, the report being built and written.
    Report,
    /// The process had exited before the kill.
    Finished,
}

/// Checks that nothing in the run directory `dir` is half written, after a fault, against
/// the reference run, and says in which phase the fault found the run. `scratch` is an empty
/// directory for a copy of `dir`.
fn check_no_torn_file(
    reference: &Reference,
    dir: &Path,
    scratch: &Path,
    what: &str,
) -> (Phase, usize) {
    let mut temporaries = 0;
    for (name, bytes) in files_of(dir) {
        let file = Path::new(&name)
            .file_name()
            .and_then(|n| n.to_str())
            .expect("a file name")
            .to_owned();
        let at = |problem: &str| format!("{what}: {name}: {problem}");
        let text =
            || String::from_utf8(bytes.clone()).unwrap_or_else(|_| panic!("{}", at("not UTF-8")));
        let in_chains = name.starts_with(&format!("{CHAINS_DIR}/"));
        // A temporary: hidden (what `ls`, polars' globs and pyarrow's datasets skip), or a
        // part being written, named so, outside `chains/`. Inside `chains/`, only parts.
        if !in_chains
            && (file.starts_with('.') && file.ends_with(".tmp")
                || file.ends_with(".parquet.partial"))
        {
            assert!(
                !name.contains('/') || file.starts_with('.'),
                "{}",
                at("a part being written inside a folder")
            );
            temporaries += 1;
            continue;
        }
        if in_chains {
            assert!(
                file.starts_with("part-") && file.ends_with(".parquet"),
                "{}",
                at("not a part, in the folder readers take as the chains")
            );
            continue; // read together below
        }
        if let (Some(fixed), false) = (reference.fixed.get(&name), rewritten(&name)) {
            // Written once: absent, or the final version.
            assert!(&bytes == fixed, "{}", at("differs from the complete file"));
        }
        match file.as_str() {
            SUMMARY_JSON | SETTINGS_JSON | CURVES_JSON | TRUTH_JSON => {
                serde_json::from_slice::<Value>(&bytes)
                    .unwrap_or_else(|e| panic!("{}", at(&e.to_string())));
            }
            SUMMARY_CSV => check_csv(&text(), CSV_COLUMNS.len(), &at("")),
            PREDICTIVE_CSV | LOO_CSV => {
                let text = text();
                let columns = text.lines().next().unwrap_or_default().split(',').count();
                check_csv(&text, columns, &at(""));
            }
            MODEL_TOML => {
                toml::from_str::<toml::Value>(&text())
                    .unwrap_or_else(|e| panic!("{}", at(&e.to_string())));
            }
            REPORT_HTML => {
                let text = text();
                assert!(
                    text.starts_with("<!DOCTYPE html>") && text.ends_with("</html>\n"),
                    "{}",
                    at("cut short")
                );
            }
            REPORT_MD => assert!(text().ends_with("\n\n"), "{}", at("cut short")),
            LOCK_FILE => {
                let text = text();
                let pid = text.lines().next().and_then(|l| l.parse::<u32>().ok());
                assert!(pid.is_some(), "{}", at("no pid"));
            }
            CHECKPOINT => {} // read below, by resuming a copy
            MARKER => {
                // Written once, whole, before anything else: the marker of a run directory.
                let text = text();
                assert!(
                    text.contains("kind = \"run\"\n") && text.ends_with('\n'),
                    "{}",
                    at("not a complete marker")
                );
            }
            _ if name.starts_with(&format!("{FIGURES_DIR}/")) && file.ends_with(".svg") => {
                let text = text();
                assert!(
                    text.starts_with("<svg") && text.ends_with("</svg>\n"),
                    "{}",
                    at("cut short")
                );
            }
            _ => panic!("{}", at("not a file of a run")),
        }
    }
    // Typed reads too, as `report` and `load` read them.
    let run = RunDir::new(dir);
    for (name, read) in [
        (SUMMARY_JSON, run.read_summary().map(drop)),
        (SETTINGS_JSON, run.read_record().map(drop)),
        (CURVES_JSON, run.read_curves().map(drop)),
        (TRUTH_JSON, run.read_truths().map(drop)),
        (PREDICTIVE_CSV, run.read_predictive().map(drop)),
        (LOO_CSV, run.read_loo().map(drop)),
    ] {
        if dir.join(name).exists() {
            read.unwrap_or_else(|e| panic!("{what}: {name}: {e}"));
        }
    }
    // The complete parts read as one table, the first steps of the uninterrupted run's.
    let chains = dir.join(CHAINS_DIR);
    let parts = fs::read_dir(&chains).map_or(0, |d| d.count());
    if parts > 0 {
        let read = read_chains(&chains).unwrap_or_else(|e| panic!("{what}: the chains: {e}"));
        assert!(
            same_bits(&reference.chains, &read, read.len()),
            "{what}: the chains are not the first steps of an uninterrupted run's"
        );
    }

    // The checkpoint, read as a resume reads it, on a copy; with the parts, it says where
    // the run was.
    if !dir.join(CHECKPOINT).exists() {
        return (Phase::Start, temporaries);
    }
    copy_dir(dir, scratch);
    let copy = RunDir::new(scratch);
    let (sink, _, finished) = ParquetSink::resume_finished::<SamplerState>(&copy.chain_files())
        .unwrap_or_else(|e| panic!("{what}: the checkpoint: {e}"));
    let checkpointed = sink.steps();
    drop(sink);
    let recorded = if parts > 0 {
        read_chains(&chains)
            .expect("read above")
            .step
            .last()
            .map_or(0, |s| s + 1)
    } else {
        0
    };
    let checkpoint_tmp = dir.join(format!(".{CHECKPOINT}.tmp")).exists();
    let phase = if finished {
        let summarised = dir.join(SUMMARY_JSON).exists() && summary_of(dir)["loo"].is_object();
        if summarised {
            Phase::Report
        } else {
            Phase::Summaries
        }
    } else if checkpoint_tmp || recorded > checkpointed {
        Phase::CheckpointWrite
    } else if checkpointed == STEPS {
        Phase::Summaries
    } else {
        Phase::Sampling
    };
    (phase, temporaries)
}

/// Every line has `columns` fields (quoted fields may hold commas) and the file ends with a
/// line end.
fn check_csv(text: &str, columns: usize, at: &str) {
    assert!(text.ends_with('\n'), "{at} cut short");
    for (i, line) in text.lines().enumerate() {
        let mut fields = 1;
        let mut quoted = false;
        for c in line.chars() {
            match c {
                '"' => quoted = !quoted,
                ',' if !quoted => fields += 1,
                _ => {}
            }
        }
        assert_eq!(fields, columns, "{at} line {}: {line}", i + 1);
    }
}

fn copy_dir(from: &Path, to: &Path) {
    let _ = fs::remove_dir_all(to);
    for (name, bytes) in files_of(from) {
        let path = to.join(name);
        fs::create_dir_all(path.parent().expect("a parent")).expect("mkdir");
        fs::write(path, bytes).expect("copy");
    }
}

/// Resumes the run in `dir` after a fault and checks it ends as the reference run. A fit
/// killed before anything was sampled has nothing to resume: it says to start a new run, and
/// that run must then succeed in the same directory.
fn resume_and_check(reference: &Reference, model: &Path, dir: &Path, what: &str) -> Resumed {
    let out = fit(model, dir, true).output().expect("resume");
    let resumed = if out.status.success() {
        Resumed::Resumed
    } else {
        let err = stderr(&out);
        assert!(
            err.contains("nothing to resume; start a new run instead")
                && !dir.join(CHECKPOINT).exists(),
            "{what}: the resume failed:\n{err}"
        );
        let out = fit(model, dir, false).output().expect("fit");
        assert!(
            out.status.success(),
            "{what}: the new run after a failed resume:\n{}",
            stderr(&out)
        );
        Resumed::Restarted
    };
    reference.check_resumed(dir, what);
    resumed
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Resumed {
    Resumed,
    Restarted,
}

/// Runs a fit into `dir` and kills it with SIGKILL `at` the instant given; whether it was
/// still running then.
fn kill_at(model: &Path, dir: &Path, at: &KillAt) -> bool {
    let mut started = Instant::now();
    let mut child: Child = fit(model, dir, false)
        .stderr(Stdio::null())
        .spawn()
        .expect("spawn");
    if let Some(file) = &at.after {
        while !dir.join(file).exists() && child.try_wait().expect("wait").is_none() {
            thread::sleep(Duration::from_micros(200));
        }
        started = Instant::now();
    }
    thread::sleep(at.delay.saturating_sub(started.elapsed()));
    let running = child.try_wait().expect("wait").is_none();
    child.kill().expect("SIGKILL"); // std's kill is SIGKILL
    child.wait().expect("wait");
    running
}

#[test]
fn a_fit_killed_at_100_instants_resumes_bit_identical_and_leaves_no_torn_file() {
    let tmp = tempfile::tempdir().expect("tmp");
    let model = write_model(tmp.path());
    let (reference, timeline) = Reference::new(&model, tmp.path());
    let mut rng = ChaCha8Rng::seed_from_u64(42);
    let instants = timeline.instants(KILLS, &mut rng);
    let results: Vec<(Phase, Resumed, bool)> = thread::scope(|s| {
        let workers: Vec<_> = (0..AT_ONCE)
            .map(|w| {
                let (reference, model, instants, tmp) = (&reference, &model, &instants, tmp.path());
                s.spawn(move || {
                    let mut results = Vec::new();
                    for (k, at) in instants.iter().enumerate().skip(w).step_by(AT_ONCE) {
                        let dir = tmp.join(format!("kill-{k}"));
                        let what = format!(
                            "kill {k}, {:.3} s after {}",
                            at.delay.as_secs_f64(),
                            at.after.as_deref().unwrap_or("the spawn")
                        );
                        let running = kill_at(model, &dir, at);
                        let scratch = tmp.join(format!("scratch-{w}"));
                        let phase = if running {
                            check_no_torn_file(reference, &dir, &scratch, &what).0
                        } else {
                            Phase::Finished
                        };
                        let locked = dir.join(LOCK_FILE).exists();
                        let resumed = resume_and_check(reference, model, &dir, &what);
                        results.push((phase, resumed, locked));
                        let _ = fs::remove_dir_all(&dir);
                    }
                    results
                })
            })
            .collect();
        workers
            .into_iter()
            .flat_map(|w| w.join().expect("a worker"))
            .collect()
    });
    let mut by_phase = BTreeMap::<Phase, usize>::new();
    for (phase, _, _) in &results {
        *by_phase.entry(*phase).or_default() += 1;
    }
    let restarted = results.iter().filter(|r| r.1 == Resumed::Restarted).count();
    let locks = results.iter().filter(|r| r.2).count();
    println!(
        "{KILLS} kills (timeline {timeline:?}): by phase {by_phase:?}; {} resumed, {restarted} \
         started anew (killed before anything was sampled), all bit-identical; {locks} stale \
         locks taken over",
        results.len() - restarted
    );
    assert_eq!(results.len(), KILLS);
    for phase in [
        Phase::Start,
        Phase::Sampling,
        Phase::CheckpointWrite,
        Phase::Summaries,
        Phase::Report,
    ] {
        assert!(
            by_phase.get(&phase).copied().unwrap_or(0) > 0,
            "no kill landed in {phase:?}: {by_phase:?}"
        );
    }
}

/// A tmpfs mounted for a test, unmounted when dropped.
struct Mount(PathBuf);

impl Mount {
    /// A tmpfs of `size` (mount's syntax: `64k`, `3m`) at `at`.
    fn tmpfs(at: &Path, size: &str) -> Self {
        let uid = Command::new("id").arg("-u").output().expect("id -u");
        assert!(
            String::from_utf8_lossy(&uid.stdout).trim() == "0",
            "the disk-full and read-only tests mount tmpfs file systems, which needs root (as \
             in CI): run them as root; they cannot be skipped without testing nothing"
        );
        fs::create_dir_all(at).expect("mount point");
        let mount = Self(at.to_path_buf());
        assert!(
            mount.mount(&["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"]),
            "cannot mount a tmpfs at {}",
            at.display()
        );
        mount
    }

    /// `mount -o remount,OPTIONS`; whether it succeeded (a read-only remount is refused while
    /// a file is open for writing).
    fn remount(&self, options: &str) -> bool {
        self.mount(&["-o", &format!("remount,{options}")])
    }

    fn mount(&self, args: &[&str]) -> bool {
        Command::new("mount")
            .args(args)
            .arg(&self.0)
            .stderr(Stdio::null())
            .status()
            .expect("mount")
            .success()
    }
}

impl Drop for Mount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg("-l").arg(&self.0).status();
    }
}

/// The bytes of every file of a run directory.
fn size_of(dir: &Path) -> u64 {
    files_of(dir).values().map(|b| b.len() as u64).sum()
}

#[test]
fn a_full_disk_or_a_read_only_directory_stops_a_fit_clearly_and_it_resumes_bit_identical() {
    let tmp = tempfile::tempdir().expect("tmp");
    let model = write_model(tmp.path());
    let (reference, timeline) = Reference::new(&model, tmp.path());
    let full = size_of(&tmp.path().join("reference-a"));
    let scratch = tmp.path().join("scratch");
    let mut rng = ChaCha8Rng::seed_from_u64(43);

    // A full disk: tmpfs file systems smaller than the run, so that it fills up at every
    // stage from the first part to the report; then room is made and the run resumed.
    let mut sizes: Vec<u64> = (0..DISK_SIZES)
        .map(|k| {
            let (lo, hi) = (16 << 10, full * 9 / 10);
            let step = (hi - lo) / DISK_SIZES;
            lo + k * step + rng.random_range(0..step)
        })
        .collect();
    sizes.sort_unstable();
    let mut full_phases = BTreeMap::<Phase, usize>::new();
    for (k, size) in sizes.iter().enumerate() {
        let mount = Mount::tmpfs(
            &tmp.path().join(format!("disk-{k}")),
            &format!("{}k", size >> 10),
        );
        let dir = mount.0.join("run");
        let what = format!("a disk of {} KiB", size >> 10);
        let out = fit(&model, &dir, false).output().expect("fit");
        let err = stderr(&out);
        assert!(!out.status.success(), "{what}: the fit succeeded");
        assert!(
            err.contains("No space left on device") && err.contains(&dir.display().to_string()),
            "{what}: the error must name the file and say the disk is full:\n{err}"
        );
        let (phase, temporaries) = check_no_torn_file(&reference, &dir, &scratch, &what);
        assert_eq!(temporaries, 0, "{what}: temporaries left behind:\n{err}");
        assert!(
            !dir.join(LOCK_FILE).exists(),
            "{what}: the lock is left behind"
        );
        *full_phases.entry(phase).or_default() += 1;
        assert!(mount.remount("size=64m"), "{what}: cannot make room");
        resume_and_check(&reference, &model, &dir, &what);
    }

    // A read-only directory: a new fit there, and the resume of a killed fit, stop at once,
    // naming the directory, and change nothing.
    let read_only = "Read-only file system";
    let mount = Mount::tmpfs(&tmp.path().join("ro-new"), "64m");
    assert!(mount.remount("ro"));
    let dir = mount.0.join("run");
    let out = fit(&model, &dir, false).output().expect("fit");
    let err = stderr(&out);
    assert!(
        !out.status.success()
            && err.contains(read_only)
            && err.contains(&dir.display().to_string()),
        "a new fit in a read-only directory:\n{err}"
    );
    assert!(!dir.exists());
    drop(mount);

    let mount = Mount::tmpfs(&tmp.path().join("ro-killed"), "64m");
    let dir = mount.0.join("run");
    let mid = KillAt {
        after: Some(CHECKPOINT.to_owned()),
        delay: (timeline.summaries - timeline.checkpoint) / 2,
    };
    assert!(
        kill_at(&model, &dir, &mid),
        "the fit ended before it was killed"
    );
    let before = files_of(&dir);
    assert!(mount.remount("ro"));
    let out = fit(&model, &dir, true).output().expect("resume");
    let err = stderr(&out);
    assert!(
        !out.status.success()
            && err.contains(read_only)
            && err.contains(&dir.display().to_string()),
        "resuming in a read-only directory:\n{err}"
    );
    assert!(
        files_of(&dir) == before,
        "resuming in a read-only directory changed it"
    );
    assert!(mount.remount("rw"));
    resume_and_check(
        &reference,
        &model,
        &dir,
        "the resume of a read-only directory made writable",
    );
    drop(mount);

    // A directory turned read-only while the fit writes it, at random instants: a remount is
    // refused while a file is open for writing, so it is retried until it takes.
    let mut ro_phases = BTreeMap::<Phase, usize>::new();
    for k in 0..READ_ONLY_FITS {
        let mount = Mount::tmpfs(&tmp.path().join(format!("ro-{k}")), "64m");
        let dir = mount.0.join("run");
        let what = format!("read-only while writing ({k})");
        let started = Instant::now();
        let at = timeline.checkpoint
            + (timeline.exit - timeline.checkpoint).mul_f64(rng.random::<f64>() * 0.9);
        let child = fit(&model, &dir, false).spawn().expect("spawn");
        thread::sleep(at.saturating_sub(started.elapsed()));
        while !mount.remount("ro") {
            thread::sleep(Duration::from_micros(200));
        }
        let out = child.wait_with_output().expect("wait");
        let err = stderr(&out);
        let (phase, temporaries) = check_no_torn_file(&reference, &dir, &scratch, &what);
        if out.status.success() {
            // Turned read-only after its last write: the run is complete, its lock stale.
            *ro_phases.entry(Phase::Finished).or_default() += 1;
        } else {
            assert!(
                err.contains(read_only) && err.contains(&dir.display().to_string()),
                "{what}: the error must name the file and say the file system is read-only:\n{err}"
            );
            assert_eq!(temporaries, 0, "{what}: temporaries left behind:\n{err}");
            *ro_phases.entry(phase).or_default() += 1;
        }
        assert!(mount.remount("rw"));
        resume_and_check(&reference, &model, &dir, &what);
    }
    println!(
        "disk full at {} sizes ({:?} KiB) in phases {full_phases:?}; read-only: a new fit, the \
         resume of a killed fit, and mid-run in phases {ro_phases:?}; every one resumed \
         bit-identical",
        sizes.len(),
        sizes.iter().map(|s| s >> 10).collect::<Vec<_>>()
    );
}
