//! One ensemble: its walkers, random streams, counters and preallocated work buffers, and the
//! two serial halves of the red-blue update of one step (drawing the proposals, accepting
//! them). The evaluation in between belongs to the caller, which evaluates the proposals of
//! all ensembles in one loop (see [`Work`]). A half-step of the slice move, whose walkers
//! each need their own number of evaluations, is instead one [`SliceTask`] per walker that
//! draws, evaluates and settles on its point by itself; the caller runs the tasks.
//!
//! A blocked update carries the walker's state into its proposals and back: all of it for a
//! block that others depend on, only the block's own entries for an independent block
//! (`work`), so that an independent block's update costs the same however many blocks there
//! are.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::moves::{ActiveHalf, BlockView, CarryTuning, Complement, Followers, Move, ProposalMove};
use super::slice::{update_coordinate, SliceError};
use crate::density::{
    BlockLinks, BlockedDensity, CarryFollowers, ExactConditional, IndependentBlocks, OwnEntries,
    SplitByPart,
};

mod slice_tasks;
mod work;

pub(crate) use slice_tasks::{SliceContext, SliceTask};
pub(crate) use work::{ProposalBuffers, Settle, Work};

/// Stream id of the ensemble-level generator (split, move choice) of ensemble `e`.
fn ensemble_stream(e: usize) -> u64 {
    (e as u64) << 32
}

/// Stream id of walker `w` of ensemble `e`.
fn walker_stream(e: usize, w: usize) -> u64 {
    ((e as u64) << 32) | (w as u64 + 1)
}

/// A stream of the generator seeded with `seed`.
pub(crate) fn stream_rng(seed: u64, stream: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(stream);
    rng
}

/// Stream id of the update of the independent block keyed `key` (its first coordinate) in
/// ensemble `e`: `slot` 0 for the split and move choice, w + 1 for walker w. The top bit keeps
/// these apart from [`ensemble_stream`] and [`walker_stream`].
fn block_stream(e: usize, key: usize, slot: usize) -> u64 {
    debug_assert!(e < 1 << 21 && key < 1 << 21 && slot < 1 << 21);
    1 << 63 | (e as u64) << 42 | (key as u64) << 21 | slot as u64
}

/// Words of a block stream set aside for one step: an update draws far fewer (a stretch move
/// three numbers per walker, a slice update a few dozen).
const BLOCK_STREAM_WORDS_PER_STEP: u128 = 1 << 36;

/// The generator of `slot` of the update of the independent block keyed `key` in ensemble
/// `e` at step `step`: a function of these alone, so that the update draws the same numbers
/// whenever, and wherever, it runs.
fn block_rng(seed: u64, e: usize, key: usize, slot: usize, step: u64) -> ChaCha8Rng {
    let mut rng = stream_rng(seed, block_stream(e, key, slot));
    rng.set_word_pos(u128::from(step) * BLOCK_STREAM_WORDS_PER_STEP);
    rng
}

/// An ensemble's generators (its own, or those of one block update, see
/// [`Ensemble::swap_streams`]).
pub(crate) struct Streams {
    ensemble: ChaCha8Rng,
    walkers: Vec<ChaCha8Rng>,
}

impl Streams {
    /// Room for the generators of block updates (none yet: see [`rekey`](Self::rekey)).
    pub fn new() -> Self {
        Self {
            ensemble: stream_rng(0, 0),
            walkers: Vec::new(),
        }
    }

    /// Makes these the generators of the update of the independent block keyed `key` (its
    /// first coordinate) in ensemble `e` of `walkers` walkers at step `step`, in the same
    /// buffers.
    pub(crate) fn rekey(&mut self, seed: u64, e: usize, key: usize, walkers: usize, step: u64) {
        self.ensemble = block_rng(seed, e, key, 0, step);
        self.walkers.clear();
        self.walkers
            .extend((0..walkers).map(|w| block_rng(seed, e, key, w + 1, step)));
    }
}

/// The coordinates one blocked update moves, its links (empty unless the updates are
/// hierarchical) and how it is updated: independence proposals are conditional on the
/// walker's `given` coordinates, and every move carries the `followers` along (evaluated with
/// the block, see
/// [`log_density_after_block`](crate::density::BlockedDensity::log_density_after_block)).
pub(crate) struct UpdateBlock<'a> {
    /// The density the block belongs to.
    pub density: &'a dyn BlockedDensity,
    pub coords: Vec<usize>,
    pub links: BlockLinks,
    pub kind: BlockKind<'a>,
    /// An exact block whose carried move is dropped after the tuning steps if it moved the
    /// block far less than the exact draw did (see `EnsembleSampler::keeps_carried_move`).
    pub carry_measured: bool,
    /// The followers are carried by a regression tuned on the draws of every ensemble and then
    /// frozen ([`CarryTuning`]), not by one fitted to the complement.
    pub tuned_carry: bool,
    /// The evaluation of a move of the block may be split by independent block, when other
    /// processes evaluate shares of it.
    pub split: Option<&'a dyn SplitByPart>,
}

impl std::fmt::Debug for UpdateBlock<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let kind = match self.kind {
            BlockKind::Moves { .. } => "moves",
            BlockKind::Exact { .. } => "exact",
            BlockKind::Independent { .. } => "independent",
        };
        f.debug_struct("UpdateBlock")
            .field("coords", &self.coords)
            .field("links", &self.links)
            .field("kind", &kind)
            .finish_non_exhaustive()
    }
}

/// How a blocked update moves its block (see [`BlockUpdate`](crate::density::BlockUpdate)).
pub(crate) enum BlockKind<'a> {
    /// By the moves, its followers carried by the density's map when it has one (under
    /// hierarchical updates), else by the sampler's regression.
    Moves {
        carry: Option<&'a dyn CarryFollowers>,
    },
    /// Drawn exactly from its cheap conditional density by slice sampling (see
    /// [`Ensemble::draw_conditional`]); when the density carries its followers, then also
    /// moved by the moves with them.
    Exact {
        conditional: &'a dyn ExactConditional,
        carry: Option<&'a dyn CarryFollowers>,
    },
    /// Conditionally independent of the other independent blocks: its update draws from
    /// streams keyed by the block, reads and writes only its own `entries` and accepts on the
    /// block's own terms, so that the order of these blocks' updates does not change the
    /// chains.
    Independent {
        own: &'a dyn IndependentBlocks,
        entries: OwnEntries,
    },
}

impl<'a> UpdateBlock<'a> {
    /// Whether the block is drawn exactly.
    pub fn exact(&self) -> bool {
        matches!(self.kind, BlockKind::Exact { .. })
    }

    /// The density's map carrying the block's followers, when the moves use it.
    pub fn carry(&self) -> Option<&'a dyn CarryFollowers> {
        match self.kind {
            BlockKind::Moves { carry } | BlockKind::Exact { carry, .. } => carry,
            BlockKind::Independent { .. } => None,
        }
    }

    /// The block's own terms and entries, when it is independent.
    pub fn own(&self) -> Option<(&'a dyn IndependentBlocks, &OwnEntries)> {
        match &self.kind {
            BlockKind::Independent { own, entries } => Some((*own, entries)),
            _ => None,
        }
    }

    /// Whether the block is independent.
    pub fn independent(&self) -> bool {
        self.own().is_some()
    }
}

/// The density's map carrying the followers of a block (its index), when it has one.
pub(crate) type CarryMap<'c> = (usize, &'c dyn CarryFollowers);

/// Serialisable state of one ensemble.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnsembleState {
    /// Walker positions, `walkers × ndim`, row-major.
    pub positions: Vec<f64>,
    /// Log-density of each walker.
    pub log_density: Vec<f64>,
    /// Derived values, `walkers × nderived`, row-major. Not stored in checkpoints (they were
    /// three quarters of a campaign's): the resume's full evaluation of every walker gives
    /// them again, bit for bit.
    #[serde(default, skip_serializing)]
    pub derived: Vec<f64>,
    /// Generator for the split and the move choice.
    pub ensemble_rng: ChaCha8Rng,
    /// One generator per walker for its proposals and acceptance draws.
    pub walker_rngs: Vec<ChaCha8Rng>,
    /// Accepted proposals per walker.
    pub accepted: Vec<u64>,
    /// Points the density refused, per reason (density errors, NaN, −∞): rejected proposals,
    /// and the points of slice updates that fell outside the support (outside the slice);
    /// Metropolis rejections are not counted here.
    pub rejections: BTreeMap<String, u64>,
    /// Log-density evaluations (proposals, and every point of a slice update) so far.
    pub evaluations: u64,
    /// The slice move's scale μ per update slot (one for joint updates, one per block
    /// otherwise); empty when the moves hold no slice move. Tuned during the first
    /// [`SLICE_ADAPT_STEPS`](super::moves::SLICE_ADAPT_STEPS) steps, then fixed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub slice_scales: Vec<f64>,
    /// Updates of every walker made by the slice move (one per block updated so), which
    /// always move and are left out of the acceptance fraction.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub slice_updates: u64,
    /// Per block, the tuning of the regression that carries its followers (`None` for a
    /// block whose regression is fitted to the complement); empty when no block is tuned.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub carry_fits: Vec<Option<CarryTuning>>,
}

fn is_zero(v: &u64) -> bool {
    *v == 0
}

/// What the current half-step of an ensemble is.
#[derive(Debug, Clone, Copy, PartialEq)]
enum HalfStep {
    /// Proposals of the moves, accepted or rejected by Metropolis–Hastings.
    Moves,
    /// Exact conditional draws, accepted as they are.
    Exact,
    /// Slice updates, accepted as they are, after this many evaluations in all.
    Slice { evaluations: u64 },
}

/// Where a fatal evaluation happened.
#[derive(Debug)]
pub(crate) struct Fatal {
    pub walker: usize,
    pub position: Vec<f64>,
    pub message: String,
}

/// One ensemble with its work buffers.
#[derive(Debug)]
pub(crate) struct Ensemble {
    pub s: EnsembleState,
    /// The density's cache at each walker, `walkers × cache_len` (rebuilt on resume, not
    /// stored: a full evaluation fills it).
    pub cache: Vec<f64>,
    ndim: usize,
    nderived: usize,
    cache_len: usize,
    /// Walker order of the current step: the first half, then the second.
    perm: Vec<usize>,
    /// Proposal density ratio of each proposal of the active half (`z^(ndim−1)` for the
    /// stretch move); when it is not a normal number, `log_factor` holds its logarithm.
    factor: Vec<f64>,
    log_factor: Vec<f64>,
    /// Acceptance uniform of each proposal.
    accept_u: Vec<f64>,
    /// The walkers' coordinates in the current block, `walkers × block dim`.
    sub: Vec<f64>,
    /// The proposals in the current block, `half × block dim`.
    sub_out: Vec<f64>,
    /// An independent block's own terms at each active walker, before its proposal.
    old_terms: Vec<f64>,
    /// What the current half-step is.
    kind: HalfStep,
    /// Expansions and contractions of the slice updates of the current step.
    slice_tally: (u64, u64),
}

impl Ensemble {
    /// Fresh generators for ensemble `e`.
    pub(crate) fn fresh_rngs(seed: u64, e: usize, walkers: usize) -> (ChaCha8Rng, Vec<ChaCha8Rng>) {
        (
            stream_rng(seed, ensemble_stream(e)),
            (0..walkers)
                .map(|w| stream_rng(seed, walker_stream(e, w)))
                .collect(),
        )
    }

    /// An ensemble in `s` whose walkers' density caches are `cache` (`walkers × cache_len`).
    pub fn new(
        s: EnsembleState,
        cache: Vec<f64>,
        ndim: usize,
        nderived: usize,
        cache_len: usize,
    ) -> Self {
        let walkers = s.log_density.len();
        let half = walkers / 2;
        Self {
            s,
            cache,
            ndim,
            nderived,
            cache_len,
            perm: (0..walkers).collect(),
            factor: vec![1.0; half],
            log_factor: vec![0.0; half],
            accept_u: vec![0.0; half],
            sub: Vec::new(),
            sub_out: Vec::new(),
            old_terms: vec![0.0; half],
            kind: HalfStep::Moves,
            slice_tally: (0, 0),
        }
    }

    /// Exchanges the ensemble's generators with `streams`: an update of an independent
    /// block draws from its own streams, and the ensemble's, exchanged back afterwards, are
    /// left where they were.
    pub(crate) fn swap_streams(&mut self, streams: &mut Streams) {
        std::mem::swap(&mut self.s.ensemble_rng, &mut streams.ensemble);
        std::mem::swap(&mut self.s.walker_rngs, &mut streams.walkers);
    }

    /// Starts a step: the random split into halves and the move of this step (its index in
    /// `moves`), both from the ensemble's stream.
    pub(crate) fn start_step(&mut self, moves: &[(Move, f64)]) -> usize {
        let walkers = self.perm.len();
        let half = walkers / 2;
        // Partial Fisher–Yates from the identity: the first half becomes a uniformly random
        // subset (the order within a half does not matter, each walker has its own stream),
        // with `half` draws instead of `walkers − 1`, depending only on the stream.
        self.slice_tally = (0, 0);
        for (i, p) in self.perm.iter_mut().enumerate() {
            *p = i;
        }
        for i in 0..half {
            let j = self.s.ensemble_rng.random_range(i..walkers);
            self.perm.swap(i, j);
        }
        if moves.len() == 1 {
            0
        } else {
            let total: f64 = moves.iter().map(|m| m.1).sum();
            let mut u = self.s.ensemble_rng.random::<f64>() * total;
            let mut chosen = moves.len() - 1;
            for (m, &(_, w)) in moves.iter().enumerate() {
                if u < w {
                    chosen = m;
                    break;
                }
                u -= w;
            }
            chosen
        }
    }

    /// The walkers updated in half `h` (0 or 1) and the complementary half.
    fn halves(perm: &[usize], h: usize) -> (&[usize], &[usize]) {
        let (first, second) = perm.split_at(perm.len() / 2);
        if h == 0 {
            (first, second)
        } else {
            (second, first)
        }
    }

    /// Draws the proposals of half `h` into `out.proposals` (`half × ndim`), each walker from
    /// its own stream: partner or move randomness first, then the acceptance uniform.
    ///
    /// With `block` the move acts in the block's subspace: on the walkers' coordinates in the
    /// block, the others staying where they are (but for the block's followers, carried along
    /// by regression, or by the density's map when the block has one, its log-Jacobian joining
    /// the proposal ratio). The walkers' state goes with the proposals apart
    /// ([`gather_state`](Self::gather_state)).
    pub fn draw(
        &mut self,
        mv: &dyn ProposalMove,
        h: usize,
        block: Option<(usize, &UpdateBlock, Option<CarryMap>)>,
        out: ProposalBuffers,
    ) {
        let followers = match block {
            Some((slot, b, None)) => self.followers(h, slot, b),
            _ => None,
        };
        let (block, carry) = match block {
            Some((_, b, c)) => (Some(b), c),
            None => (None, None),
        };
        let ndim = self.ndim;
        let Self {
            s,
            perm,
            factor,
            log_factor,
            accept_u,
            sub,
            sub_out,
            kind,
            ..
        } = self;
        *kind = HalfStep::Moves;
        let (active, complement) = Self::halves(perm, h);
        // The move sees the walkers' coordinates in the block (all of them when joint), and
        // proposes straight into the proposals when joint, into the block's scratch when not.
        let (moved, dim, proposals): (&[f64], usize, &mut [f64]) = match block {
            None => (&s.positions, ndim, &mut *out.proposals),
            Some(b) => {
                sub.clear();
                for x in s.positions.chunks_exact(ndim) {
                    sub.extend(b.coords.iter().map(|&i| x[i]));
                }
                sub_out.resize(active.len() * b.coords.len(), 0.0);
                (sub, b.coords.len(), &mut sub_out[..])
            }
        };
        let links = block.map(|b| &b.links);
        let given = links.map_or(&[][..], |l| &l.given[..]);
        let _ = mv.propose(ActiveHalf {
            complement: Complement {
                rows: moved,
                dim,
                walkers: complement,
            },
            active,
            positions: &s.positions,
            ndim,
            block: block.map(|b| BlockView {
                coords: &b.coords,
                given,
            }),
            rngs: &mut s.walker_rngs,
            proposals,
            factor,
            log_factor,
        });
        for (k, &w) in active.iter().enumerate() {
            let rng = &mut s.walker_rngs[w];
            let x = &s.positions[w * ndim..(w + 1) * ndim];
            // After the move's draws, from the same stream.
            accept_u[k] = rng.random();
            if out.in_place {
                // An independent block (no followers): its coordinates written into the
                // walker's row of the mirror, which holds the walker's point elsewhere.
                let b = block.expect("only a block's proposals are made in place");
                debug_assert!(followers.is_none() && carry.is_none());
                out.rows[k] = out.row_base + w;
                let m = &mut out.mirror[w * ndim..(w + 1) * ndim];
                for (&i, &y) in b.coords.iter().zip(&sub_out[k * dim..(k + 1) * dim]) {
                    m[i] = y;
                }
                continue;
            }
            let o = &mut out.proposals[k * ndim..(k + 1) * ndim];
            if let Some(b) = block {
                o.copy_from_slice(x);
                for (&i, &y) in b.coords.iter().zip(&sub_out[k * dim..(k + 1) * dim]) {
                    o[i] = y;
                }
                if let Some(f) = &followers {
                    f.carry(x, &b.coords, &b.links.followers, o);
                }
                if let Some((b, map)) = carry {
                    // The followers' Jacobian joins the proposal's density ratio.
                    let ln_jacobian = map.carry_followers(b, x, o);
                    let ln_factor = if factor[k].is_normal() {
                        factor[k].ln()
                    } else {
                        log_factor[k]
                    };
                    log_factor[k] = ln_factor + ln_jacobian;
                    factor[k] = log_factor[k].exp();
                }
            }
        }
    }

    /// Draws the walkers of half `h` exactly from the conditional density of `block` given
    /// their other coordinates (`ln_conditional`, cheap: no likelihood), each coordinate of
    /// the block in turn by one slice update from the walker's own stream. The proposals are
    /// accepted as they are (a Gibbs step); their evaluation only brings the stored
    /// log-density, derived values and cache up to date.
    ///
    /// The initial slice width of a coordinate is its spread over the complementary half,
    /// which the update of the active half does not change: each walker's update leaves its
    /// conditional invariant, whatever the width (see [`slice`](super::slice)).
    ///
    /// # Errors
    /// [`Fatal`] naming the walker whose conditional density is not finite where its
    /// log-density is, or whose slice collapsed.
    pub(crate) fn draw_conditional(
        &mut self,
        h: usize,
        block: &UpdateBlock,
        ln_conditional: &dyn Fn(&[f64]) -> f64,
        out: ProposalBuffers,
    ) -> Result<(), Fatal> {
        let ndim = self.ndim;
        let Self { s, perm, kind, .. } = self;
        *kind = HalfStep::Exact;
        let (active, complement) = Self::halves(perm, h);
        let widths: Vec<f64> = block
            .coords
            .iter()
            .map(|&i| {
                let (n, mut sum, mut sq) = (complement.len() as f64, 0.0, 0.0);
                for &w in complement {
                    let v = s.positions[w * ndim + i];
                    sum += v;
                    sq += v * v;
                }
                let sd = (sq / n - (sum / n).powi(2)).max(0.0).sqrt();
                // A collapsed complement still needs a positive width.
                if sd.is_normal() {
                    sd
                } else {
                    1e-3
                }
            })
            .collect();
        let mut ln_f = |x: &[f64]| ln_conditional(x);
        for (k, &w) in active.iter().enumerate() {
            let o = &mut out.proposals[k * ndim..(k + 1) * ndim];
            o.copy_from_slice(&s.positions[w * ndim..(w + 1) * ndim]);
            let rng = &mut s.walker_rngs[w];
            let mut f = ln_f(o);
            for (&i, &width) in block.coords.iter().zip(&widths) {
                f = update_coordinate(o, i, width, f, &mut ln_f, rng).map_err(|err| Fatal {
                    walker: w,
                    position: s.positions[w * ndim..(w + 1) * ndim].to_vec(),
                    message: match err {
                        SliceError::NotFinite(v) => format!(
                            "the conditional density of block {:?} is {v} at a walker where the \
                             log-density is finite",
                            block.coords
                        ),
                        SliceError::Shrunk => format!(
                            "the slice of coordinate {i} collapsed onto the walker: its \
                             conditional density is inconsistent"
                        ),
                    },
                })?;
            }
        }
        Ok(())
    }

    /// The regression carrying the followers of `block` (update slot `slot`) in half `h`,
    /// unless the density carries them itself or there are none: the tuned one once frozen,
    /// else the one fitted to the complement.
    fn followers(&self, h: usize, slot: usize, block: &UpdateBlock) -> Option<Followers> {
        if block.links.followers.is_empty() || block.carry().is_some() {
            return None;
        }
        let frozen = self
            .s
            .carry_fits
            .get(slot)
            .and_then(Option::as_ref)
            .and_then(Followers::frozen);
        frozen.or_else(|| {
            let (_, complement) = Self::halves(&self.perm, h);
            Followers::new(
                &self.s.positions,
                self.ndim,
                complement,
                &block.coords,
                &block.links.followers,
            )
        })
    }
}
