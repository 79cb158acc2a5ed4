//! Ensemble slice sampling (Karamanis & Beutler 2021, the `zeus` sampler): the move whose
//! walkers settle on their new points themselves.
//!
//! A slice update of a walker moves it along a direction drawn from the complement, by
//! stepping out (at most [`SLICE_MAX_STEPS_OUT`] widths) and shrinkage. It always moves and
//! needs no acceptance test, but evaluates the density as many times as the walker's slice
//! needs (about five on a Gaussian), so a half-step of this move runs each walker's procedure
//! as a task of its own (see `EnsembleSampler::slice_half_step`), rather than proposing for
//! the sampler to evaluate. Affine-invariant with affine-invariant directions; valid because
//! the direction depends only on the complement, which stays fixed while the active half
//! moves. The directions' scale μ (one per ensemble and block) is tuned during the first
//! [`SLICE_ADAPT_STEPS`] steps, then frozen.
//!
//! # Formula
//! The walker moves to `X + t η`, `η` its direction (see [`SliceDirection`]), `t` drawn by
//! slice sampling `π(X + t η)` from an interval of width 1 placed at random around 0. While
//! tuning, `μ ← 2 μ N_e / (N_e + N_c)` after each update, `N_e` and `N_c` the expansions and
//! contractions of all the ensemble's walkers.

use std::fmt;

use super::{Complement, MoveSpec, WalkerRng};

/// Most widths a slice update steps its interval out by (zeus allows 10⁴; with μ tuned a
/// slice needs one or two, and a cap only shortens the interval, which stays valid).
pub const SLICE_MAX_STEPS_OUT: usize = 32;

/// Initial scale μ of the slice move's directions: zeus's `2 μ₀` with `μ₀ = 1`.
pub const SLICE_MU0: f64 = 2.0;

/// Steps during which the slice move's μ is tuned; then it stays fixed, so the chains that
/// follow are a Markov chain whose kernel leaves the target invariant (adapting forever would
/// not). zeus's own tuning settles within 10–20 updates from μ₀; 50 steps give a mixture that
/// draws the slice move at 20 % about 10 updates. The sampler's suggested burn-in is at least
/// this long, so that no draw made while μ was still changing is kept.
pub const SLICE_ADAPT_STEPS: u64 = 50;

/// Where the ensemble slice move draws each walker's direction from (zeus's "moves"), mixed
/// with other moves through [`Move::slice_along`](super::Move::slice_along).
pub trait SliceDirection: fmt::Debug + Send + Sync {
    /// How the move is recorded with the chains (see [`ProposalMove::spec`](super::ProposalMove::spec)).
    fn spec(&self) -> MoveSpec;

    /// The fewest walkers the complement must hold to draw directions in `dim` dimensions.
    fn min_complement(&self, dim: usize) -> usize;

    /// What the walkers of one half-step draw their directions from: fitted to the
    /// `complement` once, then read by every walker of the active half, in parallel.
    fn fit(&self, complement: Complement<'_>) -> Box<dyn DirectionDraw>;
}

/// The directions of one half-step of the slice move (see [`SliceDirection::fit`]).
pub trait DirectionDraw: fmt::Debug + Send + Sync {
    /// Writes a walker's direction, scaled by the tuned `mu`, into `out` (one entry per
    /// coordinate the move acts on), from the walker's own `rng` and the `complement` the
    /// draw was fitted to.
    fn draw(&self, complement: Complement<'_>, mu: f64, rng: &mut WalkerRng, out: &mut [f64]);
}
