//! A fit over the ranks of an MPI job (feature `mpi`): rank 0 samples, every rank evaluates.
//!
//! Rank 0 runs the whole fit as one process would: it draws every random number, decides when
//! to stop, checkpoints and writes the run directory. Two kinds of work are shared:
//!
//! - **The contacts' blocks.** A run of independent blocks (one per contact, see
//!   [`LogDensity::independent_blocks`]) is cut into contiguous shares, one per rank. Rank 0
//!   broadcasts the walkers' state as the run begins ([`PhaseRequest`]: the sampler's
//!   configuration, positions, log-densities, derived values, caches); every other rank updates
//!   its share on a replica of the sampler ([`EnsembleSampler::replica`]) while rank 0 updates
//!   the first, and sends back what changed ([`PhaseOutcome`]), which rank 0 merges. Each
//!   block draws from streams keyed by the block, not by the rank, and reads no other
//!   contact's values, so the merged state is the bits of one process's updates.
//! - **The shared parameters' updates, by contact.** A half-step's proposals of a block that
//!   every contact depends on (a material's parameters: [`LogDensity::block_splits`]) go to
//!   every rank ([`Batch::parts`]); rank r evaluates, at every proposal, the terms of the same
//!   contacts as in a run of blocks, and sends back their entries (each run's fit, each σ
//!   group's term, their derived values) or its first failure with its position in the
//!   density's order. Rank 0 merges them into the walkers' caches and finishes each proposal
//!   from its cache, summing the per-contact terms in the one order a single process sums them
//!   (not an MPI reduction, whose order of addition is not fixed).
//! - **Every other update's proposals, on rank 0 or by proposal.** Before a fit's first
//!   request rank 0 tells the other ranks which density to build ([`Offload::share_density`],
//!   [`Cluster::receive_density`]): where every update that reads data is a contact's own or
//!   splits by contact, each builds only its share (holding only its own contacts' data), and
//!   rank 0 evaluates the other half-steps' proposals alone (a population's exact draws, which
//!   read no data). Otherwise each builds the whole density, and the other half-steps'
//!   proposals (a [`Batch`]: joint updates, blocks that do not split, exact draws) are split
//!   into contiguous shares; rank 0 evaluates its own share and the other ranks, waiting in
//!   [`Cluster::serve`], evaluate theirs and send the outcomes back. Each proposal is evaluated
//!   by the same pure density from the same inputs wherever it runs.
//!
//! So the chains are the same bits for any number of ranks, including one process without MPI.
//! A batch split by proposal is four collectives: a broadcast of its header, a scatter of the
//! points (with the walkers' derived values and caches for a block update), a gather of the
//! outcomes and a gather of the rejection labels and fatal messages among them. A batch split
//! by contact is four too: the header and the points broadcast, and two gathers (entries,
//! texts). A run of blocks is six: the header, the configuration and the state broadcast, and
//! three gathers (sizes, changes, texts).
//!
//! Work made of independent pieces (the replications of `slipbayes validate`) is dealt
//! instead: rank 0 broadcasts the list of pieces ([`Cluster::broadcast_list`]), every rank
//! takes its own, and the others send each finished piece's result to rank 0
//! ([`Cluster::send_to_root`], [`Cluster::try_receive`]), which alone writes.
//!
//! A fatal evaluation on another rank comes back as a fatal outcome naming the rank and stops
//! the run on rank 0 like any fatal evaluation (its last checkpoint stays resumable). A rank
//! that fails outside an evaluation must abort the job ([`Cluster::abort`]) so that no rank
//! waits for it forever; rank 0 releases the others when its [`Cluster`] is dropped, however
//! the fit ended.

use std::time::Instant;

use mpi::datatype::{Partition, PartitionMut};
use mpi::environment::Universe;
use mpi::topology::{Process, SimpleCommunicator};
use mpi::traits::*;
use mpi::Count;
use thiserror::Error;

use crate::density::{
    BlockPlan, BlockUpdate, Eval, LogDensity, LogDensityError, ShareError, Target,
};
use crate::sampler::{
    share, Batch, BlockShares, EnsembleSampler, EvalKind, Offload, PhaseOutcome, PhaseRequest,
    SamplerConfig, ShareApart, ShareEntries,
};

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
const STOP: u64 = 0;
const FULL: u64 = 1;
const BLOCK: u64 = 2;
const EXACT_DRAW: u64 = 3;
/// A run of independent blocks to update in shares ([`Offload::send_phase`]).
const PHASE: u64 = 4;
/// A batch of a shared block's updates split by independent block ([`Batch::parts`]).
const SHARES: u64 = 5;
/// Which density the other ranks build, before a fit's first request
/// ([`Offload::share_density`]).
const DENSITY: u64 = 6;
/// A batch of updates of an independent block, each item carrying the block's own entries.
const OWN: u64 = 7;
/// A batch of whole evaluations that fill the walkers' state.
const FULL_WITH_STATE: u64 = 8;

/// Tag of the messages of [`Cluster::send_to_root`] (the collectives use none).
const RESULT_TAG: i32 = 7;

/// Outcome codes, first value of each outcome record.
const FINITE: f64 = 0.0;
const REJECTED: f64 = 1.0;
const FATAL: f64 = 2.0;
/// Values of an outcome record before its derived values and cache: code, value, length of
/// its text (a rejection label or a fatal message, in the gathered bytes).
const RECORD_HEAD: usize = 3;
/// Byte buffers are allocated even when empty: the dangling pointer of an empty `Vec<u8>` is
/// 1, which Open MPI reads as `MPI_IN_PLACE` (and then refuses the call).
const TEXT_CAPACITY: usize = 64;

/// This process's place in an MPI job, and the evaluation service between its ranks.
pub struct Cluster {
    // Dropped last: MPI is finalised when the universe goes.
    world: SimpleCommunicator,
    stats: CommStats,
    /// Rejection labels received from other ranks, kept for the life of the process: the
    /// sampler counts rejections under `&'static str` labels, of which a density has a few.
    labels: Vec<&'static str>,
    released: bool,
    /// On rank 0: the other ranks hold only their share of the density
    /// ([`Offload::share_density`]), so that only batches split by independent block go to them.
    shared_density: bool,
    _universe: Universe,
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
    /// as rank 0 tells with [`Offload::share_density`].
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

    /// On ranks other than 0: evaluates the shares of `density` that rank 0 sends until it
    /// releases the ranks (when its [`Cluster`] is dropped).
    ///
    /// # Errors
    /// [`ClusterError::Mismatch`] when rank 0 samples another density (the caller must then
    /// [`abort`](Self::abort): rank 0 waits for this rank's share).
    pub fn serve<D: LogDensity + ?Sized>(
        &mut self,
        target: Target<'_, D>,
    ) -> Result<(), ClusterError> {
        let density = target.density();
        let ndim = density.dim();
        let rank = self.rank();
        let plan = target.blocked_density().map(|b| b.block_plan());
        // The sampler replica that updates this rank's shares of runs of independent blocks,
        // built at the first (and rebuilt should the configuration change).
        let mut replica: Option<EnsembleSampler<'_, D>> = None;
        loop {
            let root = self.world.process_at_rank(0);
            let mut header = [0u64; 6];
            let started = Instant::now();
            root.broadcast_into(&mut header[..]);
            count(&mut self.stats, started, 48);
            let [code, block, items, root_ndim, root_nderived, root_cache_len] = header;
            match code {
                STOP => return Ok(()),
                // The replica checks the walkers' shape against this rank's posterior.
                PHASE => {
                    self.update_share(target, &mut replica, block as usize, items as usize)?;
                    continue;
                }
                SHARES => {
                    self.evaluate_share(target, plan.as_ref(), block as usize, items as usize)?;
                    continue;
                }
                _ => {}
            }
            let (kind, (nderived, cache_len)) =
                remote_kind(rank, code, block as usize, target, plan.as_ref())?;
            for (what, root, here) in [
                ("coordinates", root_ndim, ndim),
                ("derived values", root_nderived, nderived),
                ("cached values", root_cache_len, cache_len),
            ] {
                if root as usize != here {
                    return Err(ClusterError::Mismatch {
                        rank,
                        what,
                        root: root as usize,
                        here,
                    });
                }
            }
            let share = share(items as usize, self.size(), rank);
            let mine = share.len();
            let input = input_len(kind, ndim, nderived, cache_len);
            let mut received = vec![0.0; mine * input];
            let started = Instant::now();
            root.scatter_varcount_into(&mut received[..]);
            count(&mut self.stats, started, 8 * received.len());

            let (dstride, cstride) = (nderived.max(1), cache_len.max(1));
            let mut proposals = vec![0.0; mine * ndim];
            let mut derived = vec![0.0; mine * dstride];
            let mut cache = vec![0.0; mine * cstride];
            for (k, item) in received.chunks_exact(input.max(1)).take(mine).enumerate() {
                proposals[k * ndim..(k + 1) * ndim].copy_from_slice(&item[..ndim]);
                if kind.reads_state() {
                    derived[k * dstride..k * dstride + nderived]
                        .copy_from_slice(&item[ndim..ndim + nderived]);
                    cache[k * cstride..k * cstride + cache_len]
                        .copy_from_slice(&item[ndim + nderived..]);
                }
            }
            let mut evals = vec![Eval::Finite(0.0); mine];
            let slots: Vec<usize> = (0..mine).collect();
            let local = |kind: EvalKind, x: &[f64], d: &mut [f64], c: &mut [f64]| {
                kind.evaluate(density, x, d, c)
            };
            Batch {
                kind,
                ndim,
                nderived,
                cache_len,
                derived_stride: dstride,
                state_stride: cstride,
                slots: &slots,
                proposals: &proposals,
                derived: &mut derived,
                cache: &mut cache,
                evals: &mut evals,
                local: &local,
                parallel: rayon::current_num_threads() > 1,
                shares: None,
            }
            .evaluate_here(0..mine);

            let record = RECORD_HEAD + nderived + cache_len;
            let mut outcomes = Vec::with_capacity(mine * record);
            let mut text = Vec::with_capacity(TEXT_CAPACITY);
            for (k, eval) in evals.iter().enumerate() {
                let (code, value, words) = match eval {
                    Eval::Finite(v) => (FINITE, *v, String::new()),
                    Eval::Rejected(label) => (REJECTED, 0.0, (*label).to_owned()),
                    Eval::Fatal(message) => (FATAL, 0.0, format!("on rank {rank}: {message}")),
                };
                outcomes.extend([code, value, words.len() as f64]);
                text.extend_from_slice(words.as_bytes());
                outcomes.extend_from_slice(&derived[k * dstride..k * dstride + nderived]);
                outcomes.extend_from_slice(&cache[k * cstride..k * cstride + cache_len]);
            }
            let started = Instant::now();
            root.gather_varcount_into(&outcomes[..]);
            root.gather_varcount_into(&text[..]);
            count(&mut self.stats, started, 8 * outcomes.len() + text.len());
            self.stats.requests += 1;
        }
    }

    /// On ranks other than 0, in [`serve`](Self::serve): receives the `items` points of a
    /// batch of updates of `block` split by independent block, evaluates this rank's share of
    /// the independent blocks for every point and sends rank 0 their entries (or where the
    /// share failed, the failure and its position).
    fn evaluate_share<D: LogDensity + ?Sized>(
        &mut self,
        target: Target<'_, D>,
        plan: Option<&BlockPlan>,
        block: usize,
        items: usize,
    ) -> Result<(), ClusterError> {
        let rank = self.rank();
        let split = plan
            .and_then(|p| p.blocks.get(block))
            .and_then(|b| b.split)
            .ok_or_else(|| ClusterError::Replica {
                rank,
                message: format!(
                    "rank 0 splits updates of block {block} by contact, which this rank's \
                     posterior does not; every rank must load the same model"
                ),
            })?;
        let parts = plan.map_or(0, |p| {
            p.blocks
                .iter()
                .filter(|b| matches!(b.update, BlockUpdate::Independent { .. }))
                .count()
        });
        let density = target.density();
        let (ndim, nderived, cache_len) = (
            density.dim(),
            density.derived_names().len(),
            target.blocked_density().map_or(0, |b| b.state_len()),
        );
        let root = self.world.process_at_rank(0);
        let mut proposals = vec![0.0; items * ndim];
        let started = Instant::now();
        if !proposals.is_empty() {
            root.broadcast_into(&mut proposals[..]);
        }
        count(&mut self.stats, started, 8 * proposals.len());

        let splitter = BlockShares { split, block };
        let apart = ShareApart {
            shares: &splitter,
            nderived,
            cache_len,
            parallel: rayon::current_num_threads() > 1,
        };
        let mine = share(parts, self.size(), rank);
        let own = split.share_entries(block, mine.clone());
        let entries = ShareEntries {
            derived: own.derived,
            cache: own.state,
        };
        let points: Vec<&[f64]> = proposals.chunks_exact(ndim.max(1)).take(items).collect();
        let (failures, values) = apart.evaluate(mine, &entries, &points);
        let width = entries.len();

        // Never a dangling pointer (see TEXT_CAPACITY), though a batch is never empty.
        let mut records = Vec::with_capacity((items * (RECORD_HEAD + width)).max(1));
        let mut text = Vec::with_capacity(TEXT_CAPACITY);
        for (k, failure) in failures.iter().enumerate() {
            let (code, position, words) = match failure {
                None => (FINITE, 0, String::new()),
                Some(f) => match &f.error {
                    LogDensityError::Rejected { reason } => {
                        (REJECTED, f.position, (*reason).to_owned())
                    }
                    LogDensityError::Fatal { message } => {
                        (FATAL, f.position, format!("on rank {rank}: {message}"))
                    }
                },
            };
            records.extend([code, position as f64, words.len() as f64]);
            records.extend_from_slice(&values[k * width..(k + 1) * width]);
            text.extend_from_slice(words.as_bytes());
        }
        let started = Instant::now();
        root.gather_varcount_into(&records[..]);
        root.gather_varcount_into(&text[..]);
        count(&mut self.stats, started, 8 * records.len() + text.len());
        self.stats.requests += 1;
        self.stats.shared += 1;
        Ok(())
    }

    /// On ranks other than 0, in [`serve`](Self::serve): receives a run of independent
    /// blocks (the sampler's configuration, `config_len` bytes, and the walkers' state,
    /// `words` values), updates this rank's share on `replica` and sends rank 0 what changed.
    fn update_share<'d, D: LogDensity + ?Sized>(
        &mut self,
        target: Target<'d, D>,
        replica: &mut Option<EnsembleSampler<'d, D>>,
        config_len: usize,
        words: usize,
    ) -> Result<(), ClusterError> {
        let root = self.world.process_at_rank(0);
        let started = Instant::now();
        let mut config = vec![0u8; config_len];
        root.broadcast_into(&mut config[..]);
        let mut state = vec![0u64; words];
        root.broadcast_into(&mut state[..]);
        count(&mut self.stats, started, config_len + 8 * words);
        let rank = self.rank();
        let config: SamplerConfig =
            serde_json::from_slice(&config).map_err(|e| ClusterError::Replica {
                rank,
                message: format!("the sampler's configuration does not read: {e}"),
            })?;
        if replica.as_ref().is_none_or(|r| *r.config() != config) {
            let built = EnsembleSampler::replica(target, config.clone()).map_err(|e| {
                ClusterError::Replica {
                    rank,
                    message: e.to_string(),
                }
            })?;
            *replica = Some(built);
        }
        let request = PhaseRequest::from_words(config, state);
        let outcome = replica
            .as_mut()
            .expect("built above")
            .update_share(&request, self.size(), rank)
            .map_err(|e| ClusterError::Replica {
                rank,
                message: e.to_string(),
            })?;
        let (words, bytes) = outcome.parts();
        let mut text = Vec::with_capacity(bytes.len().max(TEXT_CAPACITY));
        text.extend_from_slice(bytes);
        let started = Instant::now();
        root.gather_into(&[words.len() as u64, text.len() as u64][..]);
        root.gather_varcount_into(words);
        root.gather_varcount_into(&text[..]);
        count(&mut self.stats, started, 8 * words.len() + text.len() + 16);
        self.stats.requests += 1;
        self.stats.runs += 1;
        Ok(())
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
    fn label(&mut self, text: &str) -> &'static str {
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
fn count(stats: &mut CommStats, started: Instant, bytes: usize) {
    stats.mpi_s += started.elapsed().as_secs_f64();
    stats.bytes += bytes as u64;
}

/// Where each rank's part starts when parts of `counts` follow one another.
fn displacements(counts: &[Count]) -> Vec<Count> {
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
fn gather_text(root: &Process<'_>, counts: &[Count]) -> Vec<u8> {
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
fn partition(n: usize, ranks: usize, per_item: usize) -> (Vec<Count>, Vec<Count>) {
    (0..ranks)
        .map(|r| {
            let s = share(n, ranks, r);
            ((s.len() * per_item) as Count, (s.start * per_item) as Count)
        })
        .unzip()
}

/// Values sent per item: the point, and for a block update the walker's derived values and
/// cache.
fn input_len(kind: EvalKind, ndim: usize, nderived: usize, cache_len: usize) -> usize {
    if kind.reads_state() {
        ndim + nderived + cache_len
    } else {
        ndim
    }
}

impl Cluster {
    /// On rank 0: the header of a batch's request, `code` for `block` (what
    /// [`serve`](Self::serve) reads first).
    fn broadcast_header(&mut self, code: u64, block: usize, batch: &Batch<'_>) {
        let mut header = [
            code,
            block as u64,
            batch.len() as u64,
            batch.ndim() as u64,
            batch.nderived() as u64,
            batch.cache_len() as u64,
        ];
        let started = Instant::now();
        self.world
            .process_at_rank(0)
            .broadcast_into(&mut header[..]);
        count(&mut self.stats, started, 48);
    }

    /// On rank 0: a batch of updates of a shared block split by independent block. Every rank
    /// evaluates, at every point, the terms of its share of the independent blocks (the
    /// contacts [r·C/R, (r+1)·C/R) of rank r, as in a run of their blocks); rank 0 merges the
    /// other ranks' entries into the walkers' caches and finishes each point from its cache,
    /// summing the terms in the one order a single process sums them. Of the failures of a
    /// point's shares, the first in the density's order is kept, the one a whole evaluation
    /// returns.
    fn evaluate_by_part(&mut self, batch: &mut Batch<'_>) {
        let (ranks, n, parts) = (self.size(), batch.len(), batch.parts());
        let EvalKind::Block(block, _) = batch.kind() else {
            unreachable!("only block updates split by part")
        };
        self.broadcast_header(SHARES, block, batch);
        let mut points = Vec::with_capacity(n * batch.ndim());
        for k in 0..n {
            points.extend_from_slice(batch.point(k));
        }
        let root = self.world.process_at_rank(0);
        let started = Instant::now();
        if !points.is_empty() {
            root.broadcast_into(&mut points[..]);
        }
        count(&mut self.stats, started, 8 * points.len());

        let mut failures = batch.evaluate_share_here(share(parts, ranks, 0));

        let entries: Vec<ShareEntries> = (0..ranks)
            .map(|r| batch.share_entries(share(parts, ranks, r)))
            .collect();
        let counts: Vec<Count> = entries
            .iter()
            .enumerate()
            .map(|(r, e)| {
                if r == 0 {
                    0
                } else {
                    (n * (RECORD_HEAD + e.len())) as Count
                }
            })
            .collect();
        let displs = displacements(&counts);
        let mut records = vec![0.0; counts.iter().sum::<Count>() as usize];
        let started = Instant::now();
        root.gather_varcount_into_root(
            &[0.0_f64; 0][..],
            &mut PartitionMut::new(&mut records[..], &counts[..], &displs[..]),
        );
        let record = |r: usize, k: usize| {
            let width = RECORD_HEAD + entries[r].len();
            let at = displs[r] as usize + k * width;
            &records[at..at + width]
        };
        let text_counts: Vec<Count> = (0..ranks)
            .map(|r| match r {
                0 => 0,
                _ => (0..n).map(|k| record(r, k)[2] as Count).sum(),
            })
            .collect();
        let text = gather_text(&root, &text_counts);
        count(&mut self.stats, started, 8 * records.len() + text.len());
        self.stats.requests += 1;
        self.stats.shared += 1;

        let mut at = 0;
        for (r, their_entries) in entries.iter().enumerate().skip(1) {
            let mut their_failures = Vec::with_capacity(n);
            let mut values = Vec::with_capacity(n * their_entries.len());
            for k in 0..n {
                let o = record(r, k);
                let words = String::from_utf8_lossy(&text[at..at + o[2] as usize]).into_owned();
                at += o[2] as usize;
                values.extend_from_slice(&o[RECORD_HEAD..]);
                let error = match o[0] {
                    c if c < REJECTED => None,
                    c if c < FATAL => Some(LogDensityError::rejected(self.label(&words))),
                    _ => Some(LogDensityError::fatal(words)),
                };
                let position = o[1] as usize;
                their_failures.push(error.map(|error| ShareError { position, error }));
            }
            batch.merge_share(&mut failures, their_entries, (their_failures, values));
        }
        batch.finish_shares(failures);
    }
}

impl Offload for Cluster {
    /// On rank 0: tells the other ranks, waiting in [`receive_density`](Cluster::receive_density),
    /// which density to build.
    fn share_density(&mut self, words: Option<&[u64]>) {
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

    /// Every rank updates a share of a run of independent blocks.
    fn phase_shares(&self) -> usize {
        self.size()
    }

    /// On rank 0: broadcasts the sampler's configuration and the walkers' state; every other
    /// rank updates its share from them in [`serve`](Self::serve).
    fn send_phase(&mut self, request: &PhaseRequest) {
        let config = serde_json::to_vec(request.config()).expect("a configuration serialises");
        let words = request.words();
        let root = self.world.process_at_rank(0);
        let mut header = [PHASE, config.len() as u64, words.len() as u64, 0, 0, 0];
        let started = Instant::now();
        root.broadcast_into(&mut header[..]);
        let mut config = config;
        root.broadcast_into(&mut config[..]);
        let mut words = words.to_vec();
        root.broadcast_into(&mut words[..]);
        count(
            &mut self.stats,
            started,
            48 + config.len() + 8 * words.len(),
        );
    }

    /// On rank 0: the other ranks' outcomes, in rank order.
    fn gather_phase(&mut self) -> Vec<PhaseOutcome> {
        let ranks = self.size();
        let root = self.world.process_at_rank(0);
        let started = Instant::now();
        let mut sizes = vec![0u64; 2 * ranks];
        root.gather_into_root(&[0u64, 0][..], &mut sizes[..]);
        let counts =
            |at: usize| -> Vec<Count> { (0..ranks).map(|r| sizes[2 * r + at] as Count).collect() };
        let (word_counts, text_counts) = (counts(0), counts(1));
        let (word_displs, text_displs) = (displacements(&word_counts), displacements(&text_counts));
        let mut words = vec![0u64; word_counts.iter().sum::<Count>() as usize];
        root.gather_varcount_into_root(
            &[0u64; 0][..],
            &mut PartitionMut::new(&mut words[..], &word_counts[..], &word_displs[..]),
        );
        let text = gather_text(&root, &text_counts);
        count(
            &mut self.stats,
            started,
            8 * words.len() + text.len() + 16 * ranks,
        );
        self.stats.requests += 1;
        self.stats.runs += 1;
        (1..ranks)
            .map(|r| {
                let (w, t) = (word_displs[r] as usize, text_displs[r] as usize);
                PhaseOutcome::from_parts(
                    words[w..w + word_counts[r] as usize].to_vec(),
                    text[t..t + text_counts[r] as usize].to_vec(),
                )
            })
            .collect()
    }

    /// On rank 0: splits `batch` over the ranks, evaluates rank 0's share here and stores the
    /// others' outcomes. A batch that splits by independent block is split so (see
    /// `evaluate_by_part`), any other by item.
    fn evaluate(&mut self, batch: &mut Batch<'_>) {
        let ranks = self.size();
        if ranks == 1 || batch.is_empty() {
            batch.evaluate_here(0..batch.len());
            return;
        }
        if batch.parts() > 0 {
            self.evaluate_by_part(batch);
            return;
        }
        // The other ranks hold only their own contacts' data.
        if self.shared_density {
            batch.evaluate_here(0..batch.len());
            return;
        }
        let (kind, n) = (batch.kind(), batch.len());
        let (ndim, nderived, cache_len) = (batch.ndim(), batch.nderived(), batch.cache_len());
        let (code, block) = match kind {
            EvalKind::Full => (FULL, 0),
            EvalKind::FullWithState(_) => (FULL_WITH_STATE, 0),
            EvalKind::Block(b, _) => (BLOCK, b),
            EvalKind::ExactDraw(b, _) => (EXACT_DRAW, b),
            EvalKind::Own(b, _) => (OWN, b),
        };
        self.broadcast_header(code, block, batch);
        let root = self.world.process_at_rank(0);

        let input = input_len(kind, ndim, nderived, cache_len);
        let others = share(n, ranks, 0).end..n;
        let mut send = Vec::with_capacity(others.len() * input);
        for k in others.clone() {
            send.extend_from_slice(batch.point(k));
            if kind.reads_state() {
                send.extend_from_slice(batch.derived(k));
                send.extend_from_slice(batch.cache(k));
            }
        }
        // Rank 0's own share stays here: its count is 0 and the others start at 0.
        let (mut counts, mut displs) = partition(n, ranks, input);
        let skipped = displs[1];
        counts[0] = 0;
        for d in &mut displs {
            *d = (*d - skipped).max(0);
        }
        let started = Instant::now();
        root.scatter_varcount_into_root(
            &Partition::new(&send[..], &counts[..], &displs[..]),
            &mut [0.0_f64; 0][..],
        );
        count(&mut self.stats, started, 8 * send.len());

        batch.evaluate_here(share(n, ranks, 0));

        let record = RECORD_HEAD + nderived + cache_len;
        let (mut counts, mut displs) = partition(n, ranks, record);
        let skipped = displs[1];
        counts[0] = 0;
        for d in &mut displs {
            *d = (*d - skipped).max(0);
        }
        let mut outcomes = vec![0.0; others.len() * record];
        let started = Instant::now();
        root.gather_varcount_into_root(
            &[0.0_f64; 0][..],
            &mut PartitionMut::new(&mut outcomes[..], &counts[..], &displs[..]),
        );
        // The texts' lengths are in the outcomes: each rank's bytes follow the previous one's.
        let mut text_counts = vec![0 as Count; ranks];
        for (r, count) in text_counts.iter_mut().enumerate().skip(1) {
            let s = share(n, ranks, r);
            *count = outcomes[(s.start - others.start) * record..(s.end - others.start) * record]
                .chunks_exact(record)
                .map(|o| o[2] as Count)
                .sum();
        }
        let text = gather_text(&root, &text_counts);
        count(&mut self.stats, started, 8 * outcomes.len() + text.len());
        self.stats.requests += 1;

        let mut at = 0;
        for (k, o) in others.zip(outcomes.chunks_exact(record)) {
            let words = String::from_utf8_lossy(&text[at..at + o[2] as usize]).into_owned();
            at += o[2] as usize;
            let result = match o[0] {
                c if c < REJECTED => Ok(o[1]),
                c if c < FATAL => Err(LogDensityError::rejected(self.label(&words))),
                _ => Err(LogDensityError::fatal(words)),
            };
            let (derived, cache) = o[RECORD_HEAD..].split_at(nderived);
            batch.set_outcome(k, result, derived, cache);
        }
    }
}

/// On ranks other than 0: the evaluation that request `code` asks for of `block` of this
/// rank's density, with the derived values and entries of state each item carries.
///
/// # Errors
/// [`ClusterError::Replica`] when this rank's density has no such block or capability
/// (every rank must load the same model).
fn remote_kind<'a, D: LogDensity + ?Sized>(
    rank: usize,
    code: u64,
    block: usize,
    target: Target<'a, D>,
    plan: Option<&BlockPlan<'a>>,
) -> Result<(EvalKind<'a>, (usize, usize)), ClusterError> {
    let nderived = target.density().derived_names().len();
    let missing = |what: &str| ClusterError::Replica {
        rank,
        message: format!(
            "rank 0 asks for {what} of block {block}, which this rank's density does not have; \
             every rank must load the same model"
        ),
    };
    if code == FULL {
        return Ok((EvalKind::Full, (nderived, 0)));
    }
    let blocked = target
        .blocked_density()
        .ok_or_else(|| missing("a blocked evaluation"))?;
    let whole = (nderived, blocked.state_len());
    let planned = plan.and_then(|p| p.blocks.get(block));
    match (code, planned.map(|b| &b.update)) {
        (FULL_WITH_STATE, _) => Ok((EvalKind::FullWithState(blocked), whole)),
        (BLOCK, Some(_)) => Ok((EvalKind::Block(block, blocked), whole)),
        (EXACT_DRAW, Some(BlockUpdate::Exact { conditional, .. })) => {
            Ok((EvalKind::ExactDraw(block, *conditional), whole))
        }
        (OWN, Some(BlockUpdate::Independent { own, entries })) => Ok((
            EvalKind::Own(block, *own),
            (entries.derived.len(), entries.state.len()),
        )),
        (EXACT_DRAW, _) => Err(missing("an exact draw")),
        (OWN, _) => Err(missing("an update on its own entries")),
        _ => Err(missing(&format!("evaluation {code}"))),
    }
}
