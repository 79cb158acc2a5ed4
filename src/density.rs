//! The contract between models and the algorithms that explore them: a log-density over a
//! slice of `f64` ([`LogDensity`]), and what its columns report ([`Quantity`]).
//!
//! The sampler and the optimisers see a model only through [`LogDensity`]; a fit reports the
//! density's columns as the [`Quantity`]s the model names (a name, a group such as a material,
//! a unit). Neither side knows anything of friction.

use std::ops::Range;

use thiserror::Error;

/// Why a log-density could not be evaluated at a point.
///
/// The split mirrors what a sampler can do about it: a [`Rejected`](Self::Rejected) point is
/// simply not accepted (and counted under its label), a [`Fatal`](Self::Fatal) one stops the
/// run because the model itself is broken.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum LogDensityError {
    /// The point is outside the support or the model cannot be evaluated there for a reason
    /// that says nothing bad about the model (e.g. `"out_of_support"`, `"stick_slip"`). The
    /// proposal is rejected and counted under `reason`.
    #[error("point rejected: {reason}")]
    Rejected {
        /// Short label under which rejections are counted.
        reason: &'static str,
    },
    /// A genuine fault (a bug, an inconsistent model): the run stops with this message.
    #[error("fatal: {message}")]
    Fatal {
        /// What went wrong, for a human.
        message: String,
    },
}

impl LogDensityError {
    /// A recoverable rejection counted under `reason`.
    pub fn rejected(reason: &'static str) -> Self {
        Self::Rejected { reason }
    }

    /// A fatal fault with a message.
    pub fn fatal(message: impl Into<String>) -> Self {
        Self::Fatal {
            message: message.into(),
        }
    }

    /// Whether the sampler may carry on after this error (by rejecting the point).
    pub fn is_recoverable(&self) -> bool {
        matches!(self, Self::Rejected { .. })
    }
}

/// A failure in one share of a split block update
/// ([`LogDensity::log_density_block_share`]).
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

/// Rejection label used when a density returns NaN.
pub const REJECT_NAN: &str = "nan";
/// Rejection label used when a density returns −∞.
pub const REJECT_NEG_INFINITY: &str = "neg_infinity";

/// An unnormalised log-density (log-posterior) over `dim()` real parameters.
///
/// Must be pure: the same `x` gives the same result on any thread, because the sampler
/// evaluates the points of half an ensemble in parallel and promises bit-identical chains
/// however many threads run.
///
/// Derived quantities (emcee's "blobs") are written by the same call that computes the
/// log-density, because they usually share its work (a forward model evaluated once); the
/// caller owns the buffer so that the hot loop allocates nothing.
pub trait LogDensity: Sync {
    /// Number of sampled parameters.
    fn dim(&self) -> usize;

    /// Names of the sampled parameters (stored with the chains); `x0, x1, …` by default.
    fn param_names(&self) -> Vec<String> {
        (0..self.dim()).map(|i| format!("x{i}")).collect()
    }

    /// Units of the sampled parameters, in the order of [`param_names`](Self::param_names),
    /// stored with the chains; empty (the default) when the density does not declare them.
    fn param_units(&self) -> Vec<ColumnUnit> {
        Vec::new()
    }

    /// Names of the derived quantities written by [`log_density`](Self::log_density); none
    /// by default.
    fn derived_names(&self) -> Vec<String> {
        Vec::new()
    }

    /// The log-density at `x` (length [`dim`](Self::dim)), writing the derived quantities
    /// into `derived` (length `derived_names().len()`).
    ///
    /// Returning NaN or −∞ is treated like [`LogDensityError::Rejected`] (labels
    /// [`REJECT_NAN`], [`REJECT_NEG_INFINITY`]); +∞ is fatal, since it would absorb the chain.
    ///
    /// # Errors
    /// [`LogDensityError::Rejected`] outside the support, [`LogDensityError::Fatal`] on faults.
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError>;

    /// Why the density is not finite at `x`, in the density's own terms (which part of the
    /// model fails and how), for error messages; `None` (the default) when it cannot say.
    fn explain(&self, _x: &[f64]) -> Option<String> {
        None
    }

    /// Blocks of coordinates that a sampler may update one at a time (disjoint, covering every
    /// coordinate), each cheaper to re-evaluate on its own than the whole density: typically
    /// the parameters of one group of data given the parameters shared between groups. Empty
    /// (the default): no such structure, every update re-evaluates everything.
    fn blocks(&self) -> Vec<Vec<usize>> {
        Vec::new()
    }

    /// How the blocks depend on one another, one entry per block of [`blocks`](Self::blocks)
    /// (empty, the default: nothing declared). A sampler may use it to propose a block from
    /// its conditional given the coordinates it depends on, and to carry the coordinates that
    /// depend on a block along when that block moves.
    fn block_links(&self) -> Vec<BlockLinks> {
        Vec::new()
    }

    /// Coordinates in which to search for a mode (and draw the first walkers around it), for a
    /// density that has none in its own: a centred hierarchical model is unbounded where a
    /// population's spread vanishes with its members at its mean, and has a mode in the
    /// non-centred coordinates. `None` (the default): search in the density's own.
    fn search_map(&self) -> Option<&dyn SearchMap> {
        None
    }

    /// Blocks (indices into [`blocks`](Self::blocks)) whose conditional density given every
    /// other coordinate [`conditional_log_density`](Self::conditional_log_density) evaluates
    /// cheaply, without the likelihood: typically the population level of a hierarchical
    /// model (a mean and a spread) given its members' values. A sampler may then update such
    /// a block exactly, by slice sampling that conditional, instead of by ensemble moves.
    /// Empty (the default): none.
    fn conditional_blocks(&self) -> Vec<usize> {
        Vec::new()
    }

    /// ln p(x_B | every other coordinate) for a block B of
    /// [`conditional_blocks`](Self::conditional_blocks), up to a constant that does not depend
    /// on x_B; −∞ outside the support. Between two points that differ only in block B it must
    /// change exactly as [`log_density`](Self::log_density) does (to rounding). NaN by default.
    fn conditional_log_density(&self, block: usize, x: &[f64]) -> f64 {
        let _ = (block, x);
        f64::NAN
    }

    /// Whether the density moves the followers of `block` along itself, by
    /// [`carry_followers`](Self::carry_followers), when a move changes the block (false by
    /// default: a sampler carries them by regression, or not at all).
    fn carries_followers(&self, block: usize) -> bool {
        let _ = block;
        false
    }

    /// Whether the sampler may stop moving a block that is both drawn exactly
    /// ([`conditional_blocks`](Self::conditional_blocks)) and carried
    /// ([`carries_followers`](Self::carries_followers)) by the moves, once its first
    /// [`CARRY_TUNE_STEPS`](crate::sampler::CARRY_TUNE_STEPS) steps have shown that the
    /// carried move shifts the block far less than the exact draw (false by default: both
    /// updates every step).
    fn carried_move_optional(&self, block: usize) -> bool {
        let _ = block;
        false
    }

    /// Moves the followers of `block` (see [`block_links`](Self::block_links)) along with the
    /// block: `from` is the current point, `to` a copy of it with the block's coordinates
    /// already moved, whose followers this sets. Returns ln |det J| of the map from the
    /// followers' old values to their new ones at fixed block values, which the sampler adds
    /// to the proposal's log-ratio. The map must be a bijection whose inverse is the same map
    /// from `to` back to `from`, and the maps must compose: carrying from a to b and then from
    /// b to c is carrying from a to c. Both hold when the followers keep fixed coordinates of
    /// a reparametrisation, as in the non-centred map of a hierarchical model (each member
    /// keeps its standardised offset from the population). The slice move relies on the
    /// second: it evaluates every point of a walker's line carried from the walker, and the
    /// reverse update must find the same line. Unused unless
    /// [`carries_followers`](Self::carries_followers) says so.
    fn carry_followers(&self, block: usize, from: &[f64], to: &mut [f64]) -> f64 {
        let _ = (block, from, to);
        0.0
    }

    /// Blocks (indices into [`blocks`](Self::blocks)) that are conditionally independent of
    /// one another given every coordinate outside them, each with its own terms of the
    /// log-density ([`block_log_density`](Self::block_log_density)): typically one block per
    /// group of data (a contact) given the parameters the groups share. A sampler may then
    /// update them in any order, or all at once, with the same outcome: it accepts a move of
    /// such a block on the change of the block's own terms, and draws its random numbers from
    /// streams keyed by the block, not from a stream the other blocks' updates advance.
    /// Such a block must have no followers, be no [`conditional`](Self::conditional_blocks)
    /// block, and its update must write only its own cache entries and derived values
    /// (besides derived values that are functions of the point alone). Empty (the default):
    /// none.
    fn independent_blocks(&self) -> Vec<usize> {
        Vec::new()
    }

    /// The terms of the log-density that depend on the coordinates of `block`, one of
    /// [`independent_blocks`](Self::independent_blocks), at `x` with its `cache` (as
    /// [`log_density_block`](Self::log_density_block) left it): between two points that
    /// differ only in the block it must change exactly as the log-density does (to rounding),
    /// and it must read only the block's own coordinates, coordinates outside every
    /// independent block, and the cache entries the block's update writes. NaN by default.
    fn block_log_density(&self, block: usize, x: &[f64], cache: &[f64]) -> f64 {
        let _ = (block, x, cache);
        f64::NAN
    }

    /// The log-density at `x` from its `cache` alone, after updates of
    /// [`independent blocks`](Self::independent_blocks) made apart (each on a copy of the walker
    /// whose other blocks kept their earlier values) have been merged into `x`, `cache` and
    /// `derived`: rewrites the derived values that belong to no one independent block (functions
    /// of the whole point, such as a mean over the blocks) and returns the log-density. It must
    /// return the bits that [`log_density_block`](Self::log_density_block) and
    /// [`log_density_cached`](Self::log_density_cached) return at `x`, and leave every derived
    /// value as they leave it, so that updates made apart and merged give the chains of
    /// updates made one after another. `None` (the default): the density cannot, and a sampler
    /// updates its independent blocks in one process.
    fn log_density_from_cache(&self, x: &[f64], derived: &mut [f64], cache: &[f64]) -> Option<f64> {
        let _ = (x, derived, cache);
        None
    }

    /// Whether the evaluation of an update of `block`, a block outside the
    /// [`independent blocks`](Self::independent_blocks) that every one of them depends on (a
    /// parameter the contacts share), can be split by independent block: each share evaluates,
    /// at the proposal, the terms of its own independent blocks
    /// ([`log_density_block_share`](Self::log_density_block_share)), and once their entries
    /// are merged the update is finished from the cache
    /// ([`log_density_block_rest`](Self::log_density_block_rest)). False by default.
    fn block_splits(&self, block: usize) -> bool {
        let _ = block;
        false
    }

    /// The derived values and cache entries (indices) that
    /// [`log_density_block_share`](Self::log_density_block_share) of `block` writes for the
    /// independent blocks at positions `parts` of
    /// [`independent_blocks`](Self::independent_blocks): what a share must hand back. The
    /// shares' lists are disjoint. Empty by default.
    fn block_share_entries(&self, block: usize, parts: Range<usize>) -> (Vec<usize>, Vec<usize>) {
        let _ = (block, parts);
        (Vec::new(), Vec::new())
    }

    /// One share of the evaluation of an update of `block` (see
    /// [`block_splits`](Self::block_splits)) at `x`: writes the entries
    /// [`block_share_entries`](Self::block_share_entries)`(block, parts)` of `derived` and
    /// `cache`, reading none of their other entries (they may hold anything), and may write
    /// entries that belong to no independent block (every share computes them alike). A failure
    /// comes with its position in the order in which
    /// [`log_density_block`](Self::log_density_block) meets the update's terms, so that of
    /// several shares' failures the first in that order is the one a whole evaluation returns.
    ///
    /// # Errors
    /// [`ShareError`]: the first failure among the terms this share evaluates.
    fn log_density_block_share(
        &self,
        block: usize,
        parts: Range<usize>,
        x: &[f64],
        derived: &mut [f64],
        cache: &mut [f64],
    ) -> Result<(), ShareError> {
        let _ = (block, parts, x, derived, cache);
        Err(ShareError {
            position: 0,
            error: LogDensityError::fatal("this density does not split its block updates"),
        })
    }

    /// Finishes an update of `block` split by independent block: `derived` and `cache` hold
    /// the walker's values with the entries of one share evaluated in place and every other
    /// share's entries merged. Writes the derived values that belong to no independent block
    /// and returns the log-density, the bits [`log_density_block`](Self::log_density_block)
    /// returns at `x`. Whatever of the update belongs to no independent block must not fail
    /// (a density whose rest can fail does not split that block). NaN by default.
    fn log_density_block_rest(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        cache: &[f64],
    ) -> f64 {
        let _ = (block, x, derived, cache);
        f64::NAN
    }

    /// Length of the per-point cache that [`log_density_cached`](Self::log_density_cached)
    /// fills and [`log_density_block`](Self::log_density_block) reuses (0 by default).
    fn cache_len(&self) -> usize {
        0
    }

    /// [`log_density`](Self::log_density) that also fills `cache` (length
    /// [`cache_len`](Self::cache_len)) with the parts of the evaluation a block update reuses.
    ///
    /// # Errors
    /// As [`log_density`](Self::log_density).
    fn log_density_cached(
        &self,
        x: &[f64],
        derived: &mut [f64],
        cache: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        let _ = cache;
        self.log_density(x, derived)
    }

    /// The log-density at `x`, a point that differs only in the coordinates of
    /// `blocks()[block]` and of its [`followers`](BlockLinks::followers) (when
    /// [`block_links`](Self::block_links) declares any) from the point at which `derived` and
    /// `cache` were computed; brings
    /// both up to date for `x`. Must return exactly what
    /// [`log_density_cached`](Self::log_density_cached) returns at `x` (the sampler stores the
    /// value and a resume re-evaluates it in full). By default a full evaluation.
    ///
    /// # Errors
    /// As [`log_density`](Self::log_density).
    fn log_density_block(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        cache: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        let _ = block;
        self.log_density_cached(x, derived, cache)
    }

    /// [`log_density_block`](Self::log_density_block) at a point that differs from the cache's
    /// only in the coordinates of `block` itself, its followers staying where they are (an
    /// exact conditional draw moves no followers): the density may skip the parts that only
    /// the followers change. By default [`log_density_block`](Self::log_density_block).
    ///
    /// # Errors
    /// As [`log_density`](Self::log_density).
    fn log_density_block_alone(
        &self,
        block: usize,
        x: &[f64],
        derived: &mut [f64],
        cache: &mut [f64],
    ) -> Result<f64, LogDensityError> {
        self.log_density_block(block, x, derived, cache)
    }
}

/// A bijection between a density's coordinates x and the coordinates y of
/// [`LogDensity::search_map`]. The density of y is p(x(y)) |det ∂x/∂y|.
pub trait SearchMap: Sync {
    /// y of `x`, written into `y`.
    fn search_point(&self, x: &[f64], y: &mut [f64]);
    /// x of `y`, written into `x`; returns ln |det ∂x/∂y| at `y`.
    fn density_point(&self, y: &[f64], x: &mut [f64]) -> f64;
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

/// Outcome of one evaluation after the sampler's classification of raw values.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Eval {
    /// A finite log-density.
    Finite(f64),
    /// A recoverable rejection, counted under the label.
    Rejected(&'static str),
    /// The run must stop.
    Fatal(String),
}

/// Sorts the result of an evaluation into finite, rejected or fatal.
pub(crate) fn sort(result: Result<f64, LogDensityError>) -> Eval {
    match result {
        Ok(v) if v.is_finite() => Eval::Finite(v),
        Ok(v) if v.is_nan() => Eval::Rejected(REJECT_NAN),
        Ok(v) if v < 0.0 => Eval::Rejected(REJECT_NEG_INFINITY),
        Ok(_) => Eval::Fatal("log-density is +inf".to_string()),
        Err(LogDensityError::Rejected { reason }) => Eval::Rejected(reason),
        Err(LogDensityError::Fatal { message }) => Eval::Fatal(message),
    }
}

/// Whether a quantity is reported as a model parameter or as a derived value.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum QuantityKind {
    /// A parameter (or hyper-parameter) of the model: the `parameters` list of a summary.
    Parameter,
    /// A function of the parameters (a peak, a slip distance, ...): the `derived` list.
    Derived,
}

impl QuantityKind {
    /// `"parameter"` or `"derived"`, as in `summary.csv`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Parameter => "parameter",
            Self::Derived => "derived",
        }
    }
}

/// The unit of a column of a density's draws, as stored with the chains.
#[derive(Debug, Clone, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub struct ColumnUnit {
    /// SI unit of the quantity (`1` dimensionless); empty when not declared.
    pub unit: String,
    /// Whether the column holds the natural logarithm of the quantity in `unit` (a
    /// coordinate u = ln θ) rather than the quantity itself.
    pub log: bool,
}

/// One reported quantity: which column of a density's draws holds it (a sampled coordinate or
/// a derived value) and how it is reported.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Quantity {
    /// The column (a name from [`LogDensity::param_names`] or [`LogDensity::derived_names`]).
    pub column: String,
    /// Reported name (e.g. `"F_peak"`); several groups may share it.
    pub name: String,
    /// Group (material, contact, run, ...); may be empty.
    pub group: String,
    /// SI unit, for humans (e.g. `"N"`, `"1/m"`); may be empty.
    pub unit: String,
    /// The list it is reported in.
    pub kind: QuantityKind,
}

impl Quantity {
    /// `name[group]`, or `name` when the group is empty: how messages refer to it.
    pub fn label(&self) -> String {
        label(&self.name, &self.group)
    }
}

/// `name[group]`, or `name` when `group` is empty.
pub fn label(name: &str, group: &str) -> String {
    if group.is_empty() {
        name.to_owned()
    } else {
        format!("{name}[{group}]")
    }
}
