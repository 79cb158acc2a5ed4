//! The streaming Parquet writer behind [`ChainSink`], and resuming it after a kill.
//!
//! This file holds the sink the sampler talks to and its row buffer; `writer` the thread that
//! encodes row groups and writes parts; `checkpoint` the checkpoint file, resuming from it,
//! and clearing an earlier run.

mod checkpoint;
mod writer;

use std::fs;
use std::ops::Range;
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc};

use polars_arrow::array::{Array, PrimitiveArray};
use polars_parquet::write::KeyValue;
use serde::Serialize;

use super::metadata::{column_infos, key_values, rewrite_footer, ChainDescription, ColumnInfo};
use super::read::{chains_schema, Part};
use super::seal::Seal;
use super::{
    parse_part_name, part_name, partial_name, ChainFiles, ChainSink, StepView, StorageError,
    ENSEMBLE_COLUMN, LOG_DENSITY_COLUMN, STEP_COLUMN, WALKER_COLUMN,
};
use crate::data::atomic::sync_dir;
pub(crate) use checkpoint::checkpointed;
use checkpoint::{existing_run, remove_run};
pub(super) use checkpoint::{read_checkpoint, CheckpointFile};
use writer::{Files, Job, RowGroup, Writer};

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

/// What a sink has made durable: complete parts and the rows in them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Written {
    /// Complete parts in `chains/`.
    pub parts: u64,
    /// Rows in those parts.
    pub rows: u64,
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
            part_seals: resumed.part_seals,
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
        let closed = match rest {
            Some(rows) => files.write_rows(rows),
            None => Ok(()),
        }
        .and_then(|()| files.close_part(self.steps, &self.footer));
        if let Err(e) = closed {
            files.abandon_part();
            return Err(e);
        }
        if self.footer.burn_in.is_some() {
            // Every part is copied with its new footer first; a checkpoint accepting either
            // version of each part is written before any is replaced, so that the parts stay
            // verifiable whenever a kill interrupts the replacing.
            let chains_dir = &self.files.chains;
            let mut copies = Vec::new();
            let copied = (|| {
                for index in 0..files.durable_parts {
                    let path = chains_dir.join(part_name(index));
                    let steps = Part::open(path.clone())?.step_range()?;
                    let pairs = self.footer.key_values(steps);
                    let copy = self.files.dir.join(partial_name(index));
                    rewrite_footer(&path, &copy, pairs)?;
                    let seal = Seal::of_file(&copy)?;
                    files.part_seals[index as usize].push(seal);
                    copies.push((index as usize, copy, path, seal));
                }
                files.write_checkpoint(false, self.steps)
            })();
            if let Err(e) = copied {
                // A full disk while copying: the copies made so far would only hold space; the
                // parts and the last checkpoint are untouched.
                for (_, copy, _, _) in &copies {
                    let _ = fs::remove_file(copy);
                }
                return Err(e);
            }
            for (index, copy, path, seal) in copies {
                fs::rename(&copy, &path).map_err(|e| StorageError::io("rename", &copy, e))?;
                files.part_seals[index] = vec![seal];
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
    part_seals: Vec<Vec<Seal>>,
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
