//! One step: every walker of every ensemble updated once, jointly or block after block (a
//! block drawn exactly, moved with its followers, or independent of the others and drawing
//! from its own streams).

use super::super::ensemble::{BlockTerms, Fatal, ProposalBuffers, UpdateBlock, Work};
use super::super::error::SamplerError;
use super::super::moves::{Move, SLICE_ADAPT_STEPS};
use super::EnsembleSampler;
use crate::density::LogDensity;

impl<D: LogDensity + ?Sized> EnsembleSampler<'_, D> {
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
            for ens in &mut self.ensembles {
                ens.tune_carry(&blocks, freeze);
            }
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

    /// One update of every walker in each of `blocks` in turn. A run of independent blocks
    /// goes to the offload's processes in shares when it splits them (see
    /// [`update_run`](Self::update_run)).
    pub(super) fn update_blocks(
        &mut self,
        blocks: &[UpdateBlock],
        step_no: u64,
    ) -> Result<(), (usize, Fatal)> {
        let mut b = 0;
        while b < blocks.len() {
            if let Some(run) = self.split_run(blocks, b) {
                b = run.end;
                self.update_run(blocks, run)?;
                continue;
            }
            let block = &blocks[b];
            // A conditional block is drawn exactly; when the density also carries its followers
            // (the non-centred map), a move of the block with its followers follows, so that the
            // two parametrisations of a hierarchical model interweave (Yu & Meng 2011): the exact
            // draw mixes where the data pin the members, the carried move where they do not.
            let tuning = block.carry_measured && step_no < CARRY_TUNE_STEPS;
            let before = tuning.then(|| self.block_positions(block));
            if block.conditional {
                self.update(Some((b, block)), true)?;
            }
            let drawn = tuning.then(|| self.block_positions(block));
            if !block.conditional
                || (block.density_carries && self.keeps_carried_move(b, block, step_no))
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

    /// Updates every walker of every ensemble once: all coordinates, or those of `block`
    /// (its index and coordinates), by the moves or, when `exact`, by an exact draw from the
    /// block's conditional. Returns the first fatal evaluation.
    pub(super) fn update(
        &mut self,
        block: Option<(usize, &UpdateBlock)>,
        exact: bool,
    ) -> Result<(), (usize, Fatal)> {
        // An independent block draws from its own streams (keyed by its first coordinate, a
        // name that does not depend on the blocks' order), the ensembles' own streams waiting.
        let keyed = block
            .filter(|(_, ub)| ub.independent)
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

    /// [`update`](Self::update) with the ensembles' streams in place.
    pub(super) fn update_walkers(
        &mut self,
        block: Option<(usize, &UpdateBlock)>,
        exact: bool,
    ) -> Result<(), (usize, Fatal)> {
        let moves = self.config.moves();
        let half = self.config.walkers() / 2;
        let (ndim, stride, cstride) = (self.ndim, self.nderived.max(1), self.cache_len.max(1));
        for (ens, mv) in self.ensembles.iter_mut().zip(self.step_moves.iter_mut()) {
            *mv = ens.start_step(moves);
        }
        for h in 0..2 {
            let Work {
                proposals,
                derived,
                cache,
                ..
            } = &mut self.work;
            let density = self.density;
            for (((((ens, mv), p), props), der), cac) in self
                .ensembles
                .iter_mut()
                .zip(&self.step_moves)
                .zip(self.pending.iter_mut())
                .zip(proposals.chunks_exact_mut(half * ndim))
                .zip(derived.chunks_exact_mut(half * stride))
                .zip(cache.chunks_exact_mut(half * cstride))
            {
                // An ensemble whose first half failed fatally does not go on (as before); a
                // slice half-step runs below, walker by walker.
                if p.is_none() && (exact || !mv.is_slice()) {
                    let out = ProposalBuffers {
                        proposals: props,
                        derived: der,
                        cache: cac,
                    };
                    match block {
                        Some((b, ub)) if exact => {
                            let ln_conditional = |x: &[f64]| density.conditional_log_density(b, x);
                            *p = ens.draw_conditional(h, ub, &ln_conditional, out).err();
                        }
                        Some((b, ub)) if ub.density_carries => {
                            let carry =
                                |from: &[f64], to: &mut [f64]| density.carry_followers(b, from, to);
                            ens.draw(mv, h, Some((b, ub, Some(&carry))), out);
                        }
                        _ => ens.draw(mv, h, block.map(|(b, ub)| (b, ub, None)), out),
                    }
                }
            }
            if !exact && self.step_moves.iter().any(Move::is_slice) {
                self.slice_half_step(h, block);
            }
            if exact || !self.step_moves.iter().all(Move::is_slice) {
                self.evaluate(block.map(|b| b.0), exact);
            }
            let Work {
                proposals,
                derived,
                cache,
                evals,
            } = &self.work;
            // An independent block's move is accepted on the change of its own terms, which
            // the other independent blocks' updates leave alone.
            let density = self.density;
            let local = block
                .filter(|(_, ub)| ub.independent)
                .map(|(b, _)| move |x: &[f64], c: &[f64]| density.block_log_density(b, x, c));
            for (((((ens, p), props), der), cac), ev) in self
                .ensembles
                .iter_mut()
                .zip(self.pending.iter_mut())
                .zip(proposals.chunks_exact(half * ndim))
                .zip(derived.chunks_exact(half * stride))
                .zip(cache.chunks_exact(half * cstride))
                .zip(evals.chunks_exact(half))
            {
                if p.is_none() {
                    let local = local.as_ref().map(|f| f as &BlockTerms);
                    *p = ens.accept(h, props, der, cac, ev, local).err();
                }
            }
        }
        if !exact {
            let slot = block.map_or(0, |b| b.0);
            let adapt = self.step < SLICE_ADAPT_STEPS;
            for ((ens, mv), p) in self
                .ensembles
                .iter_mut()
                .zip(&self.step_moves)
                .zip(&self.pending)
            {
                if mv.is_slice() && p.is_none() {
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

    /// Whether block `b` (`block`), drawn exactly and carried by the moves, is still moved by
    /// the moves at step `step`. Both updates run in every step of a block whose carried move is not
    /// optional, and during the first [`CARRY_TUNE_STEPS`] steps of one whose carried move
    /// is. After those, the carried move is kept only if it moved the block at least
    /// [`CARRY_MIN_JUMP_RATIO`] times as far (in squared distance, summed over every walker)
    /// as the exact draws did: where the data pin the members, the exact draw does the work
    /// and the carried move, which re-evaluates every run the block's followers touch, is
    /// mostly rejected (the pooled friction posteriors: at most 3 % of the exact draws'
    /// squared jump); where the data say little, the carried move goes further than the exact
    /// draw (the centred eight schools: 2.2–2.8 times). The choice depends only on the chains, so it is the same on
    /// any number of threads, and it is made before the suggested burn-in ends.
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
/// density makes it optional, [`LogDensity::carried_move_optional`]).
pub const CARRY_TUNE_STEPS: u64 = 50;

/// Steps over which a regression carrying a block's followers is tuned (where it is, see
/// [`CarryFit`](super::CarryFit)): fitted to the ensemble's draws of the first half of them
/// (while the complement's regression carries the followers), then refitted to those of
/// the second half (carried by the first fit), then fixed. The suggested burn-in covers them.
pub const CARRY_FIT_STEPS: u64 = 100;

/// The carried move of such a block is kept when its squared jumps over the tuning steps are
/// at least this fraction of the exact draws' (measured: 2.2–2.8 on the centred eight schools,
/// where it is needed; at most 0.03 on the pooled friction posteriors, where it is not).
pub const CARRY_MIN_JUMP_RATIO: f64 = 0.1;

fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum()
}
