//! The streaming Parquet writer behind [`ChainSink`], and resuming it after a kill.

use std::fs::{self, File};
use std::io::BufWriter;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc};
use std::thread::{self, JoinHandle};

use polars_arrow::array::{Array, PrimitiveArray};
use polars_arrow::datatypes::ArrowSchema;
use polars_arrow::record_batch::RecordBatchT;
use polars_parquet::write::{
    CompressionOptions, Encoding, FileWriter, KeyValue, RowGroupIterator, StatisticsOptions,
    Version, WriteOptions,
};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::metadata::{column_infos, key_values, rewrite_footer, ChainDescription, ColumnInfo};
use super::read::{chains_schema, check_schema, Part};
use super::{
    is_leftover_name, parse_part_name, part_name, partial_name, ChainFiles, ChainSink, StepView,
    StorageError, ENSEMBLE_COLUMN, LOG_DENSITY_COLUMN, STEP_COLUMN, WALKER_COLUMN,
};
use crate::data::atomic::{sync_dir, write_atomically};

/// Tag of the checkpoint format, checked on resume: version 2 is binary (MessagePack), version
/// 1 the JSON of earlier releases, still read.
const CHECKPOINT_FORMAT: &str = "slipbayes-chains/2";
const JSON_CHECKPOINT_FORMAT: &str = "slipbayes-chains/1";
/// Where earlier releases wrote their JSON checkpoint, beside the binary one.
const JSON_CHECKPOINT: &str = "checkpoint.json";

/// How a [`ParquetSink`] writes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SinkOptions {
    /// Rows buffered in memory before they are written as one Parquet row group; bounds the
    /// memory of the sink. At least 1. The default (65 536 rows, 4 MiB for 8 value columns)
    /// keeps row groups large enough for fast reading; a table so wide that this many rows
    /// would exceed [`ROW_GROUP_BYTES`] buffers fewer (never fewer than 1,024).
    pub row_group_rows: usize,
    /// Whether [`ParquetSink::create`] may delete the chains and checkpoint of an earlier run
    /// in the same directory (other files there are left alone).
    pub overwrite: bool,
}

/// Bytes a row group may buffer before [`SinkOptions::row_group_rows`] is lowered for a wide
/// table.
pub const ROW_GROUP_BYTES: usize = 8 << 20;
/// Fewest rows a row group is lowered to for that reason.
const MIN_ROW_GROUP_ROWS: usize = 1024;

impl Default for SinkOptions {
    fn default() -> Self {
        Self {
            row_group_rows: 65_536,
            overwrite: false,
        }
    }
}

/// What a checkpoint says of the chains (the sampler state follows it in the file).
#[derive(Debug, Serialize, Deserialize)]
struct CheckpointHeader {
    format: String,
    param_names: Vec<String>,
    derived_names: Vec<String>,
    /// Rows per row group, kept so that a resumed run groups rows as the original did.
    row_group_rows: usize,
    /// Complete parts `part-000000 .. part-(parts-1)` that belong to the run.
    parts: u64,
    /// Rows in those parts.
    rows: u64,
    /// One past the largest step recorded in those parts: where a resumed run continues.
    steps: u64,
    finished: bool,
}

/// A checkpoint: binary, `header` then the state, both MessagePack.
#[derive(Debug)]
struct CheckpointFile {
    header: CheckpointHeader,
    /// The sampler state in MessagePack (named fields); `None` when none was given yet. A JSON
    /// checkpoint's state is converted on reading.
    state: Option<Vec<u8>>,
}

/// A checkpoint of an earlier release: JSON with the state inside.
#[derive(Deserialize)]
struct JsonCheckpointFile {
    #[serde(flatten)]
    header: CheckpointHeader,
    state: serde_json::Value,
}

/// Rows waiting to be written, column by column; never more than one row group.
#[derive(Debug)]
struct RowBuffer {
    ensemble: Vec<u32>,
    walker: Vec<u32>,
    step: Vec<u64>,
    /// Parameters, then log-density, then derived values.
    values: Vec<Vec<f64>>,
}

impl RowBuffer {
    fn with_capacity(rows: usize, value_columns: usize) -> Self {
        Self {
            ensemble: Vec::with_capacity(rows),
            walker: Vec::with_capacity(rows),
            step: Vec::with_capacity(rows),
            values: (0..value_columns)
                .map(|_| Vec::with_capacity(rows))
                .collect(),
        }
    }

    fn len(&self) -> usize {
        self.step.len()
    }

    fn capacity(&self) -> usize {
        let index = self
            .ensemble
            .capacity()
            .max(self.walker.capacity())
            .max(self.step.capacity());
        self.values
            .iter()
            .map(Vec::capacity)
            .fold(index, usize::max)
    }

    /// Moves the rows out as Arrow arrays, leaving an empty buffer of the same capacity.
    fn take_arrays(&mut self, rows: usize) -> Vec<Box<dyn Array>> {
        let fresh = Self::with_capacity(rows, self.values.len());
        let full = std::mem::replace(self, fresh);
        let mut arrays: Vec<Box<dyn Array>> = Vec::with_capacity(3 + full.values.len());
        arrays.push(PrimitiveArray::from_vec(full.ensemble).boxed());
        arrays.push(PrimitiveArray::from_vec(full.walker).boxed());
        arrays.push(PrimitiveArray::from_vec(full.step).boxed());
        for column in full.values {
            arrays.push(PrimitiveArray::from_vec(column).boxed());
        }
        arrays
    }
}

/// The part being written: a `.partial` file in the run directory.
struct OpenPart {
    index: u64,
    path: PathBuf,
    writer: FileWriter<BufWriter<File>>,
    rows: u64,
}

/// What every part's footer says besides its steps.
#[derive(Debug, Clone)]
struct Footer {
    /// Every column with its kind and unit.
    columns: Vec<ColumnInfo>,
    /// What the caller said about the run, if anything.
    description: Option<ChainDescription>,
    /// First kept step, once the caller knows it (see [`ParquetSink::set_burn_in`]).
    burn_in: Option<u64>,
}

impl Footer {
    fn key_values(&self, steps: Range<u64>) -> Vec<KeyValue> {
        key_values(
            &self.columns,
            self.description.as_ref(),
            steps,
            self.burn_in,
        )
    }
}

/// The file side of a sink: the part being written, what is durable, the last state. The
/// writer thread owns it while the run goes on; [`ParquetSink::finish`] takes it back.
struct Files {
    files: ChainFiles,
    param_names: Vec<String>,
    derived_names: Vec<String>,
    schema: Arc<ArrowSchema>,
    row_group_rows: usize,
    part: Option<OpenPart>,
    /// First step of the part being written (steps of one part are contiguous).
    part_first_step: u64,
    durable_parts: u64,
    durable_rows: u64,
    last_state: Option<Vec<u8>>,
}

/// Rows taken out of the buffer as Arrow arrays: one row group.
struct RowGroup {
    rows: usize,
    arrays: Vec<Box<dyn Array>>,
}

/// What the sampler's thread hands to the writer thread.
enum Job {
    /// A full row group for the open part.
    Rows(RowGroup),
    /// A checkpoint: the rows still buffered, then the part closed and the checkpoint replaced.
    Checkpoint {
        rest: Option<RowGroup>,
        /// One past the last step recorded.
        steps: u64,
        footer: Arc<Footer>,
        /// The sampler state in MessagePack.
        state: Vec<u8>,
    },
    /// Answers once every earlier job is done, with what is durable.
    Report(mpsc::SyncSender<Written>),
}

/// What a sink has made durable: complete parts and the rows in them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Written {
    /// Complete parts in `chains/`.
    pub parts: u64,
    /// Rows in those parts.
    pub rows: u64,
}

/// The thread that encodes row groups, writes parts and replaces the checkpoint, so that the
/// sampler's threads never wait for the disk (only for the writer to take the previous job,
/// when it is still busy with it).
struct Writer {
    jobs: mpsc::SyncSender<Job>,
    thread: JoinHandle<Result<Files, StorageError>>,
}

impl Writer {
    fn start(files: Files) -> Result<Self, StorageError> {
        // A rendezvous channel: a job is handed over only when the writer is free, so a sink
        // holds at most two row groups (one being written, one filling or waiting to be taken).
        let (jobs, queue) = mpsc::sync_channel::<Job>(0);
        let dir = files.files.dir.clone();
        let thread = thread::Builder::new()
            .name("slipbayes-chains".into())
            .spawn(move || {
                let mut files = files;
                for job in queue {
                    files.run(job)?;
                }
                Ok(files)
            })
            .map_err(|e| StorageError::io("start the writer thread for", &dir, e))?;
        Ok(Self { jobs, thread })
    }

    /// Waits for every job handed over and gives the files back, or the first error.
    fn stop(self) -> Result<Files, StorageError> {
        drop(self.jobs);
        match self.thread.join() {
            Ok(result) => result,
            Err(panic) => std::panic::resume_unwind(panic),
        }
    }
}

/// Streams chains to Parquet parts in a run directory and checkpoints them with the sampler
/// state (see the [module documentation](super) for the layout). Encoding and writing happen
/// on a thread of the sink's own; an error there is returned by the next call.
pub struct ParquetSink {
    files: ChainFiles,
    param_names: Vec<String>,
    derived_names: Vec<String>,
    footer: Arc<Footer>,
    row_group_rows: usize,
    buffer: RowBuffer,
    rows: u64,
    steps: u64,
    /// `None` once the writer stopped on an error (returned then) or the run finished.
    writer: Option<Writer>,
}

impl std::fmt::Debug for ParquetSink {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ParquetSink")
            .field("files", &self.files)
            .field("param_names", &self.param_names)
            .field("derived_names", &self.derived_names)
            .field("row_group_rows", &self.row_group_rows)
            .field("buffered_rows", &self.buffer.len())
            .field("rows", &self.rows)
            .field("steps", &self.steps)
            .field("writing", &self.writer.is_some())
            .finish()
    }
}

impl Drop for ParquetSink {
    /// A sink dropped without [`ParquetSink::finish`] (an error or an interruption) still
    /// completes what it handed to the writer, so the last checkpoint is on disk.
    fn drop(&mut self) {
        if let Some(writer) = self.writer.take() {
            // The run is being abandoned; a write error now changes nothing a resume needs.
            let _ = writer.stop();
        }
    }
}

impl ParquetSink {
    /// Starts a new run in the files of `files` (directories created if needed) with one f64
    /// column per parameter and per derived value, named as given.
    ///
    /// # Errors
    /// [`StorageError::InvalidName`] for empty, duplicate or reserved names
    /// (`ensemble`, `walker`, `step`, `log_density`);
    /// [`StorageError::InvalidRowGroupSize`] for a zero row-group size;
    /// [`StorageError::CompletedRunExists`] or [`StorageError::UnfinishedRunExists`] when
    /// `files` hold chains or a checkpoint and [`SinkOptions::overwrite`] is off;
    /// [`StorageError::Io`] when the directory cannot be prepared.
    pub fn create(
        files: &ChainFiles,
        param_names: &[String],
        derived_names: &[String],
        options: SinkOptions,
    ) -> Result<Self, StorageError> {
        validate_names(param_names, derived_names)?;
        if options.row_group_rows == 0 {
            return Err(StorageError::InvalidRowGroupSize { rows: 0 });
        }
        let dir = files.dir.as_path();
        fs::create_dir_all(dir).map_err(|e| StorageError::io("create directory", dir, e))?;
        let chains_dir = &files.chains;
        let existing = existing_run(files)?;
        if let Some(finished) = existing {
            if !options.overwrite {
                let dir = dir.to_path_buf();
                return Err(if finished {
                    StorageError::CompletedRunExists { dir }
                } else {
                    StorageError::UnfinishedRunExists { dir }
                });
            }
            remove_run(files)?;
        }
        fs::create_dir_all(chains_dir)
            .map_err(|e| StorageError::io("create directory", chains_dir, e))?;
        sync_dir(dir).map_err(|e| StorageError::io("sync directory", dir, e))?;
        Self::start(
            files,
            param_names.to_vec(),
            derived_names.to_vec(),
            options.row_group_rows,
            Resumed::default(),
        )
    }

    /// Reopens the run in `files` at its last checkpoint: removes `.partial` and temporary files
    /// and every part written after the checkpoint, checks the kept parts against the
    /// checkpoint, and returns the sink positioned to continue with the saved sampler state.
    /// The next step to record is [`ParquetSink::steps`]; rows are grouped as in the original
    /// run, so a resumed run writes the same files as an uninterrupted one.
    ///
    /// # Errors
    /// [`StorageError::NoCheckpoint`] when there is no checkpoint;
    /// [`StorageError::AlreadyFinished`] when the run finished;
    /// [`StorageError::BadCheckpoint`] when the checkpoint or its state cannot be parsed as `S`;
    /// [`StorageError::SchemaMismatch`] or [`StorageError::Inconsistent`] when the kept parts
    /// do not match the checkpoint; [`StorageError::Io`] on file-system errors.
    pub fn resume<S: DeserializeOwned>(files: &ChainFiles) -> Result<(Self, S), StorageError> {
        let dir = files.dir.as_path();
        let checkpoint_path = files.checkpoint.clone();
        let Some(CheckpointFile {
            header: checkpoint,
            state: stored,
        }) = read_checkpoint(files)?
        else {
            return Err(StorageError::NoCheckpoint {
                dir: dir.to_path_buf(),
            });
        };
        if checkpoint.finished {
            return Err(StorageError::AlreadyFinished {
                dir: dir.to_path_buf(),
            });
        }
        validate_names(&checkpoint.param_names, &checkpoint.derived_names)?;
        let bad_state = |source| StorageError::BadCheckpoint {
            path: checkpoint_path.clone(),
            source,
        };
        let state: S = match &stored {
            Some(bytes) => rmp_serde::from_slice(bytes).map_err(|e| bad_state(e.into()))?,
            None => return Err(bad_state("the checkpoint holds no sampler state".into())),
        };

        remove_leftovers(files)?;
        let chains_dir = &files.chains;
        let mut present = Vec::new();
        for (index, path) in list_parts(chains_dir)? {
            if index >= checkpoint.parts {
                // Written after the checkpoint by the killed run: the resumed run rewrites it.
                fs::remove_file(&path).map_err(|e| StorageError::io("remove", &path, e))?;
            } else {
                present.push(index);
            }
        }
        sync_dir(chains_dir).map_err(|e| StorageError::io("sync directory", chains_dir, e))?;
        sync_dir(dir).map_err(|e| StorageError::io("sync directory", dir, e))?;

        let inconsistent = |problem: String| StorageError::Inconsistent {
            dir: dir.to_path_buf(),
            problem,
        };
        if let Some(missing) = (0..checkpoint.parts).find(|i| present.binary_search(i).is_err()) {
            return Err(inconsistent(format!(
                "{} lists {} parts but {} is missing",
                checkpoint_path.display(),
                checkpoint.parts,
                part_name(missing)
            )));
        }
        let expected = chains_schema(&checkpoint.param_names, &checkpoint.derived_names);
        let mut rows = 0u64;
        for index in 0..checkpoint.parts {
            let path = chains_dir.join(part_name(index));
            let part = Part::open(path.clone())?;
            check_schema(&path, &part.schema, &expected)?;
            rows += part.rows() as u64;
        }
        if rows != checkpoint.rows {
            return Err(inconsistent(format!(
                "{} records {} rows but its {} parts hold {}",
                checkpoint_path.display(),
                checkpoint.rows,
                checkpoint.parts,
                rows
            )));
        }

        let sink = Self::start(
            files,
            checkpoint.param_names,
            checkpoint.derived_names,
            checkpoint.row_group_rows.max(1),
            Resumed {
                parts: checkpoint.parts,
                rows: checkpoint.rows,
                steps: checkpoint.steps,
                state: stored,
            },
        )?;
        Ok((sink, state))
    }

    /// The sink, with its writer thread started, continuing from `resumed`.
    fn start(
        files: &ChainFiles,
        param_names: Vec<String>,
        derived_names: Vec<String>,
        row_group_rows: usize,
        resumed: Resumed,
    ) -> Result<Self, StorageError> {
        let schema = Arc::new(chains_schema(&param_names, &derived_names));
        let value_columns = param_names.len() + 1 + derived_names.len();
        // A wide table (a campaign has hundreds of columns) gets shorter row groups, so the
        // buffer stays near ROW_GROUP_BYTES whatever the model.
        let row_bytes = 16 + 8 * value_columns;
        let row_group_rows =
            row_group_rows.min((ROW_GROUP_BYTES / row_bytes).max(MIN_ROW_GROUP_ROWS));
        let writer = Writer::start(Files {
            files: files.clone(),
            param_names: param_names.clone(),
            derived_names: derived_names.clone(),
            schema,
            row_group_rows,
            part: None,
            part_first_step: resumed.steps,
            durable_parts: resumed.parts,
            durable_rows: resumed.rows,
            last_state: resumed.state,
        })?;
        Ok(Self {
            files: files.clone(),
            buffer: RowBuffer::with_capacity(row_group_rows, value_columns),
            footer: Arc::new(Footer {
                columns: column_infos(&param_names, &derived_names, None),
                description: None,
                burn_in: None,
            }),
            param_names,
            derived_names,
            row_group_rows,
            rows: resumed.rows,
            steps: resumed.steps,
            writer: Some(writer),
        })
    }

    /// Checks that this run stores exactly these parameter and derived columns, e.g. that a
    /// resumed run belongs to the model being sampled.
    ///
    /// # Errors
    /// [`StorageError::SchemaMismatch`] naming the checkpoint and both column lists.
    pub fn check_columns(
        &self,
        param_names: &[String],
        derived_names: &[String],
    ) -> Result<(), StorageError> {
        if self.param_names == param_names && self.derived_names == derived_names {
            return Ok(());
        }
        let list = |p: &[String], d: &[String]| {
            let mut v = p.to_vec();
            v.push(LOG_DENSITY_COLUMN.to_owned());
            v.extend_from_slice(d);
            v
        };
        Err(StorageError::SchemaMismatch {
            path: self.files.checkpoint.clone(),
            expected: list(param_names, derived_names),
            found: list(&self.param_names, &self.derived_names),
        })
    }

    /// Describes the run for the metadata of every part written from now on (the seed,
    /// ensembles, walkers, thinning and the units of the value columns; see
    /// [`mod@super::metadata`]). Without it the parts still name their layout and columns.
    pub fn describe(&mut self, description: ChainDescription) {
        let footer = Arc::make_mut(&mut self.footer);
        footer.columns = column_infos(&self.param_names, &self.derived_names, Some(&description));
        footer.description = Some(description);
    }

    /// The first kept step (rows of earlier steps are burn-in), known once the run's summary
    /// has decided it: [`ParquetSink::finish`] then writes it into the footer of every part.
    pub fn set_burn_in(&mut self, step: u64) {
        Arc::make_mut(&mut self.footer).burn_in = Some(step);
    }

    /// Where the chains and the checkpoint are.
    pub fn files(&self) -> &ChainFiles {
        &self.files
    }

    /// Names of the parameter columns.
    pub fn param_names(&self) -> &[String] {
        &self.param_names
    }

    /// Names of the derived columns.
    pub fn derived_names(&self) -> &[String] {
        &self.derived_names
    }

    /// One past the largest step recorded (after a resume: the step to record next).
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Rows recorded, durable or not.
    pub fn rows(&self) -> u64 {
        self.rows
    }

    /// Waits until the writer thread has done everything handed to it, and says what is
    /// durable: the parts and rows of the last checkpoint written.
    ///
    /// # Errors
    /// The first error of the writer thread.
    pub fn written(&mut self) -> Result<Written, StorageError> {
        let (answer, reply) = mpsc::sync_channel(1);
        self.send(Job::Report(answer))?;
        // Taken, so every earlier job succeeded, and a report cannot fail.
        Ok(reply
            .recv()
            .expect("the writer answers every report it takes"))
    }

    /// Hands `job` to the writer thread, waiting while it is busy with the previous one.
    ///
    /// # Errors
    /// The error that stopped the writer thread, once; [`StorageError::WriterStopped`] after.
    fn send(&mut self, job: Job) -> Result<(), StorageError> {
        let Some(writer) = &self.writer else {
            return Err(StorageError::WriterStopped {
                dir: self.files.dir.clone(),
            });
        };
        if writer.jobs.send(job).is_ok() {
            return Ok(());
        }
        // The writer only stops early on an error.
        let writer = self.writer.take().expect("checked above");
        writer.stop().and(Err(StorageError::WriterStopped {
            dir: self.files.dir.clone(),
        }))
    }

    /// Rows buffered in memory, not yet written to the part file.
    pub fn buffered_rows(&self) -> usize {
        self.buffer.len()
    }

    /// Largest capacity, in rows, of the in-memory buffers: the sink's memory is bounded by
    /// this times the number of columns, and it never exceeds [`SinkOptions::row_group_rows`].
    pub fn buffer_capacity_rows(&self) -> usize {
        self.buffer.capacity()
    }

    /// Closes the last part and marks the run finished in the checkpoint, keeping the state
    /// of the last checkpoint. With a burn-in set ([`ParquetSink::set_burn_in`]), every part's
    /// footer is first rewritten to carry it (each part copied with its new footer and renamed
    /// over itself; a kill before the checkpoint is marked leaves a resumable run).
    ///
    /// # Errors
    /// When the last part, a footer or the checkpoint cannot be written.
    pub fn finish(mut self) -> Result<(), StorageError> {
        let rest = self.take_rows();
        let Some(writer) = self.writer.take() else {
            return Err(StorageError::WriterStopped {
                dir: self.files.dir.clone(),
            });
        };
        let mut files = writer.stop()?;
        if let Some(rows) = rest {
            files.write_rows(rows)?;
        }
        files.close_part(self.steps, &self.footer)?;
        if self.footer.burn_in.is_some() {
            let chains_dir = &self.files.chains;
            for index in 0..files.durable_parts {
                let path = chains_dir.join(part_name(index));
                let steps = Part::open(path.clone())?.step_range()?;
                let pairs = self.footer.key_values(steps);
                rewrite_footer(&path, &self.files.dir.join(partial_name(index)), pairs)?;
            }
            sync_dir(chains_dir).map_err(|e| StorageError::io("sync directory", chains_dir, e))?;
        }
        files.write_checkpoint(true, self.steps)
    }

    /// The buffered rows as one row group, leaving the buffer empty; `None` when it is.
    fn take_rows(&mut self) -> Option<RowGroup> {
        let rows = self.buffer.len();
        (rows > 0).then(|| RowGroup {
            rows,
            arrays: self.buffer.take_arrays(self.row_group_rows),
        })
    }
}

/// Where a sink continues from: nothing for a new run, the checkpoint's parts, rows, steps and
/// state for a resumed one.
#[derive(Default)]
struct Resumed {
    parts: u64,
    rows: u64,
    steps: u64,
    state: Option<Vec<u8>>,
}

impl Files {
    /// Does one job of the writer thread.
    fn run(&mut self, job: Job) -> Result<(), StorageError> {
        match job {
            Job::Rows(rows) => self.write_rows(rows),
            Job::Checkpoint {
                rest,
                steps,
                footer,
                state,
            } => {
                if let Some(rows) = rest {
                    self.write_rows(rows)?;
                }
                self.close_part(steps, &footer)?;
                self.last_state = Some(state);
                self.write_checkpoint(false, steps)
            }
            Job::Report(answer) => {
                // The sink may have stopped waiting; nothing is lost then.
                let _ = answer.send(Written {
                    parts: self.durable_parts,
                    rows: self.durable_rows,
                });
                Ok(())
            }
        }
    }

    /// Writes `rows` as one row group of the open part, opening it if needed.
    fn write_rows(&mut self, rows: RowGroup) -> Result<(), StorageError> {
        let part = match &mut self.part {
            Some(part) => part,
            slot => slot.insert(open_part(
                &self.files.dir,
                self.durable_parts,
                &self.schema,
            )?),
        };
        let path = part.path.clone();
        let batch = RecordBatchT::try_new(rows.rows, Arc::clone(&self.schema), rows.arrays)
            .map_err(|e| StorageError::parquet(&path, e))?;
        let encodings = vec![vec![Encoding::Plain]; self.schema.len()];
        let groups = RowGroupIterator::try_new(
            std::iter::once(Ok(batch)),
            &self.schema,
            part.writer.options(),
            encodings,
        )
        .map_err(|e| StorageError::parquet(&path, e))?;
        for group in groups {
            let group = group.map_err(|e| StorageError::parquet(&path, e))?;
            part.writer
                .write(group)
                .map_err(|e| StorageError::parquet(&path, e))?;
        }
        part.rows += rows.rows as u64;
        Ok(())
    }

    /// Makes the open part, which ends before step `steps`, complete and durable under its
    /// final name in `chains/`.
    fn close_part(&mut self, steps: u64, footer: &Footer) -> Result<(), StorageError> {
        let Some(mut part) = self.part.take() else {
            return Ok(());
        };
        let path = part.path;
        let pairs = footer.key_values(self.part_first_step..steps);
        part.writer
            .end(Some(pairs))
            .map_err(|e| StorageError::parquet(&path, e))?;
        let file = part
            .writer
            .into_inner()
            .into_inner()
            .map_err(|e| StorageError::io("write", &path, e.into_error()))?;
        file.sync_all()
            .map_err(|e| StorageError::io("sync", &path, e))?;
        drop(file);
        let chains_dir = &self.files.chains;
        let target = chains_dir.join(part_name(part.index));
        fs::rename(&path, &target).map_err(|e| StorageError::io("rename", &path, e))?;
        sync_dir(chains_dir).map_err(|e| StorageError::io("sync directory", chains_dir, e))?;
        self.durable_parts += 1;
        self.durable_rows += part.rows;
        self.part_first_step = steps;
        Ok(())
    }

    fn write_checkpoint(&self, finished: bool, steps: u64) -> Result<(), StorageError> {
        let header = CheckpointHeader {
            format: CHECKPOINT_FORMAT.to_owned(),
            param_names: self.param_names.clone(),
            derived_names: self.derived_names.clone(),
            row_group_rows: self.row_group_rows,
            parts: self.durable_parts,
            rows: self.durable_rows,
            steps,
            finished,
        };
        let path = &self.files.checkpoint;
        let mut bytes =
            rmp_serde::to_vec_named(&header).map_err(|e| StorageError::State(e.into()))?;
        if let Some(state) = &self.last_state {
            bytes.extend_from_slice(state);
        }
        write_atomically(path, &bytes).map_err(|e| StorageError::io("write", path, e))?;
        remove_json_checkpoint(&self.files)
    }
}

impl ChainSink for ParquetSink {
    type Error = StorageError;

    fn record(&mut self, view: &StepView<'_>) -> Result<(), StorageError> {
        let walkers = view.walkers();
        let nparam = self.param_names.len();
        let nderived = self.derived_names.len();
        let shape = |what, got, per_walker| StorageError::ShapeMismatch {
            ensemble: view.ensemble,
            step: view.step,
            what,
            got,
            expected: walkers * per_walker,
            walkers,
            per_walker,
        };
        if view.ndim != nparam || view.positions.len() != walkers * nparam {
            return Err(shape("positions", view.positions.len(), nparam));
        }
        if view.derived.len() != walkers * nderived {
            return Err(shape("derived", view.derived.len(), nderived));
        }
        let ensemble = u32::try_from(view.ensemble).map_err(|_| StorageError::IndexOverflow {
            what: ENSEMBLE_COLUMN,
            value: view.ensemble,
        })?;
        if walkers > 0 && u32::try_from(walkers - 1).is_err() {
            return Err(StorageError::IndexOverflow {
                what: WALKER_COLUMN,
                value: walkers - 1,
            });
        }
        for w in 0..walkers {
            let buffer = &mut self.buffer;
            buffer.ensemble.push(ensemble);
            // Checked above: every walker index fits.
            buffer.walker.push(w as u32);
            buffer.step.push(view.step);
            let (params, rest) = buffer.values.split_at_mut(nparam);
            for (column, &x) in params
                .iter_mut()
                .zip(&view.positions[w * nparam..(w + 1) * nparam])
            {
                column.push(x);
            }
            rest[0].push(view.log_density[w]);
            for (column, &x) in rest[1..]
                .iter_mut()
                .zip(&view.derived[w * nderived..(w + 1) * nderived])
            {
                column.push(x);
            }
            if buffer.len() >= self.row_group_rows {
                let rows = self.take_rows().expect("a full buffer");
                self.send(Job::Rows(rows))?;
            }
        }
        self.rows += walkers as u64;
        if walkers > 0 {
            self.steps = self.steps.max(view.step.saturating_add(1));
        }
        Ok(())
    }

    fn checkpoint<S: Serialize>(&mut self, state: &S) -> Result<(), StorageError> {
        let state = rmp_serde::to_vec_named(state).map_err(|e| StorageError::State(e.into()))?;
        let job = Job::Checkpoint {
            rest: self.take_rows(),
            steps: self.steps,
            footer: Arc::clone(&self.footer),
            state,
        };
        self.send(job)
    }
}

/// Creates the `.partial` file of part `index` and writes its header.
fn open_part(dir: &Path, index: u64, schema: &ArrowSchema) -> Result<OpenPart, StorageError> {
    let path = dir.join(partial_name(index));
    let file = File::create(&path).map_err(|e| StorageError::io("create", &path, e))?;
    let options = WriteOptions {
        statistics: StatisticsOptions::default(),
        version: Version::V2,
        compression: CompressionOptions::Snappy,
        data_page_size: None,
    };
    let writer = FileWriter::try_new(BufWriter::new(file), schema.clone(), options)
        .map_err(|e| StorageError::parquet(&path, e))?;
    Ok(OpenPart {
        index,
        path,
        writer,
        rows: 0,
    })
}

/// Refuses names that cannot be distinct, non-empty column names of the chain table.
fn validate_names(param_names: &[String], derived_names: &[String]) -> Result<(), StorageError> {
    let reserved = [
        ENSEMBLE_COLUMN,
        WALKER_COLUMN,
        STEP_COLUMN,
        LOG_DENSITY_COLUMN,
    ];
    let mut seen = std::collections::HashSet::new();
    for name in param_names.iter().chain(derived_names) {
        let refuse = |reason| {
            Err(StorageError::InvalidName {
                name: name.clone(),
                reason,
            })
        };
        if name.is_empty() {
            return refuse("column names must not be empty");
        }
        if reserved.contains(&name.as_str()) {
            return refuse("reserved for an index or the log-density column; rename it");
        }
        if !seen.insert(name.as_str()) {
            return refuse("appears twice among the parameter and derived names");
        }
    }
    Ok(())
}

/// Reads the checkpoint of `files` (or, without one, the JSON checkpoint an earlier release
/// wrote beside it); `None` when there is neither.
fn read_checkpoint(files: &ChainFiles) -> Result<Option<CheckpointFile>, StorageError> {
    let path = &files.checkpoint;
    let bad = |path: &Path, source: Box<dyn std::error::Error + Send + Sync>| {
        StorageError::BadCheckpoint {
            path: path.to_path_buf(),
            source,
        }
    };
    let checkpoint = match read_if_present(path)? {
        Some(bytes) => {
            let mut reader = std::io::Cursor::new(&bytes[..]);
            let header: CheckpointHeader =
                rmp_serde::from_read(&mut reader).map_err(|e| bad(path, e.into()))?;
            let state = &bytes[reader.position() as usize..];
            CheckpointFile {
                header,
                state: (!state.is_empty()).then(|| state.to_vec()),
            }
        }
        None => {
            let path = &json_checkpoint(files);
            let Some(bytes) = read_if_present(path)? else {
                return Ok(None);
            };
            let json: JsonCheckpointFile =
                serde_json::from_slice(&bytes).map_err(|e| bad(path, e.into()))?;
            // Its state is carried in the binary form from here on.
            let state = if json.state.is_null() {
                None
            } else {
                Some(rmp_serde::to_vec_named(&json.state).map_err(|e| bad(path, e.into()))?)
            };
            if json.header.format != JSON_CHECKPOINT_FORMAT {
                return Err(bad(
                    path,
                    format!(
                        "format {:?}, expected {JSON_CHECKPOINT_FORMAT:?}",
                        json.header.format
                    )
                    .into(),
                ));
            }
            return Ok(Some(CheckpointFile {
                header: json.header,
                state,
            }));
        }
    };
    if checkpoint.header.format != CHECKPOINT_FORMAT {
        return Err(bad(
            path,
            format!(
                "format {:?}, expected {CHECKPOINT_FORMAT:?}",
                checkpoint.header.format
            )
            .into(),
        ));
    }
    Ok(Some(checkpoint))
}

fn read_if_present(path: &Path) -> Result<Option<Vec<u8>>, StorageError> {
    match fs::read(path) {
        Ok(b) => Ok(Some(b)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(StorageError::io("read", path, e)),
    }
}

/// The JSON checkpoint of an earlier release, beside the binary one.
fn json_checkpoint(files: &ChainFiles) -> PathBuf {
    files
        .checkpoint
        .parent()
        .unwrap_or(Path::new("."))
        .join(JSON_CHECKPOINT)
}

/// Removes the JSON checkpoint of an earlier release, once a binary one replaces it.
fn remove_json_checkpoint(files: &ChainFiles) -> Result<(), StorageError> {
    let path = json_checkpoint(files);
    if path == files.checkpoint {
        return Ok(());
    }
    match fs::remove_file(&path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(StorageError::io("remove", &path, e)),
    }
}

/// Whether `files` hold a run of ours: `Some(finished)`, or `None` when they hold none.
fn existing_run(files: &ChainFiles) -> Result<Option<bool>, StorageError> {
    match read_checkpoint(files) {
        Ok(Some(c)) => return Ok(Some(c.header.finished)),
        Ok(None) => {}
        // An unreadable checkpoint still marks a run; only --overwrite may remove it.
        Err(StorageError::BadCheckpoint { .. }) => return Ok(Some(false)),
        Err(e) => return Err(e),
    }
    let has_parts = !list_parts(&files.chains)?.is_empty();
    let has_leftovers = !list_leftovers(&files.dir)?.is_empty();
    Ok((has_parts || has_leftovers).then_some(false))
}

/// Removes the parts, leftovers and checkpoint of an earlier run (nothing else).
fn remove_run(files: &ChainFiles) -> Result<(), StorageError> {
    let chains_dir = &files.chains;
    for (_, path) in list_parts(chains_dir)? {
        fs::remove_file(&path).map_err(|e| StorageError::io("remove", &path, e))?;
    }
    remove_leftovers(files)?;
    let checkpoint = &files.checkpoint;
    match fs::remove_file(checkpoint) {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
        Err(e) => return Err(StorageError::io("remove", checkpoint, e)),
    }
    remove_json_checkpoint(files)?;
    if chains_dir.is_dir() {
        sync_dir(chains_dir).map_err(|e| StorageError::io("sync directory", chains_dir, e))?;
    }
    sync_dir(&files.dir).map_err(|e| StorageError::io("sync directory", &files.dir, e))
}

/// Removes `.partial` parts and temporary files of interrupted writes in the store's directory
/// and its chains directory.
fn remove_leftovers(files: &ChainFiles) -> Result<(), StorageError> {
    let mut leftovers = list_leftovers(&files.dir)?;
    leftovers.extend(list_leftovers(&files.chains)?);
    for path in leftovers {
        fs::remove_file(&path).map_err(|e| StorageError::io("remove", &path, e))?;
    }
    Ok(())
}

fn list_leftovers(dir: &Path) -> Result<Vec<PathBuf>, StorageError> {
    Ok(list_files(dir)?
        .into_iter()
        .filter(|(name, _)| is_leftover_name(name))
        .map(|(_, path)| path)
        .collect())
}

/// Complete parts in a chains directory, sorted by number (empty when it does not exist).
pub(super) fn list_parts(chains_dir: &Path) -> Result<Vec<(u64, PathBuf)>, StorageError> {
    let mut parts: Vec<(u64, PathBuf)> = list_files(chains_dir)?
        .into_iter()
        .filter_map(|(name, path)| parse_part_name(&name).map(|i| (i, path)))
        .collect();
    parts.sort_unstable_by_key(|&(i, _)| i);
    Ok(parts)
}

/// Regular files of a directory with their UTF-8 names (empty when it does not exist).
fn list_files(dir: &Path) -> Result<Vec<(String, PathBuf)>, StorageError> {
    let entries = match fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(StorageError::io("list", dir, e)),
    };
    let mut files = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| StorageError::io("list", dir, e))?;
        let is_file = entry
            .file_type()
            .map_err(|e| StorageError::io("inspect", &entry.path(), e))?
            .is_file();
        if let (true, Some(name)) = (is_file, entry.file_name().to_str()) {
            files.push((name.to_owned(), entry.path()));
        }
    }
    Ok(files)
}
