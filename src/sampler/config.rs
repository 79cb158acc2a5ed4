//! Validated sampler settings and run lengths.

use serde::{Deserialize, Serialize};

use super::error::SamplerError;
use super::moves::Move;

/// Default number of independent ensembles.
pub const DEFAULT_ENSEMBLES: usize = 4;
/// Default seed; saved with the results so a run can be repeated.
pub const DEFAULT_SEED: u64 = 20_240_517;
/// Default maximum number of thinned rows kept per walker for the τ and R̂ estimates.
pub const DEFAULT_HISTORY_ROWS: usize = 1024;
/// Memory the thinned history may take before it keeps fewer rows than `history_rows`: a
/// campaign of many contacts (hundreds of walkers × tens of parameters) would otherwise hold
/// hundreds of MB for it.
pub const HISTORY_BUDGET_BYTES: usize = 64 << 20;
/// Fewest rows the budget leaves: rows between 64 and 128 still cover the run finer than τ/2
/// before it is 50 τ long, which overstates τ by a few per cent at most.
pub const MIN_BUDGET_ROWS: usize = 128;

/// Settings of an [`EnsembleSampler`](super::EnsembleSampler), validated once by
/// [`SamplerConfig::new`] and the `with_*` methods (also when deserialised).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RawConfig")]
pub struct SamplerConfig {
    walkers: usize,
    ensembles: usize,
    seed: u64,
    moves: Vec<(Move, f64)>,
    checkpoint_every: Option<u64>,
    parallel: bool,
    history_rows: usize,
    updates: Updates,
    carry: CarryFit,
}

/// How a block's followers are carried along under hierarchical updates: by their
/// regression on the block, fitted to what (see `Followers` in the sampler's moves).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum CarryFit {
    /// Tuned where a block has many followers ([`CARRY_FIT_MIN_FOLLOWERS`] or more) and the
    /// complementary half is too small for them (fewer than [`CARRY_FIT_MIN_COMPLEMENT`]
    /// walkers per follower), fitted to the complement elsewhere (the default).
    #[default]
    Auto,
    /// Fitted to the complementary half of the ensemble at every half-step: follows the
    /// posterior from the first step, but with half the walkers of one step its error grows
    /// with the number of followers, and every follower's error adds to the block's
    /// acceptance ratio.
    Complement,
    /// Fitted to every ensemble's draws of the first
    /// [`CARRY_FIT_STEPS`](super::CARRY_FIT_STEPS) steps (in two windows, the second using
    /// the first's fit), then fixed: precise whatever the number of followers, at the price
    /// of a burn-in that covers those steps.
    Tuned,
}

/// Under [`CarryFit::Auto`], walkers of the complementary half per follower below which a
/// block's regression is tuned rather than fitted to the complement. The complement's errors
/// in each follower's coefficients add up in the acceptance ratio of the block (10 contacts,
/// 30 followers: τ 25 steps with 16 walkers in the complement, 11 with 32).
pub const CARRY_FIT_MIN_COMPLEMENT: f64 = 1.0;

/// Under [`CarryFit::Auto`], followers from which a block's regression may be tuned. With few
/// followers the complement's errors stay small and its regression, refitted at every
/// half-step, mixed better in what was measured: the pooled three-contact SBC model (9
/// followers, 16 walkers, 86 replications of 2,000 steps each way) reached the 50 τ rule in 69
/// replications with the complement, 57 tuned (median τ_max 25 against 31 steps); from 15
/// followers (five contacts) the tuned regression was the better (τ 6.6 against 11.2).
pub const CARRY_FIT_MIN_FOLLOWERS: usize = 12;

impl CarryFit {
    /// `"auto"`, `"complement"` or `"tuned"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Complement => "complement",
            Self::Tuned => "tuned",
        }
    }

    /// Whether a block with `followers` is carried by a tuned regression when the
    /// ensembles have `walkers` walkers.
    pub fn tunes(self, followers: usize, walkers: usize) -> bool {
        match self {
            Self::Complement => false,
            Self::Tuned => followers > 0,
            Self::Auto => {
                followers >= CARRY_FIT_MIN_FOLLOWERS
                    && ((walkers / 2) as f64) < CARRY_FIT_MIN_COMPLEMENT * (followers + 2) as f64
            }
        }
    }
}

impl std::str::FromStr for CarryFit {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "complement" => Ok(Self::Complement),
            "tuned" => Ok(Self::Tuned),
            other => Err(format!(
                "unknown carry {other:?}: use \"auto\", \"complement\" or \"tuned\""
            )),
        }
    }
}

/// Which coordinates one update of a walker moves.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Updates {
    /// Every coordinate at once, each proposal a full evaluation of the density.
    #[default]
    Joint,
    /// One block of a [`BlockedDensity`](crate::density::BlockedDensity)'s plan after the
    /// other (a Metropolis-within-Gibbs sweep), each by the ensemble move in the block's own
    /// subspace (or as its plan says: drawn exactly, or on its own state), and evaluated by
    /// [`log_density_after_block`](crate::density::BlockedDensity::log_density_after_block).
    /// A density seen without its blocks is updated jointly.
    Blocked,
    /// Blocked updates that follow the blocks' [`links`](crate::density::BlockLinks), and
    /// move a block with its followers carried along the density's map where it has one
    /// ([`CarryFollowers`](crate::density::CarryFollowers)): a block that others depend
    /// on carries them along by regression when it moves, and a block that
    /// depends on others draws its independence proposals from its conditional given them.
    /// For hierarchical models, where the shared parameters and each group's own are strongly
    /// correlated, which plain Metropolis-within-Gibbs crosses slowly.
    Hierarchical,
}

impl Updates {
    /// `"joint"`, `"blocked"` or `"hierarchical"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Joint => "joint",
            Self::Blocked => "blocked",
            Self::Hierarchical => "hierarchical",
        }
    }
}

impl std::str::FromStr for Updates {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "joint" => Ok(Self::Joint),
            "blocked" => Ok(Self::Blocked),
            "hierarchical" => Ok(Self::Hierarchical),
            other => Err(format!(
                "unknown updates {other:?}: use \"joint\", \"blocked\" or \"hierarchical\""
            )),
        }
    }
}

#[derive(Deserialize)]
struct RawConfig {
    walkers: usize,
    ensembles: usize,
    seed: u64,
    moves: Vec<(Move, f64)>,
    checkpoint_every: Option<u64>,
    parallel: bool,
    history_rows: usize,
    #[serde(default)]
    updates: Updates,
    #[serde(default)]
    carry: CarryFit,
}

impl TryFrom<RawConfig> for SamplerConfig {
    type Error = SamplerError;
    fn try_from(r: RawConfig) -> Result<Self, SamplerError> {
        SamplerConfig::new(r.walkers, r.ensembles, r.seed)?
            .with_moves(r.moves)?
            .with_checkpoint_every(r.checkpoint_every)?
            .with_parallel(r.parallel)
            .with_history_rows(r.history_rows)
            .map(|c| c.with_updates(r.updates).with_carry(r.carry))
    }
}

fn invalid(name: &'static str, value: impl std::fmt::Display, req: &str) -> SamplerError {
    SamplerError::InvalidConfig {
        name,
        value: value.to_string(),
        requirement: req.to_string(),
    }
}

impl SamplerConfig {
    /// `walkers` per ensemble (even, at least 4; at least `2·ndim` is checked against the
    /// density later), `ensembles` independent ensembles (≥ 1), a `seed`; the stretch move
    /// alone, no checkpoints, parallel evaluation.
    ///
    /// # Errors
    /// [`SamplerError::InvalidConfig`] naming the setting.
    pub fn new(walkers: usize, ensembles: usize, seed: u64) -> Result<Self, SamplerError> {
        if walkers < 4 || walkers % 2 != 0 {
            return Err(invalid("walkers", walkers, "must be even and at least 4"));
        }
        if ensembles == 0 {
            return Err(invalid("ensembles", ensembles, "must be at least 1"));
        }
        Ok(Self {
            walkers,
            ensembles,
            seed,
            moves: vec![(Move::stretch(), 1.0)],
            checkpoint_every: None,
            parallel: true,
            history_rows: DEFAULT_HISTORY_ROWS,
            updates: Updates::Joint,
            carry: CarryFit::Auto,
        })
    }

    /// How the followers of hierarchical updates are carried (see [`CarryFit`]).
    pub fn with_carry(mut self, carry: CarryFit) -> Self {
        self.carry = carry;
        self
    }

    /// Joint or blocked updates (see [`Updates`]).
    pub fn with_updates(mut self, updates: Updates) -> Self {
        self.updates = updates;
        self
    }

    /// A weighted mixture of moves, built in or one's own; one move is drawn per step with
    /// probability ∝ weight.
    ///
    /// # Errors
    /// When the list is empty, a weight is not finite and positive, or half the walkers are
    /// too few for a move.
    pub fn with_moves(mut self, moves: Vec<(Move, f64)>) -> Result<Self, SamplerError> {
        if moves.is_empty() {
            return Err(invalid("moves", "[]", "give at least one move"));
        }
        for (m, w) in &moves {
            if !(w.is_finite() && *w > 0.0) {
                return Err(invalid(
                    "moves",
                    format!("{m} with weight {w}"),
                    "weights must be finite and > 0",
                ));
            }
            // The dimension is checked against the density when the sampler starts.
            m.validate_complement(self.walkers / 2, 0)?;
        }
        self.moves = moves;
        Ok(self)
    }

    /// Calls the sink's `checkpoint` every `every` steps (and always at the end of a run).
    ///
    /// # Errors
    /// When `every` is `Some(0)`.
    pub fn with_checkpoint_every(mut self, every: Option<u64>) -> Result<Self, SamplerError> {
        if every == Some(0) {
            return Err(invalid(
                "checkpoint_every",
                0,
                "must be at least 1 (or none)",
            ));
        }
        self.checkpoint_every = every;
        Ok(self)
    }

    /// Whether the log-densities of a half-step (all ensembles together) may be evaluated in
    /// parallel (rayon). When allowed, the sampler still evaluates serially while the
    /// measured serial cost of a half-step is below about 100 µs, where synchronising
    /// threads costs more than it saves. The chains are identical either way.
    pub fn with_parallel(mut self, parallel: bool) -> Self {
        self.parallel = parallel;
        self
    }

    /// Maximum number of thinned rows per walker kept for τ and R̂ (memory ∝
    /// `rows × walkers × ndim × ensembles`).
    ///
    /// # Errors
    /// When `rows < 64` (too few for a τ estimate).
    pub fn with_history_rows(mut self, rows: usize) -> Result<Self, SamplerError> {
        if rows < 64 {
            return Err(invalid("history_rows", rows, "must be at least 64"));
        }
        self.history_rows = rows;
        Ok(self)
    }

    /// Walkers per ensemble.
    pub fn walkers(&self) -> usize {
        self.walkers
    }
    /// Number of independent ensembles.
    pub fn ensembles(&self) -> usize {
        self.ensembles
    }
    /// Seed of all random streams.
    pub fn seed(&self) -> u64 {
        self.seed
    }
    /// Weighted moves.
    pub fn moves(&self) -> &[(Move, f64)] {
        &self.moves
    }
    /// Checkpoint interval in steps.
    pub fn checkpoint_every(&self) -> Option<u64> {
        self.checkpoint_every
    }
    /// Joint or blocked updates.
    pub fn updates(&self) -> Updates {
        self.updates
    }

    /// How the followers of hierarchical updates are carried.
    pub fn carry(&self) -> CarryFit {
        self.carry
    }

    /// Whether densities are evaluated in parallel.
    pub fn parallel(&self) -> bool {
        self.parallel
    }

    /// Rows the history keeps for a density of `ndim` parameters:
    /// the configured maximum per walker, fewer when rows of every walker of every
    /// ensemble would take the history beyond [`HISTORY_BUDGET_BYTES`], never fewer than
    /// [`MIN_BUDGET_ROWS`] for that reason.
    pub(crate) fn history_rows_for(&self, ndim: usize) -> usize {
        let row_bytes = self.ensembles * self.walkers * ndim.max(1) * std::mem::size_of::<f64>();
        self.history_rows
            .min((HISTORY_BUDGET_BYTES / row_bytes).max(MIN_BUDGET_ROWS))
    }
}

/// How long to run.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Steps {
    /// Exactly this many more steps.
    Fixed(u64),
    /// Until the stopping rule holds, or the sampler's step counter reaches the cap.
    UntilConverged(StopRule),
}

/// emcee-style stopping rule, checked every `check_every` steps and more often early on
/// ([`StopRule::due`]): the chains are long enough to trust τ_max at the precision
/// `tau_factor` asks ([`tau_trusted_length`](crate::diagnostics::tau_trusted_length) τ_max
/// for the walkers of all ensembles), every coordinate's τ (pooled over the walkers of all
/// ensembles) changed by less than `tau_rel_change` since the last check,
/// and (with two or more ensembles) R̂ between ensembles is below `rhat_max` for every
/// parameter.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct StopRule {
    /// Steps between checks.
    pub check_every: u64,
    /// The precision asked of τ, as emcee's required chain length in units of τ_max on 32
    /// walkers (emcee: 50); with more walkers τ is pooled over them and trusted on shorter
    /// chains ([`tau_trusted_length`](crate::diagnostics::tau_trusted_length)).
    pub tau_factor: f64,
    /// Largest relative change of τ between checks (emcee: 0.01).
    pub tau_rel_change: f64,
    /// Largest R̂ between ensembles (ArviZ: 1.01).
    pub rhat_max: f64,
    /// Cap on the total step count (counting earlier runs of a resumed sampler).
    pub max_steps: u64,
}

impl StopRule {
    /// emcee's defaults (check every 100 steps, the precision of 50 τ on 32 walkers, 1 %),
    /// R̂ < 1.01, capped at `max_steps`.
    pub fn new(max_steps: u64) -> Self {
        Self {
            check_every: 100,
            tau_factor: crate::diagnostics::TAU_FACTOR,
            tau_rel_change: 0.01,
            rhat_max: crate::diagnostics::RHAT_MAX,
            max_steps,
        }
    }

    /// Whether the rule is checked after `step`: every `check_every` steps, and before that
    /// every tenth of the steps run so far (in multiples of 10, at least every 10), so that a
    /// run whose τ is a few steps stops within about a tenth of the length it needs rather
    /// than at the next `check_every`. Every multiple of `check_every` (100 by default) is
    /// checked.
    pub fn due(&self, step: u64) -> bool {
        let early = step / 100 * 10;
        let interval = early.clamp(self.check_every.min(10), self.check_every);
        step % interval == 0
    }

    pub(crate) fn validate(&self) -> Result<(), SamplerError> {
        if self.check_every == 0 {
            return Err(invalid("check_every", 0, "must be at least 1"));
        }
        if !(self.tau_factor.is_finite() && self.tau_factor > 0.0) {
            return Err(invalid(
                "tau_factor",
                self.tau_factor,
                "must be finite and > 0",
            ));
        }
        if !(self.tau_rel_change.is_finite() && self.tau_rel_change > 0.0) {
            return Err(invalid(
                "tau_rel_change",
                self.tau_rel_change,
                "must be finite and > 0",
            ));
        }
        if !(self.rhat_max.is_finite() && self.rhat_max > 1.0) {
            return Err(invalid("rhat_max", self.rhat_max, "must be finite and > 1"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn updates_are_written_as_they_are_read() {
        for u in [Updates::Joint, Updates::Blocked, Updates::Hierarchical] {
            assert_eq!(u.as_str().parse::<Updates>(), Ok(u));
        }
        let err = "gibbs".parse::<Updates>().unwrap_err();
        assert!(
            err.contains("\"gibbs\"") && err.contains("hierarchical"),
            "{err}"
        );
    }
}
