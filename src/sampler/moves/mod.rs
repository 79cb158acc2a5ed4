//! The moves of the affine-invariant ensemble sampler, one file each, and what they share.
//!
//! Every step, each ensemble is split at random into two halves, and each half in turn is
//! updated from the other, the complement, which stays fixed meanwhile: so any move whose
//! update of a walker depends only on the walker, the complement and the walker's own
//! random stream leaves the target invariant (the red-blue update of emcee). A move is one
//! of two kinds ([`Move`]):
//!
//! - a [`ProposalMove`] proposes a new position for every walker of the active half and
//!   says how the proposal changes the acceptance ratio ([`Correction`]); the sampler
//!   evaluates the proposals (in parallel) and accepts by Metropolis–Hastings. Built in:
//!   [`Stretch`], [`DifferentialEvolution`], [`Walk`], [`Independence`] (Gaussian or
//!   Student-t), [`Snooker`] and [`Kde`].
//! - the ensemble slice move ([`ensemble_slice`]) moves each walker along a direction from the
//!   complement until it settles on its new point, with as many evaluations as it needs; what
//!   varies is where the direction comes from, a [`SliceDirection`]: built in,
//!   [`DifferentialDirection`] and [`GaussianDirection`].
//!
//! Shared pieces: the complement and what is fitted to it ([`Complement`]), the proposal's
//! [`Correction`], a move's record ([`MoveSpec`]), written mixtures ([`Mixture`]), and the
//! followers a block carries along when it moves under hierarchical updates ([`CarryTuning`]).
//!
//! # A move of one's own
//! A Metropolis–Hastings move is a type implementing [`ProposalMove`]; mixed with the
//! built-in moves, it is drawn for a step with probability proportional to its weight. Here
//! differential evolution with a fixed γ (emcee's `DEMove(gamma0=…)` with no jitter), mixed
//! with the stretch move:
//!
//! ```
//! use slipbayes::density::{LogDensity, LogDensityError};
//! use slipbayes::sampler::moves::{ActiveHalf, Correction, MoveSpec, ProposalMove, Proposed};
//! use slipbayes::sampler::{EnsembleSampler, MemorySink, Move, SamplerConfig, Silent, Steps};
//!
//! /// `Y = X + γ (X_j − X_k)`, `j ≠ k` from the complement: symmetric.
//! #[derive(Debug)]
//! struct FixedDe {
//!     gamma: f64,
//! }
//!
//! impl ProposalMove for FixedDe {
//!     fn spec(&self) -> MoveSpec {
//!         MoveSpec::new("fixed_de").with("gamma", self.gamma)
//!     }
//!     fn min_complement(&self, _dim: usize) -> usize {
//!         2
//!     }
//!     fn propose(&self, half: ActiveHalf<'_>) -> Proposed {
//!         let complement = half.complement();
//!         half.propose_each(|walker, rng, out| {
//!             let (a, b) = complement.pick_two(rng);
//!             for (((o, x), a), b) in out.iter_mut().zip(walker.x).zip(a).zip(b) {
//!                 *o = x + self.gamma * (a - b);
//!             }
//!             Correction::SYMMETRIC
//!         })
//!     }
//! }
//!
//! struct Normal;
//! impl LogDensity for Normal {
//!     fn dim(&self) -> usize { 2 }
//!     fn log_density(&self, x: &[f64], _derived: &mut [f64]) -> Result<f64, LogDensityError> {
//!         Ok(-0.5 * (x[0] * x[0] + x[1] * x[1]))
//!     }
//! }
//!
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! let moves = vec![
//!     (Move::proposal(FixedDe { gamma: 1.2 }), 0.7),
//!     (Move::stretch(), 0.3),
//! ];
//! let config = SamplerConfig::new(8, 1, 42)?.with_moves(moves)?;
//! let start = vec![(0..8).map(|w| vec![f64::cos(w as f64), f64::sin(w as f64)]).collect()];
//! let mut sampler = EnsembleSampler::new(&Normal, config, start)?;
//! let mut sink = MemorySink::new();
//! sampler.run(Steps::Fixed(100), &mut sink, &mut Silent)?;
//! // The checkpoint records the mixture, so a resume with other moves is refused.
//! assert_eq!(sampler.state().moves[0].0.to_string(), "fixed_de(gamma=1.2)");
//! # Ok(())
//! # }
//! ```

mod complement;
mod correction;
mod differential_evolution;
mod directions;
pub mod ensemble_slice;
mod followers;
mod independence;
mod kde;
mod mixture;
mod proposal;
mod snooker;
mod spec;
mod stretch;
mod walk;

/// A walker's own random stream (ChaCha8, see the sampler's determinism): every move draws
/// a walker's randomness from it alone.
pub type WalkerRng = rand_chacha::ChaCha8Rng;

pub use complement::Complement;
pub(crate) use complement::OwnedComplement;
pub use correction::Correction;
pub use differential_evolution::DifferentialEvolution;
pub use directions::{DifferentialDirection, GaussianDirection};
pub use ensemble_slice::{
    DirectionDraw, SliceDirection, SLICE_ADAPT_STEPS, SLICE_MAX_STEPS_OUT, SLICE_MU0,
};
pub use followers::CarryTuning;
pub(crate) use followers::Followers;
pub use independence::Independence;
pub use kde::Kde;
pub use mixture::{Mixture, Move, MOVE_NAMES};
#[cfg(test)]
pub(crate) use proposal::propose_one;
pub(crate) use proposal::BlockView;
pub use proposal::{ActiveHalf, ProposalMove, Proposed, Walker};
pub use snooker::Snooker;
pub use spec::{MoveSpec, Parameter};
pub use stretch::Stretch;
pub use walk::Walk;
