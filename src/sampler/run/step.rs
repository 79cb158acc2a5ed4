//! One step: every walker of every ensemble updated once, jointly or block after block (a
//! block drawn exactly, moved with its followers, or independent of the others and drawing
//! from its own streams).
//!
//! A run of independent blocks is updated block after block, each on its own entries of the
//! walkers' state, and the walkers' log-densities (and the derived values that belong to no
//! block) are brought up to date once after the run, from the state: the bits of whole
//! updates made one after another, at a cost that does not grow with the number of blocks.

use std::ops::Range;

use rayon::prelude::*;

use super::super::ensemble::{BlockKind, Ensemble, Fatal, Settle, UpdateBlock};
use super::super::error::SamplerError;
use super::super::evaluator::EvalKind;
use super::super::moves::{Move, SLICE_ADAPT_STEPS};
use super::EnsembleSampler;
use crate::density::{IndependentBlocks, LogDensity, SplitByPart};

/// How the proposals of a half-step are evaluated and settle, and what they carry of their
/// walkers' derived values and state.
#[derive(Clone, Copy)]
pub(super) struct HalfStepPlan<'s, 'a> {
    pub kind: EvalKind<'a>,
    pub settle: Settle<'s>,
    /// Derived values and entries of state each proposal carries.
    pub carried: (usize, usize),
    /// Whether a proposal carries its walker's whole derived values and state as input.
    pub whole: bool,
    /// The evaluation of a move of a block that every independent block depends on, split by
    /// independent block for other processes.
    pub split: Option<&'a dyn SplitByPart>,
}

impl<'a, D: LogDensity + ?Sized> EnsembleSampler<'a, D> {
    /// One step of every ensemble: one update of every walker (joint), or one update of
    /// every walker in each block in turn (blocked). All randomness is drawn serially,
    /// ensemble by ensemble; per half-step the proposals of all ensembles are evaluated in one
    /// loop (see [`evaluate`](Self::evaluate)).
    pub(super) fn advance(&mut self, step_no: u64) -> Result<(), SamplerError> {
        let blocks = std::mem::take(&mut self.blocks);
        let result = if blocks.is_empty() {
            self.update(None, false)
        } else {
            self.update_blocks(&blocks, step_no)
        };
        if result.is_ok() && step_no < CARRY_FIT_STEPS && blocks.iter().any(|b| b.tuned_carry) {
            let freeze = step_no + 1 == CARRY_FIT_STEPS / 2 || step_no + 1 == CARRY_FIT_STEPS;
            self.tune_carry(&blocks, freeze);
        }
        self.blocks = blocks;
        result.map_err(|(e, f)| {
            self.poisoned = true;
            SamplerError::FatalDensity {
                ensemble: e,
                walker: f.walker,
                step: step_no,
                position: f.position,
                message: f.message,
            }
        })
    }

    /// Gathers this step's walkers of every ensemble into the tuning of every tuned block,
    /// and when `freeze` ends the window (see
    /// [`CarryTuning`](super::super::moves::CarryTuning)). The ensembles tune one regression
    /// together and each keeps a copy: its error in every follower adds up in the block's
    /// acceptance ratio (about ½ × followers / effective draws per squared step of the
    /// block's sd), so a campaign of hundreds of contacts needs every draw there is. Only the
    /// fixed map is shared; each ensemble's chain stays its own.
    fn tune_carry(&mut self, blocks: &[UpdateBlock<'a>], freeze: bool) {
        let ndim = self.ndim;
        let mut fits = std::mem::take(&mut self.ensembles[0].s.carry_fits);
        for (tuning, b) in fits.iter_mut().zip(blocks) {
            if let Some(t) = tuning {
                for ens in &self.ensembles {
                    t.gather(&ens.s.positions, ndim, &b.coords, &b.links.followers);
                }
                if freeze {
                    t.freeze();
                }
            }
        }
        for ens in &mut self.ensembles[1..] {
            ens.s.carry_fits.clone_from(&fits);
        }
        self.ensembles[0].s.carry_fits = fits;
    }

    /// One update of every walker in each of `blocks` in turn. A run of independent blocks
    /// is updated block after block on the blocks' own state, or in shares by the executor's
    /// processes when it splits them (see [`update_run`](Self::update_run)), and then brought
    /// together.
    pub(super) fn update_blocks(
        &mut self,
        blocks: &[UpdateBlock<'a>],
        step_no: u64,
    ) -> Result<(), (usize, Fatal)> {
        let mut b = 0;
        while b < blocks.len() {
            if let Some((run, own)) = independent_run(blocks, b) {
                b = run.end;
                self.work.mirror_fresh = false;
                if self.splits_runs() && run.len() >= 2 {
                    self.update_run(blocks, run)?;
                } else {
                    for i in run {
                        self.update(Some((i, &blocks[i])), false)?;
                    }
                }
                self.refresh_from_state(own);
                continue;
            }
            let block = &blocks[b];
            // A conditional block is drawn exactly; when the density also carries its followers
            // (the non-centred map), a move of the block with its followers follows, so that the
            // two parametrisations of a hierarchical model interweave (Yu & Meng 2011): the exact
            // draw mixes where the data pin the members, the carried move where they do not.
            let tuning = block.carry_measured && step_no < CARRY_TUNE_STEPS;
            let before = tuning.then(|| self.block_positions(block));
            if block.exact() {
                self.update(Some((b, block)), true)?;
            }
            let drawn = tuning.then(|| self.block_positions(block));
            if !block.exact()
                || (block.carry().is_some() && self.keeps_carried_move(b, block, step_no))
            {
                self.update(Some((b, block)), false)?;
            }
            if let (Some(before), Some(drawn)) = (before, drawn) {
                let after = self.block_positions(block);
                self.carry_jumps[b][0] += squared_distance(&before, &drawn);
                self.carry_jumps[b][1] += squared_distance(&drawn, &after);
            }
            b += 1;
        }
        Ok(())
    }

    /// Each walker's log-density, and the derived values that belong to no one block, from
    /// its state after a run of independent blocks (`own`) updated on their own entries.
    pub(super) fn refresh_from_state(&mut self, own: &dyn IndependentBlocks) {
        let (ndim, nderived, state_len) = (self.ndim, self.nderived, self.state_len);
        for ens in &mut self.ensembles {
            let Ensemble { s, cache, .. } = ens;
            let walkers = s.log_density.len();
            let mut derived: Vec<&mut [f64]> = match nderived {
                0 => (0..walkers).map(|_| &mut [][..]).collect(),
                n => s.derived.chunks_exact_mut(n).collect(),
            };
            s.log_density
                .par_iter_mut()
                .zip(&mut derived)
                .enumerate()
                .for_each(|(w, (lp, derived))| {
                    let x = &s.positions[w * ndim..(w + 1) * ndim];
                    let state = &cache[w * state_len..(w + 1) * state_len];
                    *lp = own.log_density_from_state(x, derived, state);
                });
        }
    }

    /// Updates every walker of every ensemble once: all coordinates, or those of `block`
    /// (its index and coordinates), by the moves or, when `exact`, by an exact draw from the
    /// block's conditional. Returns the first fatal evaluation.
    pub(super) fn update(
        &mut self,
        block: Option<(usize, &UpdateBlock<'a>)>,
        exact: bool,
    ) -> Result<(), (usize, Fatal)> {
        // An independent block draws from its own streams (keyed by its first coordinate, a
        // name that does not depend on the blocks' order), the ensembles' own streams waiting.
        let keyed = block
            .filter(|(_, ub)| ub.independent())
            .map(|(_, ub)| ub.coords[0]);
        if let Some(key) = keyed {
            let (seed, step, walkers) = (self.config.seed(), self.step, self.config.walkers());
            for (e, (ens, streams)) in self
                .ensembles
                .iter_mut()
                .zip(&mut self.block_streams)
                .enumerate()
            {
                streams.rekey(seed, e, key, walkers, step);
                ens.swap_streams(streams);
            }
        }
        let result = self.update_walkers(block, exact);
        if keyed.is_some() {
            for (ens, streams) in self.ensembles.iter_mut().zip(&mut self.block_streams) {
                ens.swap_streams(streams);
            }
        }
        result
    }

    /// How the proposals of an update of `block` (all coordinates when `None`; an exact draw
    /// when `exact`) are evaluated and settle.
    fn half_step_plan<'s>(
        &self,
        block: Option<(usize, &'s UpdateBlock<'a>)>,
        exact: bool,
    ) -> HalfStepPlan<'s, 'a> {
        let whole = (self.nderived, self.state_len);
        let (kind, settle, split) = match block {
            None => (EvalKind::Full, Settle::Whole, None),
            Some((b, ub)) => match &ub.kind {
                BlockKind::Exact { conditional, .. } if exact => {
                    (EvalKind::ExactDraw(b, *conditional), Settle::Whole, None)
                }
                BlockKind::Independent { own, entries } => {
                    let settle = Settle::Own {
                        block: b,
                        coords: &ub.coords,
                        own: *own,
                        entries,
                    };
                    let carried = (entries.derived.len(), entries.state.len());
                    return HalfStepPlan {
                        kind: EvalKind::Own(b, *own),
                        settle,
                        carried,
                        whole: false,
                        split: None,
                    };
                }
                _ => (EvalKind::Block(b, ub.density), Settle::Whole, ub.split),
            },
        };
        HalfStepPlan {
            kind,
            settle,
            carried: whole,
            whole: block.is_some(),
            split,
        }
    }

    /// [`update`](Self::update) with the ensembles' streams in place.
    pub(super) fn update_walkers(
        &mut self,
        block: Option<(usize, &UpdateBlock<'a>)>,
        exact: bool,
    ) -> Result<(), (usize, Fatal)> {
        let moves = self.config.moves();
        for (ens, mv) in self.ensembles.iter_mut().zip(self.step_moves.iter_mut()) {
            *mv = ens.start_step(moves);
        }
        let plan = self.half_step_plan(block, exact);
        self.work.carry(plan.carried.0, plan.carried.1);
        // An independent block proposes in place, in the mirror of the walkers' points; any
        // other update may move every coordinate, so the mirror is copied afresh before the
        // next independent block.
        self.work.in_place = matches!(plan.settle, Settle::Own { .. });
        if self.work.in_place {
            let ndim = self.ndim;
            self.work
                .refresh_mirror(self.ensembles.iter().map(|e| &e.s.positions[..]));
            debug_assert_eq!(
                self.work.mirror.len(),
                self.ensembles.len() * self.config.walkers() * ndim
            );
        } else {
            self.work.mirror_fresh = false;
        }
        for h in 0..2 {
            self.draw_half_step(h, block, exact, &plan);
            let moves = self.config.moves();
            let is_slice = |&m: &usize| moves[m].0.is_slice();
            let (any_slice, all_slice) = (
                self.step_moves.iter().any(is_slice),
                self.step_moves.iter().all(is_slice),
            );
            if !exact && any_slice {
                self.slice_half_step(h, block, &plan);
            }
            if exact || !all_slice {
                self.evaluate(block.map(|b| b.0), exact, &plan);
            }
            let half = self.config.walkers() / 2;
            for ((ens, p), (mut out, evals)) in self
                .ensembles
                .iter_mut()
                .zip(self.pending.iter_mut())
                .zip(self.work.per_ensemble(half, self.ndim))
            {
                if p.is_none() {
                    *p = ens.accept(h, &mut out, evals, plan.settle).err();
                }
            }
        }
        if !exact {
            let slot = block.map_or(0, |b| b.0);
            let adapt = self.step < SLICE_ADAPT_STEPS;
            let moves = self.config.moves();
            for ((ens, mv), p) in self
                .ensembles
                .iter_mut()
                .zip(&self.step_moves)
                .zip(&self.pending)
            {
                if moves[*mv].0.is_slice() && p.is_none() {
                    ens.finish_slice_update(slot, adapt);
                }
            }
        }
        match self
            .pending
            .iter_mut()
            .enumerate()
            .find_map(|(e, p)| p.take().map(|f| (e, f)))
        {
            Some(fatal) => Err(fatal),
            None => Ok(()),
        }
    }

    /// Draws the proposals of half `h` of every ensemble still running (but those whose move
    /// this step is the slice move, which draw as they go), each carrying what `plan` says of
    /// its walker's state.
    fn draw_half_step(
        &mut self,
        h: usize,
        block: Option<(usize, &UpdateBlock<'a>)>,
        exact: bool,
        plan: &HalfStepPlan,
    ) {
        let half = self.config.walkers() / 2;
        let moves = self.config.moves();
        for (((ens, &m), p), (mut out, _)) in self
            .ensembles
            .iter_mut()
            .zip(&self.step_moves)
            .zip(self.pending.iter_mut())
            .zip(self.work.per_ensemble(half, self.ndim))
        {
            // An ensemble whose first half failed fatally does not go on (as before).
            if p.is_some() {
                continue;
            }
            ens.gather_state(h, plan.settle, plan.whole, &mut out);
            // A slice half-step runs walker by walker (see `slice_half_step`); an exact draw
            // uses no move.
            let mv = match &moves[m].0 {
                Move::Proposal(mv) => Some(mv.as_ref()),
                Move::Slice(_) => None,
            };
            if !exact && mv.is_none() {
                continue;
            }
            match (block, mv) {
                (Some((b, ub)), _) if exact => {
                    if let BlockKind::Exact { conditional, .. } = ub.kind {
                        let ln_conditional = |x: &[f64]| conditional.conditional_log_density(b, x);
                        *p = ens.draw_conditional(h, ub, &ln_conditional, out).err();
                    }
                }
                (Some((b, ub)), Some(mv)) => {
                    ens.draw(mv, h, Some((b, ub, ub.carry().map(|c| (b, c)))), out)
                }
                (None, Some(mv)) => ens.draw(mv, h, None, out),
                (_, None) => {}
            }
        }
    }

    /// Whether block `b` (`block`), drawn exactly and carried by the moves, is still moved by
    /// the moves at step `step`. Both updates run in every step of a block whose carried move is not
    /// optional, and during the first [`CARRY_TUNE_STEPS`] steps of one whose carried move
    /// is. After those, the carried move is kept only if it moved the block at least
    /// [`CARRY_MIN_JUMP_RATIO`] times as far (in squared distance, summed over every walker)
    /// as the exact draws did: where the data pin the members, the exact draw does the work
    /// and the carried move, which re-evaluates every run the block's followers touch, is
    /// mostly rejected (the pooled friction posteriors: at most 3 % of the exact draws'
    /// squared jump); where the data say little, the carried move goes further than the exact
    /// draw (the centred eight schools: 2.2–2.8 times). The choice depends only on the chains,
    /// so it is the same on any number of threads, and it is made before the suggested
    /// burn-in ends.
    pub(super) fn keeps_carried_move(&self, b: usize, block: &UpdateBlock, step: u64) -> bool {
        if !block.carry_measured || step < CARRY_TUNE_STEPS {
            return true;
        }
        let [exact, carried] = self.carry_jumps[b];
        carried >= CARRY_MIN_JUMP_RATIO * exact
    }

    /// The coordinates of `block` of every walker of every ensemble.
    pub(super) fn block_positions(&self, block: &UpdateBlock) -> Vec<f64> {
        self.ensembles
            .iter()
            .flat_map(|e| e.s.positions.chunks_exact(self.ndim))
            .flat_map(|w| block.coords.iter().map(move |&c| w[c]))
            .collect()
    }
}

/// Steps during which a block both drawn exactly and carried by the moves gets both updates
/// before the sampler decides whether the carried move is worth its evaluations (when the
/// density makes it optional, [`CarriedMove::optional`](crate::density::CarriedMove::optional)).
pub const CARRY_TUNE_STEPS: u64 = 50;

/// Steps over which a regression carrying a block's followers is tuned (where it is, see
/// [`CarryFit`](crate::sampler::CarryFit)): fitted to every ensemble's draws of the first
/// half of them (while the complement's regression carries the followers), then refitted to
/// those of the second half (carried by the first fit), then fixed. The suggested burn-in
/// covers them.
pub const CARRY_FIT_STEPS: u64 = 100;

/// The carried move of such a block is kept when its squared jumps over the tuning steps are
/// at least this fraction of the exact draws' (measured: 2.2–2.8 on the centred eight schools,
/// where it is needed; at most 0.03 on the pooled friction posteriors, where it is not).
pub const CARRY_MIN_JUMP_RATIO: f64 = 0.1;

fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}

/// The run of independent blocks that starts at block `b` (the blocks' indices) with the
/// density's independent blocks, if block `b` is one.
fn independent_run<'a>(
    blocks: &[UpdateBlock<'a>],
    b: usize,
) -> Option<(Range<usize>, &'a dyn IndependentBlocks)> {
    let (own, _) = blocks[b].own()?;
    let end = b + blocks[b..]
        .iter()
        .take_while(|block| block.independent())
        .count();
    Some((b..end, own))
}
