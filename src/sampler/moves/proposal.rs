//! The Metropolis–Hastings moves' contract: each proposes a new position for every walker of
//! the active half from the complementary half, and says how the proposal changes the
//! acceptance ratio; the sampler draws the acceptance uniforms, evaluates and accepts.

use std::fmt;

use super::{Complement, Correction, MoveSpec, WalkerRng};

/// A Metropolis–Hastings move of the ensemble sampler (emcee's `RedBlueMove`): in every
/// half-step it proposes a new position for each walker of the active half, from the
/// positions of the complementary half only, and the sampler accepts or rejects each with
/// probability `min(1, correction · π(y)/π(x))`.
///
/// The proposal of a walker may depend on the complement (which stays fixed meanwhile) and
/// on the walker itself, and must draw its randomness from the walker's own stream, which
/// keeps the chains the same on any number of threads. Mix moves with weights in
/// [`SamplerConfig::with_moves`](crate::sampler::SamplerConfig::with_moves) through
/// [`Move::proposal`](super::Move::proposal); the module's page shows a move written outside
/// the crate.
pub trait ProposalMove: fmt::Debug + Send + Sync {
    /// How the move is recorded with the chains (its kind and every parameter that changes
    /// its proposals): a run is resumed only with moves of the same specs.
    fn spec(&self) -> MoveSpec;

    /// The fewest walkers the complement must hold for this move to propose in `dim`
    /// dimensions (checked with `dim = 0` when the sampler is configured, then with the
    /// density's dimension, or its largest block's).
    fn min_complement(&self, dim: usize) -> usize;

    /// Proposes a position for every walker of `half`, by
    /// [`ActiveHalf::propose_each`], whose receipt it returns.
    fn propose(&self, half: ActiveHalf<'_>) -> Proposed;
}

/// The walkers a half-step moves and the complement they propose from; consumed by
/// [`propose_each`](Self::propose_each), which gives every walker its proposal.
#[derive(Debug)]
pub struct ActiveHalf<'a> {
    pub(crate) complement: Complement<'a>,
    /// The walkers to move: rows of the complement's `rows`, and of `positions`.
    pub(crate) active: &'a [usize],
    /// Every walker's coordinates, all `ndim` of them per row.
    pub(crate) positions: &'a [f64],
    pub(crate) ndim: usize,
    /// The block updated, when the updates are blocked.
    pub(crate) block: Option<BlockView<'a>>,
    /// Every walker's stream.
    pub(crate) rngs: &'a mut [WalkerRng],
    /// The proposals, `active × dim`.
    pub(crate) proposals: &'a mut [f64],
    /// Each proposal's correction, split as [`Correction`] keeps it.
    pub(crate) factor: &'a mut [f64],
    pub(crate) log_factor: &'a mut [f64],
}

/// The block of coordinates a blocked half-step moves (see
/// [`Updates`](crate::sampler::Updates)).
#[derive(Debug, Clone, Copy)]
pub(crate) struct BlockView<'a> {
    /// The coordinates moved.
    pub coords: &'a [usize],
    /// The coordinates the block's conditional depends on besides its own (empty unless the
    /// updates are hierarchical).
    pub given: &'a [usize],
}

/// One walker of the active half as a move sees it.
#[derive(Debug, Clone, Copy)]
pub struct Walker<'a> {
    /// Its coordinates the move acts on (a block's, or all): what the proposal replaces.
    pub x: &'a [f64],
    /// All of its coordinates.
    pub position: &'a [f64],
}

/// The receipt of [`ActiveHalf::propose_each`]: every walker of the half has its proposal.
#[derive(Debug)]
#[must_use]
pub struct Proposed(());

impl<'a> ActiveHalf<'a> {
    /// The complementary half, fixed while this one moves.
    pub fn complement(&self) -> Complement<'a> {
        self.complement
    }

    /// The number of coordinates a proposal moves.
    pub fn dim(&self) -> usize {
        self.complement.dim
    }

    /// The number of walkers to move.
    pub fn len(&self) -> usize {
        self.active.len()
    }

    /// Whether there is no walker to move (never in a sampler).
    pub fn is_empty(&self) -> bool {
        self.active.is_empty()
    }

    /// The block moved and every walker's coordinates, all `ndim` of them, when the updates
    /// are blocked.
    pub(crate) fn block(&self) -> Option<(BlockView<'a>, &'a [f64], usize)> {
        self.block.map(|b| (b, self.positions, self.ndim))
    }

    /// Calls `propose(walker, rng, out)` for every walker of the half in turn, with the
    /// walker's own stream `rng`; it writes the proposal into `out` (`dim` values) and
    /// returns its [`Correction`].
    #[inline]
    pub fn propose_each(
        self,
        mut propose: impl FnMut(Walker<'_>, &mut WalkerRng, &mut [f64]) -> Correction,
    ) -> Proposed {
        let (dim, ndim) = (self.complement.dim, self.ndim);
        let rows = self.complement.rows;
        for (k, &w) in self.active.iter().enumerate() {
            let walker = Walker {
                x: &rows[w * dim..(w + 1) * dim],
                position: &self.positions[w * ndim..(w + 1) * ndim],
            };
            let out = &mut self.proposals[k * dim..(k + 1) * dim];
            let c = propose(walker, &mut self.rngs[w], out);
            (self.factor[k], self.log_factor[k]) = (c.factor, c.log_factor);
        }
        Proposed(())
    }

    /// Every walker of the half proposes where it is: the step of a move that cannot propose
    /// (its fit to the complement failed, the complement lying in a subspace) changes nothing
    /// but still consumes each walker's acceptance uniform, so the streams stay in step.
    pub fn stay(self) -> Proposed {
        self.propose_each(|walker, _, out| {
            out.copy_from_slice(walker.x);
            Correction::SYMMETRIC
        })
    }
}

/// Test support: the proposal of `mv` for one walker at `x`, with the walkers `complement`
/// (`dim` per row) as the complement.
#[cfg(test)]
pub(crate) fn propose_one(
    mv: &dyn ProposalMove,
    x: &[f64],
    complement: &[f64],
    rng: &mut WalkerRng,
) -> (Vec<f64>, Correction) {
    let dim = x.len();
    let mut rows = complement.to_vec();
    rows.extend_from_slice(x);
    let n = complement.len() / dim;
    let walkers: Vec<usize> = (0..n).collect();
    // Every walker's stream, the proposing walker's last.
    let mut rngs = vec![rng.clone(); n + 1];
    let mut out = vec![0.0; dim];
    let (mut factor, mut log_factor) = ([0.0], [0.0]);
    let _ = mv.propose(ActiveHalf {
        complement: Complement {
            rows: &rows,
            dim,
            walkers: &walkers,
        },
        active: &[n],
        positions: &rows,
        ndim: dim,
        block: None,
        rngs: &mut rngs,
        proposals: &mut out,
        factor: &mut factor,
        log_factor: &mut log_factor,
    });
    *rng = rngs.pop().expect("one stream");
    (
        out,
        Correction {
            factor: factor[0],
            log_factor: log_factor[0],
        },
    )
}
