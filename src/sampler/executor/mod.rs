//! The seam between the sampler and where its evaluations run.
//!
//! The sampler draws every random number itself, serially, and then evaluates the proposals
//! of a half-step, which are independent pure computations. An [`Executor`] receives them as
//! one [`Batch`] and may evaluate any share of it elsewhere, as long as each item is evaluated
//! by the same density from the same inputs (the point and, for a block update, what it
//! carries of its walker's state): the outcome is then the same bits wherever it was computed,
//! and the chains do not depend on how the batch was split. An executor with other processes
//! may also take a run of independent blocks in shares, each updated on a replica of the
//! sampler there (`run::replica`).
//!
//! The default, [`InProcess`], evaluates every batch on this process's rayon pool. Which
//! executor a sampler uses is chosen through a [`Parallelism`], which a parallel engine (the
//! ranks of an MPI job in `crate::distributed`) provides. Another engine (a thread pool per
//! node, a job array) needs an implementation of [`Executor`] (its `evaluate`, and the run
//! methods if it splits runs of independent blocks) and a way into [`Parallelism`].

mod batch;

use super::run::{RunOutcome, RunRequest};
pub(crate) use batch::{share, Batch, BlockShares, Shares};
#[cfg(feature = "mpi")]
pub(crate) use batch::{ShareApart, ShareEntries};

/// Evaluates the sampler's batches, in this process and possibly others (`Send`: a sampler
/// may be moved into a thread pool).
pub(crate) trait Executor: Send {
    /// Evaluates every item of `batch`: items this process keeps through
    /// [`Batch::evaluate_here`], the others by storing what other processes computed through
    /// [`Batch::set_outcome`]. Each item must be evaluated by the sampler's density with the
    /// batch's inputs, so that the chains are the same bits as in one process.
    fn evaluate(&mut self, batch: &mut Batch<'_>);

    /// Into how many shares the sampler may split a run of independent blocks (the
    /// contacts' blocks of a campaign): this process updates the first, and share `r` goes
    /// to the `r`-th other process through [`send_run`](Self::send_run), each updating it on
    /// a replica of the sampler. 1: runs are not split, and their proposals come to
    /// [`evaluate`](Self::evaluate) like any others.
    fn run_shares(&self) -> usize;

    /// Hands the walkers' state as a run of independent blocks begins to the other
    /// processes, each of which updates its share from it (when [`run_shares`] is 2 or more).
    ///
    /// [`run_shares`]: Self::run_shares
    fn send_run(&mut self, request: &RunRequest);

    /// What the other processes' shares changed, in share order (shares 1, 2, ...), once
    /// each has updated its share of the run last sent.
    fn gather_run(&mut self) -> Vec<RunOutcome>;
}

/// Every batch evaluated in this process, on the rayon pool when the sampler finds it worth it.
#[derive(Debug, Default, Clone, Copy)]
pub(crate) struct InProcess;

impl Executor for InProcess {
    fn evaluate(&mut self, batch: &mut Batch<'_>) {
        batch.evaluate_here(0..batch.len());
    }

    fn run_shares(&self) -> usize {
        1
    }

    /// Runs are not split: nothing to send.
    fn send_run(&mut self, _request: &RunRequest) {}

    /// Runs are not split: no other share.
    fn gather_run(&mut self) -> Vec<RunOutcome> {
        Vec::new()
    }
}

/// Where a sampler evaluates: in this process (the default), or through a parallel engine
/// such as the ranks of an MPI job (`slipbayes::distributed`). The chains are the same bits
/// either way.
#[derive(Default)]
pub struct Parallelism<'a> {
    executor: Option<&'a mut dyn Executor>,
}

impl std::fmt::Debug for Parallelism<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let engine = if self.executor.is_some() {
            "engine"
        } else {
            "in process"
        };
        f.debug_tuple("Parallelism").field(&engine).finish()
    }
}

impl<'a> Parallelism<'a> {
    /// Through `executor`.
    pub(crate) fn through(executor: &'a mut dyn Executor) -> Self {
        Self {
            executor: Some(executor),
        }
    }

    /// The executor, when it is not this process alone.
    pub(crate) fn executor(&mut self) -> Option<&mut (dyn Executor + 'a)> {
        self.executor.as_deref_mut()
    }

    /// Whether every evaluation stays in this process.
    pub(crate) fn is_in_process(&self) -> bool {
        self.executor.is_none()
    }
}
