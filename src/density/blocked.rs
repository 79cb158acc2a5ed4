//! What a density with blocks offers the sampler, each capability a trait of its own.
//!
//! A [`BlockedDensity`] keeps, per walker, a state of the parts of its evaluation that a
//! block update reuses (say each group's likelihood), and lays out its blocks in a
//! [`BlockPlan`]. Each block of the plan says how it is updated ([`BlockUpdate`]), and the
//! variant carries the capability the update needs, so that a block cannot claim an update
//! the density does not provide:
//!
//! - [`BlockUpdate::Moves`]: by the ensemble moves in the block's subspace, each proposal
//!   re-evaluated by [`BlockedDensity::log_density_after_block`]; the density may carry the
//!   block's followers along ([`CarryFollowers`]) and split the evaluation by independent block
//!   ([`PlannedBlock::split`], [`SplitByPart`], for other processes).
//! - [`BlockUpdate::Exact`]: drawn exactly from its conditional ([`ExactConditional`]), and
//!   optionally moved with its followers carried as well ([`CarriedMove`]).
//! - [`BlockUpdate::Independent`]: conditionally independent of the other such blocks given the
//!   rest ([`IndependentBlocks`]): its update reads and writes only its own entries of the
//!   walker's state and derived values, and is accepted on its own terms of the log-density,
//!   so that its cost does not grow with the number of blocks. The walker's log-density, and
//!   the derived values that belong to no block, are brought up to date once after a run of
//!   such blocks ([`IndependentBlocks::log_density_from_state`]).
//!
//! # Example
//! A hierarchical normal, y_j ~ N(θ_j, 1), θ_j ~ N(μ, 1), μ ~ N(0, 10²): μ is a block moved by
//! the ensemble moves, each θ_j a block independent of the others given μ, whose update reads
//! and writes only its own entry of the walker's state (its group's terms).
//! ```
//! use slipbayes::density::{
//!     BlockLinks, BlockPlan, BlockUpdate, BlockedDensity, IndependentBlocks, LogDensity,
//!     LogDensityError, OwnEntries, PlannedBlock, Target,
//! };
//! use slipbayes::sampler::{EnsembleSampler, NullSink, SamplerConfig, Silent, Steps, Updates};
//!
//! struct Groups(Vec<f64>);
//!
//! impl Groups {
//!     /// Group j's terms: θ_j's prior given μ and y_j's likelihood (coordinates μ, θ_1, ...).
//!     fn group(&self, j: usize, x: &[f64]) -> f64 {
//!         let (t, r) = (x[j + 1] - x[0], self.0[j] - x[j + 1]);
//!         -0.5 * (t * t + r * r)
//!     }
//!     fn total(&self, x: &[f64], state: &[f64]) -> f64 {
//!         state.iter().fold(-0.5 * x[0] * x[0] / 100.0, |lp, s| lp + s)
//!     }
//! }
//!
//! impl LogDensity for Groups {
//!     fn dim(&self) -> usize {
//!         self.0.len() + 1
//!     }
//!     fn log_density(&self, x: &[f64], d: &mut [f64]) -> Result<f64, LogDensityError> {
//!         let mut state = vec![0.0; self.0.len()];
//!         self.log_density_with_state(x, d, &mut state)
//!     }
//! }
//!
//! impl BlockedDensity for Groups {
//!     fn state_len(&self) -> usize {
//!         self.0.len()
//!     }
//!     fn log_density_with_state(
//!         &self,
//!         x: &[f64],
//!         _d: &mut [f64],
//!         state: &mut [f64],
//!     ) -> Result<f64, LogDensityError> {
//!         for (j, s) in state.iter_mut().enumerate() {
//!             *s = self.group(j, x);
//!         }
//!         Ok(self.total(x, state))
//!     }
//!     fn log_density_after_block(
//!         &self,
//!         block: usize,
//!         x: &[f64],
//!         d: &mut [f64],
//!         state: &mut [f64],
//!     ) -> Result<f64, LogDensityError> {
//!         if block == 0 {
//!             return self.log_density_with_state(x, d, state);
//!         }
//!         state[block - 1] = self.group(block - 1, x);
//!         Ok(self.total(x, state))
//!     }
//!     fn block_plan(&self) -> BlockPlan<'_> {
//!         let mu = PlannedBlock {
//!             coords: vec![0],
//!             links: BlockLinks::default(),
//!             update: BlockUpdate::Moves { carry: None },
//!             split: None,
//!         };
//!         let groups = (0..self.0.len()).map(|j| PlannedBlock {
//!             coords: vec![j + 1],
//!             links: BlockLinks::default(),
//!             update: BlockUpdate::Independent {
//!                 own: self,
//!                 entries: OwnEntries { state: vec![j], derived: Vec::new() },
//!             },
//!             split: None,
//!         });
//!         BlockPlan { blocks: std::iter::once(mu).chain(groups).collect() }
//!     }
//! }
//!
//! impl IndependentBlocks for Groups {
//!     fn block_terms(&self, _block: usize, _x: &[f64], state: &[f64]) -> f64 {
//!         state[0]
//!     }
//!     fn update_block_state(
//!         &self,
//!         block: usize,
//!         x: &[f64],
//!         _d: &mut [f64],
//!         state: &mut [f64],
//!     ) -> Result<f64, LogDensityError> {
//!         state[0] = self.group(block - 1, x);
//!         Ok(state[0])
//!     }
//!     fn log_density_from_state(&self, x: &[f64], _d: &mut [f64], state: &[f64]) -> f64 {
//!         self.total(x, state)
//!     }
//! }
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let density = Groups(vec![0.5, -1.0, 2.0]);
//! let config = SamplerConfig::new(8, 2, 7)?.with_updates(Updates::Blocked);
//! let start: Vec<Vec<Vec<f64>>> = (0..2)
//!     .map(|e| (0..8).map(|w| (0..4).map(|i| 0.1 * ((w + 3 * i + e) % 7) as f64).collect()).collect())
//!     .collect();
//! let mut sampler = EnsembleSampler::new(Target::blocked(&density), config, start)?;
//! let report = sampler.run(Steps::Fixed(100), &mut NullSink, &mut Silent)?;
//! assert_eq!(report.total_steps, 100);
//! # Ok(())
//! # }
//! ```

use std::ops::Range;

use super::{LogDensity, LogDensityError};

/// A log-density whose coordinates fall into blocks that a sampler may update one at a time,
/// each cheaper to re-evaluate on its own than the whole density: typically the parameters
/// of one group of data given the parameters the groups share.
///
/// Every evaluation here must give the bits [`log_density`](LogDensity::log_density) gives at
/// the same point (and the same derived values): the sampler stores the value, and a resume
/// evaluates the walkers afresh.
pub trait BlockedDensity: LogDensity {
    /// Length of a walker's state: the parts of an evaluation that block updates reuse.
    fn state_len(&self) -> usize;

    /// [`log_density`](LogDensity::log_density) at `x` that also fills the walker's `state`
    /// (length [`state_len`](Self::state_len)).
    ///
    /// # Errors
    /// As [`log_density`](LogDensity::log_density).
    fn log_density_with_state(
        &self,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError>;

    /// The log-density at `x`, a point that differs from the one at which `derived` and
    /// `state` were computed only in the coordinates of `block` (an index into the plan's
    /// blocks) and of its followers; brings both up to date for `x`.
    ///
    /// # Errors
    /// As [`log_density`](LogDensity::log_density).
    fn log_density_after_block(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError>;

    /// The blocks (disjoint, covering every coordinate), how they depend on one another and
    /// how each is updated.
    fn block_plan(&self) -> BlockPlan<'_>;
}

/// The blocks of a [`BlockedDensity`], in the order a sweep updates them.
pub struct BlockPlan<'d> {
    /// The blocks.
    pub blocks: Vec<PlannedBlock<'d>>,
}

impl BlockPlan<'_> {
    /// The coordinates of every block.
    pub fn coords(&self) -> Vec<Vec<usize>> {
        self.blocks.iter().map(|b| b.coords.clone()).collect()
    }
}

/// One block of a [`BlockPlan`].
pub struct PlannedBlock<'d> {
    /// Its coordinates.
    pub coords: Vec<usize>,
    /// How it depends on the other blocks (read under hierarchical updates).
    pub links: BlockLinks,
    /// How it is updated.
    pub update: BlockUpdate<'d>,
    /// The evaluation of an update re-evaluated by
    /// [`log_density_after_block`](BlockedDensity::log_density_after_block) (a move of a block
    /// that is not independent) may be split by independent block, for other processes (see
    /// [`SplitByPart`]).
    pub split: Option<&'d dyn SplitByPart>,
}

/// How a block is updated, with what the update needs of the density.
pub enum BlockUpdate<'d> {
    /// By the ensemble moves, each proposal re-evaluated by
    /// [`log_density_after_block`](BlockedDensity::log_density_after_block).
    Moves {
        /// Under hierarchical updates, the density's own map carrying the block's followers
        /// along (else the sampler carries them by regression).
        carry: Option<&'d dyn CarryFollowers>,
    },
    /// Drawn exactly from its conditional given every other coordinate.
    Exact {
        /// The conditional.
        conditional: &'d dyn ExactConditional,
        /// Under hierarchical updates, also a move of the block with its followers carried
        /// along by the density's map, after the exact draw: the two parametrisations of a
        /// hierarchical model interweave (Yu & Meng 2011).
        carry: Option<CarriedMove<'d>>,
    },
    /// Conditionally independent of the plan's other independent blocks given every
    /// coordinate outside them: its update reads and writes only its own entries of the
    /// walker's state and derived values, and is accepted on the change of its own terms of
    /// the log-density. Such blocks may be updated in any order, or at once, with the same
    /// outcome. It has no followers.
    Independent {
        /// The block's terms and update.
        own: &'d dyn IndependentBlocks,
        /// The entries of the walker's state and derived values the update reads and writes.
        entries: OwnEntries,
    },
}

/// A move of a block drawn exactly, with its followers carried by the density's map.
#[derive(Clone, Copy)]
pub struct CarriedMove<'d> {
    /// The map.
    pub map: &'d dyn CarryFollowers,
    /// Whether the sampler may drop the move once its first
    /// [`CARRY_TUNE_STEPS`](crate::sampler::CARRY_TUNE_STEPS) steps have shown that it moves
    /// the block far less than the exact draw does (else both updates every step).
    pub optional: bool,
}

/// The entries of a walker's state and derived values that one independent block's update
/// reads and writes, each list in the order the update's compact buffers hold them. Those of
/// different independent blocks are disjoint (but for state entries the updates only read,
/// which none of them writes).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct OwnEntries {
    /// Indices into the walker's state.
    pub state: Vec<usize>,
    /// Indices into the derived values.
    pub derived: Vec<usize>,
}

/// How one block of a hierarchical density depends on the others: typically a group's own
/// parameters depend on the parameters shared between groups (its `given`), and the shared
/// parameters have every group's parameters as `followers`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct BlockLinks {
    /// Coordinates of other blocks through which alone this block's conditional depends on
    /// the rest: given them, the block is independent of every other coordinate.
    pub given: Vec<usize>,
    /// Coordinates of the blocks whose conditionals depend on this block (those that list
    /// it in their `given`).
    pub followers: Vec<usize>,
}

/// A block's conditional density given every other coordinate, cheap to evaluate (no
/// likelihood): typically the population level of a hierarchical model given its members.
pub trait ExactConditional: Sync {
    /// ln p(x_B | every other coordinate) for `block`, up to a constant that does not depend
    /// on x_B; −∞ outside the support. Between two points that differ only in block B it
    /// must change exactly as the log-density does (to rounding).
    fn conditional_log_density(&self, block: usize, x: &[f64]) -> f64;

    /// The log-density at `x`, which differs from the point of `derived` and `state` only in
    /// the coordinates of `block` itself (an exact draw moves no followers), bringing both up
    /// to date: the bits [`log_density_after_block`](BlockedDensity::log_density_after_block)
    /// returns there, skipping what only the followers change.
    ///
    /// # Errors
    /// As [`log_density`](LogDensity::log_density).
    fn log_density_after_draw(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError>;
}

/// The density's own map moving a block's followers along with the block.
pub trait CarryFollowers: Sync {
    /// Moves the followers of `block` along with it: `from` is the current point, `to` a
    /// copy of it with the block's coordinates already moved, whose followers this sets.
    /// Returns ln |det J| of the map from the followers' old values to their new ones at
    /// fixed block values, which the sampler adds to the proposal's log-ratio.
    ///
    /// The map must be a bijection whose inverse is the same map from `to` back to `from`,
    /// and the maps must compose: carrying from a to b and then from b to c is carrying from
    /// a to c. Both hold when the followers keep fixed coordinates of a reparametrisation, as
    /// in the non-centred map of a hierarchical model (each member keeps its standardised
    /// offset from the population). The slice move relies on the second: it evaluates every
    /// point of a walker's line carried from the walker, and the reverse update must find the
    /// same line.
    fn carry_followers(&self, block: usize, from: &[f64], to: &mut [f64]) -> f64;
}

/// The independent blocks of a density (see [`BlockUpdate::Independent`]): each block's own
/// terms of the log-density, its update on its own entries, and the walker's log-density from
/// its whole state once a run of such blocks is over.
pub trait IndependentBlocks: Sync {
    /// The terms of the log-density that depend on the coordinates of `block` at `x`, from
    /// the block's own `state` entries (in the order of its [`OwnEntries::state`]): between
    /// two points that differ only in the block they change exactly as the log-density does
    /// (to rounding).
    fn block_terms(&self, block: usize, x: &[f64], state: &[f64]) -> f64;

    /// Brings the block's own `state` and `derived` entries (in the order of its
    /// [`OwnEntries`]) up to date for `x`, a point that differs from theirs only in the
    /// block's coordinates, and returns [`block_terms`](Self::block_terms) there. Reads
    /// nothing of the walker but `x` and these entries.
    ///
    /// # Errors
    /// As [`log_density`](LogDensity::log_density), the first failure in the order in which
    /// [`log_density_after_block`](BlockedDensity::log_density_after_block) meets the terms.
    fn update_block_state(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<f64, LogDensityError>;

    /// The log-density at `x` from the walker's whole `state` after its independent blocks
    /// were updated (each writing its own entries): rewrites the derived values that belong
    /// to no block (functions of the whole point, such as a mean over the blocks) and returns
    /// the bits [`log_density_after_block`](BlockedDensity::log_density_after_block) would, so
    /// that the chains are those of whole updates made one after another.
    fn log_density_from_state(&self, x: &[f64], derived: &mut [f64], state: &[f64]) -> f64;
}

/// A failure in one share of a split block update ([`SplitByPart::evaluate_share`]).
#[derive(Debug, Clone, PartialEq)]
pub struct ShareError {
    /// Where the failing term comes in the order in which a whole evaluation of the update
    /// meets its terms.
    pub position: usize,
    /// The failure.
    pub error: LogDensityError,
}

impl ShareError {
    /// Keeps in `first` whichever of it and `other` comes first in the evaluation's order (on
    /// a tie, the one already there: every share meets the terms they share alike).
    pub fn keep_first(first: &mut Option<Self>, other: Self) {
        if first.as_ref().is_none_or(|f| other.position < f.position) {
            *first = Some(other);
        }
    }
}

/// The evaluation of an update of a block that every independent block depends on (a
/// parameter the groups share), split by independent block: each share evaluates, at the
/// proposal, the terms of its own independent blocks, and once their entries are merged the
/// update is finished from the state. Other processes, each holding some of the independent
/// blocks' data, evaluate their shares.
pub trait SplitByPart: Sync {
    /// The derived values and state entries (indices) that
    /// [`evaluate_share`](Self::evaluate_share) of `block` writes for the independent blocks
    /// at positions `parts` among the plan's independent blocks: what a share hands back.
    /// The shares' lists are disjoint.
    fn share_entries(&self, block: usize, parts: Range<usize>) -> OwnEntries;

    /// One share of the evaluation of an update of `block` at `x`: writes the entries
    /// [`share_entries`](Self::share_entries)`(block, parts)` of `derived` and `state`,
    /// reading none of their other entries (they may hold anything), and may write entries
    /// that belong to no independent block (every share computes them alike).
    ///
    /// # Errors
    /// [`ShareError`]: the first failure among the terms this share evaluates, with its
    /// position in the order in which
    /// [`log_density_after_block`](BlockedDensity::log_density_after_block) meets the update's
    /// terms, so that of several shares' failures the first in that order is the one a whole
    /// evaluation returns.
    fn evaluate_share(
        &self,
        block: usize,
        parts: Range<usize>,
        x: &[f64],
        derived: &mut [f64],
        state: &mut [f64],
    ) -> Result<(), ShareError>;

    /// Finishes an update of `block` split by independent block: `derived` and `state` hold
    /// the walker's values with every share's entries merged. Writes the derived values that
    /// belong to no independent block and returns the log-density, the bits
    /// [`log_density_after_block`](BlockedDensity::log_density_after_block) returns at `x`.
    /// What of the update belongs to no independent block must not fail (a density whose rest
    /// can fail does not split that block).
    fn log_density_from_shares(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        state: &[f64],
    ) -> f64;
}
