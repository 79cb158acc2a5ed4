//! The contract between models and the algorithms that explore them: a log-density over a
//! slice of `f64` ([`LogDensity`]), and what its columns report ([`Quantity`]).
//!
//! The sampler and the optimisers see a model only through [`LogDensity`]: a dimension, an
//! evaluation that may refuse a point (recoverably) or fail (fatally), and names. What only
//! some densities can do is a trait of its own, which the sampler asks for and uses when the
//! density offers it ([`blocked`]): blocks updated one at a time with the state they reuse,
//! exact conditional draws, followers carried along, blocks independent of one another, and
//! updates split by those blocks. A fit reports the density's columns as the [`Quantity`]s
//! the model names (a name, a group such as a material, a unit). Neither side knows anything
//! of friction.

use thiserror::Error;

pub mod blocked;

pub use blocked::{
    BlockLinks, BlockPlan, BlockUpdate, BlockedDensity, CarriedMove, CarryFollowers,
    ExactConditional, IndependentBlocks, OwnEntries, PlannedBlock, ShareError, SplitByPart,
};

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

/// Rejection label used when a density returns NaN.
pub const REJECT_NAN: &str = "nan";
/// Rejection label used when a density returns −∞.
pub const REJECT_NEG_INFINITY: &str = "neg_infinity";

/// An unnormalised log-density (log-posterior) over `dim()` real parameters: all the sampler
/// and the optimisers need of a model.
///
/// Must be pure: the same `x` gives the same result on any thread, because the sampler
/// evaluates the points of half an ensemble in parallel and promises bit-identical chains
/// however many threads run.
///
/// Derived quantities (emcee's "blobs") are written by the same call that computes the
/// log-density, because they usually share its work (a forward model evaluated once); the
/// caller owns the buffer so that the hot loop allocates nothing.
///
/// A density whose coordinates fall into blocks that are cheaper to update one at a time
/// says so by implementing [`BlockedDensity`] as well, and is handed to the sampler as
/// [`Target::blocked`].
pub trait LogDensity: Sync {
    /// Number of sampled parameters.
    fn dim(&self) -> usize;

    /// The log-density at `x` (length [`dim`](Self::dim)), writing the derived quantities
    /// into `derived` (length `derived_names().len()`).
    ///
    /// Returning NaN or −∞ is treated like [`LogDensityError::Rejected`] (labels
    /// [`REJECT_NAN`], [`REJECT_NEG_INFINITY`]); +∞ is fatal, since it would absorb the chain.
    ///
    /// # Errors
    /// [`LogDensityError::Rejected`] outside the support, [`LogDensityError::Fatal`] on faults.
    fn log_density(&self, x: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError>;

    /// Names of the sampled parameters (stored with the chains): `x0, x1, …` unless the
    /// density names them.
    fn param_names(&self) -> Vec<String> {
        (0..self.dim()).map(|i| format!("x{i}")).collect()
    }

    /// Names of the derived quantities written by [`log_density`](Self::log_density): none
    /// unless the density has some.
    fn derived_names(&self) -> Vec<String> {
        Vec::new()
    }

    /// Units of the sampled parameters, in the order of [`param_names`](Self::param_names),
    /// stored with the chains: each column's unit undeclared (an empty [`ColumnUnit`]) unless
    /// the density declares them.
    fn param_units(&self) -> Vec<ColumnUnit> {
        vec![ColumnUnit::default(); self.dim()]
    }

    /// Why the density is not finite at `x`, in the density's own terms (which part of the
    /// model fails and how), for error messages. A density with nothing to add to the error
    /// its evaluation returned keeps to that (`None`).
    fn explain(&self, x: &[f64]) -> Option<String> {
        let _ = x;
        None
    }
}

/// A density as an algorithm may use it: through [`LogDensity`] alone, or through its blocks
/// too when it offers them ([`BlockedDensity`]). `&density` converts into the first; choose
/// the second with [`Target::blocked`].
pub struct Target<'a, D: ?Sized> {
    density: &'a D,
    blocked: Option<&'a dyn BlockedDensity>,
}

impl<D: ?Sized> Clone for Target<'_, D> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<D: ?Sized> Copy for Target<'_, D> {}

impl<'a, D: LogDensity + ?Sized> Target<'a, D> {
    /// `density` seen through [`LogDensity`] alone: a sampler updates it jointly.
    pub fn joint(density: &'a D) -> Self {
        Self {
            density,
            blocked: None,
        }
    }

    /// The density.
    pub fn density(&self) -> &'a D {
        self.density
    }

    /// The density's blocks, when it is seen through them.
    pub fn blocked_density(&self) -> Option<&'a dyn BlockedDensity> {
        self.blocked
    }
}

impl<'a, D: BlockedDensity> Target<'a, D> {
    /// `density` seen through its blocks as well: a sampler may update them one at a time
    /// (when its configuration asks for blocked updates), and an optimiser re-evaluates only
    /// the block of a coordinate it moves.
    pub fn blocked(density: &'a D) -> Self {
        Self {
            density,
            blocked: Some(density),
        }
    }
}

impl<'a, D: LogDensity + ?Sized> From<&'a D> for Target<'a, D> {
    fn from(density: &'a D) -> Self {
        Self::joint(density)
    }
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
