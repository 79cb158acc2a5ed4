//! Blocks for blocked updates, and the evaluation a block update reuses.
//!
//! Given the parameters shared between contacts (a material's α and a/F_d, a t0 population),
//! the contacts are independent: each contact's own coordinates enter only its runs'
//! likelihood and their own priors. A block is the set of coordinates read by the runs of the
//! same set of contacts: one block per contact for its own parameters, one per material for
//! the parameters its contacts share. A material with a single contact therefore has a single
//! block (nothing is gained by splitting it).
//!
//! A walker's cache holds the prior of each block's coordinates, each run's fit (weighted sum
//! of squared residuals, F_end) and each marginalised σ group's likelihood, so that an update
//! of one block evaluates only the runs that read its coordinates (and the repeat slides that
//! follow them) and the σ groups of those runs. The log-density is then summed from the cache
//! in a fixed order, exactly as a full evaluation sums it.

use std::collections::BTreeSet;
use std::ops::Range;

use super::layout::{Coord, CoordPrior, Population, SigmaSource};
use super::likelihood::{RunModel, LN_SQRT_2PI, REJECT_PRIOR};
use super::Posterior;
use crate::density::{BlockLinks, LogDensityError, ShareError};

/// One block: its coordinates, the runs to re-fit when they change or its followers move
/// with them (in evaluation order), which runs' peaks and which σ groups they change.
#[derive(Debug, Clone)]
pub(super) struct Block {
    pub coords: Vec<usize>,
    pub runs: Vec<usize>,
    /// Per run: whether it reads a coordinate of the block (its peak changes).
    pub reads: Vec<bool>,
    /// Per coordinate: whether an update of the block moves it (the block's own and its
    /// followers), i.e. whether its reported value can change.
    pub moves: Vec<bool>,
    /// Per marginalised σ group: whether one of `runs` belongs to it.
    pub groups: Vec<bool>,
    /// How the block depends on the others: the coordinates read by a strict superset of its
    /// groups (given) and by a strict subset (followers).
    pub links: BlockLinks,
    /// This block and the blocks of its followers: the priors an update re-evaluates.
    pub priors: Vec<usize>,
}

impl RunModel {
    /// Every coordinate this run's term reads.
    pub(super) fn coords_read(&self) -> Vec<usize> {
        let mut out: Vec<usize> = [
            self.alpha, self.a, self.b, self.d_c, self.f_d, self.t0, self.k,
        ]
        .into_iter()
        .flatten()
        .collect();
        if let SigmaSource::Coord(s) = self.sigma {
            out.push(s);
        }
        out
    }
}

/// The blocks of the coordinates `coords` read by `runs` (evaluated in `order`, in `groups`
/// marginalised σ groups): coordinates read by the runs of the same set of groups (`group` of
/// a run: its material or its contact) form one block, in the order of their first
/// coordinate. A block read by a strict superset of another's groups (a material's shared
/// parameters, read by all its contacts) is given to that block, which follows it.
///
/// A run depends on the population of a pooled t0 through that t0's prior, so the population
/// is read by the groups of its members' runs; it forms a block of its own (its conditional
/// is cheap, see [`ExactConditional`](crate::density::ExactConditional)).
pub(super) fn blocks(
    coords: &[Coord],
    runs: &[RunModel],
    order: &[usize],
    sigma_groups: usize,
    group: impl Fn(&RunModel) -> usize,
) -> Vec<Block> {
    let read: Vec<Vec<usize>> = runs.iter().map(RunModel::coords_read).collect();
    let population = |i: usize| match coords[i].prior {
        CoordPrior::Population { mu, ln_s } => Some([mu, ln_s]),
        CoordPrior::Log(_) => None,
    };
    let mut in_population = vec![false; coords.len()];
    let mut readers: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); coords.len()];
    for (r, read) in runs.iter().zip(&read) {
        for &i in read {
            readers[i].insert(group(r));
            for p in population(i).into_iter().flatten() {
                readers[p].insert(group(r));
                in_population[p] = true;
            }
        }
    }
    let mut keys: Vec<(&BTreeSet<usize>, bool)> = Vec::new();
    let mut members: Vec<Vec<usize>> = Vec::new();
    for (i, r) in readers.iter().enumerate() {
        let key = (r, in_population[i]);
        match keys.iter().position(|k| *k == key) {
            Some(b) => members[b].push(i),
            None => {
                keys.push(key);
                members.push(vec![i]);
            }
        }
    }
    let links: Vec<(BlockLinks, Vec<usize>)> = keys
        .iter()
        .enumerate()
        .map(|(b, (key, _))| {
            let (mut l, mut priors) = (BlockLinks::default(), vec![b]);
            for (o, ((other, _), coords)) in keys.iter().zip(&members).enumerate() {
                if other.is_superset(key) && other != key {
                    l.given.extend(coords);
                } else if other.is_subset(key) && other != key {
                    l.followers.extend(coords);
                    priors.push(o);
                } else if o != b
                    && coords
                        .iter()
                        .any(|&i| population(i).is_some_and(|p| members[b].contains(&p[0])))
                {
                    // Members of this population outside its followers (one block per
                    // material): their priors change with it too.
                    priors.push(o);
                }
            }
            (l, priors)
        })
        .collect();
    members
        .into_iter()
        .zip(links)
        .map(|(coords, (links, priors))| {
            // An update moves the block's coordinates and may carry its followers along.
            let moved = |i: &usize| coords.contains(i) || links.followers.contains(i);
            let reads: Vec<bool> = read.iter().map(|c| c.iter().any(moved)).collect();
            // A repeat slide starts where the slide it follows stopped: re-fit it with that one.
            let refit = |i: usize| reads[i] || runs[i].follows.is_some_and(|j| reads[j]);
            let block_runs: Vec<usize> = order.iter().copied().filter(|&i| refit(i)).collect();
            let mut groups = vec![false; sigma_groups];
            for &i in &block_runs {
                if let SigmaSource::Marginal(g) = runs[i].sigma {
                    groups[g] = true;
                }
            }
            let moves = (0..readers.len()).map(|i| moved(&i)).collect();
            Block {
                coords,
                runs: block_runs,
                reads,
                moves,
                groups,
                links,
                priors,
            }
        })
        .collect()
}

/// Whether `block` holds populations (each a pooled parameter's μ and ln s in a material).
pub(super) fn holds_population(block: &Block, populations: &[Population]) -> bool {
    populations.iter().any(|p| block.coords.contains(&p.mu))
}

/// `blocks` with the [`independent`] ones moved after all others (each group keeping its
/// order), so that a step updates the shared parameters and populations first and then every
/// contact, in one run of independent blocks that can be updated in any order or at once;
/// and the index of the first independent block (the others are those after it).
pub(super) fn independent_last(
    blocks: Vec<Block>,
    population: impl Fn(&Block) -> bool,
) -> (Vec<Block>, usize) {
    let independent = independent(&blocks, population);
    let order: Vec<usize> = (0..blocks.len())
        .filter(|&b| !independent[b])
        .chain((0..blocks.len()).filter(|&b| independent[b]))
        .collect();
    let first = blocks.len() - independent.iter().filter(|&&i| i).count();
    let mut position = vec![0; blocks.len()];
    for (k, &b) in order.iter().enumerate() {
        position[b] = k;
    }
    let mut slots: Vec<Option<Block>> = blocks.into_iter().map(Some).collect();
    let reordered = order
        .iter()
        .map(|&b| {
            let mut block = slots[b].take().expect("each block once");
            for p in &mut block.priors {
                *p = position[*p];
            }
            block
        })
        .collect();
    (reordered, first)
}

/// Which derived values an evaluation changes.
#[derive(Debug, Clone, Copy)]
pub(super) enum Changed<'b> {
    /// All of them (a full evaluation).
    All,
    /// Those of the runs and σ groups a block update re-fits.
    Block(&'b Block),
    /// None of the runs' peaks or σ draws (no run was re-fitted).
    NoRun,
    /// Those that belong to no one block (a material's mean over its contacts, a new
    /// contact's peak): the contacts' updates were made apart and merged, each having written
    /// its own.
    Merged,
    /// Those of an update of the block that belong to the independent blocks at positions
    /// `start..end` (one share of a split update, see [`Owners`]).
    Share(&'b Block, &'b Owners, usize, usize),
    /// Those of an update of the block that belong to no independent block (what is left of
    /// a split update once its shares are merged).
    Rest(&'b Block, &'b Owners),
}

/// Which independent block (its position among them) owns each coordinate, run and
/// marginalised σ group: the one whose update writes it. An update of a shared block whose
/// re-fitted runs and σ groups all have owners can be evaluated in shares of the independent
/// blocks, each share fitting its own contacts' runs at the proposal (MPI's split of a
/// material's update over the ranks that hold its contacts).
#[derive(Debug, Clone)]
pub(super) struct Owners {
    pub coord: Vec<Option<usize>>,
    pub run: Vec<Option<usize>>,
    pub group: Vec<Option<usize>>,
    /// Per block: whether its update splits so (see [`Owners::new`]).
    pub splits: Vec<bool>,
}

impl Owners {
    /// The owners among `blocks`, of which those from `first` on are independent, of the
    /// coordinates, runs (`runs`) and σ groups (each the runs in it, `group_runs`).
    ///
    /// A block's update splits when it is not independent, there are independent blocks, and
    /// a share needs nothing of the walker's cache beyond what it computes itself: every run
    /// it re-fits has an owner and re-fits with the slide it follows, and every σ group it
    /// touches has an owner and all the group's runs among the re-fitted.
    pub fn new(
        blocks: &[Block],
        first: usize,
        coords: usize,
        runs: &[RunModel],
        group_runs: &[&[usize]],
    ) -> Self {
        let mut owners = Self {
            coord: vec![None; coords],
            run: vec![None; runs.len()],
            group: vec![None; group_runs.len()],
            splits: vec![false; blocks.len()],
        };
        for (k, block) in blocks.iter().enumerate().skip(first) {
            let part = Some(k - first);
            for &i in &block.coords {
                owners.coord[i] = part;
            }
            for &i in &block.runs {
                owners.run[i] = part;
            }
            for (g, _) in block.groups.iter().enumerate().filter(|(_, &t)| t) {
                owners.group[g] = part;
            }
        }
        for (b, block) in blocks.iter().enumerate().take(first) {
            let refits = |i: &usize| block.runs.contains(i);
            owners.splits[b] = first < blocks.len()
                && block.runs.iter().all(|&i| {
                    owners.run[i].is_some() && runs[i].follows.is_none_or(|j| refits(&j))
                })
                && block
                    .groups
                    .iter()
                    .enumerate()
                    .filter(|(_, &t)| t)
                    .all(|(g, _)| owners.group[g].is_some() && group_runs[g].iter().all(refits));
        }
        owners
    }

    /// Whether `owner` is one of the positions `start..end`.
    pub fn within(owner: Option<usize>, start: usize, end: usize) -> bool {
        owner.is_some_and(|k| (start..end).contains(&k))
    }
}

/// A walker's cache, `blocks + 2 × runs + σ groups` values: the prior of each block, each
/// run's weighted sum of squared residuals, each run's F_end, and the likelihood of each
/// marginalised σ group.
pub(super) struct Cache<'c> {
    pub prior: &'c mut [f64],
    pub ssr: &'c mut [f64],
    pub last: &'c mut [f64],
    pub group: &'c mut [f64],
}

impl<'c> Cache<'c> {
    pub fn split(cache: &'c mut [f64], blocks: usize, runs: usize) -> Self {
        let (prior, rest) = cache.split_at_mut(blocks);
        let (ssr, rest) = rest.split_at_mut(runs);
        let (last, group) = rest.split_at_mut(runs);
        Self {
            prior,
            ssr,
            last,
            group,
        }
    }
}

/// Per block of `blocks`: whether it is conditionally independent of the other such blocks
/// given the rest (`population`: whether a block is a population's). It is when it carries no
/// followers, is no population, and its update re-fits no run, re-evaluates no prior and
/// touches no σ group that another such candidate's update does (a σ shared by several
/// contacts ties them together).
fn independent(blocks: &[Block], population: impl Fn(&Block) -> bool) -> Vec<bool> {
    let candidate: Vec<bool> = blocks
        .iter()
        .map(|b| !population(b) && b.links.followers.is_empty())
        .collect();
    // How many candidates touch each run, prior and σ group.
    let (runs, groups) = blocks
        .first()
        .map_or((0, 0), |b| (b.reads.len(), b.groups.len()));
    let (mut run_users, mut prior_users, mut group_users) =
        (vec![0; runs], vec![0; blocks.len()], vec![0; groups]);
    for block in blocks.iter().zip(&candidate).filter(|c| *c.1).map(|c| c.0) {
        for &r in &block.runs {
            run_users[r] += 1;
        }
        for &p in &block.priors {
            prior_users[p] += 1;
        }
        for (g, _) in block.groups.iter().enumerate().filter(|(_, &t)| t) {
            group_users[g] += 1;
        }
    }
    blocks
        .iter()
        .zip(candidate)
        .map(|(block, candidate)| {
            candidate
                && block.runs.iter().all(|&r| run_users[r] == 1)
                && block.priors.iter().all(|&p| prior_users[p] == 1)
                && block
                    .groups
                    .iter()
                    .enumerate()
                    .all(|(g, &t)| !t || group_users[g] == 1)
        })
        .collect()
}

impl Posterior {
    /// Length of a walker's cache.
    pub(super) fn cache_size(&self) -> usize {
        self.blocks.len() + 2 * self.runs.len() + self.sigma_groups.len()
    }

    /// The log-prior of block `b`'s coordinates at `x`.
    pub(super) fn block_prior(&self, b: usize, x: &[f64]) -> Result<f64, LogDensityError> {
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
                &CoordPrior::Population { mu, ln_s } => {
                    let z = (u - x[mu]) * (-x[ln_s]).exp();
                    -0.5 * z * z - x[ln_s] - LN_SQRT_2PI
                }
            };
        }
        Ok(lp)
    }

    /// The log-density at `x` evaluated in full, filling `cache` and `derived`. Without a
    /// cache (the optimiser's and the predictive's evaluations) the per-run and per-group
    /// parts go to a scratch buffer, and the block priors are only summed.
    pub(super) fn evaluate_full(
        &self,
        x: &[f64],
        derived: &mut [f64],
        cache: Option<Cache>,
    ) -> Result<f64, LogDensityError> {
        let Some(cache) = cache else {
            let runs = self.runs.len();
            let mut scratch = vec![0.0; 2 * runs + self.sigma_groups.len()];
            let (ssr, rest) = scratch.split_at_mut(runs);
            let (last, group) = rest.split_at_mut(runs);
            let cache = Cache {
                prior: &mut [],
                ssr,
                last,
                group,
            };
            return self.evaluate_full(x, derived, Some(cache));
        };
        // The same additions in the same order as `prior_sum` over a cache.
        let mut lp = 0.0;
        for b in 0..self.blocks.len() {
            let p = self.block_prior(b, x)?;
            if let Some(slot) = cache.prior.get_mut(b) {
                *slot = p;
            }
            lp += p;
        }
        for &i in &self.order {
            self.fit_run(i, x, cache.ssr, cache.last)?;
        }
        for g in 0..self.sigma_groups.len() {
            cache.group[g] = self.group_term(g, |i| cache.ssr[i])?;
        }
        Ok(self.finish(x, derived, lp, cache.ssr, cache.group, Changed::All))
    }

    /// The log-density at `x`, which differs from the point of `cache` and `derived` only in
    /// block `b` and its followers: re-evaluates their priors, the block's runs and their σ
    /// groups, and the peaks and σ draws it changes.
    pub(super) fn evaluate_block(
        &self,
        b: usize,
        x: &[f64],
        derived: &mut [f64],
        mut cache: Cache,
    ) -> Result<f64, LogDensityError> {
        let block = &self.blocks[b];
        let lp = self.refresh_priors(block, x, &mut cache)?;
        for &i in &block.runs {
            self.fit_run(i, x, cache.ssr, cache.last)?;
        }
        for (g, _) in block.groups.iter().enumerate().filter(|(_, &t)| t) {
            cache.group[g] = self.group_term(g, |i| cache.ssr[i])?;
        }
        Ok(self.finish(
            x,
            derived,
            lp,
            cache.ssr,
            cache.group,
            Changed::Block(block),
        ))
    }

    /// The log-density at `x`, which differs from the point of `cache` and `derived` only in
    /// the coordinates of block `b` itself (an exact draw of a population): re-evaluates the
    /// priors of the block and of its followers (the population's members), and the derived
    /// values; no run reads a population, so no run is re-fitted.
    pub(super) fn evaluate_block_alone(
        &self,
        b: usize,
        x: &[f64],
        derived: &mut [f64],
        mut cache: Cache,
    ) -> Result<f64, LogDensityError> {
        let lp = self.refresh_priors(&self.blocks[b], x, &mut cache)?;
        Ok(self.finish(x, derived, lp, cache.ssr, cache.group, Changed::NoRun))
    }

    /// Re-evaluates the priors `block` changes into `cache`; returns the sum of all blocks'
    /// priors (in block order, as a full evaluation sums them).
    fn refresh_priors(
        &self,
        block: &Block,
        x: &[f64],
        cache: &mut Cache,
    ) -> Result<f64, LogDensityError> {
        for &p in &block.priors {
            cache.prior[p] = self.block_prior(p, x)?;
        }
        let mut lp = 0.0;
        for p in cache.prior.iter() {
            lp += p;
        }
        Ok(lp)
    }

    /// The log-density at `x` from its cache alone (see
    /// [`IndependentBlocks::log_density_from_state`](crate::density::IndependentBlocks::log_density_from_state)):
    /// the sum of the cached priors, as [`refresh_priors`](Self::refresh_priors) and a full
    /// evaluation add them, and the cached likelihood parts, rewriting the derived values that
    /// are no one contact's.
    pub(super) fn evaluate_from_cache(&self, x: &[f64], derived: &mut [f64], cache: &[f64]) -> f64 {
        self.finish_from_cache(x, derived, cache, Changed::Merged)
    }

    /// The log-density at `x` summed from `cache` (its priors as a block update adds them),
    /// after rewriting the derived values that `changed`.
    fn finish_from_cache(
        &self,
        x: &[f64],
        derived: &mut [f64],
        cache: &[f64],
        changed: Changed,
    ) -> f64 {
        let (prior, rest) = cache.split_at(self.blocks.len());
        let (ssr, rest) = rest.split_at(self.runs.len());
        let group = &rest[self.runs.len()..];
        let mut lp = 0.0;
        for p in prior {
            lp += p;
        }
        self.finish(x, derived, lp, ssr, group, changed)
    }

    /// One share of an update of block `b` split by independent block (see [`Owners`]): at
    /// `x`, every prior the update re-evaluates (all shares alike: they are cheap, and a
    /// rejection by a prior must come first, as in [`evaluate_block`](Self::evaluate_block)),
    /// then the runs and σ groups of the independent blocks at positions `parts`, and their
    /// derived values. A failure carries its position in `evaluate_block`'s order: the
    /// priors, the re-fitted runs, then the σ groups by index.
    pub(super) fn evaluate_share_of(
        &self,
        b: usize,
        parts: Range<usize>,
        x: &[f64],
        derived: &mut [f64],
        cache: Cache,
    ) -> Result<(), ShareError> {
        let block = &self.blocks[b];
        let mine = |owner: Option<usize>| Owners::within(owner, parts.start, parts.end);
        let at = |position: usize| move |error| ShareError { position, error };
        for (k, &p) in block.priors.iter().enumerate() {
            cache.prior[p] = self.block_prior(p, x).map_err(at(k))?;
        }
        let runs_at = block.priors.len();
        for (k, &i) in block.runs.iter().enumerate() {
            if mine(self.owners.run[i]) {
                self.fit_run(i, x, cache.ssr, cache.last)
                    .map_err(at(runs_at + k))?;
            }
        }
        let groups_at = runs_at + block.runs.len();
        for (g, _) in block.groups.iter().enumerate().filter(|(_, &t)| t) {
            if mine(self.owners.group[g]) {
                cache.group[g] = self
                    .group_term(g, |i| cache.ssr[i])
                    .map_err(at(groups_at + g))?;
            }
        }
        if !derived.is_empty() {
            let changed = Changed::Share(block, &self.owners, parts.start, parts.end);
            self.derived_values(x, cache.ssr, derived, changed);
        }
        Ok(())
    }

    /// The entries of the derived values and of the cache that [`evaluate_share_of`]
    /// (Self::evaluate_share_of) writes for the independent blocks at positions `parts` and that
    /// the rest of the update does not: what a share hands back.
    pub(super) fn share_entries_of(
        &self,
        b: usize,
        parts: Range<usize>,
    ) -> (Vec<usize>, Vec<usize>) {
        let block = &self.blocks[b];
        let mine = |owner: Option<usize>| Owners::within(owner, parts.start, parts.end);
        let changed = Changed::Share(block, &self.owners, parts.start, parts.end);
        let derived = (0..self.sources.len())
            .filter(|&j| self.rewrites(&self.sources[j], changed))
            .collect();
        let (nblocks, nruns) = (self.blocks.len(), self.runs.len());
        let runs: Vec<usize> = block
            .runs
            .iter()
            .copied()
            .filter(|&i| mine(self.owners.run[i]))
            .collect();
        let cache = runs
            .iter()
            .map(|&i| nblocks + i)
            .chain(runs.iter().map(|&i| nblocks + nruns + i))
            .chain(
                (0..self.sigma_groups.len())
                    .filter(|&g| block.groups[g] && mine(self.owners.group[g]))
                    .map(|g| nblocks + 2 * nruns + g),
            )
            .collect();
        (derived, cache)
    }

    /// Finishes an update of block `b` split by independent block, from the merged `cache`:
    /// the log-density, summed as [`evaluate_block`](Self::evaluate_block) sums it, and the
    /// derived values that no independent block owns.
    pub(super) fn evaluate_rest(
        &self,
        b: usize,
        x: &[f64],
        derived: &mut [f64],
        cache: &[f64],
    ) -> f64 {
        let changed = Changed::Rest(&self.blocks[b], &self.owners);
        self.finish_from_cache(x, derived, cache, changed)
    }

    /// The log-density from the prior `lp` and the cache's likelihood parts, each run's
    /// weighted sum of squared residuals `ssr` and each σ group's term `group` (always in the
    /// same order), after writing the derived values that `changed`.
    fn finish(
        &self,
        x: &[f64],
        derived: &mut [f64],
        lp: f64,
        ssr: &[f64],
        group: &[f64],
        changed: Changed,
    ) -> f64 {
        let mut ll = self.run_terms(x, ssr);
        for &g in group[..self.sigma_groups.len()].iter() {
            ll += g;
        }
        if !derived.is_empty() {
            self.derived_values(x, ssr, derived, changed);
        }
        lp + ll
    }
}
