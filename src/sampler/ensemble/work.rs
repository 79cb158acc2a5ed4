//! The proposals of a half-step with what they carry of their walkers' state, and their
//! acceptance.
//!
//! A proposal of a joint update carries nothing but its point: a full evaluation needs nothing
//! else. A proposal of a block that others depend on carries its walker's whole state and
//! derived values, which the block's update brings up to date. A proposal of an independent
//! block carries only the block's own entries of them, compactly: its update reads and writes
//! nothing else, and its acceptance writes back only those.
//!
//! Nor does a proposal of an independent block copy its walker's whole point: it is made in
//! place, in a mirror of the walkers' points kept for the run of independent blocks, by
//! writing the block's coordinates into its walker's row, and the row is put back to the
//! walker's point once the proposal is settled. So a proposal costs the block's size, not
//! the dimension, and a sweep over many blocks does not grow as their square.

use super::{Ensemble, Fatal, HalfStep};
use crate::density::{Eval, IndependentBlocks, OwnEntries};

/// Proposals of the active halves of all ensembles, evaluated together between
/// [`Ensemble::draw`] and [`Ensemble::accept`]: ensemble `e` owns the `e`-th block of `half`
/// points.
#[derive(Debug)]
pub(crate) struct Work {
    /// Proposed positions, `ensembles × half × ndim`.
    pub proposals: Vec<f64>,
    /// Derived values of the proposals, `ensembles × half × derived_stride`, within room for
    /// all of them.
    pub derived: Vec<f64>,
    /// The walkers' state each proposal carries, `ensembles × half × state_stride`, within
    /// room for all of it.
    pub cache: Vec<f64>,
    /// Outcome of each evaluation.
    pub evals: Vec<Eval>,
    /// Values per proposal in `derived` and `cache` in the current half-step (at least 1, so
    /// that chunking works without any).
    pub derived_stride: usize,
    pub state_stride: usize,
    /// The walkers' points, `ensembles × walkers × ndim`, in which the proposals of an
    /// independent block are made in place (see the module's documentation).
    pub mirror: Vec<f64>,
    /// Whether `mirror` holds the walkers' points (but for no block's proposal): set when it
    /// is copied from them, cleared whenever an update of another kind may move them.
    pub mirror_fresh: bool,
    /// Whether the current half-step proposes in `mirror` (an independent block's update).
    pub in_place: bool,
    /// For each proposal, its row in `mirror` when the half-step proposes in place,
    /// `ensembles × half`.
    pub rows: Vec<usize>,
}

impl Work {
    pub fn new(
        ensembles: usize,
        half: usize,
        ndim: usize,
        nderived: usize,
        state_len: usize,
    ) -> Self {
        Self {
            proposals: vec![0.0; ensembles * half * ndim],
            derived: vec![0.0; ensembles * half * nderived.max(1)],
            cache: vec![0.0; ensembles * half * state_len.max(1)],
            evals: vec![Eval::Finite(0.0); ensembles * half],
            derived_stride: nderived.max(1),
            state_stride: state_len.max(1),
            mirror: Vec::new(),
            mirror_fresh: false,
            in_place: false,
            rows: vec![0; ensembles * half],
        }
    }

    /// Copies every ensemble's walkers' points into the mirror in which the proposals of an
    /// independent block are made, unless it holds them already.
    pub fn refresh_mirror<'p>(&mut self, positions: impl Iterator<Item = &'p [f64]>) {
        if self.mirror_fresh {
            return;
        }
        self.mirror.clear();
        for p in positions {
            self.mirror.extend_from_slice(p);
        }
        self.mirror_fresh = true;
    }

    /// Makes room in each proposal for `derived` derived values and `state` entries of state.
    pub fn carry(&mut self, derived: usize, state: usize) {
        self.derived_stride = derived.max(1);
        self.state_stride = state.max(1);
    }

    /// The buffers of each ensemble's proposals, with their outcomes, in ensemble order.
    pub fn per_ensemble(
        &mut self,
        half: usize,
        ndim: usize,
    ) -> impl Iterator<Item = (ProposalBuffers<'_>, &mut [crate::density::Eval])> {
        let (ds, ss) = (self.derived_stride, self.state_stride);
        let ensembles = self.evals.len() / half.max(1);
        // The mirror is empty until a run of independent blocks needs it.
        let walkers_len = self.mirror.len() / ensembles.max(1);
        let mirrors: Box<dyn Iterator<Item = &mut [f64]>> = if self.in_place {
            Box::new(self.mirror.chunks_exact_mut(walkers_len.max(1)))
        } else {
            Box::new(std::iter::repeat_with(|| &mut [][..]))
        };
        let in_place = self.in_place;
        self.proposals
            .chunks_exact_mut(half * ndim)
            .zip(self.derived.chunks_exact_mut(half * ds))
            .zip(self.cache.chunks_exact_mut(half * ss))
            .zip(self.rows.chunks_exact_mut(half))
            .zip(mirrors)
            .enumerate()
            .zip(self.evals.chunks_exact_mut(half))
            .map(
                move |((e, ((((proposals, derived), cache), rows), mirror)), evals)| {
                    let buffers = ProposalBuffers {
                        proposals,
                        derived,
                        cache,
                        derived_stride: ds,
                        state_stride: ss,
                        in_place,
                        mirror,
                        rows,
                        row_base: e * walkers_len / ndim.max(1),
                        ndim,
                    };
                    (buffers, evals)
                },
            )
    }
}

/// The buffers of one ensemble's proposals in [`Work`].
pub(crate) struct ProposalBuffers<'w> {
    pub proposals: &'w mut [f64],
    pub derived: &'w mut [f64],
    pub cache: &'w mut [f64],
    pub derived_stride: usize,
    pub state_stride: usize,
    /// Whether the proposals are made in place, in `mirror` (an independent block's update).
    pub in_place: bool,
    /// The ensemble's walkers' points, `walkers × ndim`, when `in_place`.
    pub mirror: &'w mut [f64],
    /// Each proposal's row in [`Work::mirror`] (of every ensemble), when `in_place`.
    pub rows: &'w mut [usize],
    /// The row in [`Work::mirror`] of the ensemble's first walker.
    pub row_base: usize,
    pub ndim: usize,
}

impl ProposalBuffers<'_> {
    /// The point of proposal `k`, that of walker `w`.
    pub fn point(&self, k: usize, w: usize) -> &[f64] {
        let ndim = self.ndim;
        if self.in_place {
            &self.mirror[w * ndim..(w + 1) * ndim]
        } else {
            &self.proposals[k * ndim..(k + 1) * ndim]
        }
    }

    /// The derived values and state of proposal `k`, `derived` and `state` of them.
    pub fn carried(&mut self, k: usize, derived: usize, state: usize) -> (&mut [f64], &mut [f64]) {
        let (ds, ss) = (self.derived_stride, self.state_stride);
        (
            &mut self.derived[k * ds..k * ds + derived],
            &mut self.cache[k * ss..k * ss + state],
        )
    }
}

/// What of its walker's state a proposal carries, and so how an accepted one is written back.
#[derive(Clone, Copy)]
pub(crate) enum Settle<'e> {
    /// Nothing (joint updates: a full evaluation), or all of it (a block others depend on):
    /// an accepted proposal brings its log-density, derived values and state.
    Whole,
    /// The own entries of independent block `block`: an accepted proposal brings those, and
    /// is accepted on the change of the block's own terms. The walker's log-density is brought
    /// up to date after the run of independent blocks.
    Own {
        block: usize,
        /// The block's coordinates, the only ones in which a proposal differs from its walker.
        coords: &'e [usize],
        own: &'e dyn IndependentBlocks,
        entries: &'e OwnEntries,
    },
}

impl Ensemble {
    /// Copies what the proposals of half `h` carry of their walkers' state into `out`
    /// (nothing when `whole` is false and `settle` is [`Settle::Whole`]: a full evaluation
    /// needs none); for an independent block, notes each walker's own terms, on whose change
    /// its proposal is accepted.
    pub(crate) fn gather_state(
        &mut self,
        h: usize,
        settle: Settle,
        whole: bool,
        out: &mut ProposalBuffers,
    ) {
        let (ndim, nd, nc) = (self.ndim, self.nderived, self.cache_len);
        let (active, _) = Self::halves(&self.perm, h);
        for (k, &w) in active.iter().enumerate() {
            let (derived, cache) = (
                &self.s.derived[w * nd..(w + 1) * nd],
                &self.cache[w * nc..(w + 1) * nc],
            );
            match settle {
                Settle::Whole if whole => {
                    let (d, c) = out.carried(k, nd, nc);
                    d.copy_from_slice(derived);
                    c.copy_from_slice(cache);
                }
                Settle::Whole => {}
                Settle::Own {
                    block,
                    own,
                    entries,
                    ..
                } => {
                    let (d, c) = out.carried(k, entries.derived.len(), entries.state.len());
                    for (v, &e) in d.iter_mut().zip(&entries.derived) {
                        *v = derived[e];
                    }
                    for (v, &e) in c.iter_mut().zip(&entries.state) {
                        *v = cache[e];
                    }
                    let x = &self.s.positions[w * ndim..(w + 1) * ndim];
                    self.old_terms[k] = own.block_terms(block, x, c);
                }
            }
        }
    }

    /// Accepts or rejects the evaluated proposals of half `h` (`out` and `evals`: this
    /// ensemble's blocks of [`Work`]): on the change of the log-density, or for a move of an
    /// independent block, on the change of the block's own terms (see [`Settle`]).
    ///
    /// # Errors
    /// [`Fatal`] naming the first walker whose evaluation failed fatally, or whose exact
    /// draw the log-density refuses.
    pub fn accept(
        &mut self,
        h: usize,
        out: &mut ProposalBuffers,
        evals: &[Eval],
        settle: Settle,
    ) -> Result<(), Fatal> {
        let ndim = self.ndim;
        let kind = self.kind;
        // Exact draws and slice updates are accepted as they are.
        let exact = kind != HalfStep::Moves;
        let (active, _) = Self::halves(&self.perm, h);
        self.s.evaluations += match kind {
            HalfStep::Slice { evaluations } => evaluations,
            _ => active.len() as u64,
        };
        if let Some(k) = evals.iter().position(|e| matches!(e, Eval::Fatal(_))) {
            let message = match &evals[k] {
                Eval::Fatal(m) => m.clone(),
                _ => String::new(),
            };
            return Err(Fatal {
                walker: active[k],
                position: out.point(k, active[k]).to_vec(),
                message,
            });
        }
        // An exact draw lies where the conditional density is finite: the density must be too.
        // (A slice update ends on a finite point by construction.)
        if let Some(k) = evals
            .iter()
            .position(|e| exact && matches!(e, Eval::Rejected(_)))
        {
            return Err(Fatal {
                walker: active[k],
                position: out.point(k, active[k]).to_vec(),
                message: format!(
                    "the log-density refuses ({:?}) a point its conditional density allows",
                    evals[k]
                ),
            });
        }
        for (k, eval) in evals.iter().enumerate().take(active.len()) {
            match *eval {
                Eval::Finite(lp) => {
                    let w = Self::halves(&self.perm, h).0[k];
                    if exact || self.accepts(k, w, lp, settle) {
                        self.settle(w, k, out, lp, settle);
                        // Acceptance counts the moves' proposals, not the exact draws or the
                        // slice updates.
                        if !exact {
                            self.s.accepted[w] += 1;
                        }
                    }
                }
                Eval::Rejected(reason) => match self.s.rejections.get_mut(reason) {
                    Some(c) => *c += 1,
                    None => {
                        self.s.rejections.insert(reason.to_string(), 1);
                    }
                },
                Eval::Fatal(_) => {}
            }
        }
        // A proposal made in place is put back to its walker's point, moved or not.
        if let (true, Settle::Own { coords, .. }) = (out.in_place, settle) {
            let (active, _) = Self::halves(&self.perm, h);
            for &w in active {
                let (x, m) = (
                    &self.s.positions[w * ndim..(w + 1) * ndim],
                    &mut out.mirror[w * ndim..(w + 1) * ndim],
                );
                coords.iter().for_each(|&i| m[i] = x[i]);
            }
        }
        Ok(())
    }

    /// Metropolis–Hastings for proposal `k` evaluated at `value`: accept when
    /// ln u < ln f + Δ, i.e. ln(u/f) < Δ, Δ the change of the log-density (or of an
    /// independent block's own terms, which the other independent blocks' updates leave
    /// alone); an uphill move with u < f needs no logarithm at all.
    fn accepts(&self, k: usize, w: usize, value: f64, settle: Settle) -> bool {
        let delta = match settle {
            Settle::Whole => value - self.s.log_density[w],
            Settle::Own { .. } => value - self.old_terms[k],
        };
        let f = self.factor[k];
        if f.is_normal() {
            // ln q ≤ q − 1 and ln q ≥ 1 − 1/q decide most cases without the logarithm.
            let q = self.accept_u[k] / f;
            if q - 1.0 < delta {
                true
            } else if 1.0 - 1.0 / q >= delta {
                false
            } else {
                q.ln() < delta
            }
        } else {
            self.accept_u[k].ln() < self.log_factor[k] + delta
        }
    }

    /// Moves walker `w` to its proposal `k`: its point, and what it carried of the walker's
    /// state (with the log-density `value` when that is the whole of it).
    fn settle(&mut self, w: usize, k: usize, out: &ProposalBuffers, value: f64, settle: Settle) {
        let (ndim, nd, nc) = (self.ndim, self.nderived, self.cache_len);
        let (ds, ss) = (out.derived_stride, out.state_stride);
        let (x, y) = (
            &mut self.s.positions[w * ndim..(w + 1) * ndim],
            out.point(k, w),
        );
        match settle {
            // Element loops: `copy_from_slice` of a few values is a libc call.
            Settle::Whole => x.iter_mut().zip(y).for_each(|(p, &v)| *p = v),
            Settle::Own { coords, .. } => coords.iter().for_each(|&i| x[i] = y[i]),
        }
        match settle {
            Settle::Whole => {
                for (d, &y) in self.s.derived[w * nd..(w + 1) * nd]
                    .iter_mut()
                    .zip(&out.derived[k * ds..k * ds + nd])
                {
                    *d = y;
                }
                if nc > 0 {
                    self.cache[w * nc..(w + 1) * nc]
                        .copy_from_slice(&out.cache[k * ss..k * ss + nc]);
                }
                self.s.log_density[w] = value;
            }
            Settle::Own { entries, .. } => {
                let derived = &mut self.s.derived[w * nd..(w + 1) * nd];
                for (&e, &y) in entries.derived.iter().zip(&out.derived[k * ds..]) {
                    derived[e] = y;
                }
                let cache = &mut self.cache[w * nc..(w + 1) * nc];
                for (&e, &y) in entries.state.iter().zip(&out.cache[k * ss..]) {
                    cache[e] = y;
                }
            }
        }
    }
}
