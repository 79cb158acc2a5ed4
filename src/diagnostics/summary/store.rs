//! Where a summary keeps a quantity's draws and its sorted runs: in memory, or in working
//! files of a directory when they are many ([`Limits`]). Each working file is removed from
//! the directory as soon as it is created and lives on only as an open handle, so none is
//! ever left there, whatever happens to the process (where the system cannot remove an open
//! file, it is removed when dropped instead).

use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering as Atomic};

use crate::diagnostics::DiagnosticsError;
use crate::IoError;

/// How much of a quantity's draws a summary holds in memory at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Draws sorted in memory at a time (one run of the external sort, 12 bytes each), and
    /// draws per partition of the normal scores (20 bytes each while one is laid out). A
    /// quantity with at most this many draws is summarised wholly in memory.
    pub run_draws: usize,
}

impl Limits {
    /// 2¹⁸ draws per run (4 MB for the run being sorted): a quantity of up to 2,048 steps of
    /// 128 walkers (every quantity of a campaign's fit) is summarised in memory, to the same
    /// bits as through working files and without writing and merging them; a longer one
    /// merges runs, so a long fit's summaries hold the same memory as a short one's
    /// (reports/convergence.md compares the peaks at two lengths). Held in memory, a quantity
    /// costs several times 16 bytes a draw: its draws, their sorted records, the ranks and
    /// the normal scores.
    pub const DEFAULT: Limits = Limits { run_draws: 1 << 18 };

    /// Bytes the summary of one quantity holds at its peak, roughly, for walkers of `steps`
    /// steps: the larger of one run being sorted (16 bytes a draw), two merged streams and
    /// the partitions' write buffers (a quarter of that each), and one partition being laid
    /// out (8 bytes a draw and a write buffer); and, what grows with the chains' length,
    /// one walker's series with the FFT work of τ and of the ESS (about 128 bytes a step).
    pub fn working_bytes(&self, steps: usize) -> usize {
        16 * self.run_draws.max(1) + 128 * steps
    }
}

impl Default for Limits {
    fn default() -> Self {
        Self::DEFAULT
    }
}

/// Where the working files of summaries go and how large they may grow in memory; shared by
/// the summaries of a run (it is `Sync`).
#[derive(Debug)]
pub struct Workspace {
    dir: Option<PathBuf>,
    pub(super) limits: Limits,
    seq: AtomicU64,
    files: AtomicUsize,
    pub(super) most_runs: AtomicUsize,
}

impl Workspace {
    /// Working files in `dir` (which must exist), memory as `limits` allow.
    pub fn new(dir: &Path, limits: Limits) -> Self {
        Self {
            dir: Some(dir.to_path_buf()),
            limits,
            seq: AtomicU64::new(0),
            files: AtomicUsize::new(0),
            most_runs: AtomicUsize::new(0),
        }
    }

    /// Everything in memory, whatever the number of draws (as the in-memory functions).
    pub fn in_memory() -> Self {
        Self {
            dir: None,
            limits: Limits::DEFAULT,
            seq: AtomicU64::new(0),
            files: AtomicUsize::new(0),
            most_runs: AtomicUsize::new(0),
        }
    }

    /// The limits.
    pub fn limits(&self) -> Limits {
        self.limits
    }

    /// Working files created so far (each removed when done).
    #[cfg(test)]
    pub(crate) fn files_created(&self) -> usize {
        self.files.load(Atomic::Relaxed)
    }

    /// The most sorted runs one merge has read so far (1 when every sort fitted in memory).
    #[cfg(test)]
    pub(crate) fn most_runs_merged(&self) -> usize {
        self.most_runs.load(Atomic::Relaxed)
    }

    /// Whether `n` draws are summarised through working files.
    pub(super) fn spills(&self, n: usize) -> bool {
        self.dir.is_some() && n > self.limits.run_draws
    }

    fn error(&self, action: &'static str, path: &Path, e: std::io::Error) -> DiagnosticsError {
        DiagnosticsError::Scratch(IoError::new(action, path, e))
    }

    /// A new store: in memory, or a working file in the directory.
    pub(super) fn store(&self, spill: bool) -> Result<Store<'_>, DiagnosticsError> {
        let backing = match (&self.dir, spill) {
            (Some(dir), true) => {
                let path = dir.join(format!(
                    ".summary-{}-{}.tmp",
                    std::process::id(),
                    self.seq.fetch_add(1, Atomic::Relaxed)
                ));
                let file = OpenOptions::new()
                    .read(true)
                    .write(true)
                    .create_new(true)
                    .open(&path)
                    .map_err(|e| self.error("create", &path, e))?;
                self.files.fetch_add(1, Atomic::Relaxed);
                // Removed at once: the open handle keeps the data, and nothing is left
                // behind if the process dies. Where an open file cannot be removed, it is
                // removed on drop.
                let linked = std::fs::remove_file(&path).is_err();
                Backing::File(ScratchFile { file, path, linked })
            }
            _ => Backing::Memory(Vec::new()),
        };
        Ok(Store { ws: self, backing })
    }
}

#[derive(Debug)]
struct ScratchFile {
    file: File,
    path: PathBuf,
    /// Still in the directory (removing an open file failed).
    linked: bool,
}

impl Drop for ScratchFile {
    fn drop(&mut self) {
        if self.linked {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

#[derive(Debug)]
enum Backing {
    Memory(Vec<u8>),
    File(ScratchFile),
}

/// Bytes addressed by offset, in memory or in a working file.
#[derive(Debug)]
pub(super) struct Store<'w> {
    pub(super) ws: &'w Workspace,
    backing: Backing,
}

impl Store<'_> {
    fn write_at(&mut self, offset: usize, bytes: &[u8]) -> Result<(), DiagnosticsError> {
        match &mut self.backing {
            Backing::Memory(v) => {
                let end = offset + bytes.len();
                if v.len() < end {
                    v.resize(end, 0);
                }
                v[offset..end].copy_from_slice(bytes);
                Ok(())
            }
            Backing::File(f) => {
                let mut file = &f.file;
                file.seek(SeekFrom::Start(offset as u64))
                    .and_then(|_| file.write_all(bytes))
                    .map_err(|e| self.ws.error("write", &f.path, e))
            }
        }
    }

    fn read_at(&self, offset: usize, out: &mut [u8]) -> Result<(), DiagnosticsError> {
        match &self.backing {
            Backing::Memory(v) => {
                // Every read is of values written before: reading past them is a bug, and
                // the slice panics.
                out.copy_from_slice(&v[offset..offset + out.len()]);
                Ok(())
            }
            Backing::File(f) => {
                let mut file = &f.file;
                file.seek(SeekFrom::Start(offset as u64))
                    .and_then(|_| file.read_exact(out))
                    .map_err(|e| self.ws.error("read", &f.path, e))
            }
        }
    }

    /// Writes `values` as f64 from value `at` on.
    pub(super) fn write_f64(
        &mut self,
        at: usize,
        values: &[f64],
        bytes: &mut Vec<u8>,
    ) -> Result<(), DiagnosticsError> {
        bytes.clear();
        for v in values {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        self.write_at(at * 8, bytes)
    }

    /// Reads `out.len()` f64 from value `at` on.
    pub(super) fn read_f64(
        &self,
        at: usize,
        out: &mut [f64],
        bytes: &mut Vec<u8>,
    ) -> Result<(), DiagnosticsError> {
        bytes.resize(out.len() * 8, 0);
        self.read_at(at * 8, bytes)?;
        for (o, b) in out.iter_mut().zip(bytes.chunks_exact(8)) {
            *o = f64::from_le_bytes(b.try_into().expect("8 bytes"));
        }
        Ok(())
    }

    /// Writes records (value, index) from record `at` on.
    pub(super) fn write_records(
        &mut self,
        at: usize,
        records: &[Record],
        bytes: &mut Vec<u8>,
    ) -> Result<(), DiagnosticsError> {
        bytes.clear();
        for (v, i) in records {
            bytes.extend_from_slice(&v.to_le_bytes());
            bytes.extend_from_slice(&i.to_le_bytes());
        }
        self.write_at(at * RECORD_BYTES, bytes)
    }

    /// Reads `count` records from record `at` on into `out` (replacing its contents).
    pub(super) fn read_records(
        &self,
        at: usize,
        count: usize,
        out: &mut Vec<Record>,
        bytes: &mut Vec<u8>,
    ) -> Result<(), DiagnosticsError> {
        bytes.resize(count * RECORD_BYTES, 0);
        self.read_at(at * RECORD_BYTES, bytes)?;
        out.clear();
        out.extend(bytes.chunks_exact(RECORD_BYTES).map(|b| {
            (
                f64::from_le_bytes(b[..8].try_into().expect("8 bytes")),
                u32::from_le_bytes(b[8..].try_into().expect("4 bytes")),
            )
        }));
        Ok(())
    }
}

/// A draw's value and its index in walker-major order.
pub(super) type Record = (f64, u32);
const RECORD_BYTES: usize = 12;
/// Records encoded per write.
pub(super) const WRITE_BATCH: usize = 4096;
