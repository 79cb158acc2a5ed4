//! Whether the files of a run are the ones it wrote: the checkpoint against its own checksum,
//! each complete part against the length and checksum the checkpoint recorded, a sealed JSON
//! file against its seal.

use std::path::Path;

use super::seal::{unseal_json, Unsealed};
use super::sink::{read_checkpoint, CheckpointFile};
use super::{part_name, ChainFiles, StorageError};

/// Whether the files of a run were proved to be the ones written (see [`verify_run`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Integrity {
    /// The checkpoint matched its checksum, and every part it counts its recorded length and
    /// checksum.
    Verified,
    /// Nothing proves the files intact; why (a run of an earlier release, written without
    /// checksums; no checkpoint).
    Unverified {
        /// Why, as a sentence fragment naming the file.
        reason: String,
    },
}

/// Checks the chain store of a run against its checkpoint: the checkpoint against its own
/// checksum, then every complete part it counts against the length and checksum it recorded.
/// A run of an earlier release (a checkpoint without checksums) is [`Integrity::Unverified`],
/// not refused.
///
/// # Errors
/// [`StorageError::CorruptCheckpoint`] or [`StorageError::CorruptPart`] naming the file and
/// what to do; [`StorageError::BadCheckpoint`] for a checkpoint of an unknown format;
/// [`StorageError::Io`] when a file cannot be read.
pub fn verify_run(files: &ChainFiles) -> Result<Integrity, StorageError> {
    let mut attempt = 0;
    loop {
        attempt += 1;
        let checkpoint = read_checkpoint(files)?;
        match verify_against(files, checkpoint.as_ref()) {
            // A fit replacing the run (a new run in the same directory) may rewrite a part
            // between the reading of the checkpoint and that of the part, which then fails
            // the old checkpoint's seal: verified again, it is checked against the checkpoint
            // it belongs to. A part is corrupt only when the checkpoint did not change.
            Err(e @ (StorageError::CorruptPart { .. } | StorageError::Io(_)))
                if attempt < VERIFY_ATTEMPTS =>
            {
                let now = read_checkpoint(files)?;
                let unchanged = match (&checkpoint, &now) {
                    (Some(then), Some(now)) => then.same_chains(now),
                    (None, None) => true,
                    _ => false,
                };
                if unchanged {
                    return Err(e);
                }
            }
            other => return other,
        }
    }
}

/// Times [`verify_run`] reads a run replaced while it verifies it before it gives up.
const VERIFY_ATTEMPTS: usize = 3;

fn verify_against(
    files: &ChainFiles,
    checkpoint: Option<&CheckpointFile>,
) -> Result<Integrity, StorageError> {
    let Some(checkpoint) = checkpoint else {
        return Ok(Integrity::Unverified {
            reason: format!("there is no checkpoint {}", files.checkpoint.display()),
        });
    };
    if !checkpoint.sealed() {
        return Ok(Integrity::Unverified {
            reason: format!(
                "{} was written by an earlier release, without checksums",
                files.checkpoint.display()
            ),
        });
    }
    for index in 0..checkpoint.parts() {
        let path = files.chains.join(part_name(index));
        checkpoint.check_part(&files.checkpoint, index, &path)?;
    }
    // Parts numbered beyond the checkpoint (a fit writing, or one killed since) are neither
    // verified nor read: readers read the parts the checkpoint counts, and a resume removes
    // the rest.
    Ok(Integrity::Verified)
}

/// Checks the text of a JSON file a run seals (`summary.json`, written with
/// [`super::seal_json`]) at `path`: a seal must match; a file without one is
/// [`Integrity::Unverified`] when the run's checkpoint carries no checksums either (an earlier
/// release wrote both), and refused when it does (the seal was cut off or damaged).
///
/// # Errors
/// [`StorageError::CorruptFile`] naming `path`; the errors of reading the checkpoint.
pub fn verify_sealed_json(
    files: &ChainFiles,
    path: &Path,
    text: &str,
) -> Result<Integrity, StorageError> {
    let corrupt = |problem: String| StorageError::CorruptFile {
        path: path.to_path_buf(),
        problem,
    };
    match unseal_json(text) {
        Unsealed::Verified(_) => Ok(Integrity::Verified),
        Unsealed::Mismatch { recorded, found } => Err(corrupt(format!(
            "its checksum is {found:08x}, it recorded {recorded:08x}"
        ))),
        Unsealed::Absent(_) => match read_checkpoint(files)? {
            Some(checkpoint) if checkpoint.sealed() => Err(corrupt(format!(
                "its checksum (its last key, {:?}) is missing or damaged, and {} says the run \
                 wrote one",
                super::JSON_CHECKSUM_KEY,
                files.checkpoint.display()
            ))),
            _ => Ok(Integrity::Unverified {
                reason: format!(
                    "{} was written by an earlier release, without a checksum",
                    path.display()
                ),
            }),
        },
    }
}
