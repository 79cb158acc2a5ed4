//! The checkpoint of a chain store (binary, or the JSON of earlier releases), resuming a run
//! from it, and clearing an earlier run.
//!
//! Since format 3 the checkpoint is sealed (see [`super::super::seal`]): a CRC-32 of its body
//! ends the file, and it records the length and CRC-32 of every complete part it counts, so
//! that a resume, a report or a load refuses a corrupted checkpoint or part instead of reading
//! it. Checkpoints of formats 2 and 1 carry no checksum: their runs are still read, as
//! unverified.

use std::fs;
use std::path::{Path, PathBuf};

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::super::read::{chains_schema, check_schema, Part};
use super::super::seal::{seal_bytes, unseal_bytes, Seal, Unsealed};
use super::super::{is_leftover_name, part_name, ChainFiles, StorageError};
use super::{list_files, list_parts, validate_names, Files, ParquetSink, Resumed};
use crate::data::atomic::{sync_dir, write_atomically};

/// Tag of the checkpoint format, checked on resume: version 3 is binary (MessagePack) and
/// sealed, version 2 the same unsealed, version 1 the JSON of earlier releases; all are read.
const CHECKPOINT_FORMAT: &str = "slipbayes-chains/3";
const UNSEALED_CHECKPOINT_FORMAT: &str = "slipbayes-chains/2";
const JSON_CHECKPOINT_FORMAT: &str = "slipbayes-chains/1";
/// Where earlier releases wrote their JSON checkpoint, beside the binary one.
const JSON_CHECKPOINT: &str = "checkpoint.json";

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
    /// For each of the `parts` complete parts, the seals it may have (length and CRC-32): one,
    /// or two while a finishing run rewrites the parts' footers (before and after). Empty in
    /// formats 1 and 2.
    #[serde(default)]
    part_seals: Vec<Vec<Seal>>,
}

/// A checkpoint: binary, `header` then the state, both MessagePack.
#[derive(Debug)]
pub(in super::super) struct CheckpointFile {
    header: CheckpointHeader,
    /// Whether the file was sealed and matched its seal (format 3).
    sealed: bool,
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

impl ParquetSink {
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
        match Self::reopen(files, false)? {
            (sink, state, false) => Ok((sink, state)),
            (_, _, true) => Err(StorageError::AlreadyFinished {
                dir: files.dir.clone(),
            }),
        }
    }

    /// Like [`ParquetSink::resume`], but a finished run is reopened too (`true` says it was):
    /// its chains are complete, and a process killed while it wrote what follows them (the
    /// summaries, the report) is continued from there. Recording nothing more and calling
    /// [`ParquetSink::finish`] again leaves the same files.
    ///
    /// # Errors
    /// As [`ParquetSink::resume`], without [`StorageError::AlreadyFinished`].
    pub fn resume_finished<S: DeserializeOwned>(
        files: &ChainFiles,
    ) -> Result<(Self, S, bool), StorageError> {
        Self::reopen(files, true)
    }

    fn reopen<S: DeserializeOwned>(
        files: &ChainFiles,
        finished_ok: bool,
    ) -> Result<(Self, S, bool), StorageError> {
        let dir = files.dir.as_path();
        let checkpoint_path = files.checkpoint.clone();
        let Some(CheckpointFile {
            header: checkpoint,
            state: stored,
            sealed,
        }) = read_checkpoint(files)?
        else {
            return Err(StorageError::NoCheckpoint {
                dir: dir.to_path_buf(),
            });
        };
        if checkpoint.finished && !finished_ok {
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
        let mut part_seals = Vec::with_capacity(checkpoint.parts as usize);
        for index in 0..checkpoint.parts {
            let path = chains_dir.join(part_name(index));
            // A checkpoint of an earlier release vouches for no part: the parts it counts are
            // sealed as found, so the resumed run's checkpoint vouches for them from here on.
            let seal = if sealed {
                check_part_seal(&checkpoint_path, &checkpoint, index, &path)
            } else {
                Seal::of_file(&path)
            };
            // A part of another run is reported as such; any other mismatch as corruption.
            let part = match (Part::open(path.clone()), seal) {
                (Ok(part), seal) => {
                    check_schema(&path, &part.schema, &expected)?;
                    part_seals.push(vec![seal?]);
                    part
                }
                (Err(_), Err(corrupt)) => return Err(corrupt),
                (Err(unreadable), Ok(_)) => return Err(unreadable),
            };
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

        let finished = checkpoint.finished;
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
                part_seals,
            },
        )?;
        Ok((sink, state, finished))
    }
}

impl Files {
    pub(super) fn write_checkpoint(&self, finished: bool, steps: u64) -> Result<(), StorageError> {
        let header = CheckpointHeader {
            format: CHECKPOINT_FORMAT.to_owned(),
            param_names: self.param_names.clone(),
            derived_names: self.derived_names.clone(),
            row_group_rows: self.row_group_rows,
            parts: self.durable_parts,
            rows: self.durable_rows,
            steps,
            finished,
            part_seals: self.part_seals.clone(),
        };
        let path = &self.files.checkpoint;
        let mut bytes =
            rmp_serde::to_vec_named(&header).map_err(|e| StorageError::State(e.into()))?;
        if let Some(state) = &self.last_state {
            bytes.extend_from_slice(state);
        }
        write_atomically(path, &seal_bytes(bytes))
            .map_err(|e| StorageError::io("write", path, e))?;
        remove_json_checkpoint(&self.files)
    }
}

/// Reads the checkpoint of `files` (or, without one, the JSON checkpoint an earlier release
/// wrote beside it); `None` when there is neither.
pub(in super::super) fn read_checkpoint(
    files: &ChainFiles,
) -> Result<Option<CheckpointFile>, StorageError> {
    let path = &files.checkpoint;
    let bad = |path: &Path, source: Box<dyn std::error::Error + Send + Sync>| {
        StorageError::BadCheckpoint {
            path: path.to_path_buf(),
            source,
        }
    };
    let corrupt = |problem: String| StorageError::CorruptCheckpoint {
        path: path.to_path_buf(),
        problem,
    };
    let checkpoint = match read_if_present(path)? {
        Some(bytes) => {
            let (body, sealed) = match unseal_bytes(&bytes) {
                Unsealed::Verified(body) => (body, true),
                Unsealed::Absent(body) => (body, false),
                Unsealed::Mismatch { recorded, found } => {
                    return Err(corrupt(format!(
                        "its checksum is {found:08x}, it recorded {recorded:08x}"
                    )))
                }
            };
            let mut reader = std::io::Cursor::new(body);
            let header: CheckpointHeader = rmp_serde::from_read(&mut reader).map_err(|e| {
                if sealed {
                    bad(path, e.into())
                } else {
                    // Unsealed and unreadable: a truncated or damaged file of any format.
                    corrupt(format!("{e} (or it was written by another version)"))
                }
            })?;
            let state = &body[reader.position() as usize..];
            CheckpointFile {
                header,
                state: (!state.is_empty()).then(|| state.to_vec()),
                sealed,
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
                sealed: false,
            }));
        }
    };
    let header = &checkpoint.header;
    match (header.format.as_str(), checkpoint.sealed) {
        (CHECKPOINT_FORMAT, true) | (UNSEALED_CHECKPOINT_FORMAT, false) => {}
        (CHECKPOINT_FORMAT, false) => {
            return Err(corrupt(format!(
                "format {CHECKPOINT_FORMAT:?} ends with a checksum, this file does not: it was \
                 cut short or damaged"
            )))
        }
        (UNSEALED_CHECKPOINT_FORMAT, true) => {
            return Err(corrupt(format!(
                "format {UNSEALED_CHECKPOINT_FORMAT:?} carries no checksum, this file does"
            )))
        }
        _ => {
            return Err(bad(
                path,
                format!(
                    "format {:?}, expected {CHECKPOINT_FORMAT:?}",
                    checkpoint.header.format
                )
                .into(),
            ))
        }
    }
    if checkpoint.sealed && header.part_seals.len() as u64 != header.parts {
        return Err(corrupt(format!(
            "it counts {} parts but seals {}",
            header.parts,
            header.part_seals.len()
        )));
    }
    Ok(Some(checkpoint))
}

impl CheckpointFile {
    /// Whether the file was sealed (format 3) and matched its seal.
    pub(in super::super) fn sealed(&self) -> bool {
        self.sealed
    }

    /// Whether `other` counts the same parts with the same seals: read twice, the same
    /// checkpoint (or one that only moved the run's state on), not that of a run replacing it.
    pub(in super::super) fn same_chains(&self, other: &Self) -> bool {
        self.header.parts == other.header.parts && self.header.part_seals == other.header.part_seals
    }

    /// Complete parts the checkpoint counts.
    pub(in super::super) fn parts(&self) -> u64 {
        self.header.parts
    }

    /// Checks part `index` at `path` against its seal in the checkpoint at `checkpoint_path`
    /// (which must be sealed), returning the seal found.
    pub(in super::super) fn check_part(
        &self,
        checkpoint_path: &Path,
        index: u64,
        path: &Path,
    ) -> Result<Seal, StorageError> {
        check_part_seal(checkpoint_path, &self.header, index, path)
    }
}

/// Checks the part at `path`, number `index`, against the seals `header` records for it.
fn check_part_seal(
    checkpoint_path: &Path,
    header: &CheckpointHeader,
    index: u64,
    path: &Path,
) -> Result<Seal, StorageError> {
    let found = Seal::of_file(path)?;
    let accepted = usize::try_from(index)
        .ok()
        .and_then(|i| header.part_seals.get(i))
        .map_or(&[][..], Vec::as_slice);
    if accepted.contains(&found) {
        return Ok(found);
    }
    let recorded = accepted
        .iter()
        .map(|s| format!("{} bytes with checksum {:08x}", s.bytes, s.crc32))
        .collect::<Vec<_>>()
        .join(" or ");
    Err(StorageError::CorruptPart {
        path: path.to_path_buf(),
        checkpoint: checkpoint_path.to_path_buf(),
        problem: format!(
            "{} bytes with checksum {:08x} where {recorded} was written",
            found.bytes, found.crc32
        ),
    })
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

/// The parts and rows the checkpoint of `files` counts (what a reader may read while a fit
/// writes: parts beyond it may still be removed by a resume), or `None` without a checkpoint.
///
/// # Errors
/// [`StorageError::BadCheckpoint`] when it cannot be parsed; [`StorageError::Io`].
pub(crate) fn checkpointed(files: &ChainFiles) -> Result<Option<(u64, u64)>, StorageError> {
    Ok(read_checkpoint(files)?.map(|c| (c.header.parts, c.header.rows)))
}

/// Whether `files` hold a run of ours: `Some(finished)`, or `None` when they hold none.
pub(super) fn existing_run(files: &ChainFiles) -> Result<Option<bool>, StorageError> {
    match read_checkpoint(files) {
        Ok(Some(c)) => return Ok(Some(c.header.finished)),
        Ok(None) => {}
        // An unreadable checkpoint still marks a run; only --overwrite may remove it.
        Err(StorageError::BadCheckpoint { .. } | StorageError::CorruptCheckpoint { .. }) => {
            return Ok(Some(false))
        }
        Err(e) => return Err(e),
    }
    let has_parts = !list_parts(&files.chains)?.is_empty();
    let has_leftovers = !list_leftovers(&files.dir)?.is_empty();
    Ok((has_parts || has_leftovers).then_some(false))
}

/// Removes the parts, leftovers and checkpoint of an earlier run (nothing else).
pub(super) fn remove_run(files: &ChainFiles) -> Result<(), StorageError> {
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
