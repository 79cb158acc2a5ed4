//! What the ranks other than 0 do: wait for rank 0's requests and answer them, evaluating
//! their share of a batch, of a split update, or of a run of independent blocks.

use std::time::Instant;

use mpi::traits::*;

use super::cluster::{
    count, input_len, Cluster, ClusterError, BLOCK, EXACT_DRAW, FATAL, FINITE, FULL,
    FULL_WITH_STATE, OWN, PHASE, RECORD_HEAD, REJECTED, SHARES, STOP, TEXT_CAPACITY,
};
use crate::density::{BlockPlan, BlockUpdate, Eval, LogDensity, LogDensityError, Target};
use crate::sampler::{
    share, Batch, BlockShares, EnsembleSampler, EvalKind, RunRequest, SamplerConfig, ShareApart,
    ShareEntries,
};

impl Cluster {
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
                rows: None,
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
        let request = RunRequest::from_words(config, state);
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
