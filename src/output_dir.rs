//! Whose directory is it: the one rule every command that writes a directory or a set of files
//! follows, so that nothing of the user's is ever replaced by surprise.
//!
//! An output directory is written only if it is new, empty, or carries the marker
//! [`MARKER`] that slipbayes wrote when it first claimed it (or was written by an earlier
//! version that wrote no marker: each [`OutputKind`] says how to recognise one). Any other
//! directory is refused with an error naming it and the files that would have been replaced,
//! unless the caller says `overwrite`; even then only the files of the kind
//! ([`OutputKind::writes`]) are ever written, and every other file stays as it was.
//! [`OutputDir::claim`] decides, and writes the marker first, atomically, so that an
//! interrupted command leaves a directory it recognises as its own.
//!
//! Output files outside a directory of ours (`simulate --out FILE`, `import --out FILE`) follow
//! the same rule file by file: [`claim_files`] refuses an existing file unless `overwrite`.
//!
//! This module knows no file of a fit or of a validation: the kinds are declared where those
//! files are named ([`crate::fit::run_dir::RUN_OUTPUT`] for a run directory).

use std::path::{Path, PathBuf};

use crate::data::write_atomically;
use crate::IoError;

/// The marker file of a directory slipbayes writes.
pub const MARKER: &str = ".slipbayes-run";
/// The lock a fit holds on its run directory while it writes (see `RunLock`).
pub const LOCK_FILE: &str = ".slipbayes.lock";
/// First line of the marker: what the file is, for whoever finds it.
const MARKER_TITLE: &str = "# slipbayes output directory: slipbayes writes only its own files here";
/// Version of the marker's format (`format = 1`).
const MARKER_FORMAT: u32 = 1;
/// Names of the entries left out of a refusal's list of other files, at most.
const LISTED: usize = 6;

/// What a command writes into an output directory, and how to recognise a directory of that
/// kind written before markers existed.
#[derive(Debug, Clone, Copy)]
pub struct OutputKind {
    /// The kind, as the marker records it (`run`, `validation`): a directory of one kind is
    /// not claimed by a command of another.
    pub name: &'static str,
    /// Every entry (file or folder, by name) that commands of this kind write into the
    /// directory; with `overwrite` these, and only these, are replaced.
    pub writes: &'static [&'static str],
    /// Entries it writes besides: files whose names start with these prefixes (parts being
    /// written). Temporaries of atomic writes are always its own.
    pub writes_prefixed: &'static [&'static str],
    /// Whether a directory without a marker was written by an earlier version of this kind
    /// (so that existing runs stay resumable and reportable).
    pub written_before_markers: fn(&Path) -> bool,
}

impl OutputKind {
    fn is_written(&self, name: &str) -> bool {
        name == MARKER
            || crate::data::atomic::is_temporary_name(name)
            || self.writes.contains(&name)
            || self.writes_prefixed.iter().any(|p| name.starts_with(p))
    }
}

/// Why an output directory or file was refused; each names the directory or the files, and
/// says what to do.
#[derive(Debug, thiserror::Error)]
pub enum ClaimError {
    /// The directory is not one of ours.
    #[error(
        "{} is not a slipbayes {kind} directory ({}){}; pass --overwrite to write there anyway \
         (only slipbayes' own files are replaced, every other file is left as it is), or choose \
         another --out (a new or empty directory)",
        dir.display(),
        match marked_as {
            Some(other) => format!("its {MARKER} marks it as a slipbayes {other} directory"),
            None => format!("it holds no {MARKER} marker"),
        },
        refusal(replaced, others)
    )]
    Foreign {
        /// The directory.
        dir: PathBuf,
        /// The kind it was claimed for.
        kind: &'static str,
        /// The kind its marker names, when it names another.
        marked_as: Option<String>,
        /// Files of the directory that the command would have replaced.
        replaced: Vec<String>,
        /// Its other entries (at most a few, for the message).
        others: Vec<String>,
    },
    /// The output path exists but is not a directory.
    #[error("{} is not a directory; choose another --out", path.display())]
    NotADirectory {
        /// The path.
        path: PathBuf,
    },
    /// Output files that exist already.
    #[error(
        "{} already {}; pass --overwrite to replace {}, or choose another --out",
        list_paths(files),
        if files.len() == 1 { "exists" } else { "exist" },
        if files.len() == 1 { "it" } else { "them" }
    )]
    FilesExist {
        /// The existing files.
        files: Vec<PathBuf>,
    },
    /// The directory or its marker could not be read, created or written.
    #[error(transparent)]
    Io(#[from] IoError),
}

fn refusal(replaced: &[String], others: &[String]) -> String {
    let mut text = String::new();
    if !replaced.is_empty() {
        text.push_str(&format!(
            ": writing there would replace {}",
            replaced.join(", ")
        ));
    }
    if !others.is_empty() {
        text.push_str(if replaced.is_empty() {
            ": it holds "
        } else {
            "; it also holds "
        });
        text.push_str(&others.join(", "));
    }
    text
}

fn list_paths(files: &[PathBuf]) -> String {
    let names: Vec<String> = files.iter().map(|f| f.display().to_string()).collect();
    names.join(" and ")
}

/// How a directory stands towards a kind of output.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Ownership {
    /// It does not exist.
    Absent,
    /// It exists and is empty (but for a stale lock of ours).
    Empty,
    /// It carries a marker of this kind.
    Marked,
    /// It carries no marker but was written by an earlier version of this kind.
    WrittenBeforeMarkers,
    /// Anything else: not ours.
    Foreign {
        /// The kind its marker names, when it names another.
        marked_as: Option<String>,
        /// Its entries that the kind writes, sorted.
        replaced: Vec<String>,
        /// Its other entries, sorted.
        others: Vec<String>,
    },
}

/// A claimed output directory: a command may write the files of its kind there.
#[derive(Debug, Clone)]
pub struct OutputDir {
    path: PathBuf,
    kind: OutputKind,
}

impl OutputDir {
    /// How the directory at `path` stands towards `kind`, reading it without writing.
    ///
    /// # Errors
    /// [`ClaimError::NotADirectory`] when `path` is a file; [`ClaimError::Io`] when it cannot
    /// be listed.
    pub fn ownership(path: &Path, kind: &OutputKind) -> Result<Ownership, ClaimError> {
        let entries = match std::fs::read_dir(path) {
            Ok(entries) => entries,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Ownership::Absent),
            Err(_) if path.exists() && !path.is_dir() => {
                return Err(ClaimError::NotADirectory {
                    path: path.to_path_buf(),
                })
            }
            Err(e) => return Err(IoError::new("list", path, e).into()),
        };
        let mut names = Vec::new();
        for entry in entries {
            let entry = entry.map_err(IoError::at("list", path))?;
            names.push(entry.file_name().to_string_lossy().into_owned());
        }
        // A lock or a temporary left by a killed command of ours says nothing of whose the
        // rest is.
        names.retain(|n| n != LOCK_FILE && !crate::data::atomic::is_temporary_name(n));
        if names.is_empty() {
            return Ok(Ownership::Empty);
        }
        let marked_as = if names.iter().any(|n| n == MARKER) {
            match read_marker(&path.join(MARKER)) {
                Some(name) if name == kind.name => return Ok(Ownership::Marked),
                other => Some(other.unwrap_or_else(|| "unknown".to_owned())),
            }
        } else {
            None
        };
        if marked_as.is_none() && (kind.written_before_markers)(path) {
            return Ok(Ownership::WrittenBeforeMarkers);
        }
        names.sort();
        let (replaced, others) = names
            .into_iter()
            .filter(|n| n != MARKER)
            .partition(|n| kind.is_written(n));
        Ok(Ownership::Foreign {
            marked_as,
            replaced,
            others,
        })
    }

    /// Claims the directory at `path` for output of `kind`: creates it if need be, and writes
    /// the marker (atomically, before anything else is written) unless it carries one of this
    /// kind. A directory that is not new, empty or ours ([`Ownership::Foreign`]) is refused
    /// unless `overwrite`.
    ///
    /// # Errors
    /// [`ClaimError::Foreign`] naming the directory, the files that would be replaced and the
    /// others; [`ClaimError::NotADirectory`]; [`ClaimError::Io`] when the directory or the
    /// marker cannot be created or written.
    pub fn claim(path: &Path, kind: OutputKind, overwrite: bool) -> Result<Self, ClaimError> {
        let ownership = Self::ownership(path, &kind)?;
        match ownership {
            Ownership::Marked => {}
            Ownership::Foreign {
                marked_as,
                replaced,
                mut others,
            } if !overwrite => {
                if others.len() > LISTED {
                    let more = others.len() - LISTED;
                    others.truncate(LISTED);
                    others.push(format!("and {more} more"));
                }
                return Err(ClaimError::Foreign {
                    dir: path.to_path_buf(),
                    kind: kind.name,
                    marked_as,
                    replaced,
                    others,
                });
            }
            Ownership::Absent
            | Ownership::Empty
            | Ownership::WrittenBeforeMarkers
            | Ownership::Foreign { .. } => {
                std::fs::create_dir_all(path).map_err(IoError::at("create", path))?;
                write_marker(&path.join(MARKER), &kind)?;
            }
        }
        Ok(Self {
            path: path.to_path_buf(),
            kind,
        })
    }

    /// The directory.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The kind it was claimed for.
    pub fn kind(&self) -> &OutputKind {
        &self.kind
    }

    /// The entries of the directory its kind may write (the marker first).
    pub fn files(&self) -> Vec<PathBuf> {
        std::iter::once(MARKER)
            .chain(self.kind.writes.iter().copied())
            .map(|name| self.path.join(name))
            .collect()
    }
}

/// Refuses output files that exist already, unless `overwrite`: the rule of [`OutputDir`] for
/// commands that write files of the user's choosing (`simulate`, `import`).
///
/// # Errors
/// [`ClaimError::FilesExist`] naming every existing file.
pub fn claim_files(files: &[&Path], overwrite: bool) -> Result<(), ClaimError> {
    if overwrite {
        return Ok(());
    }
    let existing: Vec<PathBuf> = files
        .iter()
        .filter(|f| f.exists())
        .map(|f| f.to_path_buf())
        .collect();
    if existing.is_empty() {
        Ok(())
    } else {
        Err(ClaimError::FilesExist { files: existing })
    }
}

fn write_marker(path: &Path, kind: &OutputKind) -> Result<(), ClaimError> {
    let command: Vec<String> = std::env::args().collect();
    let text = format!(
        "{MARKER_TITLE}\nformat = {MARKER_FORMAT}\nkind = \"{}\"\nslipbayes_version = \"{}\"\n\
         command = {:?}\n",
        kind.name,
        env!("CARGO_PKG_VERSION"),
        command.join(" ")
    );
    write_atomically(path, text.as_bytes()).map_err(IoError::at("write", path))?;
    Ok(())
}

/// The kind a marker names, or `None` when it is not a marker of ours.
fn read_marker(path: &Path) -> Option<String> {
    let text = std::fs::read_to_string(path).ok()?;
    let mut lines = text.lines();
    if lines.next()? != MARKER_TITLE {
        return None;
    }
    lines.find_map(|line| {
        let value = line.strip_prefix("kind = ")?;
        Some(value.trim().trim_matches('"').to_owned())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const KIND: OutputKind = OutputKind {
        name: "test",
        writes: &["summary.json", "report.html", "chains"],
        writes_prefixed: &[".part-"],
        written_before_markers: |dir| dir.join("checkpoint.bin").exists(),
    };

    #[test]
    fn new_and_empty_directories_are_claimed_and_marked() {
        let tmp = tempfile::tempdir().unwrap();
        let new = tmp.path().join("new");
        OutputDir::claim(&new, KIND, false).unwrap();
        assert_eq!(read_marker(&new.join(MARKER)).as_deref(), Some("test"));
        assert_eq!(
            OutputDir::ownership(&new, &KIND).unwrap(),
            Ownership::Marked
        );
        let empty = tmp.path().join("empty");
        std::fs::create_dir(&empty).unwrap();
        OutputDir::claim(&empty, KIND, false).unwrap();
        assert!(empty.join(MARKER).exists());
    }

    #[test]
    fn a_foreign_directory_is_refused_naming_what_would_be_replaced() {
        let tmp = tempfile::tempdir().unwrap();
        for name in ["summary.json", "report.html", "notes.txt"] {
            std::fs::write(tmp.path().join(name), "mine").unwrap();
        }
        let err = OutputDir::claim(tmp.path(), KIND, false).unwrap_err();
        let text = err.to_string();
        assert!(
            text.contains(&tmp.path().display().to_string())
                && text.contains("would replace report.html, summary.json")
                && text.contains("notes.txt")
                && text.contains("--overwrite")
                && text.contains("another --out"),
            "{text}"
        );
        assert!(!tmp.path().join(MARKER).exists());
        OutputDir::claim(tmp.path(), KIND, true).unwrap();
        assert_eq!(
            OutputDir::ownership(tmp.path(), &KIND).unwrap(),
            Ownership::Marked
        );
        assert_eq!(
            std::fs::read_to_string(tmp.path().join("notes.txt")).unwrap(),
            "mine"
        );
    }

    #[test]
    fn a_directory_of_another_kind_is_refused_and_an_earlier_one_recognised() {
        let tmp = tempfile::tempdir().unwrap();
        let other = OutputKind {
            name: "other",
            ..KIND
        };
        OutputDir::claim(tmp.path(), other, false).unwrap();
        let text = OutputDir::claim(tmp.path(), KIND, false)
            .unwrap_err()
            .to_string();
        assert!(text.contains("as a slipbayes other directory"), "{text}");
        let earlier = tempfile::tempdir().unwrap();
        std::fs::write(earlier.path().join("checkpoint.bin"), "x").unwrap();
        std::fs::write(earlier.path().join("summary.json"), "{}").unwrap();
        assert_eq!(
            OutputDir::ownership(earlier.path(), &KIND).unwrap(),
            Ownership::WrittenBeforeMarkers
        );
        OutputDir::claim(earlier.path(), KIND, false).unwrap();
        assert!(earlier.path().join(MARKER).exists());
    }

    #[test]
    fn existing_files_are_refused_unless_overwrite() {
        let tmp = tempfile::tempdir().unwrap();
        let (a, b) = (tmp.path().join("a.csv"), tmp.path().join("a.json"));
        claim_files(&[&a, &b], false).unwrap();
        std::fs::write(&b, "mine").unwrap();
        let text = claim_files(&[&a, &b], false).unwrap_err().to_string();
        assert!(
            text.contains(&b.display().to_string()) && !text.contains("a.csv"),
            "{text}"
        );
        claim_files(&[&a, &b], true).unwrap();
    }
}
