//! The slice move's half-steps: each active walker's whole slice update (direction, stepping
//! out, shrinkage) is one task that evaluates as often as it needs, reading only the fixed
//! complement and its own walker and drawing only from the walker's own stream.

use rand_chacha::ChaCha8Rng;

use super::super::moves::{
    DirectionDraw, Followers, OwnedComplement, SliceDirection, SLICE_MAX_STEPS_OUT,
};
use super::super::slice::{update_along_line, LineError};
use super::{Ensemble, EnsembleState, Fatal, HalfStep, ProposalBuffers, UpdateBlock};
use crate::density::{sort, Eval, LogDensityError};

/// One evaluation of a slice update's point: the density behind the half-step's kind of
/// evaluation, from the point, writing its derived values and state.
pub(crate) type Evaluate<'e> =
    dyn Fn(&[f64], &mut [f64], &mut [f64]) -> Result<f64, LogDensityError> + Sync + 'e;

/// What the slice move of one ensemble's half-step works with, built once from the
/// complement and read by every walker of the active half.
#[derive(Debug)]
pub(crate) struct SliceContext {
    /// The coordinates the move acts on (the block's, or all).
    coords: Vec<usize>,
    /// The complement at those coordinates, and the directions fitted to it.
    complement: OwnedComplement,
    directions: Box<dyn DirectionDraw>,
    /// The regression that carries the block's followers, under hierarchical updates when the
    /// density does not carry them itself.
    followers: Option<Followers>,
    mu: f64,
}

/// One walker's slice update in a half-step: everything it reads, its own stream, and its
/// buffers in [`Work`], so that the walkers of every ensemble can run in parallel with
/// results that do not depend on the order.
pub(crate) struct SliceTask<'a> {
    walker: usize,
    /// The walker's position and log-density, and what its proposal carries of its state.
    x: &'a [f64],
    lp: f64,
    derived0: Vec<f64>,
    cache0: Vec<f64>,
    context: &'a SliceContext,
    rng: &'a mut ChaCha8Rng,
    /// Where the points are evaluated: the proposal's own buffer, or the walker's row of the
    /// mirror for an independent block, which holds the walker's point outside the block.
    out: &'a mut [f64],
    in_place: bool,
    derived: &'a mut [f64],
    cache: &'a mut [f64],
    eval: &'a mut Eval,
}

/// What one walker's slice update did.
#[derive(Debug, Default)]
pub(crate) struct SliceOutcome {
    expansions: u64,
    contractions: u64,
    evaluations: u64,
    /// The reason of every point the density refused (outside the slice, like −∞).
    rejections: Vec<&'static str>,
}

impl SliceOutcome {
    /// Evaluations of the density the update made.
    pub fn evaluations(&self) -> u64 {
        self.evaluations
    }
}

impl SliceTask<'_> {
    /// Slices the walker along its direction: `block` is the block updated (with its index),
    /// `None` for joint updates. The last evaluation is the new point, left in the task's
    /// buffers of [`Work`].
    ///
    /// The target along the line `y(t)` is `π(y(t))`, times, when the density carries the
    /// block's followers along its own map, that map's Jacobian from the walker to `y(t)`:
    /// at fixed standardised followers `z` the density of the block is `π(x_b, φ(x_b, z))
    /// |∂φ/∂z|`, and its ratio to the start's is the carry's Jacobian (docs/model.md §5).
    ///
    /// # Errors
    /// [`Fatal`] when the density fails fatally, or the slice collapses onto the walker.
    pub fn run(
        &mut self,
        evaluate: &Evaluate,
        block: Option<(usize, &UpdateBlock)>,
    ) -> Result<SliceOutcome, Fatal> {
        let context = self.context;
        let coords = &context.coords[..];
        let mut eta = vec![0.0; coords.len()];
        let complement = context.complement.view();
        (context.directions).draw(complement, context.mu, self.rng, &mut eta);
        let followers = self.context.followers.as_ref();
        let mut rejections = Vec::new();
        let (x, derived0, cache0) = (self.x, &self.derived0[..], &self.cache0[..]);
        // An independent block is sliced along its own terms (see `accept`), which its update
        // returns.
        let own = block.and_then(|(b, ub)| ub.own().map(|(own, _)| (b, own)));
        let (y, derived, cache, eval) = (
            &mut *self.out,
            &mut *self.derived,
            &mut *self.cache,
            &mut *self.eval,
        );
        let in_place = self.in_place;
        let mut ln_f = |t: f64| -> Result<f64, String> {
            if !in_place {
                y.copy_from_slice(x);
            }
            for (&i, &e) in coords.iter().zip(&eta) {
                y[i] = x[i] + t * e;
            }
            let mut ln_jacobian = 0.0;
            if let Some((b, ub)) = block {
                if let Some(f) = followers {
                    f.carry(x, &ub.coords, &ub.links.followers, y);
                }
                if let Some(map) = ub.carry() {
                    ln_jacobian = map.carry_followers(b, x, y);
                }
            }
            // Every point is evaluated from the walker's own state: a refused point may have
            // left the buffers half updated.
            derived.copy_from_slice(derived0);
            cache.copy_from_slice(cache0);
            *eval = sort(evaluate(y, derived, cache));
            match *eval {
                Eval::Finite(lp) => Ok(lp + ln_jacobian),
                Eval::Rejected(reason) => {
                    rejections.push(reason);
                    Ok(f64::NEG_INFINITY)
                }
                Eval::Fatal(ref message) => Err(message.clone()),
            }
        };
        let start = match own {
            Some((b, own)) => own.block_terms(b, x, cache0),
            None => self.lp,
        };
        match update_along_line(start, SLICE_MAX_STEPS_OUT, &mut ln_f, self.rng) {
            Ok(u) => Ok(SliceOutcome {
                expansions: u.expansions,
                contractions: u.contractions,
                evaluations: u.evaluations,
                rejections,
            }),
            Err(LineError::Eval(message)) => Err(Fatal {
                walker: self.walker,
                position: self.out.to_vec(),
                message,
            }),
            Err(LineError::Shrunk) => Err(Fatal {
                walker: self.walker,
                position: self.x.to_vec(),
                message: "the slice collapsed onto the walker: the density is not finite \
                          anywhere near a point where it was"
                    .into(),
            }),
        }
    }
}

impl Ensemble {
    /// What the slice move along `directions` of half `h` works with in update slot `slot`:
    /// the directions fitted to the complement, the followers' regression (under hierarchical
    /// updates, when the density does not carry them), and the ensemble's μ of the slot.
    pub(crate) fn slice_context(
        &self,
        h: usize,
        directions: &dyn SliceDirection,
        slot: usize,
        block: Option<&UpdateBlock>,
    ) -> SliceContext {
        let ndim = self.ndim;
        let (_, complement) = Self::halves(&self.perm, h);
        let all: Vec<usize>;
        let coords = match block {
            Some(b) => &b.coords[..],
            None => {
                all = (0..ndim).collect();
                &all[..]
            }
        };
        let complement = OwnedComplement::new(&self.s.positions, ndim, complement, coords);
        SliceContext {
            coords: coords.to_vec(),
            directions: directions.fit(complement.view()),
            complement,
            followers: block.and_then(|b| self.followers(h, slot, b)),
            mu: self.s.slice_scales[slot],
        }
    }

    /// The slice updates of the walkers of half `h`, one task each in walker order, writing
    /// into `out` and `evals` (this ensemble's blocks of [`Work`]).
    /// Each proposal carries `carried` derived values and entries of state, gathered in `out`
    /// ([`gather_state`](Self::gather_state)).
    pub(crate) fn slice_tasks<'a>(
        &'a mut self,
        h: usize,
        context: &'a SliceContext,
        out: ProposalBuffers<'a>,
        evals: &'a mut [Eval],
        carried: (usize, usize),
    ) -> Vec<SliceTask<'a>> {
        let ndim = self.ndim;
        let (nd, nc) = carried;
        let (sd, sc) = (out.derived_stride, out.state_stride);
        self.kind = HalfStep::Slice { evaluations: 0 };
        let Self { s, perm, .. } = self;
        let (active, _) = Self::halves(perm, h);
        let EnsembleState {
            positions,
            log_density,
            walker_rngs,
            ..
        } = s;
        let positions = &positions[..];
        // Each active walker's stream, taken out of the ensemble's (the halves are disjoint).
        let mut rngs: Vec<Option<&mut ChaCha8Rng>> = walker_rngs.iter_mut().map(Some).collect();
        let ProposalBuffers {
            proposals,
            derived,
            cache,
            in_place,
            mirror,
            rows: mirror_rows,
            row_base,
            ..
        } = out;
        // Each active walker's row of the mirror, likewise, when the proposals are made there.
        let mut rows: Vec<Option<&mut [f64]>> = if in_place {
            for (r, &w) in mirror_rows.iter_mut().zip(active) {
                *r = row_base + w;
            }
            mirror.chunks_exact_mut(ndim).map(Some).collect()
        } else {
            Vec::new()
        };
        active
            .iter()
            .zip(proposals.chunks_exact_mut(ndim))
            .zip(derived.chunks_exact_mut(sd))
            .zip(cache.chunks_exact_mut(sc))
            .zip(evals.iter_mut())
            .map(|((((&w, o), d), c), e)| SliceTask {
                walker: w,
                x: &positions[w * ndim..(w + 1) * ndim],
                lp: log_density[w],
                derived0: d[..nd].to_vec(),
                cache0: c[..nc].to_vec(),
                context,
                rng: rngs[w].take().expect("each active walker once"),
                out: match rows.get_mut(w) {
                    Some(row) => row.take().expect("each active walker once"),
                    None => o,
                },
                in_place,
                derived: &mut d[..nd],
                cache: &mut c[..nc],
                eval: e,
            })
            .collect()
    }

    /// Takes in the outcomes of this ensemble's slice tasks (in walker order): evaluations,
    /// refused points and the tally of expansions and contractions; the new points themselves
    /// are in [`Work`], for [`accept`](Self::accept).
    ///
    /// # Errors
    /// The first walker's [`Fatal`].
    pub(crate) fn finish_slice(
        &mut self,
        outcomes: impl IntoIterator<Item = Result<SliceOutcome, Fatal>>,
    ) -> Result<(), Fatal> {
        let mut evaluations = 0;
        for outcome in outcomes {
            let o = outcome?;
            evaluations += o.evaluations;
            self.slice_tally.0 += o.expansions;
            self.slice_tally.1 += o.contractions;
            for reason in o.rejections {
                *self.s.rejections.entry(reason.to_string()).or_insert(0) += 1;
            }
        }
        self.kind = HalfStep::Slice { evaluations };
        Ok(())
    }

    /// Ends a step's slice update of slot `slot` (both halves done): counts it, and while
    /// `adapt`, tunes the slot's μ by zeus's rule `μ ← 2 μ N_e / (N_e + N_c)` from the
    /// expansions and contractions of every walker (N_e at least 1, as zeus, so that μ
    /// cannot collapse to 0 when no slice needed stepping out).
    pub(crate) fn finish_slice_update(&mut self, slot: usize, adapt: bool) {
        self.s.slice_updates += 1;
        if adapt {
            let (e, c) = self.slice_tally;
            let e = e.max(1) as f64;
            self.s.slice_scales[slot] *= 2.0 * e / (e + c as f64);
        }
    }
}
