//! The run directory: the one place that names, writes and reads every file of a fit.
//!
//! ```text
//! DIR/model.toml          the exact model fitted (data paths relative to `data_dir`)
//! DIR/settings.json       how it was run: version, command, settings, coordinates, priors
//! DIR/summary.json        parameters, derived quantities, aggregates, comparisons, sampler
//! DIR/summary.csv         one row per parameter and derived quantity (ArviZ's columns)
//! DIR/predictive.csv      posterior and posterior predictive bands at the data times
//! DIR/curves.json         the law in interface time and the peak against t0, redrawn
//! DIR/truth.json          the simulations behind synthetic data, when there are any
//! DIR/loo.csv             each observation's PSIS-LOO predictive density and Pareto k̂
//! DIR/kfold.csv           each observation's K-fold predictive density (`slipbayes kfold`)
//! DIR/kfold/fold-J/       the run directory of each fold's fit (`slipbayes kfold`)
//! DIR/chains/*.parquet    the draws (see crate::storage)
//! DIR/checkpoint.bin      the sampler state of the last checkpoint (MessagePack)
//! DIR/report.html         the report (crate::report), with report.md and figures/*.svg
//! DIR/.slipbayes.lock     held while a fit writes the directory ([`RunLock`])
//! DIR/.slipbayes-run      the marker: slipbayes wrote this directory ([`RUN_OUTPUT`])
//! ```
//!
//! Every command that writes a run directory claims it first ([`OutputDir::claim`](crate::output_dir::OutputDir::claim) with
//! [`RUN_OUTPUT`]): a new, empty or marked directory, or a run of an earlier release, else
//! only with `--overwrite`, and then only these files are written.
//!
//! A fit writes the first ten ([`crate::fit::run_fit`], [`crate::fit::fit_model`]); the
//! report reads them back through the same types ([`FitSummary`], [`RunRecord`], [`Band`],
//! [`Curves`], [`RunTruth`]), and nothing outside the directory, and writes the last three.
//! Every file is written atomically: a reader never sees half of one.

mod csv;
mod curves;
mod kfold;
mod lock;
mod loo;
mod predictive;
mod record;
mod summary;

use std::path::{Path, PathBuf};

use super::RunFile;
use crate::data::write_atomically;
use crate::model::{Band, SpecError};
use crate::output_dir::OutputKind;
use crate::storage::{
    read_chains_at_checkpoint, seal_json, verify_run, verify_sealed_json, ChainFiles, ChainReader,
    Chains, Integrity, StorageError,
};
use crate::IoError;

pub(crate) use csv::summary_csv;
pub use csv::CSV_COLUMNS;
pub use curves::{Curves, InterfaceCurve, PeakVsT0, RunCurves, RunTruth};
pub use kfold::{KFoldPoint, KFoldSummary, RunKFold, KFOLD_HEADER};
pub use lock::{LockError, RunLock, LOCK_FILE};
pub use loo::{LooPoint, LooSummary, RunLoo, LOO_HEADER};
pub(crate) use predictive::to_csv as predictive_csv;
pub use predictive::PREDICTIVE_HEADER;
pub(crate) use record::relative_path;
pub use record::RunRecord;
pub use summary::{
    AggregateSummary, Comparison, FitSummary, ForwardModelRecord, QuantitySummary, SamplerSummary,
};

/// The exact model fitted.
pub const MODEL_TOML: &str = "model.toml";
/// How the fit was run.
pub const SETTINGS_JSON: &str = "settings.json";
/// The posterior summary as JSON.
pub const SUMMARY_JSON: &str = "summary.json";
/// The posterior summary as CSV.
pub const SUMMARY_CSV: &str = "summary.csv";
/// The posterior and posterior predictive bands.
pub const PREDICTIVE_CSV: &str = "predictive.csv";
/// The curves a report draws that the data do not sample.
pub const CURVES_JSON: &str = "curves.json";
/// The simulations behind synthetic data.
pub const TRUTH_JSON: &str = "truth.json";
/// Each observation's leave-one-out predictive density and Pareto k̂.
pub const LOO_CSV: &str = "loo.csv";
/// Each observation's K-fold cross-validated predictive density (`slipbayes kfold`).
pub const KFOLD_CSV: &str = "kfold.csv";
/// The folder of complete chain parts.
pub const CHAINS_DIR: &str = "chains";
/// The sampler state of the last checkpoint (binary; earlier releases wrote
/// `checkpoint.json`, which a resume still reads).
pub const CHECKPOINT: &str = "checkpoint.bin";
/// The JSON checkpoint of earlier releases, which a resume still reads.
pub const LEGACY_CHECKPOINT: &str = "checkpoint.json";
/// The folder of the folds' run directories (`slipbayes kfold`).
pub const KFOLD_DIR: &str = "kfold";
/// The folder of the data the Python `fit` was given as arrays.
pub const DATA_DIR: &str = "data";
/// The HTML report.
pub const REPORT_HTML: &str = "report.html";
/// The Markdown report.
pub const REPORT_MD: &str = "report.md";
/// The folder of the report's SVG figures.
pub const FIGURES_DIR: &str = "figures";

/// The entries of a run directory that `fit`, `demo`, `report`, `kfold` and the Python `fit`
/// write (the report's, the folds' of `kfold`, the lock, and the JSON checkpoint of earlier
/// releases, which a resume replaces), then `extra`.
macro_rules! run_files {
    ($($extra:expr),*) => {
        &[
            MODEL_TOML,
            SETTINGS_JSON,
            SUMMARY_JSON,
            SUMMARY_CSV,
            PREDICTIVE_CSV,
            CURVES_JSON,
            TRUTH_JSON,
            LOO_CSV,
            KFOLD_CSV,
            KFOLD_DIR,
            CHAINS_DIR,
            CHECKPOINT,
            LEGACY_CHECKPOINT,
            REPORT_HTML,
            REPORT_MD,
            FIGURES_DIR,
            LOCK_FILE,
            $($extra),*
        ]
    };
}

/// Every entry of a run directory that the command line writes.
const RUN_FILES: &[&str] = run_files!();

/// A run directory as an output directory
/// ([`OutputDir::claim`](crate::output_dir::OutputDir::claim)): what every command that
/// writes one claims it as.
pub const RUN_OUTPUT: OutputKind = OutputKind {
    name: "run",
    writes: RUN_FILES,
    // Chain parts being written: `part-000002.parquet.partial`.
    writes_prefixed: &["part-"],
    written_before_markers: holds_run_layout,
};

/// A run directory of the Python `fit`, which also writes the data given as arrays into
/// `data/`: the same kind as [`RUN_OUTPUT`], so either front end continues the other's runs.
pub const PYTHON_RUN_OUTPUT: OutputKind = OutputKind {
    writes: PYTHON_RUN_FILES,
    ..RUN_OUTPUT
};

const PYTHON_RUN_FILES: &[&str] = run_files!(DATA_DIR);

/// Whether `dir`, which carries no marker, is a run directory of a release that wrote none,
/// so that it stays resumable and reportable: it holds a checkpoint (`checkpoint.bin`, or the
/// `checkpoint.json` of earlier releases), or a chain part (`chains/part-NNNNNN.parquet`), or
/// a `settings.json` that is a run record (a JSON object with `slipbayes_version` and
/// `settings`, which a fit writes last: the committed example report has no chains). A
/// user's own `summary.json` or `report.html` is none of these.
fn holds_run_layout(dir: &Path) -> bool {
    let has_checkpoint = [CHECKPOINT, LEGACY_CHECKPOINT]
        .iter()
        .any(|name| dir.join(name).is_file());
    let has_part = std::fs::read_dir(dir.join(CHAINS_DIR)).is_ok_and(|entries| {
        entries.flatten().any(|e| {
            e.file_name().to_str().is_some_and(|n| {
                n.strip_prefix("part-")
                    .and_then(|n| n.strip_suffix(".parquet"))
                    .is_some_and(|digits| {
                        !digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit())
                    })
            })
        })
    });
    let has_record = std::fs::read(dir.join(SETTINGS_JSON))
        .ok()
        .and_then(|bytes| serde_json::from_slice::<serde_json::Value>(&bytes).ok())
        .is_some_and(|v| v.get("slipbayes_version").is_some() && v.get("settings").is_some());
    has_checkpoint || has_part || has_record
}

/// What went wrong reading or writing a file of a run directory; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum RunDirError {
    /// A file of the run could not be read.
    #[error("{0}; is this a finished run directory (slipbayes fit --out)?")]
    Read(#[source] IoError),
    /// A file is malformed.
    #[error("{}: {message}", path.display())]
    Parse {
        /// The file.
        path: PathBuf,
        /// Where and what.
        message: String,
    },
    /// A file could not be written (or a stale one removed).
    #[error(transparent)]
    Io(#[from] IoError),
    /// The model recorded in the directory is no longer valid.
    #[error("loading the model of the run from {}: {message}", path.display())]
    Model {
        /// `model.toml`.
        path: PathBuf,
        /// The cause and what to do.
        message: String,
    },
    /// The run was replaced while it was read (a fit with `--overwrite` began).
    #[error(
        "the run in {} changed while it was read ({problem}): a fit is writing it; read it \
         again when the fit ends",
        dir.display()
    )]
    Changed {
        /// The run directory.
        dir: PathBuf,
        /// What no longer matches.
        problem: String,
    },
    /// A file of the run does not match the checksum the run recorded for it.
    #[error(transparent)]
    Corrupt(StorageError),
    /// The chains could not be read.
    #[error("reading the chains of {}", dir.display())]
    Chains {
        /// The run directory.
        dir: PathBuf,
        /// The cause.
        #[source]
        source: StorageError,
    },
}

/// A run directory: where a fit writes and from where a report reads.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RunDir {
    path: PathBuf,
}

impl RunDir {
    /// The run directory at `path` (nothing is created or read yet).
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self { path: path.into() }
    }

    /// The directory itself.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A file of the directory, by one of this module's names.
    pub fn file(&self, name: &str) -> PathBuf {
        self.path.join(name)
    }

    /// Where the chain store keeps its parts and checkpoint.
    pub fn chain_files(&self) -> ChainFiles {
        ChainFiles {
            dir: self.path.clone(),
            chains: self.file(CHAINS_DIR),
            checkpoint: self.file(CHECKPOINT),
        }
    }

    /// The chains, read back into memory after checking them against the checkpoint: those
    /// of the last checkpoint while a fit writes the directory (see [`RunDir::chain_reader`]).
    ///
    /// # Errors
    /// [`RunDirError::Chains`] when they cannot be read or do not match their checksums.
    pub fn read_chains(&self) -> Result<Chains, RunDirError> {
        let files = self.chain_files();
        verify_run(&files)
            .and_then(|_| read_chains_at_checkpoint(&files))
            .map_err(|source| RunDirError::Chains {
                dir: self.path.clone(),
                source,
            })
    }

    /// The chains of the run, to be read one column or one row group at a time: the parts
    /// its checkpoint counts, so that a reader of a directory a fit is writing (`report`,
    /// `slipbayes.load`) reads the last checkpoint's chains, whole, and never a part the fit
    /// wrote after it; once the fit finished, every part.
    ///
    /// # Errors
    /// [`RunDirError::Chains`] when they cannot be opened or are not a complete grid of steps,
    /// ensembles and walkers.
    pub fn chain_reader(&self) -> Result<ChainReader, RunDirError> {
        ChainReader::open_run(&self.chain_files()).map_err(|source| RunDirError::Chains {
            dir: self.path.clone(),
            source,
        })
    }

    /// The chains of the finished run that `summary` (its `summary.json`, read first) sums
    /// up, checked to be that run's: as many steps, and the burn-in it chose in every part's
    /// footer. A reader that read the summary of a run that a fit then began to replace
    /// (`--overwrite`) gets [`RunDirError::Changed`] instead of the new run's chains.
    ///
    /// # Errors
    /// [`RunDirError::Chains`] as [`RunDir::chain_reader`]; [`RunDirError::Changed`] when the
    /// chains are not those of `summary`.
    pub fn finished_chain_reader(&self, summary: &FitSummary) -> Result<ChainReader, RunDirError> {
        let reader = self.chain_reader()?;
        let sampler = &summary.sampler;
        let changed = |problem: String| RunDirError::Changed {
            dir: self.path.clone(),
            problem,
        };
        if reader.steps() != sampler.steps {
            return Err(changed(format!(
                "{SUMMARY_JSON} sums up {} steps, the chains hold {}",
                sampler.steps,
                reader.steps()
            )));
        }
        let metadata = reader.metadata().map_err(|source| RunDirError::Chains {
            dir: self.path.clone(),
            source,
        })?;
        // Runs of releases that wrote no footer metadata carry no burn-in to compare.
        if let Some(burn_in) = metadata.map(|m| m.burn_in) {
            if burn_in != Some(sampler.burn_in) {
                return Err(changed(format!(
                    "{SUMMARY_JSON} has burn-in {}, the chains {burn_in:?}",
                    sampler.burn_in
                )));
            }
        }
        Ok(reader)
    }

    /// Writes `bytes` to the file `name` of the directory, atomically.
    ///
    /// # Errors
    /// [`RunDirError::Io`] naming the file.
    pub fn write(&self, name: &str, bytes: &[u8]) -> Result<PathBuf, RunDirError> {
        let path = self.file(name);
        write_atomically(&path, bytes).map_err(IoError::at("write", &path))?;
        Ok(path)
    }

    /// Reads the text of the file `name`.
    ///
    /// # Errors
    /// [`RunDirError::Read`] naming the file.
    pub fn read(&self, name: &str) -> Result<String, RunDirError> {
        let path = self.file(name);
        std::fs::read_to_string(&path)
            .map_err(|e| RunDirError::Read(IoError::new("read", &path, e)))
    }

    /// Writes `summary.json` and `summary.csv`.
    ///
    /// # Errors
    /// [`RunDirError::Io`] naming the file.
    pub fn write_summary(&self, summary: &FitSummary) -> Result<(), RunDirError> {
        let json = serde_json::to_vec_pretty(summary).map_err(|e| RunDirError::Parse {
            path: self.file(SUMMARY_JSON),
            message: format!("cannot serialise the summary: {e}"),
        })?;
        self.write(SUMMARY_JSON, &seal_json(&json))?;
        self.write(SUMMARY_CSV, summary_csv(summary).as_bytes())?;
        Ok(())
    }

    /// `summary.json`, checked against its checksum.
    ///
    /// # Errors
    /// [`RunDirError::Read`] or [`RunDirError::Parse`] naming the file and line;
    /// [`RunDirError::Corrupt`] when it does not match its checksum.
    pub fn read_summary(&self) -> Result<FitSummary, RunDirError> {
        Ok(self.read_summary_verified()?.0)
    }

    /// `summary.json` and whether it was proved to be the one written.
    ///
    /// # Errors
    /// As [`RunDir::read_summary`].
    pub fn read_summary_verified(&self) -> Result<(FitSummary, Integrity), RunDirError> {
        let path = self.file(SUMMARY_JSON);
        let text = self.read(SUMMARY_JSON)?;
        let integrity =
            verify_sealed_json(&self.chain_files(), &path, &text).map_err(RunDirError::Corrupt)?;
        Ok((parse_json(&path, &text)?, integrity))
    }

    /// Removes the summaries of an earlier run, which must not survive next to new chains.
    ///
    /// # Errors
    /// [`RunDirError::Io`] when a summary exists but cannot be removed.
    pub(crate) fn remove_summaries(&self) -> Result<(), RunDirError> {
        for name in [SUMMARY_JSON, SUMMARY_CSV] {
            let path = self.file(name);
            match std::fs::remove_file(&path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => return Err(IoError::new("remove", path, e).into()),
            }
        }
        Ok(())
    }

    /// Writes `model.toml`: the run file as fitted, with a header saying where its data paths
    /// are relative to.
    ///
    /// # Errors
    /// [`RunDirError::Io`] naming the file.
    pub(crate) fn write_model(&self, run: &RunFile) -> Result<(), RunDirError> {
        let spec = &run.model;
        let model = run.to_toml().map_err(|e| RunDirError::Parse {
            path: self.file(MODEL_TOML),
            message: format!("cannot serialise the model: {e}"),
        })?;
        let header = format!(
            "# The exact model fitted (from {}); data paths are relative to {}.\n",
            spec.source.display(),
            spec.base_dir.display()
        );
        self.write(MODEL_TOML, format!("{header}{model}").as_bytes())?;
        Ok(())
    }

    /// The run file of the run: its `model.toml`, with data paths resolved against the directory
    /// `settings.json` records (`data_dir`, relative to the run directory), or, for runs that
    /// predate it, against the directory of the model file it names.
    ///
    /// # Errors
    /// [`RunDirError::Read`] or [`RunDirError::Parse`] for a missing or malformed file;
    /// [`RunDirError::Model`] when the model is invalid.
    pub fn read_model(&self) -> Result<RunFile, RunDirError> {
        let record = self.read_record()?;
        let base_dir = match &record.data_dir {
            Some(d) => self.path.join(d),
            None => Path::new(&record.model_file)
                .parent()
                .map(Path::to_path_buf)
                .unwrap_or_default(),
        };
        let path = self.file(MODEL_TOML);
        RunFile::parse_in(&self.read(MODEL_TOML)?, base_dir, path.clone()).map_err(|e| match e {
            SpecError::Syntax { message, .. } => RunDirError::Parse { path, message },
            other => RunDirError::Model {
                path,
                message: other.to_string(),
            },
        })
    }

    /// Writes `settings.json`.
    ///
    /// # Errors
    /// [`RunDirError::Io`] naming the file.
    pub(crate) fn write_record(&self, record: &RunRecord) -> Result<(), RunDirError> {
        let json = serde_json::to_string_pretty(record).map_err(|e| RunDirError::Parse {
            path: self.file(SETTINGS_JSON),
            message: format!("cannot serialise the run record: {e}"),
        })?;
        self.write(SETTINGS_JSON, json.as_bytes())?;
        Ok(())
    }

    /// `settings.json`.
    ///
    /// # Errors
    /// [`RunDirError::Read`] or [`RunDirError::Parse`] naming the file and line.
    pub fn read_record(&self) -> Result<RunRecord, RunDirError> {
        parse_json(&self.file(SETTINGS_JSON), &self.read(SETTINGS_JSON)?)
    }

    /// Writes `predictive.csv`.
    ///
    /// # Errors
    /// [`RunDirError::Io`] naming the file.
    pub(crate) fn write_predictive(&self, bands: &[Band]) -> Result<(), RunDirError> {
        self.write(PREDICTIVE_CSV, predictive::to_csv(bands).as_bytes())?;
        Ok(())
    }

    /// Writes `loo.csv`.
    ///
    /// # Errors
    /// [`RunDirError::Io`] naming the file.
    pub(crate) fn write_loo(&self, points: &[LooPoint]) -> Result<(), RunDirError> {
        self.write(LOO_CSV, loo::to_csv(points).as_bytes())?;
        Ok(())
    }

    /// `loo.csv`, one row per observation.
    ///
    /// # Errors
    /// [`RunDirError::Read`], or [`RunDirError::Parse`] naming the line and column.
    pub fn read_loo(&self) -> Result<Vec<LooPoint>, RunDirError> {
        let path = self.file(LOO_CSV);
        loo::parse(&path, &self.read(LOO_CSV)?)
    }

    /// Writes `kfold.csv`.
    ///
    /// # Errors
    /// [`RunDirError::Io`] naming the file.
    pub fn write_kfold(&self, points: &[KFoldPoint]) -> Result<(), RunDirError> {
        self.write(KFOLD_CSV, kfold::to_csv(points).as_bytes())?;
        Ok(())
    }

    /// `kfold.csv`, one row per observation.
    ///
    /// # Errors
    /// [`RunDirError::Read`], or [`RunDirError::Parse`] naming the line and column.
    pub fn read_kfold(&self) -> Result<Vec<KFoldPoint>, RunDirError> {
        let path = self.file(KFOLD_CSV);
        kfold::parse(&path, &self.read(KFOLD_CSV)?)
    }

    /// Writes `curves.json`.
    ///
    /// # Errors
    /// [`RunDirError::Io`] naming the file.
    pub(crate) fn write_curves(&self, curves: &Curves) -> Result<(), RunDirError> {
        // Long arrays of numbers: on one line, half the size of pretty JSON.
        self.write_json(CURVES_JSON, curves, false)
    }

    /// `curves.json`.
    ///
    /// # Errors
    /// [`RunDirError::Read`] or [`RunDirError::Parse`] naming the file and line.
    pub fn read_curves(&self) -> Result<Curves, RunDirError> {
        parse_json(&self.file(CURVES_JSON), &self.read(CURVES_JSON)?)
    }

    /// Writes `truth.json` (an empty list when no run's data are synthetic).
    ///
    /// # Errors
    /// [`RunDirError::Io`] naming the file.
    pub(crate) fn write_truths(&self, truths: &[RunTruth]) -> Result<(), RunDirError> {
        self.write_json(TRUTH_JSON, &truths, true)
    }

    /// `truth.json`.
    ///
    /// # Errors
    /// [`RunDirError::Read`] or [`RunDirError::Parse`] naming the file and line.
    pub fn read_truths(&self) -> Result<Vec<RunTruth>, RunDirError> {
        parse_json(&self.file(TRUTH_JSON), &self.read(TRUTH_JSON)?)
    }

    /// Writes `value` as JSON, `pretty` or on one line, with a final line end.
    fn write_json<T: serde::Serialize + ?Sized>(
        &self,
        name: &str,
        value: &T,
        pretty: bool,
    ) -> Result<(), RunDirError> {
        let json = if pretty {
            serde_json::to_vec_pretty(value)
        } else {
            serde_json::to_vec(value)
        };
        let mut json = json.map_err(|e| RunDirError::Parse {
            path: self.file(name),
            message: format!("cannot serialise: {e}"),
        })?;
        json.push(b'\n');
        self.write(name, &json)?;
        Ok(())
    }

    /// `predictive.csv`, one band per run in file order.
    ///
    /// # Errors
    /// [`RunDirError::Read`], or [`RunDirError::Parse`] naming the line and column.
    pub fn read_predictive(&self) -> Result<Vec<Band>, RunDirError> {
        let path = self.file(PREDICTIVE_CSV);
        predictive::parse(&path, &self.read(PREDICTIVE_CSV)?)
    }
}

fn parse_json<T: serde::de::DeserializeOwned>(path: &Path, text: &str) -> Result<T, RunDirError> {
    serde_json::from_str(text).map_err(|e| RunDirError::Parse {
        path: path.to_path_buf(),
        message: format!("line {}, column {}: {e}", e.line(), e.column()),
    })
}
