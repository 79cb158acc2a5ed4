//! What rank 0 does: the sampler's executor, cutting each batch over the ranks by item or by
//! contact, and each run of independent blocks into the ranks' shares.

use std::time::Instant;

use mpi::datatype::{Partition, PartitionMut};
use mpi::traits::*;
use mpi::Count;

use super::cluster::{
    count, displacements, gather_text, input_len, partition, Cluster, BLOCK, EXACT_DRAW, FATAL,
    FULL, FULL_WITH_STATE, OWN, PHASE, RECORD_HEAD, REJECTED, SHARES,
};
use crate::density::{LogDensityError, ShareError};
use crate::sampler::{
    share, Batch, EvalKind, Executor, Parallelism, RunOutcome, RunRequest, ShareEntries,
};

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

/// Every batch and run shared by the ranks of the job.
impl Executor for Cluster {
    /// Every rank updates a share of a run of independent blocks.
    fn run_shares(&self) -> usize {
        self.size()
    }

    /// On rank 0: broadcasts the sampler's configuration and the walkers' state; every other
    /// rank updates its share from them in [`serve`](Self::serve).
    fn send_run(&mut self, request: &RunRequest) {
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
    fn gather_run(&mut self) -> Vec<RunOutcome> {
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
                RunOutcome::from_parts(
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

impl<'a> From<&'a mut Cluster> for Parallelism<'a> {
    fn from(cluster: &'a mut Cluster) -> Self {
        Parallelism::through(cluster)
    }
}
