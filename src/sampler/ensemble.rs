//! One ensemble: its walkers, random streams, counters and preallocated work buffers, and the
//! red-blue update of one step.

use std::collections::BTreeMap;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::density::{classify, Eval, LogDensity};
use super::moves::Move;

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

/// One ensemble with its work buffers.
#[derive(Debug)]
pub(crate) struct Ensemble {
    pub s: EnsembleState,
    ndim: usize,
    nderived: usize,
    perm: Vec<usize>,
    proposals: Vec<f64>,
    prop_derived: Vec<f64>,
    prop_eval: Vec<Eval>,
    log_factor: Vec<f64>,
    log_u: Vec<f64>,
    scratch_idx: Vec<usize>,
    scratch_z: Vec<f64>,
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

    pub fn new(s: EnsembleState, ndim: usize, nderived: usize) -> Self {
        let walkers = s.log_density.len();
        let half = walkers / 2;
        Self {
            s,
            ndim,
            nderived,
            perm: (0..walkers).collect(),
            proposals: vec![0.0; half * ndim],
            // Stride ≥ 1 so that parallel chunking works without derived values.
            prop_derived: vec![0.0; half * nderived.max(1)],
            prop_eval: vec![Eval::Finite(0.0); half],
            log_factor: vec![0.0; half],
            log_u: vec![0.0; half],
            scratch_idx: vec![0; half],
            scratch_z: vec![0.0; half],
        }
    }

    pub fn walkers(&self) -> usize {
        self.s.log_density.len()
    }

    /// One red-blue step: random split, then each half updated from the other.
    pub fn step<D: LogDensity + ?Sized>(
        &mut self,
        density: &D,
        moves: &[(Move, f64)],
        parallel: bool,
    ) -> Result<(), Fatal> {
        let walkers = self.walkers();
        // Random split (Fisher–Yates from the identity, so it depends only on the stream).
        for (i, p) in self.perm.iter_mut().enumerate() {
            *p = i;
        }
        for i in (1..walkers).rev() {
            let j = self.s.ensemble_rng.random_range(0..=i);
            self.perm.swap(i, j);
        }
        let mv = if moves.len() == 1 {
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
        };
        let half = walkers / 2;
        self.update_half(density, &mv, 0, half, parallel)?;
        self.update_half(density, &mv, half, 0, parallel)
    }

    /// Updates the walkers `perm[active..active+half]` from `perm[comp..comp+half]`.
    fn update_half<D: LogDensity + ?Sized>(
        &mut self,
        density: &D,
        mv: &Move,
        active: usize,
        comp: usize,
        parallel: bool,
    ) -> Result<(), Fatal> {
        let Self {
            s,
            ndim,
            nderived,
            perm,
            proposals,
            prop_derived,
            prop_eval,
            log_factor,
            log_u,
            scratch_idx,
            scratch_z,
        } = self;
        let (ndim, nderived) = (*ndim, *nderived);
        let half = log_u.len();
        let active = &perm[active..active + half];
        let complement = &perm[comp..comp + half];

        // Randomness drawn serially, each walker from its own stream.
        for (k, &w) in active.iter().enumerate() {
            let rng = &mut s.walker_rngs[w];
            log_factor[k] = mv.propose(
                &s.positions[w * ndim..(w + 1) * ndim],
                &s.positions,
                complement,
                rng,
                &mut proposals[k * ndim..(k + 1) * ndim],
                scratch_idx,
                scratch_z,
            );
            log_u[k] = rng.random::<f64>().ln();
        }

        // The expensive, pure part in parallel.
        let stride = nderived.max(1);
        let eval = |((x, d), e): ((&[f64], &mut [f64]), &mut Eval)| {
            *e = classify(density, x, &mut d[..nderived]);
        };
        if parallel {
            proposals
                .par_chunks(ndim)
                .zip(prop_derived.par_chunks_mut(stride))
                .zip(prop_eval.par_iter_mut())
                .for_each(eval);
        } else {
            proposals
                .chunks(ndim)
                .zip(prop_derived.chunks_mut(stride))
                .zip(prop_eval.iter_mut())
                .for_each(eval);
        }
        s.evaluations += half as u64;

        if let Some(k) = prop_eval.iter().position(|e| matches!(e, Eval::Fatal(_))) {
            let message = match &prop_eval[k] {
                Eval::Fatal(m) => m.clone(),
                _ => String::new(),
            };
            return Err(Fatal {
                walker: active[k],
                position: proposals[k * ndim..(k + 1) * ndim].to_vec(),
                message,
            });
        }

        for (k, &w) in active.iter().enumerate() {
            match prop_eval[k] {
                Eval::Finite(lp) => {
                    if log_u[k] < log_factor[k] + lp - s.log_density[w] {
                        s.positions[w * ndim..(w + 1) * ndim]
                            .copy_from_slice(&proposals[k * ndim..(k + 1) * ndim]);
                        s.derived[w * nderived..(w + 1) * nderived]
                            .copy_from_slice(&prop_derived[k * stride..k * stride + nderived]);
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
