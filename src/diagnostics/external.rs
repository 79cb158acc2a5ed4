//! The summary of one quantity in memory that does not grow with the number of draws: the
//! same numbers as [`summarize`](super::summarize), to the last bit, from draws kept in a
//! working file.
//!
//! [`summarize`](super::summarize) holds every draw of a quantity and several working copies
//! (sorted draws, ranks, normal scores, split chains, folded draws): 16 MB per copy for the
//! 2 million draws of a 16,000-step run of 128 walkers. Here the draws are written once,
//! walker by walker ([`DrawsWriter`]), to a working file that is read back one walker (or one
//! half-walker) at a time, and everything that needs the draws in sorted order takes them
//! from an external sort:
//!
//! - Mean, sd, MCSE of the mean and sd, ESS of the mean, tail ESS (indicators of the
//!   exact 5 % and 95 % quantiles) and τ stream over the walkers, taking every sum in the
//!   order the in-memory functions take it, so the floating-point results are identical.
//! - The sorted draws: runs of at most [`Limits::run_draws`] draws (value, index) are sorted
//!   in memory and written to a working file; a k-way merge streams them in order.
//!   Quantiles (median, equal-tailed interval, the 5 % and 95 % quantiles) pick their order
//!   statistics from one merged stream; the HDI scans two merged streams `floor(p n)` apart.
//! - Rank-normalised R̂ and bulk ESS need each draw's average rank over all draws. A merged
//!   stream gives the ranks in sorted order; a second stream, running behind the first by
//!   one group of ties, hands each draw its group's average rank, and the normal scores go,
//!   by index, to partitions of at most [`Limits::run_draws`] draws, each of which is then
//!   laid out in walker order and written to a file of scores read back like the draws.
//!   The folded draws |x − median| of the tail R̂ go through the same sort. The normal
//!   scores depend only on exact ranks, so they are the in-memory scores to the bit.
//!
//! A quantity of at most [`Limits::run_draws`] draws keeps all of this in memory (one run, one
//! partition); a longer one writes its working files to the [`Workspace`]'s directory. Each
//! file is removed from the directory as soon as it is created and lives on only as an open
//! handle, so no working file is ever left there, whatever happens to the process (where the
//! system cannot remove an open file, it is removed when dropped instead).

use std::cmp::Ordering;
use std::collections::BinaryHeap;
use std::fs::{File, OpenOptions};
use std::io::{Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering as Atomic};

use super::arviz::{
    average_rank, eti_at, hdi_scan, hdi_span, median_at, mquantile_at, normal_score, Autocov,
    EssRows, RhatRows, SeqSum, TAIL_PROBS,
};
use super::autocorr::{time_of_acf, AcfSum, DEFAULT_WINDOW_FACTOR};
use super::ensemble::Summary;
use super::error::{check_prob, DiagnosticsError};
use super::MIN_DRAWS;

/// How much of a quantity's draws a summary holds in memory at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Limits {
    /// Draws sorted in memory at a time (one run of the external sort, 12 bytes each), and
    /// draws per partition of the normal scores (20 bytes each while one is laid out). A
    /// quantity with at most this many draws is summarised wholly in memory.
    pub run_draws: usize,
}

impl Limits {
    /// 65,536 draws per run: 1 MB for the run being sorted, and a 2-million-draw quantity
    /// (16,000 steps of 128 walkers) merges 32 runs.
    pub const DEFAULT: Limits = Limits { run_draws: 1 << 16 };

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
    limits: Limits,
    seq: AtomicU64,
    files: AtomicUsize,
    most_runs: AtomicUsize,
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
    pub fn files_created(&self) -> usize {
        self.files.load(Atomic::Relaxed)
    }

    /// The most sorted runs one merge has read so far (1 when every sort fitted in memory).
    pub fn most_runs_merged(&self) -> usize {
        self.most_runs.load(Atomic::Relaxed)
    }

    /// Whether `n` draws are summarised through working files.
    fn spills(&self, n: usize) -> bool {
        self.dir.is_some() && n > self.limits.run_draws
    }

    fn error(&self, action: &'static str, e: std::io::Error) -> DiagnosticsError {
        DiagnosticsError::Scratch {
            action,
            dir: self.dir.clone().unwrap_or_default(),
            message: e.to_string(),
        }
    }

    /// A new store: in memory, or a working file in the directory.
    fn store(&self, spill: bool) -> Result<Store<'_>, DiagnosticsError> {
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
                    .map_err(|e| self.error("create", e))?;
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
struct Store<'w> {
    ws: &'w Workspace,
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
                    .map_err(|e| self.ws.error("write", e))
            }
        }
    }

    fn read_at(&self, offset: usize, out: &mut [u8]) -> Result<(), DiagnosticsError> {
        match &self.backing {
            Backing::Memory(v) => {
                let end = offset + out.len();
                if v.len() < end {
                    return Err(self.ws.error(
                        "read",
                        std::io::Error::new(
                            std::io::ErrorKind::UnexpectedEof,
                            "read beyond what was written",
                        ),
                    ));
                }
                out.copy_from_slice(&v[offset..end]);
                Ok(())
            }
            Backing::File(f) => {
                let mut file = &f.file;
                file.seek(SeekFrom::Start(offset as u64))
                    .and_then(|_| file.read_exact(out))
                    .map_err(|e| self.ws.error("read", e))
            }
        }
    }

    /// Writes `values` as f64 from value `at` on.
    fn write_f64(
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
    fn read_f64(
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
    fn write_records(
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
    fn read_records(
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
type Record = (f64, u32);
const RECORD_BYTES: usize = 12;
/// Records encoded per write.
const WRITE_BATCH: usize = 4096;

/// Draws of one quantity from `ensembles × walkers` walkers of `steps` steps each, walker
/// by walker (`[e][w][t]`), as [`EnsembleDraws`](super::EnsembleDraws) lays them out, kept in
/// a [`Workspace`]. Written by a [`DrawsWriter`].
#[derive(Debug)]
pub struct WalkerDraws<'w> {
    store: Store<'w>,
    ensembles: usize,
    walkers: usize,
    steps: usize,
}

/// Writes the draws of one quantity, in the order the chains hold them (step, then
/// ensemble, then walker), into [`WalkerDraws`].
#[derive(Debug)]
pub struct DrawsWriter<'w> {
    draws: WalkerDraws<'w>,
    written: usize,
    /// The first non-finite draw in walker order: (index, value).
    first_bad: Option<(usize, f64)>,
    per_walker: Vec<Vec<f64>>,
    bytes: Vec<u8>,
}

impl<'w> DrawsWriter<'w> {
    /// A writer of `ensembles × walkers × steps` draws in `ws`.
    ///
    /// # Errors
    /// No ensembles or walkers, fewer than [`MIN_DRAWS`] steps, 2³² draws or more; a working
    /// file that cannot be created.
    pub fn new(
        ws: &'w Workspace,
        ensembles: usize,
        walkers: usize,
        steps: usize,
    ) -> Result<Self, DiagnosticsError> {
        if ensembles == 0 || walkers == 0 {
            return Err(DiagnosticsError::NoChains { needed: 1 });
        }
        if steps < MIN_DRAWS {
            return Err(DiagnosticsError::TooFewDraws {
                what: "ensemble diagnostics",
                have: steps,
                needed: MIN_DRAWS,
            });
        }
        let n = ensembles * walkers * steps;
        if u32::try_from(n).is_err() {
            return Err(DiagnosticsError::InvalidArgument {
                name: "draws",
                value: n as f64,
                reason: "a summary takes fewer than 2^32 draws of a quantity",
            });
        }
        Ok(Self {
            draws: WalkerDraws {
                store: ws.store(ws.spills(n))?,
                ensembles,
                walkers,
                steps,
            },
            written: 0,
            first_bad: None,
            per_walker: vec![Vec::new(); ensembles * walkers],
            bytes: Vec::new(),
        })
    }

    /// Appends the next draws in the chains' order (step, then ensemble, then walker),
    /// continuing where the last call stopped.
    ///
    /// # Errors
    /// More draws than the shape holds; a working file that cannot be written.
    pub fn push(&mut self, values: &[f64]) -> Result<(), DiagnosticsError> {
        let d = &mut self.draws;
        let chains = d.ensembles * d.walkers;
        let n = chains * d.steps;
        if self.written + values.len() > n {
            return Err(DiagnosticsError::InvalidArgument {
                name: "draws written",
                value: (self.written + values.len()) as f64,
                reason: "must not exceed ensembles * walkers * steps",
            });
        }
        let first_step = self.written / chains;
        let mut starts = vec![usize::MAX; chains];
        for (k, &v) in values.iter().enumerate() {
            let row = self.written + k;
            let (t, c) = (row / chains, row % chains);
            if starts[c] == usize::MAX {
                starts[c] = t;
            }
            self.per_walker[c].push(v);
            if !v.is_finite() {
                let at = c * d.steps + t;
                if self.first_bad.is_none_or(|(i, _)| at < i) {
                    self.first_bad = Some((at, v));
                }
            }
        }
        debug_assert!(starts.iter().all(|&s| s == usize::MAX || s >= first_step));
        for (c, series) in self.per_walker.iter_mut().enumerate() {
            if !series.is_empty() {
                d.store
                    .write_f64(c * d.steps + starts[c], series, &mut self.bytes)?;
                series.clear();
            }
        }
        self.written += values.len();
        Ok(())
    }

    /// The draws written.
    ///
    /// # Errors
    /// Fewer draws than the shape holds; a non-finite draw (reported as chain
    /// `e * walkers + w` at index `t`, as [`EnsembleDraws::new`](super::EnsembleDraws::new)
    /// does).
    pub fn finish(self) -> Result<WalkerDraws<'w>, DiagnosticsError> {
        let d = self.draws;
        let n = d.ensembles * d.walkers * d.steps;
        if self.written != n {
            return Err(DiagnosticsError::InvalidArgument {
                name: "draws written",
                value: self.written as f64,
                reason: "must equal ensembles * walkers * steps",
            });
        }
        if let Some((i, value)) = self.first_bad {
            return Err(DiagnosticsError::NonFinite {
                chain: i / d.steps,
                index: i % d.steps,
                value,
            });
        }
        Ok(d)
    }
}

impl WalkerDraws<'_> {
    fn ws(&self) -> &Workspace {
        self.store.ws
    }

    fn chains(&self) -> usize {
        self.ensembles * self.walkers
    }

    fn len(&self) -> usize {
        self.chains() * self.steps
    }

    /// Number of ensembles.
    pub fn ensembles(&self) -> usize {
        self.ensembles
    }

    /// Walkers per ensemble.
    pub fn walkers(&self) -> usize {
        self.walkers
    }

    /// Steps per walker.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Walker `c` (`e * walkers + w`) from step `t` on, `out.len()` steps.
    fn read(
        &self,
        c: usize,
        t: usize,
        out: &mut [f64],
        bytes: &mut Vec<u8>,
    ) -> Result<(), DiagnosticsError> {
        self.store.read_f64(c * self.steps + t, out, bytes)
    }

    /// Calls `f(c, series)` for every walker in order.
    fn each_walker(
        &self,
        mut f: impl FnMut(usize, &[f64]) -> Result<(), DiagnosticsError>,
    ) -> Result<(), DiagnosticsError> {
        let mut series = vec![0.0; self.steps];
        let mut bytes = Vec::new();
        for c in 0..self.chains() {
            self.read(c, 0, &mut series, &mut bytes)?;
            f(c, &series)?;
        }
        Ok(())
    }

    /// Calls `f(segment)` for every row of the split chains in ArviZ's order: the first
    /// `steps/2` steps of every walker, then the last `steps/2` of every walker.
    fn each_half(&self, mut f: impl FnMut(&[f64])) -> Result<(), DiagnosticsError> {
        let half = self.steps / 2;
        let mut segment = vec![0.0; half];
        let mut bytes = Vec::new();
        for first in [0, self.steps - half] {
            for c in 0..self.chains() {
                self.read(c, first, &mut segment, &mut bytes)?;
                f(&segment);
            }
        }
        Ok(())
    }

    /// Whether draw `i` (walker-major) is in the split chains (the middle step of an odd
    /// number of steps is not).
    fn in_split(&self, i: u32) -> bool {
        self.steps % 2 == 0 || i as usize % self.steps != self.steps / 2
    }

    /// The mean of the draws and the Monte-Carlo standard error of the mean (ArviZ
    /// `mcse(method="mean")` with every walker as a chain), as
    /// [`mean`](super::arviz) and [`mcse_mean`](super::mcse_mean) give them on the same
    /// draws.
    ///
    /// # Errors
    /// A working file that cannot be read.
    pub fn mean_and_mcse(&self) -> Result<(f64, f64), DiagnosticsError> {
        let moments = self.moments()?;
        let mut ess = EssRows::new(self.steps / 2);
        let mut autocov = Autocov::new(self.steps / 2);
        self.each_half(|segment| ess.push(segment, &mut autocov))?;
        Ok((moments.mean, moments.var.sqrt() / ess.finish().sqrt()))
    }

    /// The mean and the sums of squares about it, in walker order.
    fn moments(&self) -> Result<Moments, DiagnosticsError> {
        let n = self.len() as f64;
        let mut total = SeqSum::default();
        self.each_walker(|_, s| {
            total.add_all(s.iter().copied());
            Ok(())
        })?;
        let mean = total.0 / n;
        let (mut c2, mut c4) = (SeqSum::default(), SeqSum::default());
        self.each_walker(|_, s| {
            for &v in s {
                let d = (v - mean) * (v - mean);
                c2.0 += d;
                c4.0 += d * d;
            }
            Ok(())
        })?;
        Ok(Moments {
            mean,
            var: c2.0 / (n - 1.0),
            evar: c2.0 / n,
            mean_sq: c4.0 / n,
        })
    }

    /// The draws (or the values `f` gives of them) sorted in runs, with their indices; only
    /// the draws `keep` accepts.
    fn sorted_runs(
        &self,
        keep: impl Fn(u32) -> bool,
        f: impl Fn(f64) -> f64,
    ) -> Result<Runs<'_>, DiagnosticsError> {
        let ws = self.ws();
        let mut runs = RunWriter::new(ws, ws.spills(self.len()))?;
        let steps = self.steps;
        self.each_walker(|c, s| {
            for (t, &v) in s.iter().enumerate() {
                let i = (c * steps + t) as u32;
                if keep(i) {
                    runs.push((f(v), i))?;
                }
            }
            Ok(())
        })?;
        runs.finish()
    }
}

/// Mean, variance (`ddof = 1`) and the mean of squared and fourth-power deviations.
struct Moments {
    mean: f64,
    var: f64,
    evar: f64,
    mean_sq: f64,
}

/// Sorted runs of records in one store.
#[derive(Debug)]
struct Runs<'w> {
    store: Store<'w>,
    /// (first record, records) of each run.
    bounds: Vec<(usize, usize)>,
}

struct RunWriter<'w> {
    store: Store<'w>,
    buf: Vec<Record>,
    cap: usize,
    bounds: Vec<(usize, usize)>,
    written: usize,
    bytes: Vec<u8>,
}

impl<'w> RunWriter<'w> {
    fn new(ws: &'w Workspace, spill: bool) -> Result<Self, DiagnosticsError> {
        Ok(Self {
            store: ws.store(spill)?,
            buf: Vec::new(),
            cap: if spill {
                ws.limits.run_draws.max(1)
            } else {
                usize::MAX
            },
            bounds: Vec::new(),
            written: 0,
            bytes: Vec::new(),
        })
    }

    fn push(&mut self, r: Record) -> Result<(), DiagnosticsError> {
        self.buf.push(r);
        if self.buf.len() >= self.cap {
            self.flush()?;
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), DiagnosticsError> {
        if self.buf.is_empty() {
            return Ok(());
        }
        // Ties may come out in any order: equal values have equal ranks.
        self.buf.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let start = self.written;
        for (k, batch) in self.buf.chunks(WRITE_BATCH).enumerate() {
            self.store
                .write_records(start + k * WRITE_BATCH, batch, &mut self.bytes)?;
        }
        self.bounds.push((start, self.buf.len()));
        self.written += self.buf.len();
        self.buf.clear();
        Ok(())
    }

    fn finish(mut self) -> Result<Runs<'w>, DiagnosticsError> {
        self.flush()?;
        self.buf = Vec::new();
        Ok(Runs {
            store: self.store,
            bounds: self.bounds,
        })
    }
}

impl Runs<'_> {
    /// A stream of every record in ascending order of value (ties by run, then as sorted).
    fn merge(&self) -> Merge<'_> {
        let k = self.bounds.len();
        self.store.ws.most_runs.fetch_max(k, Atomic::Relaxed);
        // The read buffers of one stream share a quarter of the memory of one run.
        let batch = (self.store.ws.limits.run_draws / (4 * k.max(1))).max(1);
        Merge {
            runs: self,
            cursors: self
                .bounds
                .iter()
                .map(|&(start, len)| Cursor {
                    next: start,
                    end: start + len,
                    buf: Vec::new(),
                    pos: 0,
                })
                .collect(),
            heap: BinaryHeap::with_capacity(k),
            batch,
            started: false,
            bytes: Vec::new(),
        }
    }
}

struct Cursor {
    next: usize,
    end: usize,
    buf: Vec<Record>,
    pos: usize,
}

/// Heads of the runs, smallest value first (then lowest run).
struct Head {
    value: f64,
    index: u32,
    run: usize,
}

impl PartialEq for Head {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Head {}

impl PartialOrd for Head {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Head {
    fn cmp(&self, other: &Self) -> Ordering {
        // Reversed: BinaryHeap is a max-heap.
        other
            .value
            .total_cmp(&self.value)
            .then(other.run.cmp(&self.run))
    }
}

/// The k-way merge of sorted runs.
struct Merge<'a> {
    runs: &'a Runs<'a>,
    cursors: Vec<Cursor>,
    heap: BinaryHeap<Head>,
    batch: usize,
    started: bool,
    bytes: Vec<u8>,
}

impl<'a> Merge<'a> {
    /// The next record of run `r`, refilling its buffer from the store.
    fn pull(&mut self, r: usize) -> Result<Option<Record>, DiagnosticsError> {
        let c = &mut self.cursors[r];
        if c.pos == c.buf.len() {
            if c.next == c.end {
                return Ok(None);
            }
            let count = self.batch.min(c.end - c.next);
            self.runs
                .store
                .read_records(c.next, count, &mut c.buf, &mut self.bytes)?;
            c.next += count;
            c.pos = 0;
        }
        let rec = c.buf[c.pos];
        c.pos += 1;
        Ok(Some(rec))
    }

    fn next(&mut self) -> Result<Option<Record>, DiagnosticsError> {
        if !self.started {
            self.started = true;
            for r in 0..self.cursors.len() {
                if let Some((value, index)) = self.pull(r)? {
                    self.heap.push(Head {
                        value,
                        index,
                        run: r,
                    });
                }
            }
        }
        let Some(head) = self.heap.pop() else {
            return Ok(None);
        };
        if let Some((value, index)) = self.pull(head.run)? {
            self.heap.push(Head {
                value,
                index,
                run: head.run,
            });
        }
        Ok(Some((head.value, head.index)))
    }

    /// The values from here on, as an iterator; an error ends it and is kept in `error`.
    fn values<'e>(
        &'e mut self,
        error: &'e mut Option<DiagnosticsError>,
    ) -> impl Iterator<Item = f64> + use<'a, 'e> {
        std::iter::from_fn(move || match self.next() {
            Ok(r) => r.map(|(v, _)| v),
            Err(e) => {
                *error = Some(e);
                None
            }
        })
    }
}

/// The order statistics at `all` (positions among every record) and `kept` (positions among
/// the records `keep` accepts), from one merged stream.
fn pick(
    runs: &Runs,
    all: &[usize],
    kept: &[usize],
    keep: impl Fn(u32) -> bool,
) -> Result<(Picked, Picked), DiagnosticsError> {
    let (mut a, mut k) = (Picked::wanting(all), Picked::wanting(kept));
    let mut merge = runs.merge();
    let (mut i, mut j) = (0, 0);
    while let Some((v, index)) = merge.next()? {
        a.offer(i, v);
        i += 1;
        if keep(index) {
            k.offer(j, v);
            j += 1;
        }
    }
    Ok((a, k))
}

/// Values at chosen positions of a sorted stream.
struct Picked(Vec<(usize, f64)>);

impl Picked {
    fn wanting(positions: &[usize]) -> Self {
        let mut p: Vec<(usize, f64)> = positions.iter().map(|&i| (i, f64::NAN)).collect();
        p.sort_by_key(|x| x.0);
        p.dedup_by_key(|x| x.0);
        Self(p)
    }

    fn offer(&mut self, i: usize, v: f64) {
        if let Ok(k) = self.0.binary_search_by_key(&i, |x| x.0) {
            self.0[k].1 = v;
        }
    }

    fn at(&self, i: usize) -> f64 {
        let k = self
            .0
            .binary_search_by_key(&i, |x| x.0)
            .expect("a position asked for was picked");
        self.0[k].1
    }
}

/// The positions a function of sorted values reads: it is called with an accessor that
/// records them (the functions here read positions that depend only on the count).
fn positions(f: impl Fn(&dyn Fn(usize) -> f64)) -> Vec<usize> {
    let seen = std::cell::RefCell::new(Vec::new());
    f(&|i| {
        seen.borrow_mut().push(i);
        0.0
    });
    seen.into_inner()
}

/// The normal scores of the average ranks of the records `keep` accepts (`kept` of them),
/// as [`z_scale`](super::arviz) gives them, laid out by index in a store of `n` f64 (other
/// indices hold NaN).
fn rank_scores<'w>(
    ws: &'w Workspace,
    spill: bool,
    runs: &Runs,
    n: usize,
    keep: &dyn Fn(u32) -> bool,
    kept: usize,
) -> Result<Store<'w>, DiagnosticsError> {
    let span = if spill {
        ws.limits.run_draws.max(1)
    } else {
        n.max(1)
    };
    let parts = n.div_ceil(span).max(1);
    // The write buffers of the partitions share a quarter of the memory of one run.
    let batch = (ws.limits.run_draws / (4 * parts)).max(1);
    let mut out = Partitions {
        store: ws.store(spill)?,
        span,
        batch,
        buffers: vec![Vec::new(); parts],
        counts: vec![0; parts],
        bytes: Vec::new(),
    };

    // The leader finds the end of each group of equal values; the follower, one group
    // behind, hands its records their average rank.
    let size = kept as f64;
    let (mut lead, mut follow) = (runs.merge(), runs.merge());
    let mut next = lead.next()?;
    let mut start = 0;
    while let Some((v, i)) = next {
        let (mut count, mut members) = (1, usize::from(keep(i)));
        next = None;
        while let Some((w, j)) = lead.next()? {
            // partial_cmp, as average_ranks: -0.0 and 0.0 tie.
            if w.partial_cmp(&v) == Some(Ordering::Equal) {
                count += 1;
                members += usize::from(keep(j));
            } else {
                next = Some((w, j));
                break;
            }
        }
        let z = normal_score(average_rank(start, start + members), size);
        for _ in 0..count {
            let (_, j) = follow.next()?.expect("the follower trails the leader");
            if keep(j) {
                out.push(z, j)?;
            }
        }
        start += members;
    }
    for p in 0..parts {
        out.flush(p)?;
    }
    let Partitions {
        store: partitions,
        counts,
        mut bytes,
        ..
    } = out;

    // Each partition laid out by index.
    let mut scores = ws.store(spill)?;
    let mut slab = Vec::new();
    let mut records = Vec::new();
    for (p, &count) in counts.iter().enumerate() {
        let first = p * span;
        slab.clear();
        slab.resize(span.min(n - first), f64::NAN);
        let mut done = 0;
        while done < count {
            let take = batch.min(count - done);
            partitions.read_records(first + done, take, &mut records, &mut bytes)?;
            for &(z, j) in &records {
                slab[j as usize - first] = z;
            }
            done += take;
        }
        scores.write_f64(first, &slab, &mut bytes)?;
    }
    Ok(scores)
}

/// Records (score, index) written to partitions of `span` indices, each buffered.
struct Partitions<'w> {
    store: Store<'w>,
    span: usize,
    batch: usize,
    buffers: Vec<Vec<Record>>,
    counts: Vec<usize>,
    bytes: Vec<u8>,
}

impl Partitions<'_> {
    fn push(&mut self, z: f64, index: u32) -> Result<(), DiagnosticsError> {
        let p = index as usize / self.span;
        self.buffers[p].push((z, index));
        if self.buffers[p].len() >= self.batch {
            self.flush(p)?;
        }
        Ok(())
    }

    fn flush(&mut self, p: usize) -> Result<(), DiagnosticsError> {
        let buffer = &mut self.buffers[p];
        if !buffer.is_empty() {
            self.store
                .write_records(p * self.span + self.counts[p], buffer, &mut self.bytes)?;
            self.counts[p] += buffer.len();
            buffer.clear();
        }
        Ok(())
    }
}

/// Scores laid out like the draws (walker-major, `steps` per walker).
struct Scores<'s, 'w> {
    store: &'s Store<'w>,
    chains: usize,
    walkers: usize,
    steps: usize,
}

impl<'s, 'w> Scores<'s, 'w> {
    fn of(store: &'s Store<'w>, x: &WalkerDraws) -> Self {
        Self {
            store,
            chains: x.chains(),
            walkers: x.walkers,
            steps: x.steps,
        }
    }

    /// Bulk ESS: ArviZ `_ess` of the split half-walkers.
    fn ess(&self) -> Result<f64, DiagnosticsError> {
        let half = self.steps / 2;
        let mut rows = EssRows::new(half);
        let mut autocov = Autocov::new(half);
        let mut segment = vec![0.0; half];
        let mut bytes = Vec::new();
        for first in [0, self.steps - half] {
            for c in 0..self.chains {
                self.store
                    .read_f64(c * self.steps + first, &mut segment, &mut bytes)?;
                rows.push(&segment, &mut autocov);
            }
        }
        Ok(rows.finish())
    }

    /// ArviZ `_rhat` of the split half-ensembles: the row of half `h` of ensemble `e` is
    /// that half of every walker of `e`, walker after walker.
    fn rhat(&self) -> Result<f64, DiagnosticsError> {
        let half = self.steps / 2;
        let ensembles = self.chains / self.walkers;
        let cols = self.walkers * half;
        let mut rows = RhatRows::new(cols);
        let mut segment = vec![0.0; half];
        let mut bytes = Vec::new();
        for first in [0, self.steps - half] {
            for e in 0..ensembles {
                let mut each = |f: &mut dyn FnMut(&[f64])| -> Result<(), DiagnosticsError> {
                    for w in 0..self.walkers {
                        let c = e * self.walkers + w;
                        self.store
                            .read_f64(c * self.steps + first, &mut segment, &mut bytes)?;
                        f(&segment);
                    }
                    Ok(())
                };
                let mut sum = SeqSum::default();
                each(&mut |s| sum.add_all(s.iter().copied()))?;
                let mu = sum.0 / cols as f64;
                let mut ss = SeqSum::default();
                each(&mut |s| ss.add_all(s.iter().map(|v| (v - mu) * (v - mu))))?;
                rows.push(mu, ss.0 / (cols - 1) as f64);
            }
        }
        Ok(rows.finish())
    }
}

/// [`summarize`](super::summarize) of the draws `x`, with the memory of
/// [`Limits`]: every field identical to the bit.
///
/// # Errors
/// `ci_prob` or `hdi_prob` outside (0, 1); as [`summarize`](super::summarize) for the HDI; a
/// working file that cannot be written or read.
pub fn summarize_draws(
    x: &WalkerDraws,
    ci_prob: f64,
    hdi_prob: f64,
) -> Result<Summary, DiagnosticsError> {
    check_prob("ci_prob", ci_prob, false)?;
    check_prob("hdi_prob", hdi_prob, false)?;
    let ws = x.ws();
    let n = x.len();
    let spill = ws.spills(n);
    let inc = hdi_span(n, hdi_prob)?;

    // τ, walker by walker; the draws sorted in runs.
    let mut acf = Some(AcfSum::new(x.steps));
    x.each_walker(|_, s| {
        if let Some(a) = acf.as_mut() {
            if a.push(s).is_none() {
                acf = None;
            }
        }
        Ok(())
    })?;
    let autocorr = acf.map(|a| time_of_acf(&a.finish(), DEFAULT_WINDOW_FACTOR));
    let m = x.moments()?;
    let runs = x.sorted_runs(|_| true, |v| v)?;

    // Order statistics: every draw for the intervals and the tail quantiles, the split
    // draws for the median the tail R̂ folds about.
    let split = |i: u32| x.in_split(i);
    let kept = 2 * x.chains() * (x.steps / 2);
    let wanted = positions(|at| {
        median_at(n, at);
        eti_at(n, at, ci_prob);
        mquantile_at(n, at, TAIL_PROBS.0);
        mquantile_at(n, at, TAIL_PROBS.1);
    });
    let wanted_split = positions(|at| {
        median_at(kept, at);
    });
    let (all, of_split) = pick(&runs, &wanted, &wanted_split, split)?;
    let at = |i| all.at(i);
    let median = median_at(n, &at);
    let ci = eti_at(n, &at, ci_prob);
    let q = (
        mquantile_at(n, &at, TAIL_PROBS.0),
        mquantile_at(n, &at, TAIL_PROBS.1),
    );
    let split_median = median_at(kept, &|i| of_split.at(i));
    let hdi = {
        let (mut low, mut high) = (runs.merge(), runs.merge());
        let mut error = None;
        for _ in 0..inc {
            high.next()?;
        }
        let mut error_high = None;
        let hdi = hdi_scan(low.values(&mut error), high.values(&mut error_high));
        if let Some(e) = error.or(error_high) {
            return Err(e);
        }
        hdi
    };

    // ESS of the mean, of the squared deviations (MCSE of the sd) and of the tail
    // indicators, over the split half-walkers.
    let half = x.steps / 2;
    let mut autocov = Autocov::new(half);
    let mut ess = [
        EssRows::new(half),
        EssRows::new(half),
        EssRows::new(half),
        EssRows::new(half),
    ];
    let mut mapped = vec![0.0; half];
    x.each_half(|s| {
        ess[0].push(s, &mut autocov);
        for (o, &v) in mapped.iter_mut().zip(s) {
            *o = (v - m.mean) * (v - m.mean);
        }
        ess[1].push(&mapped, &mut autocov);
        for (k, q) in [q.0, q.1].into_iter().enumerate() {
            for (o, &v) in mapped.iter_mut().zip(s) {
                *o = if v <= q { 1.0 } else { 0.0 };
            }
            ess[2 + k].push(&mapped, &mut autocov);
        }
    })?;
    let [ess_mean, ess_sd, ess_q05, ess_q95] = ess.map(EssRows::finish);
    let mcse_sd = {
        let varvar = (m.mean_sq - m.evar * m.evar) / ess_sd;
        (varvar / m.evar / 4.0).sqrt()
    };

    // Normal scores of the ranks of the split draws: bulk ESS and bulk R̂.
    let scores = rank_scores(ws, spill, &runs, n, &split, kept)?;
    drop(runs);
    let ess_bulk = Scores::of(&scores, x).ess()?;
    let r_hat = if x.ensembles >= 2 {
        let bulk = Scores::of(&scores, x).rhat()?;
        drop(scores);
        let folded = x.sorted_runs(split, |v| (v - split_median).abs())?;
        let scores = rank_scores(ws, spill, &folded, n, &split, kept)?;
        drop(folded);
        let tail = Scores::of(&scores, x).rhat()?;
        // ArviZ uses Python's max(): NaN if either is NaN.
        let r = if bulk.is_nan() || tail.is_nan() {
            f64::NAN
        } else {
            bulk.max(tail)
        };
        Some(r).filter(|r| !r.is_nan())
    } else {
        None
    };

    Ok(Summary {
        mean: m.mean,
        sd: m.var.sqrt(),
        median,
        ci_low: ci.0,
        ci_high: ci.1,
        ci_prob,
        hdi_low: hdi.0,
        hdi_high: hdi.1,
        hdi_prob,
        ess_bulk,
        ess_tail: ess_q05.min(ess_q95),
        r_hat,
        mcse_mean: m.var.sqrt() / ess_mean.sqrt(),
        mcse_sd,
        ess_mean,
        tau: autocorr.map(|a| a.tau),
        tau_reliable: autocorr.map(|a| a.reliable),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnostics::{summarize, EnsembleDraws};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Draws walker-major: a random walk that repeats its value (a rejected move) about half
    /// the time, rounded to a few values so that ties fall in different runs, with -0.0 and
    /// 0.0 among them.
    fn draws(ensembles: usize, walkers: usize, steps: usize, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut data = Vec::with_capacity(ensembles * walkers * steps);
        for e in 0..ensembles {
            for _ in 0..walkers {
                let mut x: f64 = 0.3 * e as f64;
                for _ in 0..steps {
                    if rng.random::<f64>() < 0.5 {
                        x += rng.random::<f64>() - 0.5;
                    }
                    let v = (x * 4.0).round() / 4.0;
                    data.push(if v == 0.0 && rng.random::<bool>() {
                        -0.0
                    } else {
                        v
                    });
                }
            }
        }
        data
    }

    /// Writes walker-major `data` in the chains' order (step, ensemble, walker), in pieces
    /// of uneven length.
    fn write<'w>(
        ws: &'w Workspace,
        data: &[f64],
        shape: (usize, usize, usize),
    ) -> Result<WalkerDraws<'w>, DiagnosticsError> {
        let (e, w, t) = shape;
        let step_major: Vec<f64> = (0..t)
            .flat_map(|s| (0..e * w).map(move |c| data[c * t + s]))
            .collect();
        let mut writer = DrawsWriter::new(ws, e, w, t)?;
        let mut rest = &step_major[..];
        let mut k = 0;
        while !rest.is_empty() {
            let take = (1 + (k * 7) % 23).min(rest.len());
            writer.push(&rest[..take])?;
            rest = &rest[take..];
            k += 1;
        }
        writer.finish()
    }

    fn bits(s: &Summary) -> Vec<u64> {
        let opt = |v: Option<f64>| v.map_or(u64::MAX - 1, f64::to_bits);
        vec![
            s.mean.to_bits(),
            s.sd.to_bits(),
            s.median.to_bits(),
            s.ci_low.to_bits(),
            s.ci_high.to_bits(),
            s.hdi_low.to_bits(),
            s.hdi_high.to_bits(),
            s.ess_bulk.to_bits(),
            s.ess_tail.to_bits(),
            opt(s.r_hat),
            s.mcse_mean.to_bits(),
            s.mcse_sd.to_bits(),
            s.ess_mean.to_bits(),
            opt(s.tau),
            s.tau_reliable.map_or(2, u64::from),
        ]
    }

    /// The external path, with runs of a few draws (so that every merge reads many runs,
    /// ties span runs, and the scores go through many partitions), gives the in-memory
    /// summary to the bit; so does the in-memory workspace.
    #[test]
    fn external_summary_is_the_in_memory_summary_to_the_bit() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let shapes = [(2, 3, 40), (3, 2, 41), (1, 4, 30), (4, 5, 17), (2, 2, 4)];
        for (k, &(e, w, t)) in shapes.iter().enumerate() {
            let data = draws(e, w, t, k as u64);
            let reference = summarize(
                &EnsembleDraws::new(data.clone(), e, w, t).expect("valid draws"),
                0.9,
                0.8,
            )
            .expect("summary");
            for run_draws in [1, 3, 7, 50, 1 << 16] {
                let ws = Workspace::new(dir.path(), Limits { run_draws });
                let x = write(&ws, &data, (e, w, t)).expect("written");
                let s = summarize_draws(&x, 0.9, 0.8).expect("external summary");
                assert_eq!(
                    bits(&s),
                    bits(&reference),
                    "{e}×{w}×{t}, runs of {run_draws}: {s:?} against {reference:?}"
                );
                if run_draws < e * w * t {
                    assert!(ws.files_created() > 0, "working files were used");
                    assert!(ws.most_runs_merged() > 1, "merges read several runs");
                } else {
                    assert_eq!(ws.files_created(), 0, "a short quantity stays in memory");
                }
            }
            let ws = Workspace::in_memory();
            let s = summarize_draws(&write(&ws, &data, (e, w, t)).unwrap(), 0.9, 0.8).unwrap();
            assert_eq!(bits(&s), bits(&reference));
        }
        // No working file is left behind.
        assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
    }

    #[test]
    fn constant_draws_and_mean_and_mcse() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let ws = Workspace::new(dir.path(), Limits { run_draws: 5 });
        let (e, w, t) = (2, 3, 11);
        let constant = vec![2.5; e * w * t];
        let reference = summarize(
            &EnsembleDraws::new(constant.clone(), e, w, t).unwrap(),
            0.95,
            0.95,
        )
        .unwrap();
        let s = summarize_draws(&write(&ws, &constant, (e, w, t)).unwrap(), 0.95, 0.95).unwrap();
        assert_eq!(bits(&s), bits(&reference));
        assert_eq!(s.r_hat, None);

        // Indicators, as a comparison's P(A > B) takes them.
        let data: Vec<f64> = draws(e, w, t, 9)
            .into_iter()
            .map(|v| if v > 0.1 { 1.0 } else { 0.0 })
            .collect();
        let x = write(&ws, &data, (e, w, t)).unwrap();
        let chains: Vec<&[f64]> = data.chunks(t).collect();
        let (mean, mcse) = x.mean_and_mcse().unwrap();
        assert_eq!(
            mean.to_bits(),
            (data.iter().sum::<f64>() / data.len() as f64).to_bits()
        );
        assert_eq!(
            mcse.to_bits(),
            crate::diagnostics::mcse_mean(&chains).unwrap().to_bits()
        );
    }

    #[test]
    fn writer_checks_what_it_is_given() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let ws = Workspace::new(dir.path(), Limits { run_draws: 4 });
        let (e, w, t) = (2, 2, 5);
        let mut data = draws(e, w, t, 3);
        data[2 * t + 3] = f64::NAN;
        data[3 * t + 1] = f64::INFINITY;
        let expected = EnsembleDraws::new(data.clone(), e, w, t).unwrap_err();
        // NaN is not equal to itself: compare the words.
        assert_eq!(
            format!("{:?}", write(&ws, &data, (e, w, t)).unwrap_err()),
            format!("{expected:?}")
        );
        let mut short = DrawsWriter::new(&ws, e, w, t).unwrap();
        short.push(&[1.0; 7]).unwrap();
        assert!(short.finish().is_err());
        let mut long = DrawsWriter::new(&ws, e, w, t).unwrap();
        assert!(long.push(&[1.0; 21]).is_err());
        assert!(DrawsWriter::new(&ws, e, w, 3).is_err());
        let s = summarize_draws(
            &write(&ws, &draws(e, w, t, 4), (e, w, t)).unwrap(),
            1.0,
            0.5,
        );
        assert!(s.is_err());
    }
}
