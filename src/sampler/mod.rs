//! Affine-invariant ensemble MCMC (Goodman & Weare 2010, as in emcee) over any log-density.
//!
//! The sampler knows nothing of friction: it sees a [`LogDensity`](crate::density::LogDensity)
//! over `&[f64]` with a fallible result. Points the density refuses (out of support, NaN, −∞) are rejected
//! proposals counted per reason; only fatal faults (and +∞) stop a run.
//!
//! - Moves ([`moves`]): stretch, differential evolution, walk, independence, KDE, DE-snooker
//!   and ensemble slice sampling, mixable with weights, and moves of one's own
//!   ([`ProposalMove`]); the red-blue update splits each ensemble randomly in two halves every
//!   step and updates one from the other.
//! - Blocked updates ([`Updates`]) of a density that offers blocks
//!   ([`BlockedDensity`](crate::density::BlockedDensity), handed over as
//!   [`Target::blocked`](crate::density::Target::blocked)): one block of its coordinates after
//!   the other, each as the density's plan says: by the moves, drawn exactly from a cheap
//!   conditional (the population level of a hierarchical model) by slice sampling, or, for
//!   blocks independent of one another (a campaign's contacts), on the block's own state
//!   alone, so that a block's update costs the same however many blocks there are.
//! - Several independent ensembles (default 4) run side by side; R̂ between them detects
//!   ensembles stuck in different modes.
//! - Determinism: every walker draws from its own ChaCha8 stream (`seed`, stream id), all
//!   randomness is drawn serially and only the densities are evaluated in parallel (rayon),
//!   so a seed gives bit-identical chains on any number of threads. A slice update, whose
//!   evaluations depend on its own draws, runs each walker's whole procedure as one parallel
//!   task reading only the fixed complement and drawing only from the walker's stream.
//! - Run control ([`Steps`]): fixed steps, or emcee's stopping rule (τ_max trusted, τ
//!   settled to 1 %, plus R̂ between ensembles) with a cap; the [`RunReport`] gives τ, burn-in
//!   (≈ 2 τ_max), thinning (≈ τ_min/2), R̂, acceptance, rejections and evaluation counts.
//! - Draws go to a [`ChainSink`] (contract in [`sink`]); the complete [`SamplerState`] is
//!   checkpointed through it, and [`EnsembleSampler::from_state`] resumes bit-identically.
//! - Progress goes to an [`Observer`]; the library never prints.
//! - Parallelism: the proposals of a half-step are evaluated in this process (rayon), or
//!   through a parallel engine ([`Parallelism`], [`EnsembleSampler::set_parallelism`]) such as
//!   the ranks of an MPI job (`crate::distributed`); the chains stay the same bits.
//!
//! # Quick start
//! ```
//! use slipbayes::density::{LogDensity, LogDensityError};
//! use slipbayes::optimize::initial_around_optimum;
//! use slipbayes::sampler::{EnsembleSampler, MemorySink, SamplerConfig, Silent, Steps};
//! use rand::SeedableRng;
//!
//! /// A standard normal in two dimensions, restricted to x0 > -5.
//! struct Normal;
//! impl LogDensity for Normal {
//!     fn dim(&self) -> usize { 2 }
//!     fn log_density(&self, x: &[f64], _derived: &mut [f64]) -> Result<f64, LogDensityError> {
//!         if x[0] <= -5.0 {
//!             return Err(LogDensityError::rejected("out_of_support"));
//!         }
//!         Ok(-0.5 * (x[0] * x[0] + x[1] * x[1]))
//!     }
//! }
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let config = SamplerConfig::new(8, 2, 42)?;
//! let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
//! let start = initial_around_optimum(&Normal, &[1.0, 1.0], 8, 2, &mut rng)?;
//! let mut sampler = EnsembleSampler::new(&Normal, config, start.walkers)?;
//! let mut sink = MemorySink::new();
//! let report = sampler.run(Steps::Fixed(200), &mut sink, &mut Silent)?;
//! assert_eq!(report.total_steps, 200);
//! assert_eq!(sink.chains[0].steps.len(), 200);
//! # Ok(())
//! # }
//! ```
mod config;
mod ensemble;
mod error;
mod evaluator;
mod executor;
mod history;
mod memory;
pub mod moves;
mod observer;
mod report;
mod run;
pub mod sink;
mod slice;

pub use config::{
    CarryFit, SamplerConfig, Steps, StopRule, Updates, CARRY_FIT_MIN_COMPLEMENT,
    CARRY_FIT_MIN_FOLLOWERS, DEFAULT_ENSEMBLES, DEFAULT_HISTORY_ROWS, DEFAULT_SEED,
    HISTORY_BUDGET_BYTES, MIN_BUDGET_ROWS,
};
pub use ensemble::EnsembleState;
pub use error::SamplerError;
#[cfg(feature = "mpi")]
pub(crate) use evaluator::EvalKind;
pub use executor::Parallelism;
pub(crate) use executor::{share, Batch, Executor};
#[cfg(feature = "mpi")]
pub(crate) use executor::{BlockShares, ShareApart, ShareEntries};
pub use history::History;
pub use memory::{MemoryChain, MemorySink, NullSink};
pub use moves::{
    CarryTuning, Mixture, Move, MoveSpec, ProposalMove, MOVE_NAMES, SLICE_ADAPT_STEPS,
    SLICE_MAX_STEPS_OUT, SLICE_MU0,
};
pub use observer::{Observer, Progress, RunStart, Silent};
pub use report::{EnsembleReport, RunReport, StopReason, TauReport};
pub use run::{
    EnsembleSampler, SamplerState, CARRY_FIT_STEPS, CARRY_MIN_JUMP_RATIO, CARRY_TUNE_STEPS,
    RESUME_RTOL, STATE_VERSION,
};
pub(crate) use run::{RunOutcome, RunRequest};
pub use sink::{ChainSink, StepView};
