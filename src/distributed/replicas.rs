//! One process standing in for the ranks of an MPI job: each run of independent blocks split
//! over replicas of the sampler, each share of a split update evaluated apart from the
//! walkers' values, then merged, exactly as the ranks would. It checks the split's bits
//! wherever MPI is not built.

use crate::density::{LogDensity, Target};
use crate::sampler::{
    share, Batch, EnsembleSampler, Executor, Parallelism, RunOutcome, RunRequest, SamplerConfig,
    SamplerError,
};

/// An engine that splits each run of independent blocks into `shares` and updates all
/// but the first on replicas of the sampler in this process, one after another: what the
/// ranks of an MPI job do at the same time, in one process. It saves no time; it checks that
/// updates of independent blocks made apart and merged give the chains of a sampler without
/// it, bit for bit.
pub struct ReplicaShares<'a, D: LogDensity + ?Sized> {
    replicas: Vec<EnsembleSampler<'a, D>>,
    request: Option<RunRequest>,
    /// Batches split by independent block so far.
    split_batches: usize,
}

impl<'a, D: LogDensity + ?Sized> ReplicaShares<'a, D> {
    /// Shares for a sampler of `density` with `config`, cut `shares` ways (at least 1).
    ///
    /// # Errors
    /// As [`EnsembleSampler::new`], for an invalid configuration.
    pub fn new(
        target: impl Into<Target<'a, D>>,
        config: &SamplerConfig,
        shares: usize,
    ) -> Result<Self, SamplerError> {
        let target = target.into();
        let replicas = (1..shares.max(1))
            .map(|_| EnsembleSampler::replica(target, config.clone()))
            .collect::<Result<_, _>>()?;
        Ok(Self {
            replicas,
            request: None,
            split_batches: 0,
        })
    }

    /// How many batches were split by independent block (the rest by item).
    pub fn split_batches(&self) -> usize {
        self.split_batches
    }
}

impl<D: LogDensity + ?Sized> Executor for ReplicaShares<'_, D> {
    /// A batch that splits by independent block is split as the MPI offload splits it: the
    /// first share in place, the others apart from the walkers' values (as another process
    /// evaluates them, from the points alone), then merged.
    fn evaluate(&mut self, batch: &mut Batch<'_>) {
        let (parts, shares) = (batch.parts(), self.run_shares());
        if parts == 0 || shares == 1 {
            batch.evaluate_here(0..batch.len());
            return;
        }
        self.split_batches += 1;
        let mut failures = batch.evaluate_share_here(share(parts, shares, 0));
        for r in 1..shares {
            let entries = batch.share_entries(share(parts, shares, r));
            let outcome = batch.evaluate_share_apart(share(parts, shares, r), &entries);
            batch.merge_share(&mut failures, &entries, outcome);
        }
        batch.finish_shares(failures);
    }

    fn run_shares(&self) -> usize {
        self.replicas.len() + 1
    }

    fn send_run(&mut self, request: &RunRequest) {
        self.request = Some(request.clone());
    }

    fn gather_run(&mut self) -> Vec<RunOutcome> {
        let request = self
            .request
            .take()
            .expect("a run is sent before it is gathered");
        let shares = self.run_shares();
        self.replicas
            .iter_mut()
            .enumerate()
            .map(|(r, replica)| {
                replica
                    .update_share(&request, shares, r + 1)
                    .expect("a replica of the same density and configuration")
            })
            .collect()
    }
}

impl<'a, D: LogDensity + ?Sized> From<&'a mut ReplicaShares<'_, D>> for Parallelism<'a> {
    fn from(replicas: &'a mut ReplicaShares<'_, D>) -> Self {
        Parallelism::through(replicas)
    }
}
