//! Updating a run of independent blocks in shares, some in other processes (an
//! executor that splits them, such as the ranks of an MPI job).
//!
//! The independent blocks of a density (one per contact in the friction posterior) may be
//! updated in any order with the same chains: each draws from streams keyed by the block and
//! accepts on its own terms. So they may also be updated at the same time, each share of them
//! by another process on its own copy of the walkers, as long as what each share changed is
//! merged back. This process sends the walkers' state as the run of blocks begins (a
//! [`RunRequest`]); a replica of the sampler in each other process
//! ([`EnsembleSampler::replica`]) updates its share from it and answers with what changed (a
//! [`RunOutcome`]): the entries of the positions, derived values, caches and slice scales
//! whose bits differ, and the counters' increments. This process updates its own share
//! meanwhile, applies the others' outcomes, and recomputes each walker's log-density and the
//! derived values that belong to no one block from the merged state, as after any run of
//! independent blocks. A copy's other blocks keep their earlier values, which no block's
//! update reads (that is what independence promises), so the merged state is the bits of
//! updates made one after another.
//!
//! Both messages are flat vectors of `u64` (an `f64` as its bits) and bytes (rejection labels
//! and a fatal message), for any transport.

use std::collections::BTreeMap;
use std::ops::Range;

use super::super::ensemble::{Ensemble, EnsembleState, Fatal, UpdateBlock};
use super::super::error::SamplerError;
use super::super::executor::share;
use super::super::moves::SLICE_MU0;
use super::construct::Layout;
use super::plan::{fresh_carry_fits, slice_slots};
use super::EnsembleSampler;
use super::SamplerConfig;
use crate::density::{LogDensity, Target};

/// The walkers' state as a run of independent blocks begins, for the other processes'
/// replicas: the step, the run of blocks (indices into the sampler's blocks), and per
/// ensemble the positions, log-densities, derived values, caches and slice scales, as bits.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RunRequest {
    config: SamplerConfig,
    words: Vec<u64>,
}

/// What one share of a run of independent blocks changed: the entries of the walkers'
/// positions, derived values, caches and slice scales whose bits differ from the request's, the
/// counters' increments, and the first fatal evaluation, if any.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct RunOutcome {
    words: Vec<u64>,
    text: Vec<u8>,
}

/// Values of a request before the ensembles' state: the step and the run's first and end
/// block.
const REQUEST_HEAD: usize = 3;

impl RunRequest {
    #[cfg(feature = "mpi")]
    /// The request as one vector (to send).
    pub(crate) fn words(&self) -> &[u64] {
        &self.words
    }

    #[cfg(feature = "mpi")]
    /// The configuration of the sampler that sent it, for its replicas
    /// ([`EnsembleSampler::replica`]).
    pub(crate) fn config(&self) -> &SamplerConfig {
        &self.config
    }

    #[cfg(feature = "mpi")]
    /// A request received as [`words`](Self::words), from a sampler with `config`.
    pub(crate) fn from_words(config: SamplerConfig, words: Vec<u64>) -> Self {
        Self { config, words }
    }

    /// The step at which the run is updated.
    pub(crate) fn step(&self) -> u64 {
        self.words[0]
    }

    /// The run of blocks, indices into the sampler's blocks.
    pub(crate) fn blocks(&self) -> Range<usize> {
        self.words[1] as usize..self.words[2] as usize
    }
}

impl RunOutcome {
    #[cfg(feature = "mpi")]
    /// The outcome as numbers and bytes (to send).
    pub(crate) fn parts(&self) -> (&[u64], &[u8]) {
        (&self.words, &self.text)
    }

    #[cfg(feature = "mpi")]
    /// An outcome received as [`parts`](Self::parts).
    pub(crate) fn from_parts(words: Vec<u64>, text: Vec<u8>) -> Self {
        Self { words, text }
    }
}

/// The blocks of share `r` of `shares` of the run `run` (see [`share`]).
fn blocks_of_share(run: &Range<usize>, shares: usize, r: usize) -> Range<usize> {
    let part = share(run.len(), shares, r);
    run.start + part.start..run.start + part.end
}

/// The arrays of an ensemble that a share's updates may change, in the order of an outcome's
/// flat indices: positions, derived values, caches, slice scales.
fn changeable(ens: &mut Ensemble) -> [&mut Vec<f64>; 4] {
    let Ensemble { s, cache, .. } = ens;
    [&mut s.positions, &mut s.derived, cache, &mut s.slice_scales]
}

/// A fatal evaluation of a share: the block (index into the sampler's blocks), the ensemble
/// and what failed.
pub(crate) type RunFatal = (usize, usize, Fatal);

/// Reads an outcome's words in order.
struct Reader<'o> {
    words: &'o [u64],
    text: &'o [u8],
    at: usize,
    text_at: usize,
}

impl Reader<'_> {
    fn word(&mut self) -> u64 {
        self.at += 1;
        self.words[self.at - 1]
    }

    fn text(&mut self, len: u64) -> String {
        let (from, to) = (self.text_at, self.text_at + len as usize);
        self.text_at = to;
        String::from_utf8_lossy(&self.text[from..to]).into_owned()
    }
}

impl<'a, D: LogDensity + ?Sized> EnsembleSampler<'a, D> {
    /// A sampler with the blocks and configuration of one whose runs of independent blocks
    /// another process splits, to update shares of them
    /// ([`update_share`](Self::update_share)) in this process. Its walkers are set by each
    /// request; it runs nothing else.
    ///
    /// # Errors
    /// As [`new`](Self::new), for an invalid configuration.
    pub(crate) fn replica(
        target: impl Into<Target<'a, D>>,
        config: SamplerConfig,
    ) -> Result<Self, SamplerError> {
        let target = target.into();
        let layout = Layout::new(target, &config)?;
        let (ndim, nderived, state_len) = (layout.ndim, layout.nderived, layout.state_len);
        let walkers = config.walkers();
        let states = (0..config.ensembles())
            .map(|e| {
                let (ensemble_rng, walker_rngs) = Ensemble::fresh_rngs(config.seed(), e, walkers);
                EnsembleState {
                    positions: vec![0.0; walkers * ndim],
                    log_density: vec![0.0; walkers],
                    derived: vec![0.0; walkers * nderived],
                    ensemble_rng,
                    walker_rngs,
                    accepted: vec![0; walkers],
                    rejections: BTreeMap::new(),
                    evaluations: 0,
                    slice_scales: vec![SLICE_MU0; slice_slots(&config, &layout.blocks)],
                    slice_updates: 0,
                    carry_fits: fresh_carry_fits(&layout.blocks),
                }
            })
            .collect();
        let caches = vec![vec![0.0; walkers * state_len]; config.ensembles()];
        // A replica keeps no chains: one row of history.
        Ok(Self::at_first_step(
            target.density(),
            layout,
            config,
            states,
            caches,
            1,
        ))
    }

    /// Whether the executor splits runs of independent blocks over its processes.
    pub(super) fn splits_runs(&mut self) -> bool {
        self.parallelism
            .executor()
            .is_some_and(|executor| executor.run_shares() >= 2)
    }

    /// Updates the independent blocks `run` in shares: the executor's other processes update
    /// theirs while this one updates the first share; then their outcomes are merged in.
    /// Returns the first fatal evaluation in block order.
    pub(super) fn update_run(
        &mut self,
        blocks: &[UpdateBlock<'a>],
        run: Range<usize>,
    ) -> Result<(), (usize, Fatal)> {
        // The first share is updated by this process with the executor out of the way: its
        // evaluations stay here.
        let mut parallelism = std::mem::take(&mut self.parallelism);
        let request = self.run_request(&run);
        let shares = match parallelism.executor() {
            Some(executor) => {
                executor.send_run(&request);
                executor.run_shares()
            }
            None => 1,
        };
        let mut fatal: Option<RunFatal> = None;
        for b in blocks_of_share(&run, shares, 0) {
            if let Err((e, f)) = self.update(Some((b, &blocks[b])), false) {
                fatal = Some((b, e, f));
                break;
            }
        }
        let outcomes = parallelism
            .executor()
            .map_or_else(Vec::new, |executor| executor.gather_run());
        self.parallelism = parallelism;
        for outcome in &outcomes {
            if let Some(f) = self.apply_outcome(outcome) {
                if fatal.as_ref().is_none_or(|g| f.0 < g.0) {
                    fatal = Some(f);
                }
            }
        }
        match fatal {
            Some((_, e, f)) => Err((e, f)),
            None => Ok(()),
        }
    }

    /// The walkers' state for the replicas, as the run `run` begins.
    fn run_request(&mut self, run: &Range<usize>) -> RunRequest {
        let mut words = vec![self.step, run.start as u64, run.end as u64];
        for ens in &mut self.ensembles {
            words.extend(ens.s.log_density.iter().map(|v| v.to_bits()));
            for array in changeable(ens) {
                words.push(array.len() as u64);
                words.extend(array.iter().map(|v| v.to_bits()));
            }
        }
        RunRequest {
            config: self.config.clone(),
            words,
        }
    }

    /// Whether `request` holds walkers of this sampler's shape: each array's length (sent
    /// before it) as this sampler's, but for an empty cache, which a sampler resumed from a
    /// checkpoint and one started afresh size differently.
    fn fits(&mut self, request: &RunRequest) -> bool {
        let words = &request.words;
        let (walkers, cache_len) = (self.config.walkers(), self.state_len);
        let mut at = REQUEST_HEAD;
        let blocks = request.blocks();
        if words.len() < REQUEST_HEAD || blocks.end > self.blocks.len() {
            return false;
        }
        for ens in &mut self.ensembles {
            at += walkers;
            for (k, array) in changeable(ens).into_iter().enumerate() {
                let Some(&len) = words.get(at) else {
                    return false;
                };
                let empty_cache = k == 2 && cache_len == 0 && len as usize == walkers;
                if len as usize != array.len() && !empty_cache {
                    return false;
                }
                at += 1 + len as usize;
            }
        }
        at == words.len()
    }

    /// In a replica: sets the walkers to `request`'s, updates the blocks of share `r` of
    /// `shares` of its run, and returns what changed.
    ///
    /// # Errors
    /// [`SamplerError::StateMismatch`] when the request's walkers do not have this sampler's
    /// shape (another density or configuration sent it).
    pub(crate) fn update_share(
        &mut self,
        request: &RunRequest,
        shares: usize,
        r: usize,
    ) -> Result<RunOutcome, SamplerError> {
        if !self.fits(request) {
            return Err(SamplerError::StateMismatch {
                detail: format!(
                    "a run of independent blocks was sent with {} values, which do not fit {} \
                     ensembles of {} walkers of this density ({} coordinates, {} derived \
                     values, {} cached values); every process must load the same model",
                    request.words.len(),
                    self.ensembles.len(),
                    self.config.walkers(),
                    self.ndim,
                    self.nderived,
                    self.state_len
                ),
            });
        }
        self.step = request.step();
        let mut at = REQUEST_HEAD;
        let words = &request.words;
        let mut take = |into: &mut Vec<f64>, sized: bool| {
            if sized {
                into.resize(words[at] as usize, 0.0);
                at += 1;
            }
            for (v, &w) in into.iter_mut().zip(&words[at..]) {
                *v = f64::from_bits(w);
            }
            at += into.len();
        };
        for ens in &mut self.ensembles {
            take(&mut ens.s.log_density, false);
            for array in changeable(ens) {
                take(array, true);
            }
            ens.s.accepted.fill(0);
            ens.s.rejections.clear();
            ens.s.evaluations = 0;
            ens.s.slice_updates = 0;
        }
        // An independent block is updated by the moves alone: no exact draw, no followers.
        // The walkers were just set from the request: the proposals' mirror is stale.
        self.work.mirror_fresh = false;
        let blocks = std::mem::take(&mut self.blocks);
        let mut fatal = None;
        for b in blocks_of_share(&request.blocks(), shares, r) {
            if let Err((e, f)) = self.update(Some((b, &blocks[b])), false) {
                fatal = Some((b, e, f));
                break;
            }
        }
        self.blocks = blocks;

        // What changed, against the request's values.
        let mut words = Vec::new();
        let mut text = Vec::new();
        let mut at = REQUEST_HEAD;
        for ens in &mut self.ensembles {
            at += ens.s.log_density.len();
            let mut changes = Vec::new();
            let mut flat = 0u64;
            for array in changeable(ens) {
                at += 1;
                for (v, &was) in array.iter().zip(&request.words[at..]) {
                    if v.to_bits() != was {
                        changes.extend([flat, v.to_bits()]);
                    }
                    flat += 1;
                }
                at += array.len();
            }
            words.push(changes.len() as u64 / 2);
            words.extend(changes);
            words.extend(&ens.s.accepted);
            words.extend([
                ens.s.evaluations,
                ens.s.slice_updates,
                ens.s.rejections.len() as u64,
            ]);
            for (label, &count) in &ens.s.rejections {
                words.extend([count, label.len() as u64]);
                text.extend_from_slice(label.as_bytes());
            }
        }
        match fatal {
            None => words.push(0),
            Some((b, e, f)) => {
                words.extend([1, b as u64, e as u64, f.walker as u64]);
                words.extend(f.position.iter().map(|v| v.to_bits()));
                words.push(f.message.len() as u64);
                text.extend_from_slice(f.message.as_bytes());
            }
        }
        Ok(RunOutcome { words, text })
    }

    /// Applies another process's outcome of its share: the changed entries, and the counters'
    /// increments. Returns its fatal evaluation, if any.
    fn apply_outcome(&mut self, outcome: &RunOutcome) -> Option<RunFatal> {
        let mut read = Reader {
            words: &outcome.words,
            text: &outcome.text,
            at: 0,
            text_at: 0,
        };
        for ens in &mut self.ensembles {
            let changes = read.word();
            let arrays = changeable(ens);
            let lens: Vec<u64> = arrays.iter().map(|a| a.len() as u64).collect();
            for _ in 0..changes {
                let (mut flat, bits) = (read.word(), read.word());
                let mut k = 0;
                while flat >= lens[k] {
                    flat -= lens[k];
                    k += 1;
                }
                arrays[k][flat as usize] = f64::from_bits(bits);
            }
            for a in &mut ens.s.accepted {
                *a += read.word();
            }
            ens.s.evaluations += read.word();
            ens.s.slice_updates += read.word();
            for _ in 0..read.word() {
                let count = read.word();
                let len = read.word();
                *ens.s.rejections.entry(read.text(len)).or_insert(0) += count;
            }
        }
        (read.word() == 1).then(|| {
            let (b, e, walker) = (read.word(), read.word(), read.word());
            let position = (0..self.ndim)
                .map(|_| f64::from_bits(read.word()))
                .collect();
            let len = read.word();
            let message = read.text(len);
            (
                b as usize,
                e as usize,
                Fatal {
                    walker: walker as usize,
                    position,
                    message,
                },
            )
        })
    }
}
