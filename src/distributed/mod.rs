//! Fits over several processes, behind the sampler's one seam for parallelism
//! ([`Parallelism`](crate::sampler::Parallelism)): the ranks of an MPI job (`Cluster`,
//! feature `mpi`), and the same split in one process ([`ReplicaShares`]), which checks its
//! bits wherever MPI is not built. A one-process fit never comes here.
//!
//! With MPI, rank 0 samples and every rank evaluates.
//!
//! Rank 0 runs the whole fit as one process would: it draws every random number, decides when
//! to stop, checkpoints and writes the run directory. Two kinds of work are shared:
//!
//! - **The contacts' blocks.** A run of independent blocks (one per contact, see
//!   [`IndependentBlocks`](crate::density::IndependentBlocks)) is cut into contiguous shares, one per rank. Rank 0
//!   broadcasts the walkers' state as the run begins (the sampler's
//!   configuration, positions, log-densities, derived values, caches); every other rank updates
//!   its share on a replica of the sampler while rank 0 updates
//!   the first, and sends back what changed, which rank 0 merges. Each
//!   block draws from streams keyed by the block, not by the rank, and reads no other
//!   contact's values, so the merged state is the bits of one process's updates.
//! - **The shared parameters' updates, by contact.** A half-step's proposals of a block that
//!   every contact depends on (a material's parameters:
//!   [`SplitByPart`](crate::density::SplitByPart)) go to every rank; rank r evaluates, at every proposal, the terms of the same
//!   contacts as in a run of blocks, and sends back their entries (each run's fit, each σ
//!   group's term, their derived values) or its first failure with its position in the
//!   density's order. Rank 0 merges them into the walkers' caches and finishes each proposal
//!   from its cache, summing the per-contact terms in the one order a single process sums them
//!   (not an MPI reduction, whose order of addition is not fixed).
//! - **Every other update's proposals, on rank 0 or by proposal.** Before a fit's first
//!   request rank 0 tells the other ranks which density to build
//!   (`Cluster::share_density`, `Cluster::receive_density`): where every update that reads data is a contact's own or
//!   splits by contact, each builds only its share (holding only its own contacts' data), and
//!   rank 0 evaluates the other half-steps' proposals alone (a population's exact draws, which
//!   read no data). Otherwise each builds the whole density, and the other half-steps'
//!   proposals (joint updates, blocks that do not split, exact draws) are split
//!   into contiguous shares; rank 0 evaluates its own share and the other ranks, waiting in
//!   `Cluster::serve`, evaluate theirs and send the outcomes back. Each proposal is evaluated
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
//! instead: rank 0 broadcasts the list of pieces (`Cluster::broadcast_list`), every rank
//! takes its own, and the others send each finished piece's result to rank 0
//! (`Cluster::send_to_root`, `Cluster::try_receive`), which alone writes.
//!
//! A fatal evaluation on another rank comes back as a fatal outcome naming the rank and stops
//! the run on rank 0 like any fatal evaluation (its last checkpoint stays resumable). A rank
//! that fails outside an evaluation must abort the job (`Cluster::abort`) so that no rank
//! waits for it forever; rank 0 releases the others when its `Cluster` is dropped, however
//! the fit ended.

mod replicas;

pub use replicas::ReplicaShares;

#[cfg(feature = "mpi")]
mod cluster;
#[cfg(feature = "mpi")]
mod root;
#[cfg(feature = "mpi")]
mod serve;

#[cfg(feature = "mpi")]
pub use cluster::{Cluster, ClusterError, CommStats, DensityShare};
