//! Chain storage: streaming, checkpoints, resuming after a kill, reading back, errors.
#![cfg(feature = "parquet")]

use std::fs;
use std::path::Path;

use serde::{Deserialize, Serialize};
use slipbayes::data::write_atomically;
use slipbayes::storage::metadata::{LAYOUT, METADATA_FORMAT};
use slipbayes::storage::{
    read_chains, read_part_metadata, ChainDescription, ChainReader, ChainSink, Chains, ColumnKind,
    ColumnUnit, ParquetSink, SinkOptions, StepView, StorageError, Written,
};

/// The chain store of a run directory, laid out as a fit's run directory lays it out.
fn files(dir: &std::path::Path) -> slipbayes::storage::ChainFiles {
    slipbayes::fit::RunDir::new(dir).chain_files()
}

const ENSEMBLES: usize = 3;
const WALKERS: usize = 5;
const TOTAL_STEPS: u64 = 100;
const CHECKPOINT_EVERY: u64 = 20;

/// What a fake sampler would save: where it stands.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
struct FakeState {
    next_step: u64,
    tag: String,
}

fn params() -> Vec<String> {
    vec!["alpha".into(), "beta_per_s".into()]
}

fn derived() -> Vec<String> {
    vec!["t0_s".into()]
}

/// SplitMix64: a deterministic value for every (ensemble, walker, step, column).
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A finite double of any magnitude, including subnormals, from a seed.
fn value(e: usize, w: usize, step: u64, column: usize) -> f64 {
    let bits = mix(step ^ ((e as u64) << 40) ^ ((w as u64) << 48) ^ ((column as u64) << 56));
    let x = f64::from_bits(bits);
    if x.is_finite() {
        x
    } else {
        f64::from_bits(bits >> 12)
    }
}

/// One ensemble's step as the sampler would hand it.
struct FakeStep {
    positions: Vec<f64>,
    log_density: Vec<f64>,
    derived: Vec<f64>,
}

fn fake_step(e: usize, step: u64) -> FakeStep {
    let (np, nd) = (params().len(), derived().len());
    let mut s = FakeStep {
        positions: Vec::new(),
        log_density: Vec::new(),
        derived: Vec::new(),
    };
    for w in 0..WALKERS {
        s.positions.extend((0..np).map(|c| value(e, w, step, c)));
        s.log_density.push(value(e, w, step, np));
        s.derived
            .extend((0..nd).map(|c| value(e, w, step, np + 1 + c)));
    }
    s
}

/// Records steps `from..to` of every ensemble, checkpointing every `CHECKPOINT_EVERY` steps.
fn produce(sink: &mut ParquetSink, from: u64, to: u64) {
    for step in from..to {
        for e in 0..ENSEMBLES {
            record(sink, e, step).expect("record");
        }
        if (step + 1) % CHECKPOINT_EVERY == 0 {
            let state = FakeState {
                next_step: step + 1,
                tag: format!("after {}", step + 1),
            };
            sink.checkpoint(&state).expect("checkpoint");
        }
    }
}

/// Records step `step` of ensemble `e`.
fn record(sink: &mut ParquetSink, e: usize, step: u64) -> Result<(), StorageError> {
    let s = fake_step(e, step);
    sink.record(&StepView {
        ensemble: e,
        step,
        ndim: params().len(),
        positions: &s.positions,
        log_density: &s.log_density,
        derived: &s.derived,
    })
}

fn options(row_group_rows: usize) -> SinkOptions {
    SinkOptions {
        row_group_rows,
        overwrite: false,
    }
}

/// The reference: 100 steps written without interruption.
fn uninterrupted(dir: &Path) -> Chains {
    let mut sink =
        ParquetSink::create(&files(dir), &params(), &derived(), options(7)).expect("create");
    produce(&mut sink, 0, TOTAL_STEPS);
    sink.finish().expect("finish");
    read_chains(&files(dir).chains).expect("read")
}

fn assert_bit_identical(a: &Chains, b: &Chains) {
    assert_eq!(a.param_names, b.param_names);
    assert_eq!(a.derived_names, b.derived_names);
    assert_eq!(a.ensemble, b.ensemble);
    assert_eq!(a.walker, b.walker);
    assert_eq!(a.step, b.step);
    assert_eq!(a.columns.len(), b.columns.len());
    for (ca, cb) in a.columns.iter().zip(&b.columns) {
        let ba: Vec<u64> = ca.iter().map(|x| x.to_bits()).collect();
        let bb: Vec<u64> = cb.iter().map(|x| x.to_bits()).collect();
        assert_eq!(ba, bb);
    }
}

fn names_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = fs::read_dir(dir)
        .expect("list")
        .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

fn part_bytes(dir: &Path) -> Vec<Vec<u8>> {
    names_in(&dir.join("chains"))
        .iter()
        .map(|n| fs::read(dir.join("chains").join(n)).expect("read part"))
        .collect()
}

#[test]
fn uninterrupted_run_reads_back_every_value_in_order() {
    let tmp = tempfile::tempdir().expect("tmp");
    let chains = uninterrupted(tmp.path());
    assert_eq!(chains.len(), TOTAL_STEPS as usize * ENSEMBLES * WALKERS);
    assert_eq!(
        chains.column_names(),
        vec!["alpha", "beta_per_s", "log_density", "t0_s"]
    );
    assert_eq!(
        names_in(&tmp.path().join("chains")),
        (0..5)
            .map(|i| format!("part-{i:06}.parquet"))
            .collect::<Vec<_>>()
    );
    assert_eq!(names_in(tmp.path()), vec!["chains", "checkpoint.bin"]);
    // Row order: step, then ensemble, then walker; values as produced.
    let mut row = 0;
    for step in 0..TOTAL_STEPS {
        for e in 0..ENSEMBLES {
            for w in 0..WALKERS {
                assert_eq!(chains.step[row], step);
                assert_eq!(chains.ensemble[row] as usize, e);
                assert_eq!(chains.walker[row] as usize, w);
                for (c, column) in chains.columns.iter().enumerate() {
                    assert_eq!(column[row].to_bits(), value(e, w, step, c).to_bits());
                }
                row += 1;
            }
        }
    }
    // The per-chain view the diagnostics use.
    let beta = chains.series("beta_per_s").expect("series");
    assert_eq!((beta.len(), beta[0].len()), (ENSEMBLES, WALKERS));
    for (e, ensemble) in beta.iter().enumerate() {
        for (w, chain) in ensemble.iter().enumerate() {
            let expected: Vec<u64> = (0..TOTAL_STEPS)
                .map(|s| value(e, w, s, 1).to_bits())
                .collect();
            let got: Vec<u64> = chain.iter().map(|x| x.to_bits()).collect();
            assert_eq!(got, expected);
        }
    }
    let lp = chains.column("log_density").expect("log_density");
    assert_eq!(lp.as_ptr(), chains.log_density().as_ptr());
    assert!(matches!(
        chains.column("gamma"),
        Err(StorageError::ColumnMissing { column, .. }) if column == "gamma"
    ));
}

/// Every part describes itself in its Parquet footer: its format, the layout and which index
/// is a chain for which diagnostic, every column's kind, unit and scale, its steps, the seed
/// and shape. The burn-in is `pending` while the run goes on; once set, `finish` writes it
/// into every part, and the values read back unchanged.
#[test]
fn parts_describe_themselves_and_carry_the_burn_in_once_finished() {
    let reference_dir = tempfile::tempdir().expect("tmp");
    let reference = uninterrupted(reference_dir.path());
    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path();
    let mut sink =
        ParquetSink::create(&files(dir), &params(), &derived(), options(7)).expect("create");
    let unit = |unit: &str, log| ColumnUnit {
        unit: unit.into(),
        log,
    };
    sink.describe(ChainDescription {
        seed: 42,
        ensembles: ENSEMBLES,
        walkers: WALKERS,
        thin: 1,
        param_units: vec![unit("1", true), unit("1/s", true)],
        derived_units: vec![unit("s", false)],
    });
    produce(&mut sink, 0, 2 * CHECKPOINT_EVERY);
    sink.written().expect("written");
    let part = |i: usize| files(dir).chains.join(format!("part-{i:06}.parquet"));
    let running = read_part_metadata(&part(1))
        .expect("readable")
        .expect("written");
    assert_eq!(running.format, METADATA_FORMAT);
    assert_eq!(running.layout, LAYOUT);
    assert!(
        running.layout.contains("for R-hat a chain is one ensemble")
            && running
                .layout
                .contains("for ESS a chain is one walker of one ensemble"),
        "{}",
        running.layout
    );
    assert_eq!(running.steps, CHECKPOINT_EVERY..2 * CHECKPOINT_EVERY);
    assert_eq!((running.burn_in, running.is_kept(30)), (None, None));
    assert_eq!(
        (
            running.seed,
            running.ensembles,
            running.walkers,
            running.thin
        ),
        (Some(42), Some(ENSEMBLES), Some(WALKERS), Some(1))
    );
    let described: Vec<(&str, ColumnKind, &str, bool)> = running
        .columns
        .iter()
        .map(|c| (c.name.as_str(), c.kind, c.unit.as_str(), c.log))
        .collect();
    assert_eq!(
        described,
        [
            ("ensemble", ColumnKind::Index, "1", false),
            ("walker", ColumnKind::Index, "1", false),
            ("step", ColumnKind::Step, "1", false),
            ("alpha", ColumnKind::Parameter, "1", true),
            ("beta_per_s", ColumnKind::Parameter, "1/s", true),
            ("log_density", ColumnKind::LogDensity, "1", true),
            ("t0_s", ColumnKind::Derived, "s", false),
        ]
    );

    produce(&mut sink, 2 * CHECKPOINT_EVERY, TOTAL_STEPS);
    sink.set_burn_in(30);
    sink.finish().expect("finish");
    let parts = (TOTAL_STEPS / CHECKPOINT_EVERY) as usize;
    for i in 0..parts {
        let m = read_part_metadata(&part(i)).unwrap().unwrap();
        let first = i as u64 * CHECKPOINT_EVERY;
        assert_eq!(m.steps, first..first + CHECKPOINT_EVERY, "part {i}");
        assert_eq!(m.burn_in, Some(30), "part {i}");
        assert_eq!(m.columns, running.columns, "part {i}");
        // Any Parquet reader finds the keys in the footer, beside the Arrow schema.
        let footer =
            polars_parquet::read::read_metadata(&mut fs::File::open(part(i)).unwrap()).unwrap();
        let keys: Vec<(&str, Option<&str>)> = footer
            .key_value_metadata
            .as_ref()
            .unwrap()
            .iter()
            .map(|kv| (kv.key.as_str(), kv.value.as_deref()))
            .collect();
        assert!(
            keys.contains(&("slipbayes.burn_in", Some("30"))),
            "{keys:?}"
        );
        assert!(keys.iter().any(|(k, _)| *k == "ARROW:schema"), "{keys:?}");
    }
    let whole = ChainReader::open(&files(dir).chains)
        .unwrap()
        .metadata()
        .unwrap()
        .unwrap();
    assert_eq!(whole.steps, 0..TOTAL_STEPS);
    assert_eq!(
        (whole.is_kept(29), whole.is_kept(30)),
        (Some(false), Some(true))
    );
    // The footers were rewritten, the values not; nothing is left beside the parts.
    assert_bit_identical(&read_chains(&files(dir).chains).expect("read"), &reference);
    assert_eq!(names_in(dir), vec!["chains", "checkpoint.bin"]);
}

#[test]
fn killed_run_resumed_from_checkpoint_equals_uninterrupted_run() {
    let reference_dir = tempfile::tempdir().expect("tmp");
    let reference = uninterrupted(reference_dir.path());

    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path();
    let mut sink =
        ParquetSink::create(&files(dir), &params(), &derived(), options(7)).expect("create");
    produce(&mut sink, 0, 55);
    assert!(
        sink.buffered_rows() > 0,
        "the kill must happen with rows in memory"
    );
    drop(sink); // killed: no finish, no checkpoint after step 40

    // The part in progress is visibly partial and outside chains/.
    assert_eq!(
        names_in(dir),
        vec!["chains", "checkpoint.bin", "part-000002.parquet.partial"]
    );
    assert_eq!(
        read_chains(&files(dir).chains).expect("read").len(),
        40 * ENSEMBLES * WALKERS
    );

    let (mut sink, state) = ParquetSink::resume::<FakeState>(&files(dir)).expect("resume");
    assert_eq!(
        state,
        FakeState {
            next_step: 40,
            tag: "after 40".into()
        }
    );
    assert_eq!(sink.steps(), 40);
    assert_eq!(
        sink.written().expect("written"),
        Written {
            parts: 2,
            rows: 40 * (ENSEMBLES * WALKERS) as u64
        }
    );
    assert_eq!(names_in(dir), vec!["chains", "checkpoint.bin"]);
    sink.check_columns(&params(), &derived())
        .expect("same model");
    produce(&mut sink, state.next_step, TOTAL_STEPS);
    sink.finish().expect("finish");

    assert_bit_identical(&read_chains(&files(dir).chains).expect("read"), &reference);
    // Same part boundaries and deterministic encoding: the files themselves are identical.
    let (resumed, reference) = (part_bytes(dir), part_bytes(reference_dir.path()));
    assert_eq!(resumed.len(), reference.len());
    for (i, (a, b)) in resumed.iter().zip(&reference).enumerate() {
        let first_difference = a.iter().zip(b).position(|(x, y)| x != y);
        assert!(
            a.len() == b.len() && first_difference.is_none(),
            "part {i}: {} vs {} bytes, first difference at {first_difference:?}",
            a.len(),
            b.len()
        );
    }
}

/// A run checkpointed by an earlier release (JSON, `checkpoint.json`) resumes, and its first
/// new checkpoint replaces the JSON one by the binary one; the chains equal an uninterrupted run.
#[test]
fn a_json_checkpoint_of_an_earlier_release_resumes() {
    let reference_dir = tempfile::tempdir().expect("tmp");
    let reference = uninterrupted(reference_dir.path());

    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path();
    let mut sink =
        ParquetSink::create(&files(dir), &params(), &derived(), options(7)).expect("create");
    produce(&mut sink, 0, 55);
    drop(sink);
    // Rewrite the checkpoint as the earlier release wrote it: one JSON object, the state
    // inside under `state`, format version 1.
    let bytes = fs::read(dir.join("checkpoint.bin")).expect("checkpoint");
    let mut reader = std::io::Cursor::new(&bytes[..]);
    let mut header: serde_json::Value = rmp_serde::from_read(&mut reader).expect("header");
    let state: serde_json::Value =
        rmp_serde::from_slice(&bytes[reader.position() as usize..]).expect("state");
    header["format"] = "slipbayes-chains/1".into();
    header["state"] = state;
    fs::write(
        dir.join("checkpoint.json"),
        serde_json::to_vec_pretty(&header).expect("json"),
    )
    .expect("write json");
    fs::remove_file(dir.join("checkpoint.bin")).expect("remove binary");

    let (mut sink, state) = ParquetSink::resume::<FakeState>(&files(dir)).expect("resume");
    assert_eq!(state.next_step, 40);
    assert_eq!(sink.steps(), 40);
    produce(&mut sink, state.next_step, TOTAL_STEPS);
    sink.finish().expect("finish");
    assert_eq!(names_in(dir), vec!["chains", "checkpoint.bin"]);
    assert_bit_identical(&read_chains(&files(dir).chains).expect("read"), &reference);
}

#[test]
fn crash_after_part_rename_and_mid_write_leftovers_are_cleaned_on_resume() {
    let reference_dir = tempfile::tempdir().expect("tmp");
    let reference = uninterrupted(reference_dir.path());

    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path();
    let mut sink =
        ParquetSink::create(&files(dir), &params(), &derived(), options(7)).expect("create");
    produce(&mut sink, 0, 40);
    sink.written().expect("written");
    let checkpoint_at_40 = fs::read(dir.join("checkpoint.bin")).expect("checkpoint");
    produce(&mut sink, 40, 70);
    drop(sink);
    // The crash hit checkpoint 60 after part 2 was renamed into chains/ but before
    // checkpoint.bin was replaced: the old checkpoint is still there.
    fs::write(dir.join("checkpoint.bin"), &checkpoint_at_40).expect("restore");
    // ... and while a new checkpoint was half written, and part 3 half written.
    fs::write(dir.join(".checkpoint.bin.tmp"), b"{\"format\": \"slipb").expect("tmp");
    let partial = dir.join("part-000003.parquet.partial");
    let full = fs::read(dir.join("chains/part-000001.parquet")).expect("part");
    fs::write(&partial, &full[..full.len() / 2]).expect("half part");
    assert_eq!(
        names_in(&dir.join("chains")),
        vec![
            "part-000000.parquet",
            "part-000001.parquet",
            "part-000002.parquet"
        ]
    );

    let (mut sink, state) = ParquetSink::resume::<FakeState>(&files(dir)).expect("resume");
    assert_eq!(state.next_step, 40);
    assert_eq!(names_in(dir), vec!["chains", "checkpoint.bin"]);
    assert_eq!(
        names_in(&dir.join("chains")),
        vec!["part-000000.parquet", "part-000001.parquet"]
    );
    produce(&mut sink, state.next_step, TOTAL_STEPS);
    sink.finish().expect("finish");
    assert_bit_identical(&read_chains(&files(dir).chains).expect("read"), &reference);
}

/// The writer thread's failure (here: the run directory removed under a running sink) is
/// returned by the sink's next call, naming the file; later calls say the writer stopped.
#[test]
fn a_failed_write_in_the_background_is_returned_by_the_next_call() {
    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path().join("run");
    let mut sink =
        ParquetSink::create(&files(&dir), &params(), &derived(), options(7)).expect("create");
    fs::remove_dir_all(&dir).expect("remove the run directory");
    let mut first_error = None;
    'steps: for step in 0..TOTAL_STEPS {
        for e in 0..ENSEMBLES {
            if let Err(error) = record(&mut sink, e, step) {
                first_error = Some(error);
                break 'steps;
            }
        }
    }
    match first_error.expect("the lost directory is noticed") {
        StorageError::Io(slipbayes::IoError { action, path, .. }) => {
            assert_eq!(action, "create");
            assert_eq!(path, dir.join("part-000000.parquet.partial"));
        }
        other => panic!("unexpected error {other}"),
    }
    let later = sink.checkpoint(&0u8).expect_err("the writer stopped");
    assert!(
        matches!(later, StorageError::WriterStopped { .. }),
        "{later}"
    );
    assert!(later.to_string().contains("--resume"), "{later}");
    assert!(matches!(
        sink.finish(),
        Err(StorageError::WriterStopped { .. })
    ));
}

#[test]
fn memory_held_is_one_row_group_whatever_the_run_length() {
    let tmp = tempfile::tempdir().expect("tmp");
    let row_group_rows = 40; // not a multiple of the 15 rows of a step
    let mut sink = ParquetSink::create(
        &files(tmp.path()),
        &params(),
        &derived(),
        options(row_group_rows),
    )
    .expect("create");
    let mut max_capacity = 0;
    for step in 0..400 {
        for e in 0..ENSEMBLES {
            let s = fake_step(e, step);
            sink.record(&StepView {
                ensemble: e,
                step,
                ndim: 2,
                positions: &s.positions,
                log_density: &s.log_density,
                derived: &s.derived,
            })
            .expect("record");
            assert!(sink.buffered_rows() < row_group_rows);
            max_capacity = max_capacity.max(sink.buffer_capacity_rows());
        }
    }
    // 6000 rows recorded with no checkpoint; the buffers never grew past one row group.
    assert_eq!(sink.rows(), 400 * (ENSEMBLES * WALKERS) as u64);
    assert!(max_capacity <= row_group_rows, "capacity {max_capacity}");
    sink.finish().expect("finish");
    let chains = read_chains(&files(tmp.path()).chains).expect("read");
    assert_eq!(chains.len(), 6000);
}

#[test]
fn existing_runs_are_protected_and_overwrite_replaces_them() {
    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path();
    let _ = uninterrupted(dir);
    fs::write(dir.join("summary.json"), b"{}").expect("other output");

    let err = ParquetSink::create(&files(dir), &params(), &derived(), options(7)).unwrap_err();
    assert!(matches!(err, StorageError::CompletedRunExists { .. }));
    let message = err.to_string();
    assert!(message.contains("--overwrite") && message.contains(&dir.display().to_string()));

    let err = ParquetSink::resume::<FakeState>(&files(dir)).unwrap_err();
    assert!(matches!(err, StorageError::AlreadyFinished { .. }), "{err}");

    let opts = SinkOptions {
        row_group_rows: 7,
        overwrite: true,
    };
    let opts = SinkOptions {
        row_group_rows: 1,
        ..opts
    };
    let mut sink =
        ParquetSink::create(&files(dir), &["x".to_string()], &[], opts).expect("overwrite");
    sink.record(&StepView {
        ensemble: 0,
        step: 0,
        ndim: 1,
        positions: &[1.5, -2.5],
        log_density: &[-1.0, -2.0],
        derived: &[],
    })
    .expect("record");
    drop(sink);
    assert_eq!(
        names_in(dir),
        vec!["chains", "part-000000.parquet.partial", "summary.json"]
    );
    // Killed before any checkpoint: an unfinished run with nothing to resume.
    let err = ParquetSink::create(&files(dir), &params(), &derived(), options(7)).unwrap_err();
    assert!(
        matches!(err, StorageError::UnfinishedRunExists { .. }),
        "{err}"
    );
    let err = ParquetSink::resume::<FakeState>(&files(dir)).unwrap_err();
    assert!(matches!(err, StorageError::NoCheckpoint { .. }), "{err}");
    assert!(err.to_string().contains("nothing to resume"));
    assert!(matches!(
        read_chains(&files(dir).chains),
        Err(StorageError::NoChains { .. })
    ));
}

#[test]
fn bad_names_shapes_and_foreign_parts_are_refused() {
    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path();
    for (p, d) in [
        (vec!["a".to_string(), "a".to_string()], vec![]),
        (vec!["a".to_string()], vec!["a".to_string()]),
        (vec!["step".to_string()], vec![]),
        (vec![String::new()], vec![]),
        (vec!["a".to_string()], vec!["log_density".to_string()]),
    ] {
        let err = ParquetSink::create(&files(dir), &p, &d, options(7)).unwrap_err();
        assert!(
            matches!(err, StorageError::InvalidName { .. }),
            "{p:?} {d:?}"
        );
    }

    let mut sink =
        ParquetSink::create(&files(dir), &params(), &derived(), options(7)).expect("create");
    let s = fake_step(0, 0);
    let wrong_positions = StepView {
        ensemble: 0,
        step: 0,
        ndim: 2,
        positions: &s.positions[1..],
        log_density: &s.log_density,
        derived: &s.derived,
    };
    let err = sink.record(&wrong_positions).unwrap_err();
    assert!(
        matches!(
            err,
            StorageError::ShapeMismatch {
                what: "positions",
                ..
            }
        ),
        "{err}"
    );
    let no_derived = StepView {
        derived: &[],
        positions: &s.positions,
        ..wrong_positions
    };
    let err = sink.record(&no_derived).unwrap_err();
    assert!(
        matches!(
            err,
            StorageError::ShapeMismatch {
                what: "derived",
                ..
            }
        ),
        "{err}"
    );
    let err = sink
        .check_columns(&["alpha".to_string()], &derived())
        .unwrap_err();
    assert!(matches!(err, StorageError::SchemaMismatch { .. }), "{err}");
    produce(&mut sink, 0, 20);
    drop(sink);

    // A part of another model slipped in: resuming and reading both refuse it.
    let other_dir = tempfile::tempdir().expect("tmp");
    let mut other = ParquetSink::create(
        &files(other_dir.path()),
        &["gamma".to_string()],
        &[],
        options(7),
    )
    .expect("create");
    other
        .record(&StepView {
            ensemble: 0,
            step: 0,
            ndim: 1,
            positions: &[1.0],
            log_density: &[0.0],
            derived: &[],
        })
        .expect("record");
    other.checkpoint(&0u8).expect("checkpoint");
    other.written().expect("written");
    let foreign = other_dir.path().join("chains/part-000000.parquet");
    fs::copy(&foreign, dir.join("chains/part-000001.parquet")).expect("copy");
    assert!(matches!(
        read_chains(&files(dir).chains),
        Err(StorageError::SchemaMismatch { .. })
    ));
    fs::copy(&foreign, dir.join("chains/part-000000.parquet")).expect("copy");
    let err = ParquetSink::resume::<FakeState>(&files(dir)).unwrap_err();
    assert!(matches!(err, StorageError::SchemaMismatch { .. }), "{err}");

    // A state of another sampler does not parse.
    let err = ParquetSink::resume::<Vec<String>>(&files(other_dir.path())).unwrap_err();
    assert!(matches!(err, StorageError::BadCheckpoint { .. }), "{err}");
}

#[test]
fn missing_part_is_reported() {
    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path();
    let _ = uninterrupted(dir);
    fs::remove_file(dir.join("chains/part-000001.parquet")).expect("remove");
    let err = read_chains(&files(dir).chains).unwrap_err();
    assert!(matches!(err, StorageError::Inconsistent { .. }), "{err}");
    assert!(err.to_string().contains("part-000001.parquet"));
}

#[test]
fn write_atomically_is_public_and_replaces_files() {
    let tmp = tempfile::tempdir().expect("tmp");
    let path = tmp.path().join("report.md");
    write_atomically(&path, b"# one").expect("write");
    write_atomically(&path, b"# two").expect("write");
    assert_eq!(fs::read(&path).expect("read"), b"# two");
    assert_eq!(names_in(tmp.path()), vec!["report.md"]);
}

/// The column-at-a-time reader gives exactly what the whole-table reader gives, reads only the
/// parts it needs from a step on, and refuses rows that are not a complete grid.
#[test]
fn chain_reader_reads_one_column_like_the_whole_table() {
    let tmp = tempfile::tempdir().expect("tmp");
    let dir = tmp.path();
    let whole = uninterrupted(dir);
    let reader = slipbayes::storage::ChainReader::open(&files(dir).chains).expect("open");
    assert_eq!(
        (reader.ensembles(), reader.walkers(), reader.steps()),
        (ENSEMBLES, WALKERS, TOTAL_STEPS)
    );
    assert_eq!(reader.param_names(), whole.param_names.as_slice());
    assert_eq!(reader.derived_names(), whole.derived_names.as_slice());
    for name in whole.column_names() {
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let expected = whole.column(name).expect("column");
        assert_eq!(bits(&reader.column(name).expect("column")), bits(expected));
        // From step 37 on (parts hold 20 steps: the first is skipped, the second cut).
        let from = reader.column_from(name, 37).expect("column_from");
        assert_eq!(bits(&from), bits(&expected[reader.row(37, 0, 0)..]));
        assert_eq!(
            reader.series(name).expect("series"),
            whole.series(name).expect("series")
        );
        // Row group by row group (7 rows each, cut at step 37), every row once, in order.
        let mut chunked = Vec::new();
        reader
            .for_each_chunk::<StorageError>(&[name, "alpha"], 37, |first, chunks| {
                assert_eq!(first, reader.row(37, 0, 0) + chunked.len());
                assert!(chunks[0].len() <= 7 && chunks[0].len() == chunks[1].len());
                assert_eq!(
                    bits(&chunks[1]),
                    bits(&whole.column("alpha").unwrap()[first..][..chunks[1].len()])
                );
                chunked.extend_from_slice(&chunks[0]);
                Ok(())
            })
            .expect("chunks");
        assert_eq!(bits(&chunked), bits(&from));
        // Chosen rows, read one row group at a time.
        let rows = [3, 4, 11, reader.row(37, 1, 2), reader.rows() - 1];
        let picked: Vec<f64> = rows.iter().map(|&r| expected[r]).collect();
        assert_eq!(
            bits(&reader.rows_of(name, &rows).expect("rows")),
            bits(&picked)
        );
        assert!(reader.rows_of(name, &[]).expect("no rows").is_empty());
    }
    assert!(reader.rows_of("alpha", &[4, 3]).is_err());
    assert!(reader.rows_of("alpha", &[reader.rows()]).is_err());
    for row in [0, 1, WALKERS, ENSEMBLES * WALKERS + 3, reader.rows() - 1] {
        let (step, e, w) = reader.locate(row);
        assert_eq!(reader.row(step, e, w), row);
        assert_eq!(
            (step, e as u32, w as u32),
            (whole.step[row], whole.ensemble[row], whole.walker[row])
        );
    }
    assert!(matches!(
        reader.column("gamma"),
        Err(StorageError::ColumnMissing { column, .. }) if column == "gamma"
    ));

    // A run that skipped a walker is not a grid: the reader names the part and the row.
    let gap = tempfile::tempdir().expect("tmp");
    let mut sink =
        ParquetSink::create(&files(gap.path()), &params(), &derived(), options(7)).expect("create");
    for step in 0..3u64 {
        let s = fake_step(0, step);
        let walkers = if step == 2 { WALKERS - 1 } else { WALKERS };
        let np = params().len();
        sink.record(&StepView {
            ensemble: 0,
            step,
            ndim: np,
            positions: &s.positions[..walkers * np],
            log_density: &s.log_density[..walkers],
            derived: &s.derived[..walkers],
        })
        .expect("record");
    }
    sink.finish().expect("finish");
    let err = slipbayes::storage::ChainReader::open(&files(gap.path()).chains).unwrap_err();
    assert!(matches!(err, StorageError::Inconsistent { .. }), "{err}");
    assert!(err.to_string().contains("whole steps"), "{err}");
}
