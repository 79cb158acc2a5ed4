//! One ensemble: its walkers, random streams, counters and preallocated work buffers, and the
//! two serial halves of the red-blue update of one step (drawing the proposals, accepting
//! them). The evaluation in between belongs to the caller, which evaluates the proposals of
//! all ensembles in one loop (see [`Work`]).

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::moves::{Followers, HalfStepFit, Move};
use crate::density::{BlockLinks, Eval};

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

/// The coordinates one blocked update moves, and its links (empty unless the updates are
/// hierarchical): independence proposals are conditional on the walker's `given`
/// coordinates, and every move carries the `followers` along (evaluated with the block, see
/// [`log_density_block`](crate::density::LogDensity::log_density_block)).
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct UpdateBlock {
    pub coords: Vec<usize>,
    pub links: BlockLinks,
}

/// Serialisable state of one ensemble.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EnsembleState {
    /// Walker positions, `walkers × ndim`, row-major.
    pub positions: Vec<f64>,
    /// Log-density of each walker.
    pub log_density: Vec<f64>,
    /// Derived values, `walkers × nderived`, row-major.
    pub derived: Vec<f64>,
    /// Generator for the split and the move choice.
    pub ensemble_rng: ChaCha8Rng,
    /// One generator per walker for its proposals and acceptance draws.
    pub walker_rngs: Vec<ChaCha8Rng>,
    /// Accepted proposals per walker.
    pub accepted: Vec<u64>,
    /// Rejected proposals per reason (density errors, NaN, −∞); Metropolis rejections are not
    /// counted here.
    pub rejections: BTreeMap<String, u64>,
    /// Log-density evaluations (proposals) so far.
    pub evaluations: u64,
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
    scratch_idx: Vec<usize>,
    scratch_z: Vec<f64>,
    /// The walkers' coordinates in the current block, `walkers × block dim`.
    sub: Vec<f64>,
    /// One proposal in the current block.
    sub_out: Vec<f64>,
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
            scratch_idx: vec![0; half],
            scratch_z: vec![0.0; half],
            sub: Vec::new(),
            sub_out: Vec::new(),
        }
    }

    /// Starts a step: the random split into halves and the move of this step, both from the
    /// ensemble's stream.
    pub fn start_step(&mut self, moves: &[(Move, f64)]) -> Move {
        let walkers = self.perm.len();
        let half = walkers / 2;
        // Partial Fisher–Yates from the identity: the first half becomes a uniformly random
        // subset (the order within a half does not matter, each walker has its own stream),
        // with `half` draws instead of `walkers − 1`, depending only on the stream.
        for (i, p) in self.perm.iter_mut().enumerate() {
            *p = i;
        }
        for i in 0..half {
            let j = self.s.ensemble_rng.random_range(i..walkers);
            self.perm.swap(i, j);
        }
        if moves.len() == 1 {
            moves[0].0
        } else {
            let total: f64 = moves.iter().map(|m| m.1).sum();
            let mut u = self.s.ensemble_rng.random::<f64>() * total;
            let mut chosen = moves[moves.len() - 1].0;
            for &(m, w) in moves {
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
    /// by regression); the proposal's derived values and cache start as the walker's own, for
    /// the block update to bring up to date.
    pub fn draw(&mut self, mv: &Move, h: usize, block: Option<&UpdateBlock>, out: ProposalBuffers) {
        let ndim = self.ndim;
        let Self {
            s,
            cache,
            perm,
            factor,
            log_factor,
            accept_u,
            scratch_idx,
            scratch_z,
            sub,
            sub_out,
            nderived,
            cache_len,
            ..
        } = self;
        let (active, complement) = Self::halves(perm, h);
        // The move sees the walkers' coordinates in the block (all of them when joint).
        let (moved, dim): (&[f64], usize) = match block {
            None => (&s.positions, ndim),
            Some(b) => {
                sub.clear();
                for x in s.positions.chunks_exact(ndim) {
                    sub.extend(b.coords.iter().map(|&i| x[i]));
                }
                sub_out.resize(b.coords.len(), 0.0);
                (sub, b.coords.len())
            }
        };
        let links = block.map(|b| &b.links);
        let given = links.map_or(&[][..], |l| &l.given[..]);
        let mut fit = HalfStepFit::new(
            mv,
            (&s.positions, ndim),
            (moved, dim),
            complement,
            block.map(|b| (&b.coords[..], given)),
        );
        let followers = block
            .filter(|b| !b.links.followers.is_empty())
            .and_then(|b| {
                Followers::new(
                    &s.positions,
                    ndim,
                    complement,
                    &b.coords,
                    &b.links.followers,
                )
            });
        let (nd, nc) = (*nderived, *cache_len);
        let (sd, sc) = (nd.max(1), nc.max(1));
        for (k, &w) in active.iter().enumerate() {
            let rng = &mut s.walker_rngs[w];
            let x = &s.positions[w * ndim..(w + 1) * ndim];
            let o = &mut out.proposals[k * ndim..(k + 1) * ndim];
            // Joint: straight into the proposal; blocked: into the block's scratch.
            let target = if block.is_some() {
                &mut sub_out[..]
            } else {
                &mut *o
            };
            let c = mv.propose(
                &moved[w * dim..(w + 1) * dim],
                moved,
                complement,
                fit.for_walker(x, given),
                rng,
                target,
                scratch_idx,
                scratch_z,
            );
            (factor[k], log_factor[k]) = (c.factor, c.log_factor);
            accept_u[k] = rng.random();
            if let Some(b) = block {
                o.copy_from_slice(x);
                for (&i, &y) in b.coords.iter().zip(sub_out.iter()) {
                    o[i] = y;
                }
                if let Some(f) = &followers {
                    f.carry(x, &b.coords, &b.links.followers, o);
                }
                out.derived[k * sd..k * sd + nd].copy_from_slice(&s.derived[w * nd..(w + 1) * nd]);
                out.cache[k * sc..k * sc + nc].copy_from_slice(&cache[w * nc..(w + 1) * nc]);
            }
        }
    }

    /// Accepts or rejects the evaluated proposals of half `h` (`proposals`, `derived` with
    /// stride max(nderived, 1), `caches` with stride max(cache_len, 1), `evals`: this
    /// ensemble's blocks of [`Work`]).
    pub fn accept(
        &mut self,
        h: usize,
        proposals: &[f64],
        derived: &[f64],
        caches: &[f64],
        evals: &[Eval],
    ) -> Result<(), Fatal> {
        let (ndim, nderived, cache_len) = (self.ndim, self.nderived, self.cache_len);
        let Self {
            s,
            cache,
            perm,
            factor,
            log_factor,
            accept_u,
            ..
        } = self;
        let (active, _) = Self::halves(perm, h);
        s.evaluations += active.len() as u64;

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

        let stride = nderived.max(1);
        for (k, &w) in active.iter().enumerate() {
            match evals[k] {
                Eval::Finite(lp) => {
                    // Metropolis–Hastings: accept when ln u < ln f + Δ, i.e. ln(u/f) < Δ; an
                    // uphill move with u < f needs no logarithm at all.
                    let delta = lp - s.log_density[w];
                    let f = factor[k];
                    let accept = if f.is_normal() {
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
                        s.accepted[w] += 1;
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
