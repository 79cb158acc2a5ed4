//! Fits over MPI (feature `mpi`): `mpirun -n R slipbayes fit` gives the same chains, bit for
//! bit, as one process without MPI, for R = 1, 2 and 3 on loopback; a rank that dies ends the
//! job with a message naming it, and the last checkpoint resumes on another number of ranks
//! to the chains of an uninterrupted run. `mpirun -n R slipbayes validate` gives the records
//! and report of one process for R = 1, 2 and 3, also when continued; a rank that cannot load
//! the model, or has other settings than rank 0's, ends it naming the rank.
//!
//! Needs Open MPI's `mpirun` on PATH (`.ci/run` installs it). `SLIPBAYES_MPI_RANKS` (e.g.
//! `2`) limits the rank counts tried (default `1,2,3`).
#![cfg(feature = "mpi")]

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use slipbayes::storage::read_chains;
use slipbayes_cli::validate::{table, Replication};

/// Three contacts of one material with t0 pooled: material blocks, contact blocks and the
/// exact draws of a population, each a kind of request the ranks serve.
fn model() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/fixtures/campaign-3/campaign.toml")
}

fn slipbayes() -> &'static str {
    env!("CARGO_BIN_EXE_slipbayes")
}

/// `mpirun -n ranks slipbayes ARGS` on loopback, allowed to run as root (CI runs as root)
/// and on more ranks than cores.
fn mpirun(ranks: usize) -> Command {
    let mut cmd = Command::new("mpirun");
    cmd.args(["--oversubscribe", "--allow-run-as-root", "-n"])
        .arg(ranks.to_string())
        .env("OMPI_ALLOW_RUN_AS_ROOT", "1")
        .env("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
        .arg(slipbayes());
    cmd
}

fn ranks_to_try() -> Vec<usize> {
    std::env::var("SLIPBAYES_MPI_RANKS")
        .unwrap_or_else(|_| "1,2,3".to_owned())
        .split(',')
        .map(|r| {
            r.trim()
                .parse()
                .expect("SLIPBAYES_MPI_RANKS: ranks, e.g. 1,2,3")
        })
        .collect()
}

fn fit_args(out: &Path, steps: u64) -> Vec<String> {
    vec![
        "fit".into(),
        model().display().to_string(),
        "--out".into(),
        out.display().to_string(),
        "--steps".into(),
        steps.to_string(),
        "--seed".into(),
        "11".into(),
        "--quiet".into(),
    ]
}

fn check(out: Output, what: &str) -> String {
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "{what} failed:\n{err}");
    err
}

/// Every row's (step, ensemble, walker), and every value column as bits.
type ChainBits = (Vec<(u64, u32, u32)>, Vec<Vec<u64>>);

/// The chains of run directory `run`, every value as its bits.
fn chain_bits(run: &Path) -> ChainBits {
    let chains = read_chains(&run.join("chains")).expect("reading the chains");
    let rows = (0..chains.len())
        .map(|i| (chains.step[i], chains.ensemble[i], chains.walker[i]))
        .collect();
    let values = chains
        .columns
        .iter()
        .map(|c| c.iter().map(|v| v.to_bits()).collect())
        .collect();
    (rows, values)
}

fn single_process(out: &Path, steps: u64) {
    let output = Command::new(slipbayes())
        .args(fit_args(out, steps))
        .output()
        .unwrap();
    check(output, "the single-process fit");
}

#[test]
fn chains_are_the_same_bits_on_one_process_and_on_1_2_and_3_ranks() {
    let dir = tempfile::tempdir().unwrap();
    let alone = dir.path().join("alone");
    single_process(&alone, 150);
    let expected = chain_bits(&alone);
    let summary = std::fs::read(alone.join("summary.csv")).unwrap();
    for ranks in ranks_to_try() {
        let run = dir.path().join(format!("ranks-{ranks}"));
        let err = check(
            mpirun(ranks).args(fit_args(&run, 150)).output().unwrap(),
            &format!("the fit on {ranks} ranks"),
        );
        if ranks > 1 {
            // The requests really went to the other ranks.
            assert!(err.contains(&format!("MPI: {ranks} ranks")), "{err}");
            // Each rank other than 0 held the data of its own contacts' runs only: of 3
            // contacts, 1 or 2 (2 or 4 of the 6 runs).
            for rank in 1..ranks {
                let at = format!("rank {rank} held the data of ");
                let held = err
                    .find(&at)
                    .map(|i| &err[i + at.len()..])
                    .and_then(|rest| rest.split(' ').next()?.parse::<usize>().ok());
                assert!(
                    matches!(held, Some(2 | 4)) && err.contains(" of 6 runs, served "),
                    "rank {rank}: {err}"
                );
            }
            // The contacts' blocks were updated in shares on every rank, once per step: 150
            // runs, merged into the chains of one process.
            assert!(
                err.contains("(150 of them runs of contacts' blocks updated in shares, "),
                "{err}"
            );
            assert!(err.contains("(150 runs of contacts' blocks, "), "{err}");
            // And the updates of the material's shared parameters were split by contact, rank 0
            // and rank 1 alike.
            let split = |what: &str| -> Vec<u64> {
                err.match_indices(what)
                    .filter_map(|(at, _)| {
                        let before = err[..at].trim_end();
                        before[before.rfind(' ')? + 1..].parse().ok()
                    })
                    .collect()
            };
            let counts = split(" batches of shared updates split by contact)");
            assert!(counts.len() >= 2, "{err}");
            assert!(counts.iter().all(|&c| c > 0 && c == counts[0]), "{err}");
        }
        assert!(
            chain_bits(&run) == expected,
            "{ranks} ranks: the chains differ from one process's"
        );
        assert_eq!(
            std::fs::read(run.join("summary.csv")).unwrap(),
            summary,
            "{ranks} ranks"
        );
        // Only rank 0 wrote: one run directory, one set of chains.
        assert_eq!(
            std::fs::read_dir(run.join("chains")).unwrap().count(),
            std::fs::read_dir(alone.join("chains")).unwrap().count()
        );
    }
}

/// A campaign of long records: each rank other than 0 holds only its contacts' runs and
/// reduces them to sufficient statistics at the reference points rank 0 sends it (which come
/// from the whole posterior's start); the chains are one process's bits on 2 and 3 ranks.
/// Three contacts, each a first slide of 2 × 10⁴ points and a repeat slide of 10⁴.
#[test]
fn long_records_held_by_their_ranks_give_the_chains_of_one_process() {
    let dir = tempfile::tempdir().unwrap();
    let mut model = String::from("[[material]]\nname = \"M\"\n");
    for c in 1..=3 {
        let f_d = format!("{:e}", 1e-2 * (1.0 + 0.1 * c as f64));
        let t0 = (10 * c).to_string();
        model += &format!("[[contact]]\nname = \"c{c}\"\nmaterial = \"M\"\n");
        for (scene, extra) in [
            ("first", ["--duration", "4000"]),
            ("repeat", ["--after-first", "4000"]),
        ] {
            let csv = dir.path().join(format!("c{c}-{scene}.csv"));
            let seed = (10 * c + usize::from(scene == "repeat")).to_string();
            let a = format!("{:e}", 0.62 * 1e-2 * (1.0 + 0.1 * c as f64));
            let args = [
                "simulate",
                "--scene",
                scene,
                "--alpha",
                "0.92e6",
                "--a",
                &a,
                "--f-d",
                &f_d,
                "--t0",
                &t0,
                "--k",
                "1.2e4",
                "--velocity",
                "1e-9",
                "--sigma",
                "1e-4",
                "--interval",
                "0.2",
                "--seed",
                &seed,
            ];
            let out = Command::new(slipbayes())
                .args(args)
                .args(extra)
                .args(if scene == "repeat" {
                    &["--duration", "2000"][..]
                } else {
                    &[]
                })
                .arg("--out")
                .arg(&csv)
                .output()
                .unwrap();
            check(out, "simulating a long record");
            model += &format!(
                "[[run]]\nname = \"c{c}-{scene}\"\ncontact = \"c{c}\"\ndata = \"c{c}-{scene}.csv\"\n\
                 velocity_m_per_s = 1e-9\nscene = \"{scene}\"\n"
            );
        }
    }
    let path = dir.path().join("long.toml");
    std::fs::write(&path, model).unwrap();
    let args = |out: &Path| -> Vec<String> {
        let mut args = fit_args(out, 30);
        args[1] = path.display().to_string();
        args
    };
    let alone = dir.path().join("alone");
    check(
        Command::new(slipbayes())
            .args(args(&alone))
            .output()
            .unwrap(),
        "the single-process fit of long records",
    );
    let summary = std::fs::read_to_string(alone.join("summary.json")).unwrap();
    // Every run was reduced.
    assert_eq!(summary.matches("\"binning\": {").count(), 6, "{summary}");
    for ranks in ranks_to_try().into_iter().filter(|&r| r > 1) {
        let run = dir.path().join(format!("long-{ranks}"));
        let err = check(
            mpirun(ranks).args(args(&run)).output().unwrap(),
            &format!("the fit of long records on {ranks} ranks"),
        );
        assert!(err.contains("rank 1 held the data of "), "{err}");
        assert!(!err.contains("rank 1 held the data of 6 of 6"), "{err}");
        assert!(
            chain_bits(&run) == chain_bits(&alone),
            "{ranks} ranks: the chains of long records differ from one process's"
        );
    }
}

/// The process id of rank `rank` of the job writing `out` (read from /proc: its environment
/// holds Open MPI's rank, its command line the run directory).
fn rank_pid(rank: usize, out: &Path) -> Option<u32> {
    let wanted = format!("OMPI_COMM_WORLD_RANK={rank}");
    for entry in std::fs::read_dir("/proc").ok()?.flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let cmdline = std::fs::read(entry.path().join("cmdline")).unwrap_or_default();
        let environ = std::fs::read(entry.path().join("environ")).unwrap_or_default();
        let has =
            |haystack: &[u8], needle: &[u8]| haystack.split(|&b| b == 0).any(|part| part == needle);
        if has(&cmdline, out.as_os_str().as_encoded_bytes()) && has(&environ, wanted.as_bytes()) {
            return Some(pid);
        }
    }
    None
}

#[test]
fn a_killed_rank_ends_the_job_naming_it_and_the_last_checkpoint_resumes() {
    let ranks = *ranks_to_try().iter().max().unwrap();
    if ranks < 2 {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let run = dir.path().join("killed");
    let job = mpirun(ranks)
        .args(fit_args(&run, 20_000))
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Killed once a checkpoint (every 200 steps) is on disk.
    let started = Instant::now();
    while !run.join("checkpoint.bin").exists() {
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "no checkpoint"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let pid = rank_pid(1, &run).expect("rank 1 is running");
    assert!(Command::new("kill")
        .args(["-KILL", &pid.to_string()])
        .status()
        .unwrap()
        .success());
    let out = job.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    // Open MPI names the rank that failed and how.
    assert!(err.contains("rank 1") && err.contains("signal 9"), "{err}");

    // The checkpoint is complete: the run resumes on another number of ranks and ends with
    // the chains of an uninterrupted run in one process.
    let mut resume = fit_args(&run, 600);
    resume.push("--resume".into());
    check(
        mpirun(ranks - 1).args(&resume).output().unwrap(),
        &format!("resuming the killed job's run on {} ranks", ranks - 1),
    );
    let alone = dir.path().join("alone");
    single_process(&alone, 600);
    assert!(
        chain_bits(&run) == chain_bits(&alone),
        "killed on {ranks} ranks, resumed on {}: the chains differ from one process's",
        ranks - 1
    );
}

/// `slipbayes validate` with a few short replications into `out` (each about a second).
fn validate_args(out: &Path, replications: usize) -> Vec<String> {
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("../models/sbc.toml");
    vec![
        "validate".into(),
        "--model".into(),
        model.display().to_string(),
        "--replications".into(),
        replications.to_string(),
        "--steps".into(),
        "60".into(),
        "--seed".into(),
        "5".into(),
        "--out".into(),
        out.display().to_string(),
    ]
}

/// Runs a validation and returns its exit code and stderr; a code other than 0 or 4
/// (miscalibrated, which a few short replications may well be) fails.
fn validation(cmd: &mut Command, what: &str) -> (Option<i32>, String) {
    let out = cmd.output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(
        matches!(out.status.code(), Some(0 | 4)),
        "{what} failed:\n{err}"
    );
    (out.status.code(), err)
}

/// A JSON file without the key `timing` (wall time, which no two runs share), anywhere.
fn json_without(path: &Path, timing: &str) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut value: serde_json::Value = serde_json::from_str(&text).unwrap();
    let object = value.as_object_mut().unwrap();
    assert!(
        object.remove(timing).is_some(),
        "{}: no {timing}",
        path.display()
    );
    value
}

/// What a validation run left that must not depend on how it ran: every replication of the
/// table (index, truth, ranks, quantiles, fit diagnostics; not its wall time), the report
/// (not its median wall time) and the rank histograms, bytes for bytes.
fn validation_results(out: &Path) -> (Vec<Replication>, serde_json::Value, Vec<u8>) {
    let rows = table::read(&out.join(table::REPLICATIONS_TABLE))
        .unwrap()
        .unwrap_or_else(|| panic!("{}: no table of replications", out.display()))
        .rows;
    let records = rows
        .into_values()
        .map(|mut r| {
            r.wall_s = 0.0;
            r
        })
        .collect();
    (
        records,
        json_without(&out.join("validation.json"), "wall_s_median"),
        std::fs::read(out.join("rank_histograms.svg")).unwrap(),
    )
}

/// The indices of the replications a run reports finished (done or failed) on its stderr.
fn replications_done(err: &str) -> Vec<usize> {
    let mut done: Vec<usize> = err
        .lines()
        .filter_map(|l| l.strip_prefix("replication "))
        .filter_map(|l| l.split_whitespace().next()?.parse().ok())
        .collect();
    done.sort_unstable();
    done
}

#[test]
fn validate_on_1_2_and_3_ranks_gives_the_replications_and_report_of_one_process() {
    let dir = tempfile::tempdir().unwrap();
    let alone = dir.path().join("alone");
    let (code, _) = validation(
        Command::new(slipbayes()).args(validate_args(&alone, 7)),
        "the single-process validation",
    );
    let expected = validation_results(&alone);
    assert_eq!(expected.0.len(), 7);
    let mut largest = None;
    for ranks in ranks_to_try() {
        let out = dir.path().join(format!("ranks-{ranks}"));
        let (ranks_code, err) = validation(
            mpirun(ranks).args(validate_args(&out, 7)),
            &format!("the validation on {ranks} ranks"),
        );
        assert_eq!(ranks_code, code, "{ranks} ranks:\n{err}");
        assert_eq!(replications_done(&err), (0..7).collect::<Vec<_>>(), "{err}");
        if ranks > 1 {
            // The other ranks ran their shares (every R-th replication from their rank on)
            // and rank 0 received them over MPI.
            let received = (1..ranks)
                .map(|r| (r..7).step_by(ranks).count())
                .sum::<usize>();
            let line = format!(
                "MPI: {ranks} ranks; rank 0 ran {} of the 7 replications to run and received {received} from the other ranks",
                7 - received
            );
            assert!(err.contains(&line), "`{line}` not in:\n{err}");
        }
        assert!(
            validation_results(&out) == expected,
            "{ranks} ranks: the replications or the report differ from one process's"
        );
        largest = Some((ranks, out));
    }

    // A run stopped part way (records 1, 4 and 5 missing) and grown to 9 replications
    // continues on the most ranks: only the missing and the new ones run, and the results
    // are those of one process continued the same way.
    let Some((ranks, out)) = largest else { return };
    let path = out.join(table::REPLICATIONS_TABLE);
    let mut t = table::read(&path).unwrap().unwrap();
    for i in [1, 4, 5] {
        t.rows.remove(&i).unwrap();
    }
    table::write(&path, &t.quantities, &t.rows).unwrap();
    let (_, err) = validation(
        mpirun(ranks).args(validate_args(&out, 9)),
        &format!("the continued validation on {ranks} ranks"),
    );
    assert_eq!(replications_done(&err), vec![1, 4, 5, 7, 8], "{err}");
    validation(
        Command::new(slipbayes()).args(validate_args(&alone, 9)),
        "the continued single-process validation",
    );
    assert!(
        validation_results(&out) == validation_results(&alone),
        "continued on {ranks} ranks: the replications or the report differ from one process's"
    );
}

/// The stderr of a failed validation on 2 ranks whose rank 1 is given `flag` = `value` instead
/// of rank 0's (mpirun's MPMD syntax: one command line per rank); `None` when
/// `SLIPBAYES_MPI_RANKS` allows a single rank only.
fn validate_with_rank_1_given(flag: &str, value: &str) -> Option<String> {
    if *ranks_to_try().iter().max().unwrap() < 2 {
        return None;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("sbc");
    let mut other = validate_args(&out, 4);
    let at = other.iter().position(|a| a == flag).unwrap();
    other[at + 1] = value.into();
    let result = mpirun(1)
        .args(validate_args(&out, 4))
        .args([":", "-n", "1", slipbayes()])
        .args(&other)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&result.stderr).into_owned();
    assert!(!result.status.success(), "{err}");
    Some(err)
}

/// A rank that cannot run its share (here rank 1 is given a model that does not exist) ends
/// the job with an error naming it.
#[test]
fn a_rank_that_cannot_load_the_model_ends_validate_naming_it() {
    let Some(err) = validate_with_rank_1_given("--model", "/nonexistent/missing.toml") else {
        return;
    };
    assert!(
        err.contains("rank 1: error: loading the model") && err.contains("missing.toml"),
        "{err}"
    );
}

/// A rank given other settings than rank 0's (here another seed) refuses to run replications
/// that would belong to another run, and ends the job naming itself.
#[test]
fn a_rank_with_other_settings_than_rank_0_ends_validate_naming_it() {
    let Some(err) = validate_with_rank_1_given("--seed", "6") else {
        return;
    };
    assert!(
        err.contains("rank 1: error: the settings or the model file")
            && err.contains("differ from rank 0's"),
        "{err}"
    );
}
