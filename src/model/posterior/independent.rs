//! The contacts' own blocks updated on their own entries of a walker's state.
//!
//! An independent block (`blocks::independent`: one contact's own parameters, given the
//! parameters its material shares) re-fits only its own runs, re-evaluates only its own prior
//! and touches only its own σ groups. Its update therefore works on a compact copy of the
//! entries of the walker's state it reads and writes ([`OwnLayout`]): its prior, its runs'
//! fits, its σ groups' terms, and what it only reads (the F_end of a slide it follows that it
//! does not re-fit, the fits of its σ groups' other runs), and writes only its own derived
//! values. Its cost does not grow with the number of contacts; the walker's log-density and
//! the derived values that are no one contact's (a material's mean over its contacts, a new
//! contact's peak) are brought up to date once after all the contacts' updates, from the
//! state (`evaluate_from_cache`).
//!
//! Every number is computed as `evaluate_block` computes it, in the same order: the
//! terms, their sum and every derived value are the same bits.

use super::blocks::{Block, Changed};
use super::derived::PeakCache;
use super::layout::{SigmaSource, Source};
use super::Posterior;
use crate::density::{IndependentBlocks, LogDensityError, OwnEntries};

/// Where an independent block's update finds, in its compact copy of the walker's state, each
/// entry it reads or writes.
#[derive(Debug, Clone)]
pub(super) struct OwnLayout {
    /// The entries of the walker's state and derived values, in the compact order.
    pub entries: OwnEntries,
    /// Slot of the prior of each of the block's `priors`.
    prior: Vec<usize>,
    /// Slots of the sum of squared residuals and of F_end of each of the block's `runs`.
    ssr: Vec<usize>,
    last: Vec<usize>,
    /// Each σ group the block touches (in index order) with its slot.
    groups: Vec<(usize, usize)>,
    /// Each run whose sum of squared residuals the update reads, with its slot.
    ssr_at: Vec<(usize, usize)>,
    /// Each run whose F_end the update reads, with its slot.
    last_at: Vec<(usize, usize)>,
}

/// The slot of `run` in `at`.
fn slot(at: &[(usize, usize)], run: usize) -> usize {
    at.iter()
        .find(|&&(r, _)| r == run)
        .map(|&(_, k)| k)
        .expect("an independent block reads only the entries of its layout")
}

impl OwnLayout {
    /// The layout of `block`'s update in `post`, whose state holds `blocks` priors, then each
    /// run's sum of squared residuals and F_end, then each σ group's term; `derived`: the
    /// block's own derived values.
    fn new(post: &Posterior, block: &Block, derived: Vec<usize>) -> Self {
        let (nblocks, nruns) = (post.blocks.len(), post.runs.len());
        let mut state = Vec::new();
        let mut take = |entry: usize| {
            state.push(entry);
            state.len() - 1
        };
        let prior = block.priors.iter().map(|&p| take(p)).collect();
        let ssr: Vec<usize> = block.runs.iter().map(|&i| take(nblocks + i)).collect();
        let last: Vec<usize> = block
            .runs
            .iter()
            .map(|&i| take(nblocks + nruns + i))
            .collect();
        // The σ groups of its runs, in index order.
        let mut touched: Vec<usize> = block
            .runs
            .iter()
            .filter_map(|&i| match post.runs[i].sigma {
                SigmaSource::Marginal(g) => Some(g),
                SigmaSource::Coord(_) => None,
            })
            .collect();
        touched.sort_unstable();
        touched.dedup();
        let groups: Vec<(usize, usize)> = touched
            .into_iter()
            .map(|g| (g, take(nblocks + 2 * nruns + g)))
            .collect();
        let mut ssr_at: Vec<(usize, usize)> = block.runs.iter().copied().zip(ssr.clone()).collect();
        let mut last_at: Vec<(usize, usize)> =
            block.runs.iter().copied().zip(last.clone()).collect();
        // What the update reads and no update of the run of independent blocks writes.
        for &i in &block.runs {
            if let Some(j) = post.runs[i].follows {
                if last_at.iter().all(|&(r, _)| r != j) {
                    last_at.push((j, take(nblocks + nruns + j)));
                }
            }
        }
        for &(g, _) in &groups {
            for &i in &post.sigma_groups[g].runs {
                if ssr_at.iter().all(|&(r, _)| r != i) {
                    ssr_at.push((i, take(nblocks + i)));
                }
            }
        }
        Self {
            entries: OwnEntries { state, derived },
            prior,
            ssr,
            last,
            groups,
            ssr_at,
            last_at,
        }
    }
}

/// The layout of every independent block of `post` (those from `first_independent` on).
pub(super) fn own_layouts(post: &Posterior) -> Vec<OwnLayout> {
    let first = post.first_independent;
    let independent = &post.blocks[first..];
    // Each block's derived values: those its update rewrites, but for those of no one block,
    // found through the block that owns what each column is computed from.
    let mut derived = vec![Vec::new(); independent.len()];
    for (j, source) in post.sources.iter().enumerate() {
        let Some(k) = post.owner_of(source) else {
            continue;
        };
        if post.rewrites(source, Changed::Block(&independent[k]))
            && !post.rewrites(source, Changed::Merged)
        {
            derived[k].push(j);
        }
    }
    independent
        .iter()
        .zip(derived)
        .map(|(block, derived)| OwnLayout::new(post, block, derived))
        .collect()
}

impl Posterior {
    /// The layout of independent block `b`.
    pub(super) fn own_layout(&self, b: usize) -> &OwnLayout {
        &self.own[b - self.first_independent]
    }
}

impl IndependentBlocks for Posterior {
    /// The block's priors, the Gaussian terms of the runs it re-fits and the likelihoods of
    /// its σ groups, as `evaluate_block` adds them.
    fn block_terms(&self, block: usize, x: &[f64], state: &[f64]) -> f64 {
        let (b, layout) = (&self.blocks[block], self.own_layout(block));
        let mut lp = 0.0;
        for &k in &layout.prior {
            lp += state[k];
        }
        for (&i, &k) in b.runs.iter().zip(&layout.ssr) {
            lp += self.runs[i].gaussian_term(x, state[k]);
        }
        for &(_, k) in &layout.groups {
            lp += state[k];
        }
        lp
    }

    fn update_block_state(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        let (b, layout) = (&self.blocks[block], self.own_layout(block));
        for (&p, &k) in b.priors.iter().zip(&layout.prior) {
            state[k] = self.block_prior(p, x)?;
        }
        // In evaluation order: a repeat slide's F_end comes from the slide it follows.
        for ((&i, &s), &l) in b.runs.iter().zip(&layout.ssr).zip(&layout.last) {
            let f_end = self.runs[i]
                .follows
                .map(|j| state[slot(&layout.last_at, j)]);
            let fit = self.run_residuals(i, x, f_end)?;
            state[s] = fit.ssr;
            state[l] = fit.last_force;
        }
        for &(g, k) in &layout.groups {
            let term = self.group_term(g, |i| state[slot(&layout.ssr_at, i)])?;
            state[k] = term;
        }
        let mut peaks = PeakCache::default();
        let ssr_of = |i: usize| state[slot(&layout.ssr_at, i)];
        for (out, &j) in derived.iter_mut().zip(&layout.entries.derived) {
            let source: Source = self.sources[j];
            *out = self.column_value(source, x, &ssr_of, &mut peaks);
        }
        Ok(self.block_terms(block, x, state))
    }

    fn log_density_from_state(&self, x: &[f64], derived: &mut [f64], state: &[f64]) -> f64 {
        self.evaluate_from_cache(x, derived, state)
    }
}
