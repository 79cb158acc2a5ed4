//! Evaluating a half-step's proposals, serially or on the rayon pool, and the slice move's
//! half-steps, whose walkers each evaluate as often as they need.

use std::time::Instant;

use rayon::prelude::*;

use super::super::ensemble::{SliceContext, SliceTask, UpdateBlock, Work};
use super::super::executor::{Batch, BlockShares, Executor, InProcess, Shares};
use super::super::moves::Move;
use super::step::HalfStepPlan;
use super::EnsembleSampler;
use crate::density::LogDensity;

impl<'a, D: LogDensity + ?Sized> EnsembleSampler<'a, D> {
    /// Evaluates the proposals in [`Work`] (in full, or as updates of `block`): on the rayon
    /// pool when parallel evaluation is allowed and the half-step's estimated serial cost
    /// exceeds [`PARALLEL_MIN_WORK_NS`] (below it the synchronisation costs more than it
    /// saves), serially otherwise. The results are the same either way, so the choice (which
    /// depends on timing) cannot change the chains.
    pub(super) fn evaluate(
        &mut self,
        block: Option<usize>,
        exact: bool,
        plan: &HalfStepPlan<'_, 'a>,
    ) {
        let density = self.density;
        let ndim = self.ndim;
        let (nderived, cache_len) = plan.carried;
        let half = self.config.walkers() / 2;
        // The ensembles whose half-step is a slice update have their points already.
        let moves = self.config.moves();
        let skip: Vec<bool> = self
            .step_moves
            .iter()
            .map(|&m| !exact && moves[m].0.is_slice())
            .collect();
        let Work {
            proposals,
            derived,
            cache,
            evals,
            derived_stride,
            state_stride,
            mirror,
            in_place,
            rows,
            ..
        } = &mut self.work;
        // An independent block's proposals are made in place, in the mirror of the walkers.
        let (proposals, rows) = if *in_place {
            (&mirror[..], Some(&rows[..]))
        } else {
            (&proposals[..], None)
        };
        let n = half * skip.iter().filter(|&&s| !s).count();
        let threads = rayon::current_num_threads();
        // Exact draws move no followers and cost less: timed apart from the moves.
        // (`self.blocks` is taken out during a step: the slots' count is the blocks'.)
        let slot = block.unwrap_or(0) + if exact { self.eval_ns.len() / 2 } else { 0 };
        let cost = &mut self.eval_ns[slot];
        let parallel = self.config.parallel()
            && threads > 1
            && cost.is_some_and(|c| c * n as f64 >= PARALLEL_MIN_WORK_NS);
        self.half_steps += 1;
        let timed = parallel || cost.is_none() || self.half_steps % RETIME_EVERY == 0;
        let started = timed.then(Instant::now);
        let kind = plan.kind;
        let slots: Vec<usize> = (0..evals.len()).filter(|&k| !skip[k / half]).collect();
        let local = |kind: super::super::evaluator::EvalKind<'_>,
                     x: &[f64],
                     d: &mut [f64],
                     c: &mut [f64]| kind.evaluate(density, x, d, c);
        // With another process to share with, a shared block's update may be split by
        // independent block (the contacts' terms where the contacts are).
        let splitter = match (block, plan.split) {
            (Some(b), Some(split)) if !self.parallelism.is_in_process() && !exact => {
                Some(BlockShares { split, block: b })
            }
            _ => None,
        };
        let parts = self.independent_parts;
        let mut batch = Batch {
            kind,
            ndim,
            nderived,
            cache_len,
            derived_stride: *derived_stride,
            state_stride: *state_stride,
            slots: &slots,
            proposals,
            rows,
            derived,
            cache,
            evals,
            local: &local,
            // Another process's share costs far more than a parallel loop: this process's
            // share always goes to the pool.
            parallel: if !self.parallelism.is_in_process() {
                self.config.parallel() && threads > 1
            } else {
                parallel
            },
            shares: splitter.as_ref().map(|s| (s as &dyn Shares, parts)),
        };
        match self.parallelism.executor() {
            Some(executor) => {
                executor.evaluate(&mut batch);
                return;
            }
            None => InProcess.evaluate(&mut batch),
        }
        if let Some(t) = started {
            let ns = t.elapsed().as_secs_f64() * 1e9;
            // In parallel the wall time times the threads over-estimates the cost (it
            // includes the synchronisation), which errs on the side of staying parallel.
            let per = if parallel {
                ns * threads.min(n) as f64 / n as f64
            } else {
                ns / n as f64
            };
            *cost = Some(match *cost {
                Some(c) => 0.5 * (c + per),
                None => per,
            });
        }
    }

    /// The half-step `h` of every ensemble whose move this step is the slice move, on all
    /// coordinates or those of `block`: each active walker's whole slice update (direction,
    /// stepping out, shrinkage, as many evaluations as it needs) is one task, and the tasks
    /// of every ensemble run together, on the rayon pool when parallel evaluation is allowed
    /// and the work is worth it. Each task reads only the fixed complement and its own
    /// walker, draws only from the walker's own stream, and writes only its own buffers of
    /// [`Work`]; the outcomes are taken in walker order. So the chains do not depend on the
    /// number of threads or on the (timing-based) choice to run in parallel. The new points
    /// are then accepted as they are by [`Ensemble::accept`].
    pub(super) fn slice_half_step(
        &mut self,
        h: usize,
        block: Option<(usize, &UpdateBlock<'a>)>,
        plan: &HalfStepPlan<'_, 'a>,
    ) {
        let half = self.config.walkers() / 2;
        let slot = block.map_or(0, |b| b.0);
        let moves = self.config.moves();
        let contexts: Vec<Option<SliceContext>> = self
            .ensembles
            .iter()
            .zip(&self.step_moves)
            .zip(&self.pending)
            .map(|((ens, &m), p)| match &moves[m].0 {
                Move::Slice(directions) if p.is_none() => {
                    Some(ens.slice_context(h, directions.as_ref(), slot, block.map(|b| b.1)))
                }
                _ => None,
            })
            .collect();
        let mut tasks = Vec::new();
        for ((ens, context), (out, ev)) in self
            .ensembles
            .iter_mut()
            .zip(&contexts)
            .zip(self.work.per_ensemble(half, self.ndim))
        {
            if let Some(context) = context {
                tasks.extend(ens.slice_tasks(h, context, out, ev, plan.carried));
            }
        }
        let density = self.density;
        let kind = plan.kind;
        let evaluate = |x: &[f64], d: &mut [f64], c: &mut [f64]| kind.evaluate(density, x, d, c);
        let threads = rayon::current_num_threads();
        // A slice update costs a few evaluations; until one has been timed, assume it is worth
        // spreading (the choice cannot change the chains).
        let cost = &mut self.eval_ns[slot];
        let parallel = self.config.parallel()
            && threads > 1
            && cost.is_none_or(|c| {
                c * (SLICE_EVALS_GUESS * tasks.len()) as f64 >= PARALLEL_MIN_WORK_NS
            });
        let started = Instant::now();
        let run = |t: &mut SliceTask| t.run(&evaluate, block);
        let outcomes: Vec<_> = if parallel {
            tasks.par_iter_mut().map(run).collect()
        } else {
            tasks.iter_mut().map(run).collect()
        };
        drop(tasks);
        let evaluations: u64 = outcomes
            .iter()
            .filter_map(|o| o.as_ref().ok())
            .map(|o| o.evaluations())
            .sum();
        if evaluations > 0 {
            let ns = started.elapsed().as_secs_f64() * 1e9;
            let per = ns * if parallel { threads as f64 } else { 1.0 } / evaluations as f64;
            *cost = Some(cost.map_or(per, |c| 0.5 * (c + per)));
        }
        let mut outcomes = outcomes.into_iter();
        for ((ens, context), p) in self
            .ensembles
            .iter_mut()
            .zip(&contexts)
            .zip(self.pending.iter_mut())
        {
            if context.is_some() {
                *p = ens.finish_slice(outcomes.by_ref().take(half)).err();
            }
        }
    }
}

/// Serial cost (ns) of a half-step's evaluations above which they are spread over the rayon
/// pool. One parallel loop costs a few to tens of µs of synchronisation (`cargo bench --bench
/// sampler` shows it), so parallelism pays only well above that.
const PARALLEL_MIN_WORK_NS: f64 = 100_000.0;

/// Evaluations a slice update is assumed to cost when deciding whether to run a half-step's
/// slice updates in parallel (zeus reports about five on Gaussian targets once μ is tuned).
const SLICE_EVALS_GUESS: usize = 5;

/// Half-steps between re-timings of serial evaluations (each timing costs two clock reads).
const RETIME_EVERY: u64 = 64;
