//! Blocks for blocked updates, and the evaluation a block update reuses.
//!
//! Given the parameters shared between contacts (a material's α and a/F_d, a t0 population),
//! the contacts are independent: each contact's own coordinates enter only its runs'
//! likelihood and their own priors. A block is the set of coordinates read by the runs of the
//! same set of contacts: one block per contact for its own parameters, one per material for
//! the parameters its contacts share. A material with a single contact therefore has a single
//! block (nothing is gained by splitting it).
//!
//! A walker's cache holds the prior of each block's coordinates and each run's fit (weighted
//! sum of squared residuals, F_end), so that an update of one block evaluates only the runs
//! that read its coordinates (and the repeat slides that follow them). The log-density is
//! then summed from the cache in a fixed order, exactly as a full evaluation sums it.

use std::collections::BTreeSet;

use super::layout::{CoordPrior, SigmaSource, T0Source};
use super::likelihood::{RunModel, SigmaFit, LN_SQRT_2PI, MAX_RUNS, REJECT_PRIOR};
use super::Posterior;
use crate::density::LogDensityError;

/// One block: its coordinates, the runs to re-fit when they change (in evaluation order), and
/// which runs' peaks they change.
#[derive(Debug, Clone)]
pub(super) struct Block {
    pub coords: Vec<usize>,
    pub runs: Vec<usize>,
    /// Per run: whether it reads a coordinate of the block (its peak changes).
    pub reads: Vec<bool>,
}

impl RunModel {
    /// Every coordinate this run's term reads.
    fn coords_read(&self) -> Vec<usize> {
        let mut out: Vec<usize> = [self.alpha, self.a, Some(self.f_d), self.k]
            .into_iter()
            .flatten()
            .collect();
        match self.t0 {
            Some(T0Source::Direct(i)) => out.push(i),
            Some(T0Source::Pooled { mu, ln_s, z }) => out.extend([mu, ln_s, z]),
            None => {}
        }
        if let SigmaSource::Coord(s) = self.sigma {
            out.push(s);
        }
        out
    }
}

/// The blocks of `ncoords` coordinates read by `runs` (evaluated in `order`): coordinates
/// read by the runs of the same set of contacts form one block, in the order of their first
/// coordinate.
pub(super) fn blocks(
    ncoords: usize,
    runs: &[RunModel],
    order: &[usize],
    group: impl Fn(&RunModel) -> usize,
) -> Vec<Block> {
    let mut readers: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); ncoords];
    for r in runs {
        for i in r.coords_read() {
            readers[i].insert(group(r));
        }
    }
    let mut keys: Vec<&BTreeSet<usize>> = Vec::new();
    let mut blocks: Vec<Block> = Vec::new();
    for (i, key) in readers.iter().enumerate() {
        match keys.iter().position(|k| *k == key) {
            Some(b) => blocks[b].coords.push(i),
            None => {
                keys.push(key);
                blocks.push(Block {
                    coords: vec![i],
                    runs: Vec::new(),
                    reads: vec![false; runs.len()],
                });
            }
        }
    }
    for b in &mut blocks {
        for (i, r) in runs.iter().enumerate() {
            b.reads[i] = r.coords_read().iter().any(|c| b.coords.contains(c));
        }
        // A repeat slide starts where the slide it follows stopped: re-fit it with that one.
        let refit = |i: usize| b.reads[i] || runs[i].follows.is_some_and(|j| b.reads[j]);
        b.runs = order.iter().copied().filter(|&i| refit(i)).collect();
    }
    blocks
}

/// A walker's cache, `blocks + 2 × runs` values: the prior of each block, then each run's
/// weighted sum of squared residuals, then each run's F_end.
pub(super) struct Cache<'c> {
    pub prior: &'c mut [f64],
    pub ssr: &'c mut [f64],
    pub last: &'c mut [f64],
}

impl<'c> Cache<'c> {
    pub fn split(cache: &'c mut [f64], blocks: usize, runs: usize) -> Self {
        let (prior, rest) = cache.split_at_mut(blocks);
        let (ssr, last) = rest.split_at_mut(runs);
        Self { prior, ssr, last }
    }
}

impl Posterior {
    /// Length of a walker's cache.
    pub(super) fn cache_size(&self) -> usize {
        self.blocks.len() + 2 * self.runs.len()
    }

    /// The log-prior of block `b`'s coordinates at `x`.
    fn block_prior(&self, b: usize, x: &[f64]) -> Result<f64, LogDensityError> {
        let mut lp = 0.0;
        for &i in &self.blocks[b].coords {
            let u = x[i];
            lp += match &self.coords[i].prior {
                CoordPrior::Log(prior) => {
                    let l = prior.ln_density(u.exp());
                    if l == f64::NEG_INFINITY {
                        return Err(LogDensityError::rejected(REJECT_PRIOR));
                    }
                    l + u
                }
                CoordPrior::StdNormal => -0.5 * u * u - LN_SQRT_2PI,
            };
        }
        Ok(lp)
    }

    /// The log-density at `x` evaluated in full, filling `cache` and `derived`.
    pub(super) fn evaluate_full(
        &self,
        x: &[f64],
        derived: &mut [f64],
        cache: Cache,
    ) -> Result<f64, LogDensityError> {
        for (b, p) in cache.prior.iter_mut().enumerate() {
            *p = self.block_prior(b, x)?;
        }
        for &i in &self.order {
            self.fit_run(i, x, cache.ssr, cache.last)?;
        }
        self.finish(x, derived, &cache, None)
    }

    /// The log-density at `x`, which differs from the point of `cache` and `derived` only in
    /// block `b`: re-evaluates that block's prior and runs, and the peaks it changes.
    pub(super) fn evaluate_block(
        &self,
        b: usize,
        x: &[f64],
        derived: &mut [f64],
        cache: Cache,
    ) -> Result<f64, LogDensityError> {
        cache.prior[b] = self.block_prior(b, x)?;
        for &i in &self.blocks[b].runs {
            self.fit_run(i, x, cache.ssr, cache.last)?;
        }
        self.finish(x, derived, &cache, Some(&self.blocks[b].reads))
    }

    /// Sums the cache into the log-density (always in the same order) and writes the derived
    /// values, the peaks of the runs `peaks` marks only (all when `None`).
    fn finish(
        &self,
        x: &[f64],
        derived: &mut [f64],
        cache: &Cache,
        peaks: Option<&[bool]>,
    ) -> Result<f64, LogDensityError> {
        let mut lp = 0.0;
        for p in cache.prior.iter() {
            lp += p;
        }
        let mut sigma_fit: SigmaFit = [(0.0, 0); MAX_RUNS];
        let ll = self.log_likelihood(x, cache.ssr, &mut sigma_fit)?;
        if !derived.is_empty() {
            self.derived_values(x, &sigma_fit, derived, peaks);
        }
        Ok(lp + ll)
    }
}
