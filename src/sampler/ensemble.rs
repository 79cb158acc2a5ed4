//! One ensemble: its walkers, random streams, counters and preallocated work buffers, and the
//! two serial halves of the red-blue update of one step (drawing the proposals, accepting
//! them). The evaluation in between belongs to the caller, which evaluates the proposals of
//! all ensembles in one loop (see [`Work`]). A half-step of the slice move, whose walkers
//! each need their own number of evaluations, is instead one [`SliceTask`] per walker that
//! draws, evaluates and settles on its point by itself; the caller runs the tasks.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::moves::{
    ActiveHalf, BlockView, CarryTuning, Complement, DirectionDraw, Followers, Move,
    OwnedComplement, ProposalMove, SliceDirection, SLICE_MAX_STEPS_OUT,
};
use super::slice::{update_along_line, update_coordinate, LineError, SliceError};
use crate::density::{sort, BlockLinks, Eval, LogDensity};

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

/// The terms of the log-density of an independent block at a point with its cache (see
/// [`block_log_density`](crate::density::LogDensity::block_log_density)).
pub(crate) type BlockTerms<'a> = dyn Fn(&[f64], &[f64]) -> f64 + 'a;

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
    pub fn rekey(&mut self, seed: u64, e: usize, key: usize, walkers: usize, step: u64) {
        self.ensemble = block_rng(seed, e, key, 0, step);
        self.walkers.clear();
        self.walkers
            .extend((0..walkers).map(|w| block_rng(seed, e, key, w + 1, step)));
    }
}

/// The coordinates one blocked update moves, and its links (empty unless the updates are
/// hierarchical): independence proposals are conditional on the walker's `given`
/// coordinates, and every move carries the `followers` along (evaluated with the block, see
/// [`log_density_block`](crate::density::LogDensity::log_density_block)). A `conditional`
/// block is drawn exactly from its cheap conditional density by slice sampling (see
/// [`Ensemble::draw_conditional`]), not by the moves.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct UpdateBlock {
    pub coords: Vec<usize>,
    pub links: BlockLinks,
    pub conditional: bool,
    /// The density moves the followers along itself (its non-centred map), instead of the
    /// sampler's regression.
    pub density_carries: bool,
    /// A conditional block whose carried move is dropped after the tuning steps if it moved
    /// the block far less than the exact draw did (see `EnsembleSampler::keeps_carried_move`).
    pub carry_measured: bool,
    /// The followers are carried by a regression tuned on the ensemble's own draws and then
    /// frozen ([`CarryTuning`]), not by one fitted to the complement.
    pub tuned_carry: bool,
    /// Conditionally independent of the other independent blocks
    /// ([`independent_blocks`](crate::density::LogDensity::independent_blocks)): its update
    /// draws from streams keyed by the block and accepts on the block's own terms, so that
    /// the order of these blocks' updates does not change the chains.
    pub independent: bool,
}

/// The density's map carrying a block's followers along (see
/// [`carry_followers`](crate::density::LogDensity::carry_followers)): from the current point
/// to the proposal, returning the log-Jacobian.
pub(crate) type CarryMap<'c> = &'c dyn Fn(&[f64], &mut [f64]) -> f64;

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
    /// The walker's position, log-density, derived values and cache.
    x: &'a [f64],
    lp: f64,
    derived0: &'a [f64],
    cache0: &'a [f64],
    context: &'a SliceContext,
    rng: &'a mut ChaCha8Rng,
    out: &'a mut [f64],
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
    pub fn run<D: LogDensity + ?Sized>(
        &mut self,
        density: &D,
        block: Option<(usize, &UpdateBlock)>,
    ) -> Result<SliceOutcome, Fatal> {
        let context = self.context;
        let coords = &context.coords[..];
        let mut eta = vec![0.0; coords.len()];
        let complement = context.complement.view();
        (context.directions).draw(complement, context.mu, self.rng, &mut eta);
        let followers = self.context.followers.as_ref();
        let mut rejections = Vec::new();
        let (x, derived0, cache0) = (self.x, self.derived0, self.cache0);
        let independent = block.filter(|(_, ub)| ub.independent).map(|(b, _)| b);
        let (y, derived, cache, eval) = (
            &mut *self.out,
            &mut *self.derived,
            &mut *self.cache,
            &mut *self.eval,
        );
        let mut ln_f = |t: f64| -> Result<f64, String> {
            y.copy_from_slice(x);
            for (&i, &e) in coords.iter().zip(&eta) {
                y[i] = x[i] + t * e;
            }
            let mut ln_jacobian = 0.0;
            if let Some((b, ub)) = block {
                if let Some(f) = followers {
                    f.carry(x, &ub.coords, &ub.links.followers, y);
                }
                if ub.density_carries {
                    ln_jacobian = density.carry_followers(b, x, y);
                }
            }
            // Every point is evaluated from the walker's own cache: a refused point may have
            // left the buffers half updated.
            derived.copy_from_slice(derived0);
            cache.copy_from_slice(cache0);
            *eval = sort(match block {
                None => density.log_density_cached(y, derived, cache),
                Some((b, _)) => density.log_density_block(b, y, derived, cache),
            });
            match *eval {
                // An independent block is sliced along its own terms (see `accept`).
                Eval::Finite(lp) => Ok(match independent {
                    Some(b) => density.block_log_density(b, y, cache),
                    None => lp,
                } + ln_jacobian),
                Eval::Rejected(reason) => {
                    rejections.push(reason);
                    Ok(f64::NEG_INFINITY)
                }
                Eval::Fatal(ref message) => Err(message.clone()),
            }
        };
        let start = match independent {
            Some(b) => density.block_log_density(b, x, cache0),
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

/// Row `i` of `len` values of `rows` (empty when `len` is 0).
fn row(rows: &[f64], i: usize, len: usize) -> &[f64] {
    &rows[i * len..(i + 1) * len]
}

/// Where a fatal evaluation happened.
#[derive(Debug)]
pub(crate) struct Fatal {
    pub walker: usize,
    pub position: Vec<f64>,
    pub message: String,
}

/// Proposals of the active halves of all ensembles, evaluated together between
/// [`Ensemble::draw`] and [`Ensemble::accept`]: ensemble `e` owns the `e`-th block of `half`
/// points.
#[derive(Debug)]
pub(crate) struct Work {
    /// Proposed positions, `ensembles × half × ndim`.
    pub proposals: Vec<f64>,
    /// Derived values of the proposals, `ensembles × half × max(nderived, 1)` (stride ≥ 1 so
    /// that chunking works without derived values). A block update starts from the walker's
    /// current values.
    pub derived: Vec<f64>,
    /// The density's cache of each proposal, `ensembles × half × max(cache_len, 1)`; a block
    /// update starts from the walker's cache.
    pub cache: Vec<f64>,
    /// Outcome of each evaluation.
    pub evals: Vec<Eval>,
}

impl Work {
    pub fn new(
        ensembles: usize,
        half: usize,
        ndim: usize,
        nderived: usize,
        cache_len: usize,
    ) -> Self {
        Self {
            proposals: vec![0.0; ensembles * half * ndim],
            derived: vec![0.0; ensembles * half * nderived.max(1)],
            cache: vec![0.0; ensembles * half * cache_len.max(1)],
            evals: vec![Eval::Finite(0.0); ensembles * half],
        }
    }
}

/// The buffers of one ensemble's proposals in [`Work`].
pub(crate) struct ProposalBuffers<'w> {
    pub proposals: &'w mut [f64],
    pub derived: &'w mut [f64],
    pub cache: &'w mut [f64],
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
    /// What the current half-step is.
    kind: HalfStep,
    /// Expansions and contractions of the slice updates of the current step.
    slice_tally: (u64, u64),
}

impl Ensemble {
    /// Fresh generators for ensemble `e`.
    pub fn fresh_rngs(seed: u64, e: usize, walkers: usize) -> (ChaCha8Rng, Vec<ChaCha8Rng>) {
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
            kind: HalfStep::Moves,
            slice_tally: (0, 0),
        }
    }

    /// Exchanges the ensemble's generators with `streams`: an update of an independent
    /// block draws from its own streams, and the ensemble's, exchanged back afterwards, are
    /// left where they were.
    pub fn swap_streams(&mut self, streams: &mut Streams) {
        std::mem::swap(&mut self.s.ensemble_rng, &mut streams.ensemble);
        std::mem::swap(&mut self.s.walker_rngs, &mut streams.walkers);
    }

    /// Starts a step: the random split into halves and the move of this step (its index in
    /// `moves`), both from the ensemble's stream.
    pub fn start_step(&mut self, moves: &[(Move, f64)]) -> usize {
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
    /// by regression, or by the density's map when one is given, its log-Jacobian joining the
    /// proposal ratio); the proposal's derived values and cache start as the walker's own, for
    /// the block update to bring up to date.
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
            cache,
            perm,
            factor,
            log_factor,
            accept_u,
            sub,
            sub_out,
            nderived,
            cache_len,
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
        let (nd, nc) = (*nderived, *cache_len);
        let (sd, sc) = (nd.max(1), nc.max(1));
        for (k, &w) in active.iter().enumerate() {
            let rng = &mut s.walker_rngs[w];
            let x = &s.positions[w * ndim..(w + 1) * ndim];
            let o = &mut out.proposals[k * ndim..(k + 1) * ndim];
            // After the move's draws, from the same stream.
            accept_u[k] = rng.random();
            if let Some(b) = block {
                o.copy_from_slice(x);
                for (&i, &y) in b.coords.iter().zip(&sub_out[k * dim..(k + 1) * dim]) {
                    o[i] = y;
                }
                if let Some(f) = &followers {
                    f.carry(x, &b.coords, &b.links.followers, o);
                }
                if let Some(map) = carry {
                    // The followers' Jacobian joins the proposal's density ratio.
                    let ln_jacobian = map(x, o);
                    let ln_factor = if factor[k].is_normal() {
                        factor[k].ln()
                    } else {
                        log_factor[k]
                    };
                    log_factor[k] = ln_factor + ln_jacobian;
                    factor[k] = log_factor[k].exp();
                }
                out.derived[k * sd..k * sd + nd].copy_from_slice(&s.derived[w * nd..(w + 1) * nd]);
                out.cache[k * sc..k * sc + nc].copy_from_slice(&cache[w * nc..(w + 1) * nc]);
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
    pub fn draw_conditional(
        &mut self,
        h: usize,
        block: &UpdateBlock,
        ln_conditional: &dyn Fn(&[f64]) -> f64,
        out: ProposalBuffers,
    ) -> Result<(), Fatal> {
        let ndim = self.ndim;
        let Self {
            s,
            cache,
            perm,
            nderived,
            cache_len,
            kind,
            ..
        } = self;
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
        let (nd, nc) = (*nderived, *cache_len);
        let (sd, sc) = (nd.max(1), nc.max(1));
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
            out.derived[k * sd..k * sd + nd].copy_from_slice(&s.derived[w * nd..(w + 1) * nd]);
            out.cache[k * sc..k * sc + nc].copy_from_slice(&cache[w * nc..(w + 1) * nc]);
        }
        Ok(())
    }

    /// What the slice move along `directions` of half `h` works with in update slot `slot`:
    /// the directions fitted to the complement, the followers' regression (under hierarchical
    /// updates, when the density does not carry them), and the ensemble's μ of the slot.
    pub fn slice_context(
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

    /// The regression carrying the followers of `block` (update slot `slot`) in half `h`,
    /// unless the density carries them itself or there are none: the tuned one once frozen,
    /// else the one fitted to the complement.
    fn followers(&self, h: usize, slot: usize, block: &UpdateBlock) -> Option<Followers> {
        if block.links.followers.is_empty() || block.density_carries {
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

    /// Gathers this step's walkers into the tuning of every tuned block, and when `freeze`
    /// ends the window (see [`CarryTuning`]).
    pub fn tune_carry(&mut self, blocks: &[UpdateBlock], freeze: bool) {
        let ndim = self.ndim;
        let EnsembleState {
            positions,
            carry_fits,
            ..
        } = &mut self.s;
        for (tuning, b) in carry_fits.iter_mut().zip(blocks) {
            if let Some(t) = tuning {
                t.gather(positions, ndim, &b.coords, &b.links.followers);
                if freeze {
                    t.freeze();
                }
            }
        }
    }

    /// The slice updates of the walkers of half `h`, one task each in walker order, writing
    /// into `out` and `evals` (this ensemble's blocks of [`Work`]).
    pub fn slice_tasks<'a>(
        &'a mut self,
        h: usize,
        context: &'a SliceContext,
        out: ProposalBuffers<'a>,
        evals: &'a mut [Eval],
    ) -> Vec<SliceTask<'a>> {
        let (ndim, nd, nc) = (self.ndim, self.nderived, self.cache_len);
        let (sd, sc) = (nd.max(1), nc.max(1));
        self.kind = HalfStep::Slice { evaluations: 0 };
        let Self { s, cache, perm, .. } = self;
        let (active, _) = Self::halves(perm, h);
        let EnsembleState {
            positions,
            log_density,
            derived,
            walker_rngs,
            ..
        } = s;
        let positions = &positions[..];
        // Each active walker's stream, taken out of the ensemble's (the halves are disjoint).
        let mut rngs: Vec<Option<&mut ChaCha8Rng>> = walker_rngs.iter_mut().map(Some).collect();
        active
            .iter()
            .zip(out.proposals.chunks_exact_mut(ndim))
            .zip(out.derived.chunks_exact_mut(sd))
            .zip(out.cache.chunks_exact_mut(sc))
            .zip(evals.iter_mut())
            .map(|((((&w, o), d), c), e)| SliceTask {
                walker: w,
                x: &positions[w * ndim..(w + 1) * ndim],
                lp: log_density[w],
                derived0: &derived[w * nd..(w + 1) * nd],
                cache0: &cache[w * nc..(w + 1) * nc],
                context,
                rng: rngs[w].take().expect("each active walker once"),
                out: o,
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
    pub fn finish_slice(
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
    pub fn finish_slice_update(&mut self, slot: usize, adapt: bool) {
        self.s.slice_updates += 1;
        if adapt {
            let (e, c) = self.slice_tally;
            let e = e.max(1) as f64;
            self.s.slice_scales[slot] *= 2.0 * e / (e + c as f64);
        }
    }

    /// Accepts or rejects the evaluated proposals of half `h` (`proposals`, `derived` with
    /// stride max(nderived, 1), `caches` with stride max(cache_len, 1), `evals`: this
    /// ensemble's blocks of [`Work`]): on the change of the log-density, or, for a move of an
    /// independent block, on the change of the block's own terms `local`.
    pub fn accept(
        &mut self,
        h: usize,
        proposals: &[f64],
        derived: &[f64],
        caches: &[f64],
        evals: &[Eval],
        local: Option<&BlockTerms>,
    ) -> Result<(), Fatal> {
        let (ndim, nderived, cache_len) = (self.ndim, self.nderived, self.cache_len);
        let Self {
            s,
            cache,
            perm,
            factor,
            log_factor,
            accept_u,
            kind,
            ..
        } = self;
        let kind = *kind;
        // Exact draws and slice updates are accepted as they are.
        let exact = kind != HalfStep::Moves;
        let (active, _) = Self::halves(perm, h);
        s.evaluations += match kind {
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
                position: proposals[k * ndim..(k + 1) * ndim].to_vec(),
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
                position: proposals[k * ndim..(k + 1) * ndim].to_vec(),
                message: format!(
                    "the log-density refuses ({:?}) a point its conditional density allows",
                    evals[k]
                ),
            });
        }
        let stride = nderived.max(1);
        for (k, &w) in active.iter().enumerate() {
            match evals[k] {
                Eval::Finite(lp) => {
                    // Metropolis–Hastings: accept when ln u < ln f + Δ, i.e. ln(u/f) < Δ; an
                    // uphill move with u < f needs no logarithm at all.
                    let delta = match local {
                        // Each term reads only the block's values, whatever the other
                        // independent blocks' updates did to the totals.
                        Some(terms) if !exact => {
                            let (new, old) = (row(caches, k, cache_len), row(cache, w, cache_len));
                            terms(&proposals[k * ndim..(k + 1) * ndim], new)
                                - terms(&s.positions[w * ndim..(w + 1) * ndim], old)
                        }
                        _ => lp - s.log_density[w],
                    };
                    let f = factor[k];
                    let accept = if exact {
                        true
                    } else if f.is_normal() {
                        // ln q ≤ q − 1 and ln q ≥ 1 − 1/q decide most cases without the
                        // logarithm.
                        let q = accept_u[k] / f;
                        if q - 1.0 < delta {
                            true
                        } else if 1.0 - 1.0 / q >= delta {
                            false
                        } else {
                            q.ln() < delta
                        }
                    } else {
                        accept_u[k].ln() < log_factor[k] + delta
                    };
                    if accept {
                        // Element loops: `copy_from_slice` of a few values is a libc call.
                        for (p, &y) in s.positions[w * ndim..(w + 1) * ndim]
                            .iter_mut()
                            .zip(&proposals[k * ndim..(k + 1) * ndim])
                        {
                            *p = y;
                        }
                        for (d, &y) in s.derived[w * nderived..(w + 1) * nderived]
                            .iter_mut()
                            .zip(&derived[k * stride..k * stride + nderived])
                        {
                            *d = y;
                        }
                        if cache_len > 0 {
                            let c = &caches[k * cache_len..(k + 1) * cache_len];
                            cache[w * cache_len..(w + 1) * cache_len].copy_from_slice(c);
                        }
                        s.log_density[w] = lp;
                        // Acceptance counts the moves' proposals, not the exact draws or the
                        // slice updates.
                        if !exact {
                            s.accepted[w] += 1;
                        }
                    }
                }
                Eval::Rejected(reason) => match s.rejections.get_mut(reason) {
                    Some(c) => *c += 1,
                    None => {
                        s.rejections.insert(reason.to_string(), 1);
                    }
                },
                Eval::Fatal(_) => {}
            }
        }
        Ok(())
    }
}
