//! Simulation-based calibration over the ranks of an MPI job (feature `mpi`): every rank runs
//! its share of the replications still to run; rank 0 alone writes the output directory.
//!
//! Rank 0 opens the run ([`SbcRun::open`]), finds the replications still to run and gives
//! every rank the list (`Cluster::broadcast_list`), headed by the [`fingerprint`] of its
//! settings and model file, which every rank checks against its own; rank `r` of `R` runs the
//! replications at positions `r, r + R, ...` of it ([`share`]). A replication depends only on (seed, index),
//! never on the rank or the number of threads that ran it, so the records and the report are
//! those of one process. The other ranks send each finished replication's record to rank 0,
//! which appends it to the table at once, as one process does: a job stopped at any moment
//! leaves whole rows, and the same command continues with the rest, on any number of
//! ranks. Each fit writes its chains under `fits/NNNNN/` on the rank that runs it
//! and deletes them when done (a scratch directory: on a cluster without a shared file
//! system, on that node's disk).

use std::convert::Infallible;
use std::hash::{Hash, Hasher};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Duration;

use slipbayes::distributed::Cluster;

use super::{Replication, SbcRun, SbcSettings, ValidateError};

/// How long rank 0's collector sleeps when no record has arrived: a replication takes
/// seconds, and a blocking receive would spin on a core that rank 0's own fits need.
const POLL: Duration = Duration::from_millis(10);

/// Errors of a validation over ranks.
#[derive(Debug, thiserror::Error)]
pub enum RanksError {
    /// A rank sent bytes that are not a replication record (ranks running different builds).
    #[error(
        "rank {rank} sent a replication record that does not parse ({message}); every rank must \
         run the same slipbayes"
    )]
    BadRecord {
        /// The rank that sent it.
        rank: usize,
        /// Why it does not parse.
        message: String,
    },
    /// Rank 0's own replications stopped because recording the others' failed.
    #[error("stopped: recording another rank's replication failed")]
    Stopped,
    /// Writing a record failed.
    #[error(transparent)]
    Validate(#[from] ValidateError),
}

/// A fingerprint of what every replication depends on besides its index: the settings and
/// the bytes of the model file. Rank 0 sends its own with the list; a rank whose own differs
/// (another command line, another model file at that path on its node) must not run
/// replications, whose records would belong to another run.
///
/// # Errors
/// [`ValidateError::Io`] when the model file cannot be read.
pub fn fingerprint(settings: &SbcSettings) -> Result<u64, ValidateError> {
    let model =
        std::fs::read(&settings.model).map_err(slipbayes::IoError::at("read", &settings.model))?;
    // The same binary on every rank: its std hasher (fixed keys) gives the same value.
    let mut hasher = std::hash::DefaultHasher::new();
    serde_json::to_vec(settings)
        .unwrap_or_default()
        .hash(&mut hasher);
    model.hash(&mut hasher);
    Ok(hasher.finish())
}

/// Rank `rank`'s share of `pending` on `ranks` ranks: the replications at positions
/// `rank, rank + ranks, ...`, so that ranks with the same list agree without talking and a
/// continued run with a few left spreads them over every rank.
pub fn share(pending: &[usize], ranks: usize, rank: usize) -> Vec<usize> {
    pending
        .iter()
        .skip(rank)
        .step_by(ranks.max(1))
        .copied()
        .collect()
}

/// What rank 0 ran and received.
#[derive(Debug)]
pub struct Shared {
    /// Every replication of the list, in index order.
    pub replications: Vec<Replication>,
    /// How many of them the other ranks ran and sent.
    pub received: usize,
}

/// On rank 0: runs its share of `pending` and records every replication of `pending`, its
/// own and those the other ranks send, as each finishes (calling `progress` for each).
///
/// # Errors
/// [`RanksError`] when a record cannot be written or a rank sends something else than a
/// record. The records written stay; the caller must then end the job (the other ranks are
/// still running theirs).
pub fn run_root(
    run: &SbcRun,
    pending: &[usize],
    cluster: &mut Cluster,
    progress: &(dyn Fn(&Replication) + Sync),
) -> Result<Shared, RanksError> {
    let mine = share(pending, cluster.size(), 0);
    let expected = pending.len() - mine.len();
    let stop = AtomicBool::new(false);
    let (own, others) = std::thread::scope(|scope| {
        let collector = scope.spawn(|| {
            let received = collect(run, cluster, expected, &stop, progress);
            if received.is_err() {
                stop.store(true, Ordering::Relaxed);
            }
            received
        });
        let own = run.run_share(&mine, &|rep| {
            if stop.load(Ordering::Relaxed) {
                return Err(RanksError::Stopped);
            }
            run.record(rep)?;
            progress(rep);
            Ok(())
        });
        if own.is_err() {
            stop.store(true, Ordering::Relaxed);
        }
        let others = collector
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (own, others)
    });
    // The collector's error is the cause when rank 0's own share only stopped for it.
    let others = others?;
    let received = others.len();
    let mut replications = own?;
    replications.extend(others);
    replications.sort_by_key(|r| r.index);
    run.finish()?;
    Ok(Shared {
        replications,
        received,
    })
}

/// Receives and records the `expected` replications of the other ranks, until `stop`.
fn collect(
    run: &SbcRun,
    cluster: &mut Cluster,
    expected: usize,
    stop: &AtomicBool,
    progress: &(dyn Fn(&Replication) + Sync),
) -> Result<Vec<Replication>, RanksError> {
    let mut reps = Vec::with_capacity(expected);
    while reps.len() < expected && !stop.load(Ordering::Relaxed) {
        let Some((rank, bytes)) = cluster.try_receive() else {
            std::thread::sleep(POLL);
            continue;
        };
        let rep: Replication =
            serde_json::from_slice(&bytes).map_err(|e| RanksError::BadRecord {
                rank,
                message: e.to_string(),
            })?;
        run.record(&rep)?;
        progress(&rep);
        reps.push(rep);
    }
    Ok(reps)
}

/// On a rank other than 0: runs this rank's share of `pending` and sends each replication's
/// record to rank 0 as it finishes.
pub fn run_rank(run: &SbcRun, pending: &[usize], cluster: &mut Cluster) {
    let mine = share(pending, cluster.size(), cluster.rank());
    // The threads that run the fits take turns to send (MPI at the serialized level).
    let cluster = Mutex::new(cluster);
    let Ok(_) = run.run_share::<Infallible>(&mine, &|rep| {
        let mut cluster = cluster
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner());
        cluster.send_to_root(&SbcRun::record_bytes(rep));
        Ok(())
    });
}

#[cfg(test)]
mod tests {
    use super::share;

    #[test]
    fn the_shares_cover_every_replication_once() {
        let pending = [0, 2, 3, 5, 8, 9, 10];
        for ranks in 1..=4 {
            let mut all: Vec<usize> = (0..ranks).flat_map(|r| share(&pending, ranks, r)).collect();
            all.sort_unstable();
            assert_eq!(all, pending, "{ranks} ranks");
        }
        assert_eq!(share(&pending, 3, 1), vec![2, 8]);
    }
}
