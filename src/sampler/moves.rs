//! Proposal moves of the affine-invariant ensemble sampler.
//!
//! Every move proposes a new position for one walker of the active half from the positions
//! of the complementary half only (which stays fixed while the active half is updated), so the
//! red-blue update keeps the target invariant. The proposals are affine-invariant and need no
//! tuning beyond their defaults.

use rand::Rng;
use rand_distr::StandardNormal;
use serde::{Deserialize, Serialize};

use super::error::SamplerError;

/// A proposal move; mix several with weights in [`SamplerConfig`](super::SamplerConfig).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Move {
    /// Goodman–Weare stretch move.
    ///
    /// # Formula
    /// `Y = X_j + z (X − X_j)`, `X_j` from the complement, `z = ((a−1)u + 1)² / a`,
    /// `u ~ U(0, 1)` (so `g(z) ∝ 1/√z` on `[1/a, a]`); the log acceptance ratio gains
    /// `(ndim − 1) ln z`.
    Stretch {
        /// Scale `a > 1`; 2 is the usual choice.
        a: f64,
    },
    /// Differential evolution (ter Braak 2006; emcee's `DEMove`).
    ///
    /// # Formula
    /// `Y = X + γ (X_j − X_k)` with `j ≠ k` from the complement and
    /// `γ = γ₀ (1 + σ N(0, 1))`; `γ₀ = 2.38 / √(2 ndim)` unless given.
    DifferentialEvolution {
        /// `γ₀`; `None` for `2.38 / √(2 ndim)`.
        gamma: Option<f64>,
        /// Relative jitter `σ` of `γ` (emcee: 1e-5).
        sigma: f64,
    },
    /// Walk move (emcee's `WalkMove`): a Gaussian step centred on the walker whose covariance
    /// is the sample covariance of the complement, or of a random subset of it.
    ///
    /// # Formula
    /// `Y = X + (s − 1)^{-1/2} Σ_j (Z_j − Z̄) X_j` over `s` complement walkers, `Z_j ~ N(0, 1)`:
    /// exactly `N(X, Ĉ)` with `Ĉ` their unbiased sample covariance, without factorising `Ĉ`.
    Walk {
        /// Subset size `s ≥ 2`; `None` for the whole complement.
        subset: Option<usize>,
    },
    /// Independence proposal fitted to the complement: a Gaussian (or Student-t) with the
    /// complement's sample mean and covariance, drawn afresh for every walker of the active
    /// half. Valid because the complement stays fixed while the active half is updated, and
    /// affine-invariant because the mean and covariance transform with the walkers. Where the
    /// posterior is close to Gaussian, however badly conditioned, it decorrelates in a few
    /// steps; it needs more complement walkers than dimensions.
    ///
    /// # Formula
    /// `Y = μ + L Z / √W`, `L Lᵀ = Ĉ` (the complement's unbiased sample covariance),
    /// `Z ~ N(0, I)`, `W ~ χ²_ν/ν` (`W = 1` for the Gaussian); the log acceptance ratio gains
    /// `ln q(X) − ln q(Y)`.
    Independence {
        /// Degrees of freedom ν of the Student-t; `None` for the Gaussian.
        dof: Option<f64>,
    },
    /// Differential-evolution snooker update (ter Braak & Vrugt 2008; emcee's
    /// `DESnookerMove`): a step along the line from a complement walker `Z` through the walker,
    /// as long as the difference of two more complement walkers projected on that line. It
    /// reaches along curved and elongated regions where a straight difference move stalls.
    /// Not affine-invariant (the projection is Euclidean); it needs three complement walkers.
    ///
    /// # Formula
    /// `Y = Z + (1 + γ p)(X − Z)`, `p = (X − Z)·(Z₁ − Z₂) / |X − Z|²` with `Z, Z₁, Z₂` distinct
    /// complement walkers (so the step along the line is `γ e·(Z₁ − Z₂)`, `e` the line's unit
    /// vector, symmetric in `Z₁ ↔ Z₂`); the log acceptance ratio gains
    /// `(ndim − 1) ln |1 + γ p|`, the Jacobian of a move along a line through `Z`.
    Snooker {
        /// `γ`; 1.7 as in emcee (ter Braak & Vrugt draw it from U(1.2, 2.2)).
        gamma: f64,
    },
    /// Independence proposal from a Gaussian kernel density estimate of the complement (emcee's
    /// `KDEMove`): pick a complement walker, add a Gaussian step with the complement's sample
    /// covariance scaled by `h²`. Follows non-Gaussian shapes (skewed, curved, several modes)
    /// that a single Gaussian fitted to the complement misses; affine-invariant, valid because
    /// the complement stays fixed during a half-step; needs more complement walkers than
    /// dimensions.
    ///
    /// # Formula
    /// `Y = X_j + h L Z`, `X_j` uniform over the complement, `L Lᵀ = Ĉ`, `Z ~ N(0, I)`;
    /// `q(y) ∝ Σ_j exp(−|L⁻¹(y − X_j)|² / 2h²)`; the log acceptance ratio gains
    /// `ln q(X) − ln q(Y)`.
    Kde {
        /// `h`; `None` for Scott's factor `n^(−1/(ndim+4))`, `n` the complement's size (scipy's
        /// `gaussian_kde` default, which emcee uses).
        bandwidth: Option<f64>,
    },
    /// Ensemble slice sampling (Karamanis & Beutler 2021, the `zeus` sampler): a univariate
    /// slice update of the walker along a direction drawn from the complement, by stepping
    /// out (at most [`SLICE_MAX_STEPS_OUT`] widths) and shrinkage. It always moves and needs
    /// no acceptance test, but evaluates the density as many times as the walker's slice
    /// needs (about five on a Gaussian), so a half-step of this move runs each walker's
    /// procedure as its own loop (see `EnsembleSampler::slice_half_step`). Affine-invariant;
    /// valid because the direction depends only on the complement, which stays fixed while
    /// the active half moves. The direction's scale μ (one per ensemble and block) is tuned
    /// during the first [`SLICE_ADAPT_STEPS`] steps, then frozen.
    ///
    /// # Formula
    /// Direction `η = μ (X_j − X_k)`, `j ≠ k` from the complement (zeus's differential
    /// direction), or `η = μ √2 L Z` with `L Lᵀ = Ĉ` the complement's sample covariance and
    /// `Z ~ N(0, I)` (zeus's Gaussian direction, with the differential direction's
    /// covariance); the walker moves to `X + t η`, `t` drawn by slice sampling
    /// `π(X + t η)` from an interval of width 1 placed at random around 0. While tuning,
    /// `μ ← 2 μ N_e / (N_e + N_c)` after each update, `N_e` and `N_c` the expansions and
    /// contractions of all the ensemble's walkers.
    Slice {
        /// Directions from the Gaussian fitted to the complement instead of differences of
        /// two complement walkers.
        gaussian: bool,
    },
}

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

/// The names of the moves in a written mixture, each with its default parameters.
pub const MOVE_NAMES: [&str; 9] = [
    "stretch",
    "de",
    "walk",
    "gaussian",
    "student-t",
    "snooker",
    "kde",
    "slice",
    "slice-gaussian",
];

/// A weighted mixture of moves with their default parameters, as a model file
/// (`[sampler] moves`) or the command line (`--moves`) writes it: `name=weight` pairs
/// separated by commas, e.g. `student-t=0.8,stretch=0.2` (names in [`MOVE_NAMES`]; a name
/// alone has weight 1). Parsed once where it is read, so a bad mixture is an error naming the
/// file, line and key.
#[derive(Debug, Clone, PartialEq)]
pub struct Mixture(Vec<(Move, f64)>);

impl Mixture {
    /// The moves and their weights.
    pub fn moves(&self) -> &[(Move, f64)] {
        &self.0
    }
}

impl std::str::FromStr for Mixture {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        parse_mixture(text).map(Self)
    }
}

impl std::fmt::Display for Mixture {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        for (i, (m, w)) in self.0.iter().enumerate() {
            // Every move of a parsed mixture has its named defaults.
            let name = MOVE_NAMES
                .iter()
                .find(|n| Move::named(n).as_ref() == Ok(m))
                .expect("a mixture holds named moves only");
            let sep = if i == 0 { "" } else { "," };
            write!(f, "{sep}{name}={w}")?;
        }
        Ok(())
    }
}

impl Serialize for Mixture {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_str(self)
    }
}

impl<'de> Deserialize<'de> for Mixture {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let text = String::deserialize(d)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

/// Parses a written mixture (see [`Mixture`]).
///
/// # Errors
/// A sentence naming the unknown move or the weight that is not a finite positive number.
fn parse_mixture(text: &str) -> Result<Vec<(Move, f64)>, String> {
    let mut moves = Vec::new();
    for part in text.split(',').map(str::trim).filter(|p| !p.is_empty()) {
        let (name, weight) = match part.split_once('=') {
            Some((n, w)) => (n.trim(), w.trim()),
            None => (part, "1"),
        };
        let weight: f64 = weight
            .parse()
            .ok()
            .filter(|w: &f64| w.is_finite() && *w > 0.0)
            .ok_or_else(|| format!("move `{name}`: weight `{weight}` is not a number > 0"))?;
        moves.push((Move::named(name)?, weight));
    }
    if moves.is_empty() {
        return Err("give at least one move, e.g. `student-t=0.8,stretch=0.2`".into());
    }
    Ok(moves)
}

impl Move {
    /// The move called `name` (one of [`MOVE_NAMES`]) with its default parameters.
    ///
    /// # Errors
    /// A sentence listing the known names.
    pub fn named(name: &str) -> Result<Self, String> {
        Ok(match name {
            "stretch" => Self::stretch(),
            "de" => Self::differential_evolution(),
            "walk" => Self::walk(),
            "gaussian" => Self::Independence { dof: None },
            "student-t" => Self::student_t(),
            "snooker" => Self::snooker(),
            "kde" => Self::Kde { bandwidth: None },
            "slice" => Self::slice(),
            "slice-gaussian" => Self::Slice { gaussian: true },
            _ => {
                return Err(format!(
                    "unknown move `{name}`; the moves are {}",
                    MOVE_NAMES.join(", ")
                ))
            }
        })
    }

    /// Stretch move with `a = 2`.
    pub fn stretch() -> Self {
        Self::Stretch { a: 2.0 }
    }

    /// Differential evolution with emcee's defaults (`γ₀ = 2.38/√(2 ndim)`, `σ = 1e-5`).
    pub fn differential_evolution() -> Self {
        Self::DifferentialEvolution {
            gamma: None,
            sigma: 1e-5,
        }
    }

    /// Walk move over the whole complement.
    pub fn walk() -> Self {
        Self::Walk { subset: None }
    }

    /// Student-t independence proposal with ν = 5, fitted to the complement.
    pub fn student_t() -> Self {
        Self::Independence { dof: Some(5.0) }
    }

    /// DE-snooker with emcee's `γ = 1.7`.
    pub fn snooker() -> Self {
        Self::Snooker { gamma: 1.7 }
    }

    /// Ensemble slice sampling along differences of two complement walkers (zeus's default).
    pub fn slice() -> Self {
        Self::Slice { gaussian: false }
    }

    /// Whether this is the slice move, whose half-steps do not go through the batched
    /// propose, evaluate, accept.
    pub fn is_slice(&self) -> bool {
        matches!(self, Self::Slice { .. })
    }

    /// Checks the move's own parameters.
    pub(crate) fn validate(&self) -> Result<(), SamplerError> {
        let bad = |what: String| Err(SamplerError::InvalidMove { detail: what });
        match *self {
            Self::Stretch { a } if !(a.is_finite() && a > 1.0) => {
                bad(format!("stretch scale a = {a} must be finite and > 1"))
            }
            Self::DifferentialEvolution { gamma, sigma } => {
                if let Some(g) = gamma {
                    if !(g.is_finite() && g > 0.0) {
                        return bad(format!(
                            "differential-evolution gamma = {g} must be finite and > 0"
                        ));
                    }
                }
                if !(sigma.is_finite() && sigma >= 0.0) {
                    return bad(format!(
                        "differential-evolution sigma = {sigma} must be finite and >= 0"
                    ));
                }
                Ok(())
            }
            Self::Walk { subset: Some(s) } if s < 2 => {
                bad(format!("walk subset size {s} must be at least 2"))
            }
            Self::Independence { dof: Some(nu) } if !(nu.is_finite() && nu > 0.0) => bad(format!(
                "independence degrees of freedom {nu} must be finite and > 0"
            )),
            Self::Snooker { gamma } if !(gamma.is_finite() && gamma > 0.0) => {
                bad(format!("snooker gamma = {gamma} must be finite and > 0"))
            }
            Self::Kde { bandwidth: Some(h) } if !(h.is_finite() && h > 0.0) => {
                bad(format!("KDE bandwidth {h} must be finite and > 0"))
            }
            _ => Ok(()),
        }
    }

    /// Checks that the complement (half the ensemble) is large enough for this move in
    /// `ndim` dimensions.
    pub(crate) fn validate_complement(
        &self,
        complement: usize,
        ndim: usize,
    ) -> Result<(), SamplerError> {
        let need = match *self {
            Self::Stretch { .. } => 1,
            Self::DifferentialEvolution { .. } => 2,
            Self::Walk { subset } => subset.unwrap_or(2).max(2),
            Self::Snooker { .. } => 3,
            // Two walkers for a difference (the Gaussian direction falls back to it when the
            // complement has no full-rank covariance).
            Self::Slice { .. } => 2,
            // A full-rank sample covariance needs ndim + 1 points.
            Self::Independence { .. } | Self::Kde { .. } => ndim + 1,
        };
        if complement < need {
            return Err(SamplerError::InvalidMove {
                detail: format!(
                    "{self:?} needs at least {need} walkers in each half, the ensemble has {complement}"
                ),
            });
        }
        Ok(())
    }

    /// Writes a proposal for the walker at `x` into `out` and returns the proposal's
    /// correction to the acceptance ratio.
    ///
    /// `positions` holds all walkers (`walkers × ndim`), `complement` the indices of the
    /// complementary half; `fit` is what was fitted to the complement for [`Move::Independence`]
    /// or [`Move::Kde`] ([`Fitted::Nothing`] when the complement has no full-rank covariance:
    /// the walker is proposed unchanged); `idx` and `z` are scratch of at least
    /// `complement.len()`.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn propose<R: Rng>(
        &self,
        x: &[f64],
        positions: &[f64],
        complement: &[usize],
        fit: Fitted<'_>,
        rng: &mut R,
        out: &mut [f64],
        idx: &mut [usize],
        z: &mut [f64],
    ) -> Correction {
        let ndim = x.len();
        let row = |i: usize| &positions[i * ndim..(i + 1) * ndim];
        let nc = complement.len();
        match *self {
            Self::Stretch { a } => {
                let j = row(complement[rng.random_range(0..nc)]);
                let u: f64 = rng.random();
                let zz = ((a - 1.0) * u + 1.0).powi(2) / a;
                for ((o, &xi), &xj) in out.iter_mut().zip(x).zip(j) {
                    *o = xj + zz * (xi - xj);
                }
                // z^(ndim−1) by multiplication: the acceptance test then needs no logarithm.
                Correction::power(zz, ndim as u64 - 1)
            }
            Self::DifferentialEvolution { gamma, sigma } => {
                let g0 = gamma.unwrap_or_else(|| 2.38 / (2.0 * ndim as f64).sqrt());
                let i1 = rng.random_range(0..nc);
                let mut i2 = rng.random_range(0..nc - 1);
                if i2 >= i1 {
                    i2 += 1;
                }
                let n: f64 = rng.sample(StandardNormal);
                let g = g0 * (1.0 + sigma * n);
                let (a, b) = (row(complement[i1]), row(complement[i2]));
                for (((o, &xi), &ai), &bi) in out.iter_mut().zip(x).zip(a).zip(b) {
                    *o = xi + g * (ai - bi);
                }
                Correction::NONE
            }
            Self::Walk { subset } => {
                let s = subset.unwrap_or(nc).min(nc);
                let idx = &mut idx[..nc];
                idx.copy_from_slice(complement);
                if s < nc {
                    // Partial Fisher–Yates: the first `s` entries become a uniform subset.
                    for k in 0..s {
                        let r = rng.random_range(k..nc);
                        idx.swap(k, r);
                    }
                }
                let z = &mut z[..s];
                for zj in z.iter_mut() {
                    *zj = rng.sample(StandardNormal);
                }
                let mean = z.iter().sum::<f64>() / s as f64;
                let scale = 1.0 / (s as f64 - 1.0).sqrt();
                out.copy_from_slice(x);
                for (&zj, &i) in z.iter().zip(idx.iter()) {
                    let c = scale * (zj - mean);
                    // Centred on `x` (allowed because Σ (Z_j − Z̄) = 0) to avoid cancellation
                    // when the ensemble sits far from the origin.
                    for ((o, &xj), &xi) in out.iter_mut().zip(row(i)).zip(x) {
                        *o += c * (xj - xi);
                    }
                }
                Correction::NONE
            }
            Self::Snooker { gamma } => {
                // Three distinct complement walkers by a partial Fisher–Yates over positions.
                let idx = &mut idx[..nc];
                for (k, i) in idx.iter_mut().enumerate() {
                    *i = k;
                }
                for k in 0..3 {
                    let r = rng.random_range(k..nc);
                    idx.swap(k, r);
                }
                let (z, z1, z2) = (
                    row(complement[idx[0]]),
                    row(complement[idx[1]]),
                    row(complement[idx[2]]),
                );
                let (mut dot, mut norm2) = (0.0, 0.0);
                for ((&xi, &zi), (&ai, &bi)) in x.iter().zip(z).zip(z1.iter().zip(z2)) {
                    dot += (xi - zi) * (ai - bi);
                    norm2 += (xi - zi) * (xi - zi);
                }
                if norm2 == 0.0 {
                    // The walker sits on Z: no line to move along.
                    out.copy_from_slice(x);
                    return Correction::NONE;
                }
                let stretch = 1.0 + gamma * dot / norm2;
                for ((o, &xi), &zi) in out.iter_mut().zip(x).zip(z) {
                    *o = zi + stretch * (xi - zi);
                }
                Correction::power(stretch.abs(), ndim as u64 - 1)
            }
            // The slice move's half-steps run their own loop (`slice_half_step`) and never
            // ask for a proposal: reaching this is a bug of the sampler, not of the input.
            Self::Slice { .. } => unreachable!("the slice move does not make proposals"),
            Self::Independence { .. } | Self::Kde { .. } => match fit {
                Fitted::Gaussian(fit) => Correction::log(fit.propose(x, rng, out)),
                Fitted::Kde(fit) => Correction::log(fit.propose(x, rng, out)),
                // The complement lies in a subspace: the walker stays where it is (a step
                // that changes nothing but still consumes its uniform).
                Fitted::Nothing => {
                    out.copy_from_slice(x);
                    Correction::NONE
                }
            },
        }
    }
}

/// A proposal's correction to the Metropolis–Hastings acceptance ratio: the factor itself,
/// and its logarithm where the factor is not a normal number.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Correction {
    /// The factor (`z^(ndim−1)` for the stretch move, 1 for a symmetric proposal).
    pub factor: f64,
    /// ln factor; only read when `factor` is not normal.
    pub log_factor: f64,
}

impl Correction {
    /// A symmetric proposal.
    const NONE: Self = Self {
        factor: 1.0,
        log_factor: 0.0,
    };

    /// The factor e^`log_factor`.
    fn log(log_factor: f64) -> Self {
        Self {
            factor: log_factor.exp(),
            log_factor,
        }
    }

    /// The factor `z^n`, by binary powering (`f64::powi` with a run-time exponent is a
    /// library call); its logarithm only where the power under- or overflows.
    #[inline]
    fn power(z: f64, n: u64) -> Self {
        let (mut x, mut k, mut factor) = (z, n, 1.0);
        while k > 0 {
            if k & 1 == 1 {
                factor *= x;
            }
            x *= x;
            k >>= 1;
        }
        let log_factor = if factor.is_normal() {
            0.0
        } else {
            n as f64 * z.ln()
        };
        Self { factor, log_factor }
    }
}

/// The complement's sample mean of coordinates `coords` (`positions` of all walkers, `ndim`
/// per row).
fn complement_mean(
    positions: &[f64],
    ndim: usize,
    complement: &[usize],
    coords: &[usize],
) -> Vec<f64> {
    let mut mean = vec![0.0; coords.len()];
    for &w in complement {
        let x = &positions[w * ndim..(w + 1) * ndim];
        for (m, &i) in mean.iter_mut().zip(coords) {
            *m += x[i];
        }
    }
    let n = complement.len() as f64;
    for m in &mut mean {
        *m /= n;
    }
    mean
}

/// The complement's unbiased sample covariance of coordinates `rows` (mean `row_mean`) with
/// coordinates `cols` (mean `col_mean`).
fn complement_cov(
    positions: &[f64],
    ndim: usize,
    complement: &[usize],
    (rows, row_mean): (&[usize], &[f64]),
    (cols, col_mean): (&[usize], &[f64]),
) -> nalgebra::DMatrix<f64> {
    let mut cov = nalgebra::DMatrix::<f64>::zeros(rows.len(), cols.len());
    let mut dc = vec![0.0; cols.len()];
    for &w in complement {
        let x = &positions[w * ndim..(w + 1) * ndim];
        for ((d, &j), &m) in dc.iter_mut().zip(cols).zip(col_mean) {
            *d = x[j] - m;
        }
        for (a, (&i, &m)) in rows.iter().zip(row_mean).enumerate() {
            let da = x[i] - m;
            for (b, &d) in dc.iter().enumerate() {
                cov[(a, b)] += da * d;
            }
        }
    }
    cov / (complement.len() as f64 - 1.0)
}

/// The complement's sample mean and unbiased covariance of all `ndim` coordinates.
fn complement_moments(
    positions: &[f64],
    ndim: usize,
    complement: &[usize],
) -> (Vec<f64>, nalgebra::DMatrix<f64>) {
    let all: Vec<usize> = (0..ndim).collect();
    let mean = complement_mean(positions, ndim, complement, &all);
    let cov = complement_cov(positions, ndim, complement, (&all, &mean), (&all, &mean));
    (mean, cov)
}

/// The Gaussian (or Student-t) fitted to the complementary half for [`Move::Independence`]:
/// computed once per half-step, then one proposal per active walker.
#[derive(Debug, Clone)]
pub(crate) struct ComplementFit {
    mean: Vec<f64>,
    /// Lower Cholesky factor of the sample covariance, row-major `ndim × ndim`.
    chol: Vec<f64>,
    dof: Option<f64>,
    /// χ²_ν of the Student-t's scale, built once per fit.
    chi2: Option<rand_distr::ChiSquared<f64>>,
    /// Scratch for whitened vectors.
    u: Vec<f64>,
}

impl ComplementFit {
    /// Fits the complement's walkers (`positions` of all walkers, `ndim` per row); `None` when
    /// their covariance is not positive definite (the walkers lie in a subspace).
    pub fn new(
        positions: &[f64],
        complement: &[usize],
        ndim: usize,
        dof: Option<f64>,
    ) -> Option<Self> {
        if complement.len() <= ndim {
            return None;
        }
        let (mean, cov) = complement_moments(positions, ndim, complement);
        Self::from_moments(mean, cov, dof)
    }

    /// The Gaussian (or Student-t) with this mean and covariance; `None` when the covariance
    /// is not positive definite.
    fn from_moments(mean: Vec<f64>, cov: nalgebra::DMatrix<f64>, dof: Option<f64>) -> Option<Self> {
        let ndim = mean.len();
        let l = nalgebra::Cholesky::new(cov)?.unpack();
        if (0..ndim).any(|a| !(l[(a, a)].is_finite() && l[(a, a)] > 0.0)) {
            return None;
        }
        let mut chol = vec![0.0; ndim * ndim];
        for a in 0..ndim {
            for b in 0..=a {
                chol[a * ndim + b] = l[(a, b)];
            }
        }
        Some(Self {
            mean,
            chol,
            dof,
            chi2: dof.map(|nu| {
                rand_distr::ChiSquared::new(nu).expect("ν > 0, checked by Move::validate")
            }),
            u: vec![0.0; ndim],
        })
    }

    /// Solves `L u = x − μ` into `self.u` by forward substitution and returns `|u|²`.
    fn whiten(&mut self, x: &[f64]) -> f64 {
        let ndim = self.mean.len();
        let mut r2 = 0.0;
        for (a, (&xa, &ma)) in x.iter().zip(&self.mean).enumerate() {
            let row = &self.chol[a * ndim..a * ndim + a];
            let s: f64 = row.iter().zip(&self.u[..a]).map(|(l, u)| l * u).sum();
            let ua = (xa - ma - s) / self.chol[a * ndim + a];
            self.u[a] = ua;
            r2 += ua * ua;
        }
        r2
    }

    /// ln q(x) up to a constant shared by every point.
    fn log_q(&mut self, x: &[f64]) -> f64 {
        let ndim = self.mean.len();
        let r2 = self.whiten(x);
        match self.dof {
            None => -0.5 * r2,
            Some(nu) => -0.5 * (nu + ndim as f64) * (r2 / nu).ln_1p(),
        }
    }

    /// Writes a proposal into `out` and returns ln q(x) − ln q(out).
    pub fn propose<R: Rng>(&mut self, x: &[f64], rng: &mut R, out: &mut [f64]) -> f64 {
        self.draw(rng, out);
        self.log_q(x) - self.log_q(out)
    }

    /// Writes `L Z` into `out` (the fit's mean and degrees of freedom left aside), drawing
    /// `Z ~ N(0, I)` into `z`; reads the fit only, so one fit serves walkers in parallel.
    fn draw_centred<R: Rng>(&self, rng: &mut R, z: &mut [f64], out: &mut [f64]) {
        let ndim = self.mean.len();
        for v in z.iter_mut() {
            *v = rng.sample(StandardNormal);
        }
        for (a, o) in out.iter_mut().enumerate() {
            let row = &self.chol[a * ndim..=a * ndim + a];
            *o = row.iter().zip(&*z).map(|(l, v)| l * v).sum();
        }
    }

    /// Writes a draw from q into `out`.
    fn draw<R: Rng>(&mut self, rng: &mut R, out: &mut [f64]) {
        let ndim = self.mean.len();
        let scale = match (self.dof, &self.chi2) {
            (Some(nu), Some(chi2)) => (nu / rng.sample(chi2)).sqrt(),
            _ => 1.0,
        };
        for z in self.u.iter_mut() {
            *z = rng.sample::<f64, _>(StandardNormal) * scale;
        }
        for (a, (o, &ma)) in out.iter_mut().zip(&self.mean).enumerate() {
            let row = &self.chol[a * ndim..=a * ndim + a];
            *o = ma + row.iter().zip(&self.u).map(|(l, z)| l * z).sum::<f64>();
        }
    }
}

/// Where [`Move::Slice`] draws its walkers' directions from in one half-step: built once from
/// the complement, then read by every walker of the active half (in parallel).
#[derive(Debug, Clone)]
pub(crate) struct SliceDirections {
    /// The coordinates the move acts on (the block's, or all).
    coords: Vec<usize>,
    /// The complement's Gaussian for [`Move::Slice`] with `gaussian`; `None` for differences
    /// of two walkers, also when the complement has no full-rank covariance.
    fit: Option<ComplementFit>,
}

impl SliceDirections {
    /// Directions in coordinates `coords` from the `complement` (`positions` of all walkers,
    /// `ndim` per row).
    pub fn new(
        gaussian: bool,
        positions: &[f64],
        ndim: usize,
        complement: &[usize],
        coords: &[usize],
    ) -> Self {
        let fit = (gaussian && complement.len() > coords.len())
            .then(|| {
                let mean = complement_mean(positions, ndim, complement, coords);
                let m = (coords, &mean[..]);
                let cov = complement_cov(positions, ndim, complement, m, m);
                ComplementFit::from_moments(vec![0.0; coords.len()], cov, None)
            })
            .flatten();
        Self {
            coords: coords.to_vec(),
            fit,
        }
    }

    /// The number of coordinates a direction has.
    pub fn dim(&self) -> usize {
        self.coords.len()
    }

    /// The coordinates a direction moves.
    pub fn coords(&self) -> &[usize] {
        &self.coords
    }

    /// Writes the direction `μ η` of one walker into `out` (one entry per coordinate moved),
    /// from the walker's own `rng`; `z` is scratch of the same length.
    pub fn draw<R: Rng>(
        &self,
        mu: f64,
        (positions, ndim): (&[f64], usize),
        complement: &[usize],
        rng: &mut R,
        z: &mut [f64],
        out: &mut [f64],
    ) {
        match &self.fit {
            Some(fit) => {
                fit.draw_centred(rng, z, out);
                // √2: the covariance of a difference of two walkers, so that one μ suits
                // either direction.
                let scale = mu * std::f64::consts::SQRT_2;
                for o in out.iter_mut() {
                    *o *= scale;
                }
            }
            None => {
                let nc = complement.len();
                let i1 = rng.random_range(0..nc);
                let mut i2 = rng.random_range(0..nc - 1);
                if i2 >= i1 {
                    i2 += 1;
                }
                let (a, b) = (complement[i1] * ndim, complement[i2] * ndim);
                for (o, &i) in out.iter_mut().zip(&self.coords) {
                    *o = mu * (positions[a + i] - positions[b + i]);
                }
            }
        }
    }
}

/// What a move fits to the complement once per half-step, before proposing for every walker
/// of the active half.
pub(crate) enum HalfStepFit {
    /// Nothing to fit, or the complement cannot be fitted (too few walkers, or a covariance
    /// that is not positive definite).
    Nothing,
    /// [`Move::Independence`] in a block with coordinates it is given: each walker is proposed
    /// from the block's conditional given its own values of them.
    Conditional(ConditionalFit),
    /// [`Move::Independence`] otherwise: the marginal of the coordinates moved.
    Marginal(ComplementFit),
    /// [`Move::Kde`].
    Kde(KdeFit),
}

impl HalfStepFit {
    /// The fit `mv` needs. `positions` holds all walkers (`ndim` per row) and `moved` their
    /// coordinates the move acts on (`dim` per row; the same as `positions` for joint
    /// updates); `block` is the block's coordinates and those it is given, when blocked. A
    /// conditional the complement is too small for falls back to the marginal.
    pub fn new(
        mv: &Move,
        (positions, ndim): (&[f64], usize),
        (moved, dim): (&[f64], usize),
        complement: &[usize],
        block: Option<(&[usize], &[usize])>,
    ) -> Self {
        let fitted = match (*mv, block) {
            (Move::Independence { dof }, Some((coords, given))) if !given.is_empty() => {
                ConditionalFit::new(positions, ndim, complement, coords, given, dof)
                    .map(Self::Conditional)
            }
            _ => None,
        };
        fitted
            .or_else(|| match *mv {
                Move::Independence { dof } => {
                    ComplementFit::new(moved, complement, dim, dof).map(Self::Marginal)
                }
                Move::Kde { bandwidth } => {
                    KdeFit::new(moved, complement, dim, bandwidth).map(Self::Kde)
                }
                _ => None,
            })
            .unwrap_or(Self::Nothing)
    }

    /// What to propose from for the walker at `x` (all its coordinates), given coordinates
    /// `given`.
    pub fn for_walker(&mut self, x: &[f64], given: &[usize]) -> Fitted<'_> {
        match self {
            Self::Nothing => Fitted::Nothing,
            Self::Conditional(c) => Fitted::Gaussian(c.given(x, given)),
            Self::Marginal(f) => Fitted::Gaussian(f),
            Self::Kde(k) => Fitted::Kde(k),
        }
    }
}

/// What a move proposes from for one walker (see [`HalfStepFit`]).
pub(crate) enum Fitted<'f> {
    /// Nothing fitted: a move that needs no fit, or a complement without a full-rank covariance.
    Nothing,
    /// The Gaussian or Student-t of [`Move::Independence`].
    Gaussian(&'f mut ComplementFit),
    /// The kernel density estimate of [`Move::Kde`].
    Kde(&'f mut KdeFit),
}

/// The Gaussian kernel density estimate of the complement for [`Move::Kde`].
#[derive(Debug, Clone)]
pub(crate) struct KdeFit {
    /// The kernel: zero mean, covariance `h² Ĉ`.
    kernel: ComplementFit,
    /// The complement's walkers (the kernels' centres), `ndim` per row.
    centres: Vec<f64>,
    /// The centres whitened by the kernel's Cholesky factor, `ndim` per row.
    white: Vec<f64>,
    /// Scratch for a whitened point's squared distances to the centres.
    r2: Vec<f64>,
}

impl KdeFit {
    /// Fits the complement's walkers (`positions` of all walkers, `ndim` per row) with
    /// bandwidth `h` (`None`: Scott's factor); `None` when their covariance is not positive
    /// definite.
    pub fn new(
        positions: &[f64],
        complement: &[usize],
        ndim: usize,
        bandwidth: Option<f64>,
    ) -> Option<Self> {
        let n = complement.len();
        if n <= ndim {
            return None;
        }
        let h = bandwidth.unwrap_or_else(|| (n as f64).powf(-1.0 / (ndim as f64 + 4.0)));
        let (_, cov) = complement_moments(positions, ndim, complement);
        let mut kernel = ComplementFit::from_moments(vec![0.0; ndim], cov * (h * h), None)?;
        let mut centres = Vec::with_capacity(n * ndim);
        let mut white = Vec::with_capacity(n * ndim);
        for &w in complement {
            let c = &positions[w * ndim..(w + 1) * ndim];
            centres.extend_from_slice(c);
            kernel.whiten(c);
            white.extend_from_slice(&kernel.u);
        }
        Some(Self {
            kernel,
            centres,
            white,
            r2: vec![0.0; n],
        })
    }

    /// ln q(x) up to a constant shared by every point.
    fn log_q(&mut self, x: &[f64]) -> f64 {
        self.kernel.whiten(x);
        let u = &self.kernel.u;
        for (r, w) in self.r2.iter_mut().zip(self.white.chunks_exact(u.len())) {
            *r = u.iter().zip(w).map(|(a, b)| (a - b) * (a - b)).sum();
        }
        // log-sum-exp of −r²/2 about the nearest centre.
        let nearest = self.r2.iter().copied().fold(f64::INFINITY, f64::min);
        let sum: f64 = self.r2.iter().map(|r| (-0.5 * (r - nearest)).exp()).sum();
        -0.5 * nearest + sum.ln()
    }

    /// Writes a proposal into `out` and returns ln q(x) − ln q(out).
    pub fn propose<R: Rng>(&mut self, x: &[f64], rng: &mut R, out: &mut [f64]) -> f64 {
        let ndim = x.len();
        let j = rng.random_range(0..self.r2.len());
        self.kernel.draw(rng, out);
        for (o, &c) in out.iter_mut().zip(&self.centres[j * ndim..(j + 1) * ndim]) {
            *o += c;
        }
        self.log_q(x) - self.log_q(out)
    }
}

/// The least-squares regression of coordinates `responses` on coordinates `predictors`,
/// fitted to the complement's walkers: what [`ConditionalFit`] and [`Followers`] are built on.
#[derive(Debug, Clone)]
struct Regression {
    /// `C_rp C_pp⁻¹`, `responses × predictors`.
    coef: nalgebra::DMatrix<f64>,
    mean_r: Vec<f64>,
    mean_p: Vec<f64>,
    /// `C_pr`, the covariance of the predictors with the responses.
    c_pr: nalgebra::DMatrix<f64>,
}

impl Regression {
    /// `None` when the complement has no more walkers than predictors or their covariance
    /// is not positive definite.
    fn fit(
        positions: &[f64],
        ndim: usize,
        complement: &[usize],
        responses: &[usize],
        predictors: &[usize],
    ) -> Option<Self> {
        if complement.len() <= predictors.len() {
            return None;
        }
        let mean_r = complement_mean(positions, ndim, complement, responses);
        let mean_p = complement_mean(positions, ndim, complement, predictors);
        let (r, p) = ((responses, &mean_r[..]), (predictors, &mean_p[..]));
        let c_pp = complement_cov(positions, ndim, complement, p, p);
        let c_pr = complement_cov(positions, ndim, complement, p, r);
        let coef = nalgebra::Cholesky::new(c_pp)?.solve(&c_pr).transpose();
        Some(Self {
            coef,
            mean_r,
            mean_p,
            c_pr,
        })
    }
}

/// [`Move::Independence`] for a block whose conditional depends on other coordinates only
/// through `given`: the Gaussian (or Student-t) conditional of the block given the walker's
/// own `given` coordinates, from the complement's joint sample mean and covariance of both.
/// Valid because the proposal depends only on the complement and on coordinates the update
/// does not move.
///
/// # Formula
/// `Y_b = μ_b + B (x_g − μ_g) + L Z / √W`, `B = C_bg C_gg⁻¹`, `L Lᵀ = C_bb − B C_gb`.
#[derive(Debug, Clone)]
pub(crate) struct ConditionalFit {
    fit: ComplementFit,
    /// The block regressed on `given`.
    reg: Regression,
}

impl ConditionalFit {
    /// Fits block `coords` given `given` (`positions` of all walkers, `ndim` per row); `None`
    /// when the complement is too small or its covariance not positive definite.
    pub fn new(
        positions: &[f64],
        ndim: usize,
        complement: &[usize],
        coords: &[usize],
        given: &[usize],
        dof: Option<f64>,
    ) -> Option<Self> {
        if complement.len() <= coords.len() + given.len() {
            return None;
        }
        let reg = Regression::fit(positions, ndim, complement, coords, given)?;
        let b = (coords, &reg.mean_r[..]);
        let c_bb = complement_cov(positions, ndim, complement, b, b);
        let cond = c_bb - &reg.coef * &reg.c_pr;
        let fit = ComplementFit::from_moments(reg.mean_r.clone(), cond, dof)?;
        Some(Self { fit, reg })
    }

    /// Centres the proposal on the conditional mean given the walker's own coordinates `x`
    /// (all of them) at `given`; then [`ComplementFit::propose`] as usual.
    pub fn given<'f>(&'f mut self, x: &[f64], given: &[usize]) -> &'f mut ComplementFit {
        let reg = &self.reg;
        for (a, m) in self.fit.mean.iter_mut().enumerate() {
            *m = reg.mean_r[a];
            for (j, &i) in given.iter().enumerate() {
                *m += reg.coef[(a, j)] * (x[i] - reg.mean_p[j]);
            }
        }
        &mut self.fit
    }
}

/// The followers of a block carried along when it moves: each follower shifted by its
/// regression on the block's coordinates times the block's step. The map `(x_b, x_f) → (y_b,
/// x_f + B (y_b − x_b))` has unit Jacobian and is undone by the reverse step, so every move
/// keeps its acceptance ratio; it leaves a Gaussian target's conditional of the followers
/// given the block unchanged, so a block that many others depend on moves as if it were
/// alone.
///
/// `B` is either fitted to the complement at every half-step (valid because the complement
/// does not move during it), or fitted once to the ensemble's own draws of the tuning steps
/// and then fixed ([`CarryTuning`]): a fixed map is valid whatever it is, and draws of many
/// steps estimate `B` far better than half the walkers of one step, whose errors in every
/// follower add up in the block's acceptance ratio.
///
/// # Formula
/// `B = C_fb C_bb⁻¹` from the sample covariances.
#[derive(Debug, Clone)]
pub(crate) struct Followers {
    /// `B`, `followers × block`.
    coef: nalgebra::DMatrix<f64>,
}

impl Followers {
    /// The regression of `followers` on block `coords` fitted to the complement (`positions`
    /// of all walkers, `ndim` per row); `None` when the complement's covariance of the block
    /// is not positive definite.
    pub fn new(
        positions: &[f64],
        ndim: usize,
        complement: &[usize],
        coords: &[usize],
        followers: &[usize],
    ) -> Option<Self> {
        Regression::fit(positions, ndim, complement, followers, coords)
            .map(|reg| Self { coef: reg.coef })
    }

    /// The frozen regression of a [`CarryTuning`], when it has one.
    pub fn frozen(tuning: &CarryTuning) -> Option<Self> {
        (!tuning.coef.is_empty()).then(|| Self {
            coef: nalgebra::DMatrix::from_row_slice(
                tuning.coef.len() / tuning.block_dim,
                tuning.block_dim,
                &tuning.coef,
            ),
        })
    }

    /// Shifts the followers of proposal `out` (a copy of `x` apart from the block) by the
    /// block's step from `x`.
    pub fn carry(&self, x: &[f64], coords: &[usize], followers: &[usize], out: &mut [f64]) {
        for (f, &i) in followers.iter().enumerate() {
            let shift: f64 = coords
                .iter()
                .enumerate()
                .map(|(j, &c)| self.coef[(f, j)] * (out[c] - x[c]))
                .sum();
            out[i] = x[i] + shift;
        }
    }
}

/// The followers' regression on a block fitted to an ensemble's own draws over the tuning
/// steps, then frozen (see `Followers`): the cross moments being gathered, and the last
/// frozen coefficients. Saved with the ensemble, so a resumed run continues the same tuning.
///
/// The moments are sums of deviations from the first draw gathered (a shift that keeps
/// the sums of squares free of cancellation), over every walker of every step of a window.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct CarryTuning {
    /// Coordinates of the block (the predictors).
    pub block_dim: usize,
    /// Draws gathered in the current window.
    pub draws: u64,
    /// The shift: the first draw of the window, block then followers.
    pub shift: Vec<f64>,
    /// Σ d_b of the shifted draws' block coordinates.
    pub sum_block: Vec<f64>,
    /// Σ d_f of the shifted draws' followers.
    pub sum_followers: Vec<f64>,
    /// Σ d_b d_bᵀ, `block × block`, row-major.
    pub sum_block_block: Vec<f64>,
    /// Σ d_f d_bᵀ, `followers × block`, row-major.
    pub sum_followers_block: Vec<f64>,
    /// The frozen `B`, `followers × block`, row-major; empty until the first window ends.
    pub coef: Vec<f64>,
}

impl CarryTuning {
    /// Nothing gathered yet for a block of `block_dim` coordinates with `followers`.
    pub fn new(block_dim: usize, followers: usize) -> Self {
        Self {
            block_dim,
            draws: 0,
            shift: Vec::new(),
            sum_block: vec![0.0; block_dim],
            sum_followers: vec![0.0; followers],
            sum_block_block: vec![0.0; block_dim * block_dim],
            sum_followers_block: vec![0.0; followers * block_dim],
            coef: Vec::new(),
        }
    }

    /// Whether the sizes are those of a block of `block_dim` coordinates with `followers`.
    pub fn fits(&self, block_dim: usize, followers: usize) -> bool {
        self.block_dim == block_dim
            && self.sum_block.len() == block_dim
            && self.sum_followers.len() == followers
            && self.sum_block_block.len() == block_dim * block_dim
            && self.sum_followers_block.len() == followers * block_dim
            && (self.coef.is_empty() || self.coef.len() == followers * block_dim)
    }

    /// Gathers every walker of `positions` (`ndim` per row) into the window.
    pub fn gather(
        &mut self,
        positions: &[f64],
        ndim: usize,
        coords: &[usize],
        followers: &[usize],
    ) {
        let p = coords.len();
        let mut d = vec![0.0; p + followers.len()];
        for x in positions.chunks_exact(ndim) {
            if self.shift.is_empty() {
                self.shift = coords.iter().chain(followers).map(|&i| x[i]).collect();
            }
            for ((v, &i), s) in d
                .iter_mut()
                .zip(coords.iter().chain(followers))
                .zip(&self.shift)
            {
                *v = x[i] - s;
            }
            let (db, df) = d.split_at(p);
            for (a, &u) in db.iter().enumerate() {
                self.sum_block[a] += u;
                for (b, &v) in db.iter().enumerate() {
                    self.sum_block_block[a * p + b] += u * v;
                }
            }
            for (f, &u) in df.iter().enumerate() {
                self.sum_followers[f] += u;
                for (b, &v) in db.iter().enumerate() {
                    self.sum_followers_block[f * p + b] += u * v;
                }
            }
            self.draws += 1;
        }
    }

    /// Ends the window: `B` from its moments becomes the frozen regression (kept as it was
    /// when the block's covariance is not positive definite), and a new window starts.
    pub fn freeze(&mut self) {
        let p = self.block_dim;
        let nf = self.sum_followers.len();
        let n = self.draws as f64;
        if self.draws > p as u64 + 1 {
            let c_bb = nalgebra::DMatrix::from_fn(p, p, |a, b| {
                self.sum_block_block[a * p + b] - self.sum_block[a] * self.sum_block[b] / n
            });
            let c_bf = nalgebra::DMatrix::from_fn(p, nf, |b, f| {
                self.sum_followers_block[f * p + b] - self.sum_followers[f] * self.sum_block[b] / n
            });
            if let Some(chol) = nalgebra::Cholesky::new(c_bb) {
                let coef = chol.solve(&c_bf).transpose();
                self.coef = (0..nf)
                    .flat_map(|f| (0..p).map(move |b| (f, b)))
                    .map(|(f, b)| coef[(f, b)])
                    .collect();
            }
        }
        *self = Self {
            coef: std::mem::take(&mut self.coef),
            ..Self::new(p, nf)
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_written_mixture_parses_and_names_what_is_wrong() {
        assert_eq!(
            parse_mixture("student-t=0.8, stretch=0.2").unwrap(),
            vec![(Move::student_t(), 0.8), (Move::stretch(), 0.2)]
        );
        assert_eq!(
            parse_mixture("de").unwrap(),
            vec![(Move::differential_evolution(), 1.0)]
        );
        let err = parse_mixture("stretch=0.5,hmc=0.5").unwrap_err();
        assert!(
            err.contains("unknown move `hmc`") && err.contains("slice-gaussian"),
            "{err}"
        );
        assert_eq!(
            parse_mixture("student-t=0.4,de=0.4,slice=0.2,slice-gaussian").unwrap()[2..],
            [(Move::slice(), 0.2), (Move::Slice { gaussian: true }, 1.0)]
        );
        let err = parse_mixture("stretch=-1").unwrap_err();
        assert!(err.contains("weight `-1`"), "{err}");
        assert!(parse_mixture(" , ").is_err());
        // Written back as it reads.
        let m: Mixture = "student-t=0.8, stretch".parse().unwrap();
        assert_eq!(m.to_string(), "student-t=0.8,stretch=1");
        assert_eq!(m.to_string().parse::<Mixture>().unwrap(), m);
    }

    #[test]
    fn the_independence_correction_is_the_ratio_of_proposal_densities() {
        use rand::SeedableRng;
        // Complement of 4 points in 2-D: mean (0.5, 0.5), covariance 1/3·I.
        let positions = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0];
        let mut fit = ComplementFit::new(&positions, &[0, 1, 2, 3], 2, None).unwrap();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let x = [2.0, -1.0];
        let mut y = [0.0; 2];
        let log_ratio = fit.propose(&x, &mut rng, &mut y);
        let log_q = |p: &[f64]| -1.5 * ((p[0] - 0.5).powi(2) + (p[1] - 0.5).powi(2));
        assert!((log_ratio - (log_q(&x) - log_q(&y))).abs() < 1e-12);
        // Points on a line have no full-rank covariance: no fit.
        let line = [0.0, 0.0, 1.0, 1.0, 2.0, 2.0];
        assert!(ComplementFit::new(&line, &[0, 1, 2], 2, None).is_none());
    }

    #[test]
    fn the_kde_correction_is_the_ratio_of_mixture_densities() {
        use rand::SeedableRng;
        // The same complement, covariance 1/3·I; bandwidth 0.5 gives kernels of variance 1/12.
        let positions = [0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0];
        let mut fit = KdeFit::new(&positions, &[0, 1, 2, 3], 2, Some(0.5)).unwrap();
        // ln Σ_j exp(e_j) written out about the largest exponent, in the original coordinates.
        let log_q = |p: &[f64]| {
            let e: Vec<f64> = positions
                .chunks(2)
                .map(|c| -6.0 * ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)))
                .collect();
            let top = e.iter().copied().fold(f64::NEG_INFINITY, f64::max);
            top + e.iter().map(|v| (v - top).exp()).sum::<f64>().ln()
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let x = [0.3, 0.9];
        let mut y = [0.0; 2];
        for _ in 0..20 {
            let log_ratio = fit.propose(&x, &mut rng, &mut y);
            assert!((log_ratio - (log_q(&x) - log_q(&y))).abs() < 1e-12);
        }
        // Far from every centre the log-sum-exp must not underflow.
        let far = [40.0, -30.0];
        assert!(fit.log_q(&far).is_finite());
        assert!((fit.log_q(&far) - log_q(&far)).abs() < 1e-9 * log_q(&far).abs());
        // Scott's factor by default: n^(−1/(d+4)) = 4^(−1/6).
        let scott = KdeFit::new(&positions, &[0, 1, 2, 3], 2, None).unwrap();
        let h2 = 4f64.powf(-1.0 / 3.0);
        assert!((scott.kernel.chol[0] - (h2 / 3.0).sqrt()).abs() < 1e-14);
    }

    #[test]
    fn the_snooker_step_moves_along_the_line_through_z_with_its_jacobian() {
        use rand::SeedableRng;
        // Complement of three walkers in 3-D: every draw uses all three, in some order.
        let positions = [0.0, 0.0, 0.0, 1.0, 2.0, 0.5, -1.0, 0.5, 2.0];
        let complement = [0, 1, 2];
        let x = [0.4, -0.7, 1.1];
        let mv = Move::snooker();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let (mut idx, mut z) = ([0; 3], [0.0; 3]);
        let mut seen = std::collections::BTreeSet::new();
        for _ in 0..60 {
            let mut y = [0.0; 3];
            let c = mv.propose(
                &x,
                &positions,
                &complement,
                Fitted::Nothing,
                &mut rng,
                &mut y,
                &mut idx,
                &mut z,
            );
            // Which walker was Z: the one for which Y − Z is parallel to X − Z with the
            // snooker's stretch for one of the other two orderings.
            let row = |i: usize| &positions[3 * i..3 * i + 3];
            let found = (0..3).find_map(|k| {
                let (zk, a, b) = (row(k), row((k + 1) % 3), row((k + 2) % 3));
                let d: Vec<f64> = (0..3).map(|i| x[i] - zk[i]).collect();
                let n2: f64 = d.iter().map(|v| v * v).sum();
                [1.0, -1.0].into_iter().find_map(|sign| {
                    let dot: f64 = (0..3).map(|i| d[i] * sign * (a[i] - b[i])).sum();
                    let s = 1.0 + 1.7 * dot / n2;
                    let expect: Vec<f64> = (0..3).map(|i| zk[i] + s * d[i]).collect();
                    (0..3)
                        .all(|i| (expect[i] - y[i]).abs() < 1e-12)
                        .then_some((k, s))
                })
            });
            let (k, s) = found.expect("the proposal lies on a snooker line");
            seen.insert(k);
            // (ndim − 1) ln |1 + γ p| with ndim = 3.
            assert!((c.factor - s * s).abs() < 1e-12 * (s * s).max(1.0));
        }
        assert_eq!(seen.len(), 3, "every complement walker serves as Z");
        assert!(mv
            .validate_complement(2, 3)
            .unwrap_err()
            .to_string()
            .contains("at least 3"));
    }

    /// Six walkers in 3-D with x1 = 2 x0 + 1 exactly and x2 = −x0/2 + e, where e has mean 0,
    /// variance 0.8 and is uncorrelated with x0: every regression on x0 is known exactly.
    fn linear_complement() -> Vec<f64> {
        let x0 = [-2.5, -1.5, -0.5, 0.5, 1.5, 2.5];
        let e = [1.0, -1.0, 0.0, 0.0, -1.0, 1.0];
        x0.iter()
            .zip(e)
            .flat_map(|(&a, e)| [a, 2.0 * a + 1.0, -0.5 * a + e])
            .collect()
    }

    #[test]
    fn followers_move_by_their_regression_on_the_block() {
        let positions = linear_complement();
        let all: Vec<usize> = (0..6).collect();
        let f = Followers::new(&positions, 3, &all, &[0], &[1, 2]).unwrap();
        let x = [0.0, 5.0, 7.0];
        let mut out = [1.0, 5.0, 7.0];
        f.carry(&x, &[0], &[1, 2], &mut out);
        assert!((out[1] - 7.0).abs() < 1e-12, "{out:?}");
        assert!((out[2] - 6.5).abs() < 1e-12, "{out:?}");
        // One walker is no regression.
        assert!(Followers::new(&positions, 3, &[0], &[0], &[1, 2]).is_none());
    }

    #[test]
    fn the_conditional_proposal_is_centred_on_the_walkers_given_coordinates() {
        use rand::SeedableRng;
        let positions = linear_complement();
        let all: Vec<usize> = (0..6).collect();
        let mut c = ConditionalFit::new(&positions, 3, &all, &[2], &[0], None).unwrap();
        // Given x0 = 2: mean −1, variance 0.8 (the residual e's).
        let x = [2.0, 0.0, 0.3];
        let fit = c.given(&x, &[0]);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let mut y = [0.0];
        let log_ratio = fit.propose(&[x[2]], &mut rng, &mut y);
        let log_q = |v: f64| -0.5 * (v + 1.0) * (v + 1.0) / 0.8;
        assert!((log_ratio - (log_q(x[2]) - log_q(y[0]))).abs() < 1e-12);
        // x1 is exactly linear in x0: no conditional spread, no fit; nor from too few walkers.
        assert!(ConditionalFit::new(&positions, 3, &all, &[1], &[0], None).is_none());
        assert!(ConditionalFit::new(&positions, 3, &[0, 1], &[2], &[0], None).is_none());
    }
}
