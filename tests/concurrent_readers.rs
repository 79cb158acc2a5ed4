//! Readers of a run directory while a fit writes it (what `slipbayes report` and
//! `slipbayes.load` read through [`RunDir`]): every read is a consistent run, the parts of the
//! last complete checkpoint and nothing after them, never rows of one run mixed with another's,
//! and readers take no lock.
#![cfg(feature = "parquet")]

use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};

use slipbayes::density::{LogDensity, LogDensityError, Quantity, QuantityKind};
use slipbayes::fit::{run_fit, FitSettings, RunDir, RunDirError, RunLock, SummarySpec};
use slipbayes::sampler::{CarryFit, Move, Parallelism, Silent, Steps, Updates};
use slipbayes::storage::{ChainSink, ParquetSink, SinkOptions, StepView, StorageError};

/// Steps between checkpoints: one part per checkpoint, so hundreds of parts.
const EVERY: u64 = 2;
const STEPS: u64 = 400;
const ENSEMBLES: usize = 2;
const WALKERS: usize = 8;
const READERS: usize = 3;

/// A correlated 2-D Gaussian whose derived value is x0 + x1: every row of the chains can be
/// checked on its own (its log-density and derived value are those of its coordinates).
struct Gauss;

impl Gauss {
    fn at(x: &[f64]) -> (f64, f64) {
        let q = x[0] * x[0] - 1.2 * x[0] * x[1] + x[1] * x[1];
        (-0.5 * q / 0.64, x[0] + x[1])
    }
}

impl LogDensity for Gauss {
    fn dim(&self) -> usize {
        2
    }
    fn param_names(&self) -> Vec<String> {
        vec!["x0".into(), "x1".into()]
    }
    fn derived_names(&self) -> Vec<String> {
        vec!["sum".into()]
    }
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let (lp, sum) = Self::at(x);
        derived[0] = sum;
        Ok(lp)
    }
}

fn spec() -> SummarySpec {
    let quantity = |column: &str, kind| Quantity {
        column: column.into(),
        name: column.into(),
        group: String::new(),
        unit: String::new(),
        kind,
    };
    SummarySpec {
        quantities: vec![
            quantity("x0", QuantityKind::Parameter),
            quantity("x1", QuantityKind::Parameter),
            quantity("sum", QuantityKind::Derived),
        ],
        ..SummarySpec::default()
    }
}

fn settings(seed: u64, steps: u64, every: u64, overwrite: bool) -> FitSettings {
    FitSettings {
        walkers: WALKERS,
        ensembles: ENSEMBLES,
        seed,
        steps: Steps::Fixed(steps),
        checkpoint_every: Some(every),
        quiet: true,
        overwrite,
        moves: vec![(Move::stretch(), 1.0)],
        updates: Updates::Joint,
        carry: CarryFit::Auto,
        ..FitSettings::default()
    }
}

const START: [f64; 2] = [0.1, -0.1];

/// Fits `steps` steps with a checkpoint `every` steps into `dir`.
fn fit(dir: &Path, seed: u64, steps: u64, every: u64, overwrite: bool) {
    let lock = RunLock::acquire(dir).unwrap();
    run_fit(
        &Gauss,
        &spec(),
        &START,
        &settings(seed, steps, every, overwrite),
        &RunDir::new(lock.dir()),
        false,
        &mut Silent,
        Parallelism::default(),
    )
    .expect("the fit runs");
}

/// One read of the run: `Ok(Some(steps))` for a consistent run of that many steps,
/// `Ok(None)` when there is no run to read yet (before the first checkpoint, or while an
/// earlier run is being replaced), `Err` for anything else, saying what.
fn read_once(dir: &RunDir) -> Result<Option<u64>, String> {
    let reader = match dir.chain_reader() {
        Ok(reader) => reader,
        Err(RunDirError::Chains { source, .. }) if nothing_yet(&source) => return Ok(None),
        Err(e) => return Err(format!("opening: {e:?}")),
    };
    let steps = reader.steps();
    if steps % EVERY != 0 && steps != STEPS {
        return Err(format!("{steps} steps: not a checkpoint's"));
    }
    let column = |name: &str| reader.column(name).map_err(|e| format!("{name}: {e}"));
    let (x0, x1) = (column("x0")?, column("x1")?);
    let (lp, sum) = (column("log_density")?, column("sum")?);
    for values in [&x0, &x1, &lp, &sum] {
        if values.len() != reader.rows() {
            return Err(format!("{} values, {} rows", values.len(), reader.rows()));
        }
    }
    // Every row is one walker's state: its columns come from one part of one run.
    for row in 0..reader.rows() {
        let (want_lp, want_sum) = Gauss::at(&[x0[row], x1[row]]);
        if want_lp.to_bits() != lp[row].to_bits() || want_sum.to_bits() != sum[row].to_bits() {
            return Err(format!("row {row} mixes the columns of different parts"));
        }
    }
    // The in-memory read of the same directory is as consistent (it may see a later
    // checkpoint, never a torn one).
    match dir.read_chains() {
        Ok(chains) if chains.len() % (ENSEMBLES * WALKERS * EVERY as usize) == 0 => {}
        Ok(chains) if chains.len() == ENSEMBLES * WALKERS * STEPS as usize => {}
        Ok(chains) => return Err(format!("read_chains: {} rows", chains.len())),
        Err(RunDirError::Chains { source, .. }) if nothing_yet(&source) => {}
        Err(e) => return Err(format!("read_chains: {e:?}")),
    }
    // What `report` and `slipbayes.load` read: the summary, then the chains it sums up.
    match dir.read_summary() {
        Ok(summary) => match dir.finished_chain_reader(&summary) {
            Ok(chains) if chains.steps() == summary.sampler.steps => {}
            Ok(chains) => {
                return Err(format!(
                    "the summary of {} steps read with chains of {}",
                    summary.sampler.steps,
                    chains.steps()
                ))
            }
            Err(RunDirError::Changed { .. }) => {}
            Err(RunDirError::Chains { source, .. }) if nothing_yet(&source) => {}
            Err(e) => return Err(format!("finished read: {e:?}")),
        },
        // No summary: the run is not finished yet.
        Err(RunDirError::Read(_)) => {}
        Err(e) => return Err(format!("summary: {e:?}")),
    }
    Ok(Some(steps))
}

/// No run to read: no chains yet, or a run replaced while it was read (the reader refuses
/// rather than read parts of two runs).
fn nothing_yet(source: &StorageError) -> bool {
    match source {
        StorageError::NoChains { .. } | StorageError::NoCheckpoint { .. } => true,
        StorageError::Io(e) => e.kind() == std::io::ErrorKind::NotFound,
        StorageError::Inconsistent { problem, .. } => problem.contains("the checkpoint counts"),
        _ => false,
    }
}

/// Reads `dir` over and over until `done`, on `READERS` threads at once; returns the reads
/// of a run and the failures.
fn read_while(dir: &RunDir, done: &AtomicBool) -> (usize, Vec<String>) {
    std::thread::scope(|scope| {
        let readers: Vec<_> = (0..READERS)
            .map(|_| {
                scope.spawn(|| {
                    let (mut reads, mut failures) = (0, Vec::new());
                    while !done.load(Ordering::SeqCst) {
                        match read_once(dir) {
                            Ok(Some(_)) => reads += 1,
                            Ok(None) => {}
                            Err(e) => failures.push(e),
                        }
                    }
                    (reads, failures)
                })
            })
            .collect();
        readers.into_iter().map(|r| r.join().unwrap()).fold(
            (0, Vec::new()),
            |(n, mut all), (reads, failures)| {
                all.extend(failures);
                (n + reads, all)
            },
        )
    })
}

#[test]
fn readers_of_a_run_being_written_and_replaced_read_a_consistent_run() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = RunDir::new(tmp.path().join("run"));
    for (seed, overwrite) in [(1, false), (2, true)] {
        let done = AtomicBool::new(false);
        let (reads, failures) = std::thread::scope(|scope| {
            let readers = scope.spawn(|| read_while(&dir, &done));
            fit(dir.path(), seed, STEPS, EVERY, overwrite);
            done.store(true, Ordering::SeqCst);
            readers.join().unwrap()
        });
        assert!(
            failures.is_empty(),
            "{} of the reads failed, e.g. {:?}",
            failures.len(),
            &failures[..failures.len().min(3)]
        );
        assert!(reads > 0, "no read of a run while the fit ran");
        assert_eq!(read_once(&dir), Ok(Some(STEPS)));
    }
}

#[test]
fn a_part_written_after_the_last_checkpoint_is_not_read() {
    // A fit killed after it wrote a part and before its checkpoint counted it: a store of three
    // checkpoints' parts whose checkpoint file is the one written after the second. (Not the
    // checkpoint of a finished shorter run: finishing rewrites every part's footer with the
    // burn-in, so its checkpoint would not match these parts and would be refused as corrupt.)
    const EVERY: u64 = 5;
    let tmp = tempfile::tempdir().unwrap();
    let run = RunDir::new(tmp.path().join("run"));
    let files = run.chain_files();
    let names = ["x0".to_owned(), "x1".to_owned()];
    let options = SinkOptions {
        row_group_rows: 4,
        overwrite: false,
    };
    let record = |sink: &mut ParquetSink, steps: std::ops::Range<u64>| {
        for step in steps {
            let x: Vec<f64> = (0..2 * WALKERS).map(|i| (step + i as u64) as f64).collect();
            let (lp, sum): (Vec<f64>, Vec<f64>) = x.chunks(2).map(Gauss::at).unzip();
            sink.record(&StepView {
                ensemble: 0,
                step,
                ndim: 2,
                positions: &x,
                log_density: &lp,
                derived: &sum,
            })
            .unwrap();
            if step % EVERY == EVERY - 1 {
                sink.checkpoint(&step).unwrap();
            }
        }
    };
    // Two checkpoints, then the sink dropped (which completes its last checkpoint on disk,
    // the writer being a thread of its own): that checkpoint is kept; then a third part.
    let mut sink = ParquetSink::create(&files, &names, &["sum".to_owned()], options).unwrap();
    record(&mut sink, 0..2 * EVERY);
    drop(sink);
    let second = std::fs::read(&files.checkpoint).unwrap();
    let (mut sink, _) = ParquetSink::resume::<u64>(&files).unwrap();
    record(&mut sink, 2 * EVERY..3 * EVERY);
    drop(sink);
    std::fs::write(&files.checkpoint, second).unwrap();
    assert_eq!(
        std::fs::read_dir(&files.chains).unwrap().count(),
        3,
        "one part per checkpoint"
    );
    let reader = run.chain_reader().unwrap();
    assert_eq!(reader.steps(), 2 * EVERY);
    assert_eq!(
        run.read_chains().unwrap().len(),
        WALKERS * 2 * EVERY as usize
    );
}
