//! This process's place in an MPI job: initialising MPI, the ranks, the requests' codes and
//! the collectives' helpers shared by rank 0 (`root`) and the other ranks (`serve`).

use std::time::Instant;

use mpi::datatype::{Partition, PartitionMut};
use mpi::environment::Universe;
use mpi::topology::{Process, SimpleCommunicator};
use mpi::traits::*;
use mpi::Count;
use thiserror::Error;

use crate::model::DataShare;
use crate::sampler::{share, EvalKind};

/// Errors of the MPI layer.
#[derive(Debug, Error)]
pub enum ClusterError {
    /// MPI was initialised already in this process, or could not be, or does not let any
    /// thread call it (one at a time).
    #[error(
        "MPI could not be initialised with the thread level MPI_THREAD_SERIALIZED (it may be \
         initialised already in this process, or built without thread support)"
    )]
    Init,
    /// Rank 0 asked for evaluations of another density than this rank's.
    #[error(
        "rank {rank}: rank 0 sends points of {root} {what} but this rank's posterior has {here}; \
         every rank must load the same model (same file and data)"
    )]
    Mismatch {
        /// This rank.
        rank: usize,
        /// What differs (coordinates, derived values, cache length).
        what: &'static str,
        /// Rank 0's count.
        root: usize,
        /// This rank's count.
        here: usize,
    },
    /// This rank cannot build the sampler that updates its share of the contacts' blocks.
    #[error("rank {rank}: cannot update its share of the blocks: {message}")]
    Replica {
        /// This rank.
        rank: usize,
        /// Why.
        message: String,
    },
}

/// Time and traffic of this rank's MPI calls, to judge what communication costs.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct CommStats {
    /// Requests (batches, and runs of independent blocks) handled.
    pub requests: u64,
    /// Of those, runs of independent blocks (the contacts' blocks) updated in shares.
    pub runs: u64,
    /// Of those, batches of a shared block's updates split by independent block.
    pub shared: u64,
    /// Wall time inside MPI calls (s), waiting for the other ranks included.
    pub mpi_s: f64,
    /// Bytes this rank sent and received in them.
    pub bytes: u64,
}

/// Header codes: what a request asks for.
pub(super) const STOP: u64 = 0;
pub(super) const FULL: u64 = 1;
pub(super) const BLOCK: u64 = 2;
pub(super) const EXACT_DRAW: u64 = 3;
/// A run of independent blocks to update in shares.
pub(super) const PHASE: u64 = 4;
/// A batch of a shared block's updates split by independent block.
pub(super) const SHARES: u64 = 5;
/// Which density the other ranks build, before a fit's first request
/// ([`Cluster::share_density`]).
pub(super) const DENSITY: u64 = 6;
/// A batch of updates of an independent block, each item carrying the block's own entries.
pub(super) const OWN: u64 = 7;
/// A batch of whole evaluations that fill the walkers' state.
pub(super) const FULL_WITH_STATE: u64 = 8;

/// Tag of the messages of [`Cluster::send_to_root`] (the collectives use none).
pub(super) const RESULT_TAG: i32 = 7;

/// Outcome codes, first value of each outcome record.
pub(super) const FINITE: f64 = 0.0;
pub(super) const REJECTED: f64 = 1.0;
pub(super) const FATAL: f64 = 2.0;
/// Values of an outcome record before its derived values and cache: code, value, length of
/// its text (a rejection label or a fatal message, in the gathered bytes).
pub(super) const RECORD_HEAD: usize = 3;
/// Byte buffers are allocated even when empty: the dangling pointer of an empty `Vec<u8>` is
/// 1, which Open MPI reads as `MPI_IN_PLACE` (and then refuses the call).
pub(super) const TEXT_CAPACITY: usize = 64;

/// This process's place in an MPI job, and the evaluation service between its ranks.
pub struct Cluster {
    // Dropped last: MPI is finalised when the universe goes.
    pub(super) world: SimpleCommunicator,
    pub(super) stats: CommStats,
    /// Rejection labels received from other ranks, kept for the life of the process: the
    /// sampler counts rejections under `&'static str` labels, of which a density has a few.
    pub(super) labels: Vec<&'static str>,
    pub(super) released: bool,
    /// On rank 0: the other ranks hold only their share of the density
    /// ([`share_density`](Cluster::share_density)), so that only batches split by independent
    /// block go to them.
    pub(super) shared_density: bool,
    pub(super) _universe: Universe,
}

/// What rank 0 tells the other ranks to build before a fit ([`Cluster::receive_density`]).
#[derive(Debug, Clone, PartialEq)]
pub enum DensityShare {
    /// Rank 0 ended before its fit began (it failed, or ran no fit): build nothing.
    Released,
    /// The whole density, with all of the data.
    Whole,
    /// The share of the density that this rank's independent blocks read, from rank 0's
    /// description of it.
    Share(Vec<u64>),
}

// SAFETY: MPI is initialised at the `Serialized` thread level (checked in `init`): any thread
// may call it as long as no two do at once. `Cluster` stays `!Sync` (its communicator is), so
// only the one thread that holds it can call MPI through it.
unsafe impl Send for Cluster {}

impl std::fmt::Debug for Cluster {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Cluster")
            .field("rank", &self.rank())
            .field("size", &self.size())
            .field("stats", &self.stats)
            .finish()
    }
}

impl Cluster {
    /// Initialises MPI. The rayon threads only evaluate; MPI is called by whichever thread
    /// holds the `&mut Cluster` (the sampler may run inside a rayon pool), one at a time: the
    /// `Serialized` thread level.
    ///
    /// # Errors
    /// [`ClusterError::Init`] when MPI is initialised already or does not provide that level.
    pub fn init() -> Result<Self, ClusterError> {
        let (universe, provided) =
            mpi::initialize_with_threading(mpi::Threading::Serialized).ok_or(ClusterError::Init)?;
        if provided < mpi::Threading::Serialized {
            return Err(ClusterError::Init);
        }
        Ok(Self {
            world: universe.world(),
            stats: CommStats::default(),
            labels: Vec::new(),
            released: false,
            shared_density: false,
            _universe: universe,
        })
    }

    /// This process's rank (0 samples and writes).
    pub fn rank(&self) -> usize {
        self.world.rank() as usize
    }

    /// Number of ranks.
    pub fn size(&self) -> usize {
        self.world.size() as usize
    }

    /// The positions of the independent blocks, of `parts`, that this rank updates and
    /// evaluates (the contacts [r·C/R, (r+1)·C/R) of rank r).
    pub fn own_parts(&self, parts: usize) -> std::ops::Range<usize> {
        share(parts, self.size(), self.rank())
    }

    /// Time and traffic of this rank's MPI calls so far.
    pub fn stats(&self) -> CommStats {
        self.stats
    }

    /// Ends every rank of the job with `code` (after this rank has said why).
    pub fn abort(&self, code: i32) -> ! {
        self.world.abort(code)
    }

    /// On ranks other than 0, before a fit's [`serve`](Self::serve): which density to build,
    /// as rank 0 tells with [`share_density`](Self::share_density).
    ///
    /// # Errors
    /// [`ClusterError::Replica`] when rank 0 sends another request first (it runs another
    /// command).
    pub fn receive_density(&mut self) -> Result<DensityShare, ClusterError> {
        let root = self.world.process_at_rank(0);
        let mut header = [0u64; 6];
        let started = Instant::now();
        root.broadcast_into(&mut header[..]);
        count(&mut self.stats, started, 48);
        let [code, present, len, ..] = header;
        match (code, present) {
            (STOP, _) => Ok(DensityShare::Released),
            (DENSITY, 0) => Ok(DensityShare::Whole),
            (DENSITY, _) => {
                let mut words = vec![0u64; len as usize];
                let started = Instant::now();
                root.broadcast_into(&mut words[..]);
                count(&mut self.stats, started, 8 * words.len());
                Ok(DensityShare::Share(words))
            }
            _ => Err(ClusterError::Replica {
                rank: self.rank(),
                message: format!(
                    "rank 0 sent request {code} before saying which density to build; every \
                     rank must run the same command"
                ),
            }),
        }
    }

    /// On rank 0, before a fit's first request: tells the other ranks, waiting in
    /// [`receive_density`](Cluster::receive_density), which density to build. With `share`
    /// (from [`Posterior::data_share`](crate::model::Posterior::data_share)), each builds the
    /// share of it that its own contacts read and holds only their data, so that only the
    /// contacts' updates and the shared updates split by contact go to it; every other batch
    /// is then evaluated on rank 0. Without, each builds all of it.
    pub fn share_density(&mut self, share: Option<&DataShare>) {
        let words = share.map(DataShare::to_words);
        let words = words.as_deref();
        if self.size() == 1 {
            return;
        }
        let root = self.world.process_at_rank(0);
        let len = words.map_or(0, <[u64]>::len);
        let mut header = [DENSITY, u64::from(words.is_some()), len as u64, 0, 0, 0];
        let started = Instant::now();
        root.broadcast_into(&mut header[..]);
        if let Some(words) = words {
            let mut words = words.to_vec();
            root.broadcast_into(&mut words[..]);
        }
        count(&mut self.stats, started, 48 + 8 * len);
        self.shared_density = words.is_some();
    }

    /// On rank 0: releases the ranks waiting in [`serve`](Self::serve) (also done on drop).
    pub fn release(&mut self) {
        if self.rank() == 0 && self.size() > 1 && !self.released {
            let mut header = [STOP, 0, 0, 0, 0, 0];
            self.world
                .process_at_rank(0)
                .broadcast_into(&mut header[..]);
            self.released = true;
        }
    }

    /// Rank 0's `list` on every rank, for work that every rank must agree on (e.g. which
    /// replications remain): rank 0 passes `Some` (or `None` when it has nothing to hand out,
    /// having failed before), the other ranks pass `None` and receive what rank 0 passed.
    /// Every rank must call it at the same point.
    pub fn broadcast_list(&mut self, list: Option<&[u64]>) -> Option<Vec<u64>> {
        let root = self.world.process_at_rank(0);
        let mut header = [0u64; 2];
        if self.rank() == 0 {
            header = list.map_or([0, 0], |l| [1, l.len() as u64]);
        }
        let started = Instant::now();
        root.broadcast_into(&mut header[..]);
        let [present, len] = header;
        let mut values = match (self.rank(), list) {
            (0, Some(l)) => l.to_vec(),
            _ => vec![0u64; len as usize],
        };
        // An empty buffer is not broadcast: Open MPI may take its pointer for MPI_IN_PLACE.
        if len > 0 {
            root.broadcast_into(&mut values[..]);
        }
        count(&mut self.stats, started, 16 + 8 * values.len());
        (present == 1).then_some(values)
    }

    /// On ranks other than 0: sends `bytes` (one finished piece of work, e.g. a serialised
    /// record) to rank 0, which takes it with [`try_receive`](Self::try_receive). Blocks until
    /// MPI holds the bytes; small messages leave at once.
    pub fn send_to_root(&mut self, bytes: &[u8]) {
        let started = Instant::now();
        self.world
            .process_at_rank(0)
            .send_with_tag(bytes, RESULT_TAG);
        count(&mut self.stats, started, bytes.len());
    }

    /// On rank 0: one message that another rank sent with [`send_to_root`](Self::send_to_root),
    /// with the rank that sent it, or `None` at once when none has arrived (the caller may
    /// wait between calls instead of spinning in MPI).
    pub fn try_receive(&mut self) -> Option<(usize, Vec<u8>)> {
        let started = Instant::now();
        let (message, status) = self
            .world
            .any_process()
            .immediate_matched_probe_with_tag(RESULT_TAG)?;
        let (bytes, _) = (message, status).matched_receive_vec::<u8>();
        count(&mut self.stats, started, bytes.len());
        Some((status.source_rank() as usize, bytes))
    }

    /// The `&'static str` of a rejection label received from another rank.
    pub(super) fn label(&mut self, text: &str) -> &'static str {
        if let Some(known) = self.labels.iter().find(|l| **l == text) {
            return known;
        }
        let leaked: &'static str = Box::leak(text.to_owned().into_boxed_str());
        self.labels.push(leaked);
        leaked
    }

    /// Mean wall time (s) of one request's collectives on every rank, with `items` points of
    /// `values` f64 each split over the ranks and as many sent back: a broadcast of a header,
    /// a scatter and two gathers, as [`serve`](Self::serve) and the offload do them, `reps`
    /// times. Every rank must call it with the same arguments.
    pub fn request_latency_s(&self, items: usize, values: usize, reps: usize) -> f64 {
        let root = self.world.process_at_rank(0);
        let (size, rank) = (self.size(), self.rank());
        let data = vec![1.0_f64; items * values];
        let (counts, displs) = partition(items, size, values);
        let mine = share(items, size, rank).len() * values;
        let mut buffer = vec![0.0_f64; mine];
        let mut gathered = vec![0.0_f64; items * values];
        let text: Vec<u8> = Vec::with_capacity(TEXT_CAPACITY);
        let zeros = vec![0 as Count; size];
        let mut no_text: Vec<u8> = Vec::with_capacity(TEXT_CAPACITY);
        self.world.barrier();
        let started = Instant::now();
        for _ in 0..reps {
            let mut header = [FULL, 0, items as u64, 0, 0, 0];
            root.broadcast_into(&mut header[..]);
            if rank == 0 {
                root.scatter_varcount_into_root(
                    &Partition::new(&data[..], &counts[..], &displs[..]),
                    &mut buffer[..],
                );
                root.gather_varcount_into_root(
                    &buffer[..],
                    &mut PartitionMut::new(&mut gathered[..], &counts[..], &displs[..]),
                );
                root.gather_varcount_into_root(
                    &text[..],
                    &mut PartitionMut::new(&mut no_text[..], &zeros[..], &zeros[..]),
                );
            } else {
                root.scatter_varcount_into(&mut buffer[..]);
                root.gather_varcount_into(&buffer[..]);
                root.gather_varcount_into(&text[..]);
            }
        }
        self.world.barrier();
        started.elapsed().as_secs_f64() / reps.max(1) as f64
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        self.release();
    }
}

/// Adds MPI calls that began at `started` and moved `bytes` to `stats`.
pub(super) fn count(stats: &mut CommStats, started: Instant, bytes: usize) {
    stats.mpi_s += started.elapsed().as_secs_f64();
    stats.bytes += bytes as u64;
}

/// Where each rank's part starts when parts of `counts` follow one another.
pub(super) fn displacements(counts: &[Count]) -> Vec<Count> {
    counts
        .iter()
        .scan(0, |at, &c| {
            let d = *at;
            *at += c;
            Some(d)
        })
        .collect()
}

/// On rank 0: the bytes every rank sends (`counts[r]` from rank r, none from rank 0), one
/// rank's after the other's.
pub(super) fn gather_text(root: &Process<'_>, counts: &[Count]) -> Vec<u8> {
    let total = counts.iter().sum::<Count>() as usize;
    let mut text = Vec::with_capacity(total.max(TEXT_CAPACITY));
    text.resize(total, 0u8);
    root.gather_varcount_into_root(
        &[0u8; 1][..0],
        &mut PartitionMut::new(&mut text[..], counts, &displacements(counts)[..]),
    );
    text
}

/// Counts and displacements (in values) of every rank's share of `n` items of `per_item`
/// values.
pub(super) fn partition(n: usize, ranks: usize, per_item: usize) -> (Vec<Count>, Vec<Count>) {
    (0..ranks)
        .map(|r| {
            let s = share(n, ranks, r);
            ((s.len() * per_item) as Count, (s.start * per_item) as Count)
        })
        .unzip()
}

/// Values sent per item: the point, and for a block update the walker's derived values and
/// cache.
pub(super) fn input_len(kind: EvalKind, ndim: usize, nderived: usize, cache_len: usize) -> usize {
    if kind.reads_state() {
        ndim + nderived + cache_len
    } else {
        ndim
    }
}
