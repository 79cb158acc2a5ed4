//! Rank normalisation out of core: each draw's average rank over all draws, its normal
//! score, and the bulk ESS and R̂ of the scores. A merged stream gives the ranks in sorted
//! order; a second stream, running behind the first by one group of ties, hands each draw its
//! group's average rank, and the scores go, by index, to partitions of at most
//! [`Limits::run_draws`](super::Limits::run_draws) draws, each then laid out in walker order.
//! The scores depend only on exact ranks, so they are the in-memory scores to the bit.

use std::cmp::Ordering;

use super::draws::WalkerDraws;
use super::sort::Runs;
use super::store::{Record, Store, Workspace};
use crate::diagnostics::arviz::{average_rank, normal_score, Autocov, EssRows, RhatRows, SeqSum};
use crate::diagnostics::DiagnosticsError;

/// The normal scores of the average ranks of the records `keep` accepts (`kept` of them),
/// as ArviZ's rank normalisation gives them, laid out by index in a store of `n` f64 (other
/// indices hold NaN).
pub(super) fn rank_scores<'w>(
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
pub(super) struct Scores<'s, 'w> {
    store: &'s Store<'w>,
    chains: usize,
    walkers: usize,
    steps: usize,
}

impl<'s, 'w> Scores<'s, 'w> {
    pub(super) fn of(store: &'s Store<'w>, x: &WalkerDraws) -> Self {
        Self {
            store,
            chains: x.chains(),
            walkers: x.walkers,
            steps: x.steps,
        }
    }

    /// Bulk ESS: ArviZ `_ess` of the split half-walkers.
    pub(super) fn ess(&self) -> Result<f64, DiagnosticsError> {
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
    pub(super) fn rhat(&self) -> Result<f64, DiagnosticsError> {
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
