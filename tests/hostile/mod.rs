//! Every parser of slipbayes fed hostile bytes: one function per target, shared by the
//! cargo-fuzz targets (fuzz/) and the seeded mutation tests of the ordinary suite
//! (tests/hostile_inputs.rs), so both check the same promises.
//!
//! Each target must return normally whatever the bytes: a parser either reads them or
//! refuses them with an error that names the file it was given. A target panics (a finding)
//! only when that promise breaks.

#![allow(dead_code)]

use std::fs;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use slipbayes::data::import::import_bytes;
use slipbayes::data::{Format, ImportOptions, Imported, IntervalChoice, Series};
use slipbayes::fit::RunDir;
use slipbayes::model::spec::ModelFile;
use slipbayes::run_file::{RunFile, SamplerSpec};
use slipbayes::storage::{
    read_part_metadata, verify_run, ChainReader, ChainSink, ParquetSink, SinkOptions, StepView,
};

/// The targets, by name (the name of each fuzz target and of its seed folder).
pub const TARGETS: &[&str] = &[
    "csv",
    "simple_csv",
    "rheocompass",
    "trios",
    "rspace",
    "parquet",
    "model_toml",
    "model_dict",
    "run_files",
    "checkpoint",
    "chain_part",
];

/// Runs target `name` on `data` as a fuzz target does: in a scratch directory of the process
/// under the system's temporary directory, made on the first call.
pub fn fuzz(name: &str, data: &[u8]) {
    static SCRATCH: std::sync::OnceLock<Scratch> = std::sync::OnceLock::new();
    let scratch = SCRATCH.get_or_init(|| {
        let dir =
            std::env::temp_dir().join(format!("slipbayes-fuzz-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        fs::create_dir_all(&dir).unwrap();
        Scratch::new(&dir)
    });
    run(name, scratch, data);
}

/// Runs target `name` on `data` in the scratch directory `scratch`.
pub fn run(name: &str, scratch: &Scratch, data: &[u8]) {
    match name {
        "csv" => import(Format::Csv, "fuzz.csv", data),
        "simple_csv" => simple_csv(data),
        "rheocompass" => import(Format::Rheocompass, "fuzz.txt", data),
        "trios" => import(Format::Trios, "fuzz.txt", data),
        "rspace" => import(Format::Rspace, "fuzz.csv", data),
        "parquet" => import(Format::Parquet, "fuzz.parquet", data),
        "model_toml" => model_toml(data),
        "model_dict" => model_dict(data),
        "run_files" => run_files(scratch, data),
        "checkpoint" => checkpoint(scratch, data),
        "chain_part" => chain_part(scratch, data),
        other => panic!("no hostile-input target {other:?}"),
    }
}

/// Asserts that a refusal names the file it was given.
fn names(error: &dyn std::fmt::Display, file: &str) {
    let message = error.to_string();
    assert!(
        message.contains(file),
        "an error that does not name {file}: {message}"
    );
}

/// Any bytes through an importer with the format given (the first byte picks the options, so
/// one corpus explores all of them): an error naming the file, or a series that satisfies
/// the importer's promises.
pub fn import(format: Format, file: &str, data: &[u8]) {
    let (choice, bytes) = data.split_first().map_or((0, data), |(c, rest)| (*c, rest));
    let options = ImportOptions {
        format: Some(format),
        drop_invalid: choice & 1 == 1,
        intervals: match choice >> 1 & 3 {
            0 => IntervalChoice::All,
            1 => IntervalChoice::Numbers(vec![1]),
            2 => IntervalChoice::Numbers(vec![2]),
            _ => IntervalChoice::Numbers(vec![1, 2]),
        },
        ..ImportOptions::default()
    };
    match import_bytes(bytes, Path::new(file), &options) {
        Ok(imported) => check_import(&imported),
        Err(e) => names(&e, file),
    }
}

/// What every import that succeeds must promise, whatever the bytes were.
pub fn check_import(imported: &Imported) {
    let s = &imported.series;
    assert!(!s.is_empty());
    assert!(s.time_s.windows(2).all(|w| w[0] < w[1]));
    assert!(s.time_s.iter().chain(&s.force_n).all(|v| v.is_finite()));
    assert_eq!(imported.lines.len(), s.len());
    assert_eq!(imported.points_read, s.len() + imported.dropped_invalid);
}

/// Any text through the reader of slipbayes' own CSV: an error naming the file or a series;
/// a series read is written back and read again to the same numbers, bit for bit.
pub fn simple_csv(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match Series::parse_csv(text, Path::new("fuzz.csv")) {
        Ok(series) => {
            let again =
                Series::parse_csv(&series.to_csv().unwrap(), Path::new("again.csv")).unwrap();
            // Bit-exact for numbers; a NaN stays a NaN (its sign and payload are not promised).
            let same = |a: &[f64], b: &[f64]| {
                a.len() == b.len()
                    && a.iter()
                        .zip(b)
                        .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
            };
            assert!(same(&series.time_s, &again.time_s));
            assert!(same(&series.force_n, &again.force_n));
        }
        Err(e) => names(&e, "fuzz.csv"),
    }
}

/// Any text as a model file: validated or refused naming the file.
pub fn model_toml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let source = PathBuf::from("fuzz-model.toml");
    if let Err(e) = RunFile::parse_in(text, PathBuf::from("data"), source) {
        names(&e, "fuzz-model.toml");
    }
}

/// Any JSON as the Python package's model dict, through what its conversion calls: the
/// `[sampler]` table and the model's tables deserialised from the JSON value, then
/// [`RunFile::new`], which validates both as a model file's.
pub fn model_dict(data: &[u8]) {
    let Ok(value) = serde_json::from_slice::<serde_json::Value>(data) else {
        return;
    };
    let sampler = match value.get("sampler") {
        None => SamplerSpec::default(),
        Some(table) => match serde_json::from_value(table.clone()) {
            Ok(s) => s,
            Err(_) => return,
        },
    };
    let Ok(file) = serde_json::from_value::<ModelFile>(value) else {
        return;
    };
    let source = PathBuf::from("data/<model dict>");
    if let Err(e) = RunFile::new(file, sampler, PathBuf::from("data"), source) {
        names(&e, "<model dict>");
    }
}

/// A scratch directory of a target: a run directory whose files the targets overwrite, and
/// the bytes of a small chain store (two checkpointed parts) they restore before each input.
pub struct Scratch {
    dir: PathBuf,
    /// The parts of the template store, by number.
    parts: Vec<Vec<u8>>,
    /// The template's checkpoint (a seed of the `checkpoint` target).
    pub checkpoint: Vec<u8>,
}

/// The sampler state of the template store.
#[derive(Debug, Serialize, Deserialize)]
pub struct TemplateState {
    /// The step the run continues from.
    pub next_step: u64,
    walkers: Vec<f64>,
}

/// Walkers of the template store.
const WALKERS: usize = 4;

impl Scratch {
    /// Builds the template store in `dir` (created if need be; the caller removes it).
    pub fn new(dir: &Path) -> Self {
        let run = RunDir::new(dir);
        let files = run.chain_files();
        let options = SinkOptions {
            row_group_rows: 6,
            overwrite: true,
        };
        let names = vec!["alpha".to_owned(), "beta_per_s".to_owned()];
        let mut sink = ParquetSink::create(&files, &names, &["t0_s".to_owned()], options).unwrap();
        for step in 0..6u64 {
            let x = step as f64;
            let positions: Vec<f64> = (0..2 * WALKERS).map(|i| x + i as f64 * 0.25).collect();
            let log_density: Vec<f64> = (0..WALKERS).map(|i| -x - i as f64).collect();
            let derived: Vec<f64> = (0..WALKERS).map(|i| 1e3 * x + i as f64).collect();
            sink.record(&StepView {
                ensemble: 0,
                step,
                ndim: 2,
                positions: &positions,
                log_density: &log_density,
                derived: &derived,
            })
            .unwrap();
            if step % 3 == 2 {
                let state = TemplateState {
                    next_step: step + 1,
                    walkers: positions,
                };
                sink.checkpoint(&state).unwrap();
            }
        }
        drop(sink);
        let parts = (0..2)
            .map(|i| fs::read(files.chains.join(format!("part-{i:06}.parquet"))).unwrap())
            .collect();
        let checkpoint = fs::read(&files.checkpoint).unwrap();
        Self {
            dir: dir.to_path_buf(),
            parts,
            checkpoint,
        }
    }

    /// The first part of the template store (a seed of the `chain_part` target).
    pub fn part(&self) -> &[u8] {
        &self.parts[0]
    }

    /// The run directory, with the template store's parts restored and no checkpoint.
    pub fn fresh(&self) -> RunDir {
        let run = RunDir::new(&self.dir);
        let files = run.chain_files();
        let _ = fs::remove_file(&files.checkpoint);
        fs::create_dir_all(&files.chains).unwrap();
        for entry in fs::read_dir(&files.chains).unwrap() {
            fs::remove_file(entry.unwrap().path()).unwrap();
        }
        for (i, bytes) in self.parts.iter().enumerate() {
            fs::write(files.chains.join(format!("part-{i:06}.parquet")), bytes).unwrap();
        }
        run
    }
}

/// Any bytes as the checkpoint of a run whose parts are intact: checked by the readers'
/// verification and by a resume; each refuses naming the checkpoint or a part, or accepts.
///
/// A random change of a sealed checkpoint fails its checksum, so the decoding behind the seal
/// would rarely be reached: with the first byte odd, the rest is sealed as the sink seals a
/// checkpoint (a CRC-32 and the marker appended), and decoded as if the sink had written it.
pub fn checkpoint(scratch: &Scratch, data: &[u8]) {
    let run = scratch.fresh();
    let files = run.chain_files();
    match data.split_first() {
        Some((choice, body)) if choice & 1 == 1 => {
            let mut sealed = body.to_vec();
            sealed.extend_from_slice(&crc32(body).to_le_bytes());
            sealed.extend_from_slice(b"SBCRC32\n");
            fs::write(&files.checkpoint, sealed).unwrap();
        }
        _ => fs::write(&files.checkpoint, data).unwrap(),
    }
    if let Err(e) = verify_run(&files) {
        names_one_of(&e, &["checkpoint.bin", "part-"]);
    }
    match ParquetSink::resume::<TemplateState>(&files) {
        // The state is opaque to the store (a fit checks its step against the chains).
        Ok((sink, _)) => drop(sink),
        Err(e) => names_one_of(&e, &["checkpoint.bin", "part-", "chains"]),
    }
}

/// Any bytes as a complete chain part (no checkpoint: what a reader of the chains directory
/// alone sees): its footer, metadata and every column read, or refused naming the part.
pub fn chain_part(scratch: &Scratch, data: &[u8]) {
    let run = scratch.fresh();
    let files = run.chain_files();
    let path = files.chains.join("part-000000.parquet");
    fs::write(&path, data).unwrap();
    let _ = fs::remove_file(files.chains.join("part-000001.parquet"));
    if let Err(e) = read_part_metadata(&path) {
        names(&e, "part-000000.parquet");
    }
    let reader = match ChainReader::open(&files.chains) {
        Ok(reader) => reader,
        Err(e) => return names_one_of(&e, &["part-000000.parquet", "chains"]),
    };
    let columns = ["alpha", "beta_per_s", "log_density", "t0_s"];
    for name in columns {
        if let Err(e) = reader.column(name) {
            names_one_of(&e, &["part-000000.parquet", "chains"]);
        }
    }
    let _ = reader.metadata();
    let visit =
        reader.for_each_chunk::<slipbayes::storage::StorageError>(&columns, 0, |_, _| Ok(()));
    if let Err(e) = visit {
        names_one_of(&e, &["part-000000.parquet", "chains"]);
    }
}

/// Any bytes as one of the files of a run directory that `report` and `load` read back (the
/// first byte picks which): read, or refused naming the file.
pub fn run_files(scratch: &Scratch, data: &[u8]) {
    let (choice, bytes) = data.split_first().map_or((0, data), |(c, rest)| (*c, rest));
    let run = RunDir::new(&scratch.dir);
    let files = run.chain_files();
    let _ = fs::remove_file(&files.checkpoint);
    let file = RUN_FILES[choice as usize % RUN_FILES.len()];
    fs::write(run.file(file), bytes).unwrap();
    let result = match file {
        "summary.json" => run.read_summary().map(drop),
        "settings.json" => run.read_record().map(drop),
        "curves.json" => run.read_curves().map(drop),
        "truth.json" => run.read_truths().map(drop),
        "predictive.csv" => run.read_predictive().map(drop),
        "loo.csv" => run.read_loo().map(drop),
        "kfold.csv" => run.read_kfold().map(drop),
        other => unreachable!("{other}"),
    };
    if let Err(e) = result {
        names(&e, file);
    }
}

/// The files of a run directory [`run_files`] fuzzes, by the first byte of its input.
pub const RUN_FILES: &[&str] = &[
    "summary.json",
    "settings.json",
    "curves.json",
    "truth.json",
    "predictive.csv",
    "loo.csv",
    "kfold.csv",
];

fn names_one_of(error: &dyn std::fmt::Display, files: &[&str]) {
    let message = error.to_string();
    assert!(
        files.iter().any(|f| message.contains(f)),
        "an error that names none of {files:?}: {message}"
    );
}

/// CRC-32 (IEEE 802.3), bit by bit: what a checkpoint's trailer holds.
fn crc32(bytes: &[u8]) -> u32 {
    let mut c = !0u32;
    for &b in bytes {
        c ^= u32::from(b);
        for _ in 0..8 {
            c = if c & 1 == 1 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
        }
    }
    !c
}
