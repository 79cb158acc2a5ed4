//! Chains streamed to Parquet, checkpoints for resuming, and atomic output files.
//!
//! The sampler hands draws to a [`ParquetSink`] through the [`ChainSink`] contract; the
//! summaries and reports read them back with [`ChainReader`], one row group of the columns
//! they need at a time ([`ChainReader::for_each_chunk`], [`ChainReader::rows_of`]). This part knows nothing of friction or of
//! how draws are made: it stores rows and an opaque, serialisable sampler state, in the files
//! its caller names ([`ChainFiles`]; a fit's run directory names them, see
//! [`crate::fit::RunDir`]).
//!
//! # The files of a chain store
//!
//! ```text
//! <chains>/part-000000.parquet        complete parts only: one per checkpoint interval
//! <chains>/part-000001.parquet
//! <dir>/part-000002.parquet.partial   the part being written (never inside <chains>)
//! <checkpoint>                        names, durable parts/rows/steps, sampler state, finished
//! ```
//!
//! - Every part has the columns `ensemble` (u32), `walker` (u32), `step` (u64), one f64 column
//!   per parameter (named), `log_density` (f64), then one f64 column per derived value, all
//!   non-nullable, Snappy-compressed, in row groups of at most [`SinkOptions::row_group_rows`]
//!   rows. Rows are in recording order: step, then ensemble, then walker.
//! - Every part's footer carries key–value metadata (keys `slipbayes.*`, see [`metadata`]):
//!   the row layout and which index is a chain for R̂ and for ESS, every column's kind, SI
//!   unit and scale (ln or natural), the part's steps, the seed, ensembles, walkers and
//!   thinning, and, once the run has finished, its burn-in (`pending` before).
//! - A part is written under a `.partial` name in `<dir>` and renamed into `<chains>` only
//!   when complete (footer written, file fsynced, then `<chains>` fsynced), so `<chains>`
//!   never holds a half-written file and can be read as one table by polars
//!   (`pl.read_parquet("<chains>/*.parquet")`), pandas or pyarrow (`read_table("<chains>")`).
//! - [`ChainSink::checkpoint`] closes the current part, then replaces the checkpoint
//!   atomically. The parts it counts, and the state it holds, are what a resumed run continues
//!   from; parts numbered beyond it (written after the last checkpoint of a killed run) and
//!   `.partial` files are removed by [`ParquetSink::resume`].
//! - [`ParquetSink::finish`] closes the last part and marks the checkpoint finished; a
//!   finished store is neither resumed nor overwritten without [`SinkOptions::overwrite`].
//!
//! - A reader of a run that a fit may be writing ([`ChainReader::open_at_checkpoint`],
//!   [`read_chains_at_checkpoint`]) reads the parts the checkpoint counts, and nothing after
//!   them, each through the handle it opened: a consistent run, whatever the fit does
//!   meanwhile, without a lock.
//!
//! Row groups are encoded, parts written and checkpoints replaced on a thread of the sink's own,
//! so the sampler does not wait for the disk; an error there is returned by the sink's next
//! call, and a sink dropped without finishing completes what it was handed first (so its last
//! checkpoint is on disk).
//!
//! Memory held by a sink is at most two row groups of rows (one filling, one being written)
//! plus per-row-group footer metadata, whatever the length of the run.

pub mod metadata;
mod read;
mod seal;
mod sink;
mod verify;

use crate::data::atomic as io;
use std::path::{Path, PathBuf};

pub use crate::sampler::sink::{ChainSink, StepView};
pub use metadata::{
    read_part_metadata, ChainDescription, ChainMetadata, ColumnInfo, ColumnKind, ColumnUnit,
};
pub use read::{read_chains, read_chains_at_checkpoint, ChainReader, Chains};
pub use seal::{seal_json, JSON_CHECKSUM_KEY};
pub use sink::{ParquetSink, SinkOptions, Written, ROW_GROUP_BYTES};
pub use verify::{verify_run, verify_sealed_json, Integrity};

/// Name of the index column holding the ensemble number.
pub const ENSEMBLE_COLUMN: &str = "ensemble";
/// Name of the index column holding the walker number within its ensemble.
pub const WALKER_COLUMN: &str = "walker";
/// Name of the index column holding the step number.
pub const STEP_COLUMN: &str = "step";
/// Name of the column holding each walker's log-density.
pub const LOG_DENSITY_COLUMN: &str = "log_density";

/// Where a chain store keeps its files; the caller (a fit's run directory) names them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ChainFiles {
    /// The directory holding the store: parts being written (`.partial`) live here until
    /// they are complete.
    pub dir: PathBuf,
    /// The directory of complete parts (inside `dir`).
    pub chains: PathBuf,
    /// The checkpoint file (inside `dir`).
    pub checkpoint: PathBuf,
}

/// What went wrong while storing or reading chains, with the path at fault and what to do.
#[derive(Debug, thiserror::Error)]
pub enum StorageError {
    /// A file-system operation failed.
    #[error(transparent)]
    Io(#[from] crate::IoError),
    /// The directory holds a finished run.
    #[error(
        "{} already holds a completed run; choose another --out or pass --overwrite",
        dir.display()
    )]
    CompletedRunExists {
        /// The run directory.
        dir: PathBuf,
    },
    /// The directory holds chains of a run that did not finish.
    #[error(
        "{} already holds chains of an unfinished run; resume it with --resume, choose another \
         --out or pass --overwrite",
        dir.display()
    )]
    UnfinishedRunExists {
        /// The run directory.
        dir: PathBuf,
    },
    /// Resume was asked for a directory without a checkpoint.
    #[error("no checkpoint found in {}: nothing to resume; start a new run instead", dir.display())]
    NoCheckpoint {
        /// The run directory.
        dir: PathBuf,
    },
    /// Resume was asked for a run that already finished.
    #[error(
        "the run in {} already finished: nothing to resume; read its chains or start a new run",
        dir.display()
    )]
    AlreadyFinished {
        /// The run directory.
        dir: PathBuf,
    },
    /// A required column is absent.
    #[error("column {column:?} missing in {}", path.display())]
    ColumnMissing {
        /// The missing column.
        column: String,
        /// The file (or directory) searched.
        path: PathBuf,
    },
    /// The columns found are not the ones expected.
    #[error(
        "schema mismatch in {}: expected columns {expected:?}, found {found:?}; the chains \
         belong to a different model or configuration: choose another --out or pass --overwrite",
        path.display()
    )]
    SchemaMismatch {
        /// The file at fault.
        path: PathBuf,
        /// The columns (with types) expected.
        expected: Vec<String>,
        /// The columns (with types) found.
        found: Vec<String>,
    },
    /// Parameter or derived names that cannot be column names.
    #[error("invalid column name {name:?}: {reason}")]
    InvalidName {
        /// The offending name.
        name: String,
        /// Why it is refused.
        reason: &'static str,
    },
    /// A row-group size that cannot be used.
    #[error("row groups of {rows} rows are impossible: choose at least 1 row per group")]
    InvalidRowGroupSize {
        /// The size asked for.
        rows: usize,
    },
    /// A step view whose slices do not match the declared columns.
    #[error(
        "step {step} of ensemble {ensemble}: {what} has {got} values, expected {expected} \
         ({walkers} walkers x {per_walker}); the sink was created with {per_walker} {what} columns"
    )]
    ShapeMismatch {
        /// The ensemble of the view.
        ensemble: usize,
        /// The step of the view.
        step: u64,
        /// Which slice ("positions", "derived").
        what: &'static str,
        /// Its length.
        got: usize,
        /// The length expected.
        expected: usize,
        /// Walkers in the view.
        walkers: usize,
        /// Values per walker expected.
        per_walker: usize,
    },
    /// An ensemble or walker index too large for the u32 column.
    #[error("{what} index {value} does not fit the u32 column (at most {max})", max = u32::MAX)]
    IndexOverflow {
        /// "ensemble" or "walker".
        what: &'static str,
        /// The index.
        value: usize,
    },
    /// The Parquet layer refused to write or read a file.
    #[error("Parquet error in {}: {message}", path.display())]
    Parquet {
        /// The file at fault.
        path: PathBuf,
        /// The message of the Parquet layer.
        message: String,
    },
    /// The checkpoint cannot be parsed (or its state does not fit the requested type).
    #[error(
        "checkpoint {} is unreadable: {source}; it was written by another version or for \
         another sampler: start a new run with --overwrite",
        path.display()
    )]
    BadCheckpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// The decoding error.
        #[source]
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The checkpoint does not match the checksum it carries: it was changed after it was
    /// written.
    #[error(
        "checkpoint {} is corrupted: {problem}; it cannot be trusted: restore it from a backup \
         or start a new run with --overwrite",
        path.display()
    )]
    CorruptCheckpoint {
        /// The checkpoint file.
        path: PathBuf,
        /// What does not match.
        problem: String,
    },
    /// A complete part does not match the length and checksum its checkpoint recorded.
    #[error(
        "chain part {} is corrupted: {problem} ({} recorded it when it was written); its draws \
         cannot be trusted: restore the file from a backup or fit again with --overwrite",
        path.display(),
        checkpoint.display()
    )]
    CorruptPart {
        /// The part.
        path: PathBuf,
        /// The checkpoint that sealed it.
        checkpoint: PathBuf,
        /// What does not match.
        problem: String,
    },
    /// A file the run sealed (`summary.json`) does not match its checksum, or lost it.
    #[error(
        "{} is corrupted: {problem}; it cannot be trusted: restore it from a backup or fit \
         again with --overwrite",
        path.display()
    )]
    CorruptFile {
        /// The file.
        path: PathBuf,
        /// What does not match.
        problem: String,
    },
    /// The sampler state cannot be serialised.
    #[error("cannot serialise the sampler state for the checkpoint: {0}")]
    State(#[source] Box<dyn std::error::Error + Send + Sync>),
    /// The files of a run contradict each other.
    #[error("the run in {} is inconsistent: {problem}; start a new run with --overwrite", dir.display())]
    Inconsistent {
        /// The run directory.
        dir: PathBuf,
        /// What contradicts what.
        problem: String,
    },
    /// The sink's writer thread stopped on an earlier error (returned by an earlier call).
    #[error(
        "writing the chains in {} failed earlier (see the error before this one); the run \
         cannot go on: resume it from its last checkpoint with --resume",
        dir.display()
    )]
    WriterStopped {
        /// The run directory.
        dir: PathBuf,
    },
    /// There is no chain data to read.
    #[error("no chain parts in {}: the run wrote no checkpoint yet", dir.display())]
    NoChains {
        /// The chains directory.
        dir: PathBuf,
    },
}

impl StorageError {
    pub(crate) fn io(action: &'static str, path: &Path, source: std::io::Error) -> Self {
        Self::Io(crate::IoError::new(action, path, source))
    }

    pub(crate) fn parquet(path: &Path, err: impl std::fmt::Display) -> Self {
        Self::Parquet {
            path: path.to_path_buf(),
            message: err.to_string(),
        }
    }
}

/// Name of the complete part number `index` inside the chains directory.
fn part_name(index: u64) -> String {
    format!("part-{index:06}.parquet")
}

/// Name of the part being written, inside the store's directory.
fn partial_name(index: u64) -> String {
    format!("part-{index:06}.parquet.partial")
}

/// The part number of a complete part's file name, if it is one.
fn parse_part_name(name: &str) -> Option<u64> {
    let digits = name.strip_prefix("part-")?.strip_suffix(".parquet")?;
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// Whether a file name in the store's directories is a leftover of an interrupted write of ours.
fn is_leftover_name(name: &str) -> bool {
    (name.starts_with("part-") && name.ends_with(".parquet.partial")) || io::is_temporary_name(name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn part_names_round_trip_and_reject_lookalikes() {
        assert_eq!(parse_part_name(&part_name(0)), Some(0));
        assert_eq!(parse_part_name(&part_name(1_234_567)), Some(1_234_567));
        assert_eq!(parse_part_name(&partial_name(3)), None);
        assert_eq!(parse_part_name("part-.parquet"), None);
        assert_eq!(parse_part_name("part-+1.parquet"), None);
        assert_eq!(parse_part_name("part-000001.parquet.tmp"), None);
        assert!(is_leftover_name(&partial_name(7)));
        assert!(!is_leftover_name(&part_name(7)));
        assert!(!is_leftover_name("summary.json"));
    }
}
