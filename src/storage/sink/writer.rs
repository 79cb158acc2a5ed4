//! The writer thread of a sink: row groups encoded, parts written and closed.

use std::fs::{self, File};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::{mpsc, Arc, OnceLock};
use std::thread::{self, JoinHandle};

use polars_arrow::array::Array;
use polars_arrow::datatypes::ArrowSchema;
use polars_arrow::record_batch::RecordBatchT;
use polars_parquet::write::{
    CompressionOptions, Encoding, FileWriter, RowGroupIterator, StatisticsOptions, Version,
    WriteOptions,
};

use super::super::seal::Seal;
use super::super::{part_name, partial_name, ChainFiles, StorageError};
use super::{Footer, Written};
use crate::data::atomic::sync_dir;

/// The part being written: a `.partial` file in the run directory.
pub(super) struct OpenPart {
    index: u64,
    path: PathBuf,
    writer: FileWriter<BufWriter<PartFile>>,
    rows: u64,
    /// The first I/O error of the file, shared with its [`PartFile`].
    io_error: Arc<OnceLock<io::Error>>,
}

impl OpenPart {
    /// The error of a failed Parquet write: the file's own I/O error when there was one, which
    /// the Parquet writer may report only as its consequence (a footer cut short by a full
    /// disk reads "invalid thrift"), else the Parquet error.
    fn failed(&self, err: impl std::fmt::Display) -> StorageError {
        match self.io_error.get() {
            Some(e) => StorageError::io("write", &self.path, copy_of(e)),
            None => StorageError::parquet(&self.path, err),
        }
    }
}

/// The file of a part, keeping its first I/O error for [`OpenPart::failed`].
struct PartFile {
    file: File,
    error: Arc<OnceLock<io::Error>>,
}

impl PartFile {
    fn keep(&self, e: io::Error) -> io::Error {
        let _ = self.error.set(copy_of(&e));
        e
    }
}

impl Write for PartFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.write(buf).map_err(|e| self.keep(e))
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file.flush().map_err(|e| self.keep(e))
    }
}

/// An I/O error of the same cause (`io::Error` is not `Clone`).
fn copy_of(e: &io::Error) -> io::Error {
    match e.raw_os_error() {
        Some(code) => io::Error::from_raw_os_error(code),
        None => io::Error::new(e.kind(), e.to_string()),
    }
}

/// The file side of a sink: the part being written, what is durable, the last state. The
/// writer thread owns it while the run goes on; [`ParquetSink::finish`] takes it back.
pub(super) struct Files {
    pub(super) files: ChainFiles,
    pub(super) param_names: Vec<String>,
    pub(super) derived_names: Vec<String>,
    pub(super) schema: Arc<ArrowSchema>,
    pub(super) row_group_rows: usize,
    pub(super) part: Option<OpenPart>,
    /// First step of the part being written (steps of one part are contiguous).
    pub(super) part_first_step: u64,
    pub(super) durable_parts: u64,
    pub(super) durable_rows: u64,
    pub(super) last_state: Option<Vec<u8>>,
    /// The seals a checkpoint records for the durable parts (see [`Files::write_checkpoint`]).
    pub(super) part_seals: Vec<Vec<Seal>>,
}

/// Rows taken out of the buffer as Arrow arrays: one row group.
pub(super) struct RowGroup {
    pub(super) rows: usize,
    pub(super) arrays: Vec<Box<dyn Array>>,
}

/// What the sampler's thread hands to the writer thread.
pub(super) enum Job {
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

/// The thread that encodes row groups, writes parts and replaces the checkpoint, so that the
/// sampler's threads never wait for the disk (only for the writer to take the previous job,
/// when it is still busy with it).
pub(super) struct Writer {
    pub(super) jobs: mpsc::SyncSender<Job>,
    thread: JoinHandle<Result<Files, StorageError>>,
}

impl Writer {
    pub(super) fn start(files: Files) -> Result<Self, StorageError> {
        // A rendezvous channel: a job is handed over only when the writer is free, so a sink
        // holds at most two row groups (one being written, one filling or waiting to be taken).
        let (jobs, queue) = mpsc::sync_channel::<Job>(0);
        let dir = files.files.dir.clone();
        let thread = thread::Builder::new()
            .name("slipbayes-chains".into())
            .spawn(move || {
                let mut files = files;
                for job in queue {
                    if let Err(e) = files.run(job) {
                        files.abandon_part();
                        return Err(e);
                    }
                }
                Ok(files)
            })
            .map_err(|e| StorageError::io("start the writer thread for", &dir, e))?;
        Ok(Self { jobs, thread })
    }

    /// Waits for every job handed over and gives the files back, or the first error.
    pub(super) fn stop(self) -> Result<Files, StorageError> {
        drop(self.jobs);
        match self.thread.join() {
            Ok(result) => result,
            Err(panic) => std::panic::resume_unwind(panic),
        }
    }
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
    pub(super) fn write_rows(&mut self, rows: RowGroup) -> Result<(), StorageError> {
        let part = match &mut self.part {
            Some(part) => part,
            slot => slot.insert(open_part(
                &self.files.dir,
                self.durable_parts,
                &self.schema,
            )?),
        };
        let batch = RecordBatchT::try_new(rows.rows, Arc::clone(&self.schema), rows.arrays)
            .map_err(|e| part.failed(e))?;
        let encodings = vec![vec![Encoding::Plain]; self.schema.len()];
        let groups = RowGroupIterator::try_new(
            std::iter::once(Ok(batch)),
            &self.schema,
            part.writer.options(),
            encodings,
        )
        .map_err(|e| part.failed(e))?;
        for group in groups {
            let group = group.map_err(|e| part.failed(e))?;
            part.writer.write(group).map_err(|e| part.failed(e))?;
        }
        part.rows += rows.rows as u64;
        Ok(())
    }

    /// Removes the part being written after a failed write: a resume rewrites its rows from
    /// the last checkpoint anyway, and on a full disk its space is what the user must get back.
    pub(super) fn abandon_part(&mut self) {
        if let Some(part) = self.part.take() {
            drop(part.writer);
            // Best effort: a `.partial` left behind is never read and a resume removes it.
            let _ = fs::remove_file(&part.path);
        }
    }

    /// Makes the open part, which ends before step `steps`, complete and durable under its
    /// final name in `chains/`.
    pub(super) fn close_part(&mut self, steps: u64, footer: &Footer) -> Result<(), StorageError> {
        let Some(part) = &mut self.part else {
            return Ok(());
        };
        let pairs = footer.key_values(self.part_first_step..steps);
        part.writer.end(Some(pairs)).map_err(|e| part.failed(e))?;
        // Left in `self.part` until here, so that a failure above removes it.
        let part = self.part.take().expect("checked above");
        let path = part.path;
        let synced = part
            .writer
            .into_inner()
            .into_inner()
            .map_err(|e| StorageError::io("write", &path, e.into_error()))
            .and_then(|f| {
                f.file
                    .sync_all()
                    .map_err(|e| StorageError::io("sync", &path, e))
            });
        let chains_dir = &self.files.chains;
        let target = chains_dir.join(part_name(part.index));
        let renamed = synced.and_then(|()| Seal::of_file(&path)).and_then(|seal| {
            fs::rename(&path, &target)
                .map(|()| seal)
                .map_err(|e| StorageError::io("rename", &path, e))
        });
        let seal = match renamed {
            Ok(seal) => seal,
            Err(e) => {
                let _ = fs::remove_file(&path);
                return Err(e);
            }
        };
        sync_dir(chains_dir).map_err(|e| StorageError::io("sync directory", chains_dir, e))?;
        self.durable_parts += 1;
        self.durable_rows += part.rows;
        self.part_seals.push(vec![seal]);
        self.part_first_step = steps;
        Ok(())
    }
}

/// Creates the `.partial` file of part `index` and writes its header.
fn open_part(dir: &Path, index: u64, schema: &ArrowSchema) -> Result<OpenPart, StorageError> {
    let path = dir.join(partial_name(index));
    let file = File::create(&path).map_err(|e| StorageError::io("create", &path, e))?;
    let io_error = Arc::new(OnceLock::new());
    let file = PartFile {
        file,
        error: Arc::clone(&io_error),
    };
    let options = WriteOptions {
        statistics: StatisticsOptions::default(),
        version: Version::V2,
        compression: CompressionOptions::Snappy,
        data_page_size: None,
    };
    let writer = match FileWriter::try_new(BufWriter::new(file), schema.clone(), options) {
        Ok(writer) => writer,
        Err(e) => {
            let _ = fs::remove_file(&path);
            return Err(match io_error.get() {
                Some(io) => StorageError::io("write", &path, copy_of(io)),
                None => StorageError::parquet(&path, e),
            });
        }
    };
    Ok(OpenPart {
        index,
        path,
        writer,
        rows: 0,
        io_error,
    })
}
