//! A half-step's proposals as an [`Executor`](super::Executor) evaluates them ([`Batch`]):
//! by item, here or elsewhere, or, for an update of a block every independent block depends
//! on, by independent block (each share evaluating its own blocks' terms at every proposal,
//! merged and finished here).

use std::ops::Range;

use rayon::prelude::*;

use super::super::evaluator::EvalKind;
use crate::density::{sort, Eval, LogDensityError, ShareError, SplitByPart};

/// Items `[r·n/R, (r+1)·n/R)` of `n` go to share `r` of `parts`: contiguous, balanced, and
/// fixed by `n` and the number of parts alone (a batch's proposals over ranks, a run of
/// independent blocks over shares).
pub(crate) fn share(n: usize, parts: usize, r: usize) -> Range<usize> {
    n * r / parts..n * (r + 1) / parts
}

/// A batch's evaluations split by independent block instead of by item (see
/// [`SplitByPart`]): the density's methods for the batch's block.
pub(crate) trait Shares: Sync {
    /// The entries (derived values, cache) that the share of parts `parts` writes.
    fn entries(&self, parts: Range<usize>) -> (Vec<usize>, Vec<usize>);
    /// [`SplitByPart::evaluate_share`].
    fn share(
        &self,
        parts: Range<usize>,
        x: &[f64],
        derived: &mut [f64],
        cache: &mut [f64],
    ) -> Result<(), ShareError>;
    /// [`SplitByPart::log_density_from_shares`].
    fn rest(&self, x: &[f64], derived: &mut [f64], cache: &[f64]) -> f64;
}

/// [`Shares`] of a density's updates of `block`.
pub(crate) struct BlockShares<'d> {
    pub(crate) split: &'d dyn SplitByPart,
    pub(crate) block: usize,
}

impl Shares for BlockShares<'_> {
    fn entries(&self, parts: Range<usize>) -> (Vec<usize>, Vec<usize>) {
        let entries = self.split.share_entries(self.block, parts);
        (entries.derived, entries.state)
    }

    fn share(
        &self,
        parts: Range<usize>,
        x: &[f64],
        derived: &mut [f64],
        cache: &mut [f64],
    ) -> Result<(), ShareError> {
        self.split
            .evaluate_share(self.block, parts, x, derived, cache)
    }

    fn rest(&self, x: &[f64], derived: &mut [f64], cache: &[f64]) -> f64 {
        self.split
            .log_density_from_shares(self.block, x, derived, cache)
    }
}

/// How another process evaluates its share of a batch split by part, from the points alone.
pub(crate) struct ShareApart<'s> {
    pub(crate) shares: &'s dyn Shares,
    pub(crate) nderived: usize,
    pub(crate) cache_len: usize,
    /// Whether to evaluate the points on the rayon pool.
    pub(crate) parallel: bool,
}

impl ShareApart<'_> {
    /// The share of parts `parts`, which writes `entries`, at every point: each point's
    /// failure, and the values of the entries point after point (zeros for a point that
    /// failed).
    pub(crate) fn evaluate(
        &self,
        parts: Range<usize>,
        entries: &ShareEntries,
        points: &[&[f64]],
    ) -> (Vec<Option<ShareError>>, Vec<f64>) {
        let width = entries.len();
        // A slot per point even for a share that writes nothing (more ranks than parts).
        let stride = width.max(1);
        let mut failures = vec![None; points.len()];
        let mut values = vec![0.0; points.len() * stride];
        let scratch = || (vec![0.0; self.nderived], vec![0.0; self.cache_len]);
        let eval =
            |(d, c): &mut (Vec<f64>, Vec<f64>),
             ((x, failure), out): ((&&[f64], &mut Option<ShareError>), &mut [f64])| {
                // NaN where the share must not read: a share that did would spoil its values.
                d.fill(f64::NAN);
                c.fill(f64::NAN);
                match self.shares.share(parts.clone(), x, d, c) {
                    Ok(()) => {
                        let written = entries.derived.iter().map(|&j| d[j]);
                        let written = written.chain(entries.cache.iter().map(|&j| c[j]));
                        out.iter_mut().zip(written).for_each(|(o, v)| *o = v);
                    }
                    Err(e) => *failure = Some(e),
                }
            };
        if self.parallel {
            points
                .par_iter()
                .zip(failures.par_iter_mut())
                .zip(values.par_chunks_mut(stride))
                .for_each_init(scratch, eval);
        } else {
            let mut buffers = scratch();
            points
                .iter()
                .zip(failures.iter_mut())
                .zip(values.chunks_mut(stride))
                .for_each(|item| eval(&mut buffers, item));
        }
        values.truncate(points.len() * width);
        (failures, values)
    }
}

/// The density's split of a batch that splits by part.
fn splitter(shares: Option<(&dyn Shares, usize)>) -> &dyn Shares {
    shares.expect("a batch split by part").0
}

/// One item of a batch in item order: its point, derived values, cache and outcome.
type ItemMut<'w> = (&'w [f64], &'w mut [f64], &'w mut [f64], &'w mut Eval);

/// One item of a batch: its derived values, cache and outcome.
type EvalItem<'w> = ((&'w mut [f64], &'w mut [f64]), &'w mut Eval);

/// The evaluation of one item in this process: the sampler's density behind the batch's kind.
type LocalEval<'b> = dyn Fn(EvalKind<'b>, &[f64], &mut [f64], &mut [f64]) -> Result<f64, LogDensityError>
    + Sync
    + 'b;

/// The proposals of one half-step to evaluate: `len()` items, each a point of `ndim()`
/// coordinates with buffers for the derived values and state it carries (inputs as well for
/// a block update, see [`EvalKind::reads_state`]) and a slot for its outcome.
pub(crate) struct Batch<'b> {
    pub(crate) kind: EvalKind<'b>,
    pub(crate) ndim: usize,
    /// Derived values and entries of state each item carries.
    pub(crate) nderived: usize,
    pub(crate) cache_len: usize,
    /// Their strides in the buffers below (at least 1).
    pub(crate) derived_stride: usize,
    pub(crate) state_stride: usize,
    /// Positions of the items in the buffers below (which hold skipped slots too).
    pub(crate) slots: &'b [usize],
    /// The points, `ndim` values each: the slot's row, or when `rows` is given, row
    /// `rows[slot]` (proposals made in place, in a mirror of the walkers' points).
    pub(crate) proposals: &'b [f64],
    pub(crate) rows: Option<&'b [usize]>,
    pub(crate) derived: &'b mut [f64],
    pub(crate) cache: &'b mut [f64],
    pub(crate) evals: &'b mut [Eval],
    pub(crate) local: &'b LocalEval<'b>,
    /// Whether this process evaluates its items on the rayon pool.
    pub(crate) parallel: bool,
    /// When the batch's block update splits by independent block: how, and into how many
    /// parts (the independent blocks).
    pub(crate) shares: Option<(&'b dyn Shares, usize)>,
}

/// The entries of one share of a batch split by independent block (see [`Batch::parts`]): the
/// indices of the derived values and of the cache entries it writes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct ShareEntries {
    /// Derived values.
    pub derived: Vec<usize>,
    /// Cache entries.
    pub cache: Vec<usize>,
}

impl ShareEntries {
    /// Values per item.
    pub fn len(&self) -> usize {
        self.derived.len() + self.cache.len()
    }
}

impl Batch<'_> {
    #[cfg(any(test, feature = "mpi"))]
    /// The evaluation asked for.
    pub fn kind(&self) -> EvalKind<'_> {
        self.kind
    }

    /// Number of items.
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    #[cfg(feature = "mpi")]
    /// Whether there is nothing to evaluate.
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    #[cfg(feature = "mpi")]
    /// Coordinates per point.
    pub fn ndim(&self) -> usize {
        self.ndim
    }

    #[cfg(any(test, feature = "mpi"))]
    /// Derived values each point carries.
    pub fn nderived(&self) -> usize {
        self.nderived
    }

    #[cfg(any(test, feature = "mpi"))]
    /// Entries of state each point carries.
    pub(crate) fn cache_len(&self) -> usize {
        self.cache_len
    }

    /// The point of item `k`.
    pub fn point(&self, k: usize) -> &[f64] {
        point_of(self.proposals, self.rows, self.ndim, self.slots[k])
    }

    #[cfg(any(test, feature = "mpi"))]
    /// The derived values of item `k` (the walker's before, the point's after evaluation).
    pub fn derived(&self, k: usize) -> &[f64] {
        let (s, stride) = (self.slots[k], self.derived_stride);
        &self.derived[s * stride..s * stride + self.nderived]
    }

    #[cfg(any(test, feature = "mpi"))]
    /// The cache of item `k` (the walker's before, the point's after evaluation).
    pub fn cache(&self, k: usize) -> &[f64] {
        let (s, stride) = (self.slots[k], self.state_stride);
        &self.cache[s * stride..s * stride + self.cache_len]
    }

    #[cfg(any(test, feature = "mpi"))]
    /// Stores the outcome of item `k` evaluated elsewhere: its value and the derived values
    /// and cache it left.
    pub(crate) fn set_outcome(
        &mut self,
        k: usize,
        result: Result<f64, LogDensityError>,
        derived: &[f64],
        cache: &[f64],
    ) {
        let s = self.slots[k];
        let (d, c) = (self.derived_stride, self.state_stride);
        self.derived[s * d..s * d + self.nderived].copy_from_slice(derived);
        self.cache[s * c..s * c + self.cache_len].copy_from_slice(cache);
        self.evals[s] = sort(result);
    }

    /// Into how many parts (independent blocks) the batch's evaluations may be split instead
    /// of by item: 0 when they may not. Split, every share evaluates the terms of its parts for
    /// every item ([`evaluate_share_here`](Self::evaluate_share_here),
    /// [`evaluate_share_apart`](Self::evaluate_share_apart)), and the items are finished once
    /// the shares are merged ([`finish_shares`](Self::finish_shares)).
    pub fn parts(&self) -> usize {
        self.shares.map_or(0, |(_, parts)| parts)
    }

    /// What the share of parts `parts` writes of each item.
    ///
    /// # Panics
    /// When the batch does not split by part.
    pub fn share_entries(&self, parts: Range<usize>) -> ShareEntries {
        let (derived, cache) = splitter(self.shares).entries(parts);
        ShareEntries { derived, cache }
    }

    /// Evaluates the share of parts `parts` of every item in place, on the walkers' derived
    /// values and caches (the share that stays in this process); returns each item's failure.
    ///
    /// # Panics
    /// When the batch does not split by part.
    pub(crate) fn evaluate_share_here(&mut self, parts: Range<usize>) -> Vec<Option<ShareError>> {
        let splitter = splitter(self.shares);
        let parallel = self.parallel;
        let eval = |(x, d, c, _): ItemMut| splitter.share(parts.clone(), x, d, c).err();
        let items = self.items_mut();
        if parallel {
            items.into_par_iter().map(eval).collect()
        } else {
            items.into_iter().map(eval).collect()
        }
    }

    /// Each item's point, derived values, cache and outcome, in item order.
    fn items_mut(&mut self) -> Vec<ItemMut<'_>> {
        let (ndim, nderived, cache_len) = (self.ndim, self.nderived, self.cache_len);
        let proposals = self.proposals;
        let mut wanted = self.slots.iter().peekable();
        let mut items = Vec::with_capacity(self.slots.len());
        for (s, ((d, c), e)) in self
            .derived
            .chunks_mut(self.derived_stride)
            .zip(self.cache.chunks_mut(self.state_stride))
            .zip(self.evals.iter_mut())
            .enumerate()
        {
            if wanted.next_if_eq(&&s).is_some() {
                let x = point_of(proposals, self.rows, ndim, s);
                items.push((x, &mut d[..nderived], &mut c[..cache_len], e));
            }
        }
        items
    }

    /// Evaluates the share of parts `parts`, which writes `entries`
    /// ([`share_entries`](Self::share_entries)), of every item apart from the walkers'
    /// values, as another process does with the points alone: each item's failure, and the
    /// values of the entries item after item (zeros for an item that failed).
    ///
    /// # Panics
    /// When the batch does not split by part.
    pub(crate) fn evaluate_share_apart(
        &self,
        parts: Range<usize>,
        entries: &ShareEntries,
    ) -> (Vec<Option<ShareError>>, Vec<f64>) {
        let points: Vec<&[f64]> = (0..self.len()).map(|k| self.point(k)).collect();
        let apart = ShareApart {
            shares: splitter(self.shares),
            nderived: self.nderived,
            cache_len: self.cache_len,
            parallel: self.parallel,
        };
        apart.evaluate(parts, entries, &points)
    }

    /// Merges another share's outcome into every item: its `values` of `entries` where it
    /// succeeded, and where it failed, its failure into `failures` if it comes before the
    /// failure kept there (see [`ShareError::keep_first`]).
    pub(crate) fn merge_share(
        &mut self,
        failures: &mut [Option<ShareError>],
        entries: &ShareEntries,
        (their_failures, values): (Vec<Option<ShareError>>, Vec<f64>),
    ) {
        let width = entries.len();
        for (k, failure) in their_failures.into_iter().enumerate() {
            match failure {
                Some(f) => ShareError::keep_first(&mut failures[k], f),
                None => self.store_share(k, entries, &values[k * width..(k + 1) * width]),
            }
        }
    }

    /// Stores into item `k` the `values` of another share's `entries`.
    pub(crate) fn store_share(&mut self, k: usize, entries: &ShareEntries, values: &[f64]) {
        let s = self.slots[k];
        let (d, c) = (self.derived_stride, self.state_stride);
        let (from_derived, from_cache) = values.split_at(entries.derived.len());
        for (&j, &v) in entries.derived.iter().zip(from_derived) {
            self.derived[s * d + j] = v;
        }
        for (&j, &v) in entries.cache.iter().zip(from_cache) {
            self.cache[s * c + j] = v;
        }
    }

    /// Finishes every item of a batch split by part once every share is in: an item that
    /// failed in a share fails with `failures[k]`, the share's failure first in the density's
    /// order; the others are finished from their merged caches.
    ///
    /// # Panics
    /// When the batch does not split by part.
    pub(crate) fn finish_shares(&mut self, failures: Vec<Option<ShareError>>) {
        let splitter = splitter(self.shares);
        let parallel = self.parallel;
        let finish = |((x, d, c, e), failure): (ItemMut, Option<ShareError>)| {
            *e = sort(match failure {
                Some(f) => Err(f.error),
                None => Ok(splitter.rest(x, d, c)),
            });
        };
        let items = self.items_mut();
        assert_eq!(items.len(), failures.len(), "one failure slot per item");
        if parallel {
            items.into_par_iter().zip(failures).for_each(finish);
        } else {
            items.into_iter().zip(failures).for_each(finish);
        }
    }

    /// Evaluates items `items` in this process (on the rayon pool when the sampler evaluates
    /// in parallel), exactly as the sampler does without an offload.
    pub(crate) fn evaluate_here(&mut self, items: Range<usize>) {
        let mut wanted = vec![false; self.evals.len()];
        for &s in &self.slots[items] {
            wanted[s] = true;
        }
        let (kind, ndim, nderived, cache_len) =
            (self.kind, self.ndim, self.nderived, self.cache_len);
        let local = self.local;
        let (proposals, rows) = (self.proposals, self.rows);
        let eval = |(s, ((d, c), e)): (usize, EvalItem)| {
            if wanted[s] {
                let x = point_of(proposals, rows, ndim, s);
                *e = sort(local(kind, x, &mut d[..nderived], &mut c[..cache_len]));
            }
        };
        let (dstride, cstride) = (self.derived_stride, self.state_stride);
        let slots = self.evals.len();
        if self.parallel {
            self.derived
                .par_chunks_mut(dstride)
                .take(slots)
                .zip(self.cache.par_chunks_mut(cstride))
                .zip(self.evals.par_iter_mut())
                .enumerate()
                .for_each(eval);
        } else {
            self.derived
                .chunks_mut(dstride)
                .take(slots)
                .zip(self.cache.chunks_mut(cstride))
                .zip(self.evals.iter_mut())
                .enumerate()
                .for_each(eval);
        }
    }
}

/// The point of slot `s` in `proposals`: its own row, or row `rows[s]`.
fn point_of<'p>(proposals: &'p [f64], rows: Option<&[usize]>, ndim: usize, s: usize) -> &'p [f64] {
    let r = rows.map_or(s, |rows| rows[s]);
    &proposals[r * ndim..(r + 1) * ndim]
}
