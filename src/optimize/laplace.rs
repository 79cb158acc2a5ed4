//! The Laplace approximation of a log-density and the walkers drawn from it.
//!
//! The mode is found with L-BFGS on finite-difference gradients, polished with Nelder–Mead
//! (no gradients needed, robust to the rejections a density may return near the edge of its
//! support), the local curvature with a central finite-difference Hessian, and walkers are
//! drawn from `N(mode, H⁻¹)`. When `H` is not positive definite, the directions without
//! positive curvature get a small fixed spread instead.

use nalgebra::{DMatrix, DVector, SymmetricEigen};
use rand::Rng;
use rand_distr::StandardNormal;

use super::by_blocks::{ArrowheadFactor, ByBlocks, BY_BLOCKS_FROM};
use super::lbfgs::{lbfgs, LbfgsOptions, Objective};
use super::nelder_mead::{nelder_mead, NelderMeadOptions};
use super::probe::Probe;
use super::OptimizeError;
use crate::density::{BlockedDensity, LogDensity, LogDensityError, Target};
use crate::diagnostics::{blockwise_condition_number, WALKER_CONDITION_LIMIT};

/// Covariance of the Laplace approximation at `mode` of the log-density `log_f`, from a
/// central finite-difference Hessian: `(Σ, positive_definite)`, `Σ` row-major `n × n`.
///
/// Directions without positive curvature (or when a difference point is refused) get the
/// fallback standard deviation `fallback_sd · max(|x_i|, 1)` along the coordinate axes.
pub fn laplace_covariance<F: FnMut(&[f64]) -> f64>(
    mut log_f: F,
    mode: &[f64],
    fallback_sd: f64,
) -> (Vec<f64>, bool) {
    let h = hessian_steps(mode);
    let f0 = log_f(mode);
    let mut x = mode.to_vec();
    let mut at = |x: &mut Vec<f64>, moves: &[(usize, f64)]| {
        for &(i, d) in moves {
            x[i] += d;
        }
        let v = log_f(x);
        x.copy_from_slice(mode);
        v
    };
    let n = mode.len();
    let axis: Vec<[f64; 2]> = (0..n)
        .map(|i| [at(&mut x, &[(i, h[i])]), at(&mut x, &[(i, -h[i])])])
        .collect();
    let pairs: Vec<Vec<[f64; 4]>> = (0..n)
        .map(|i| {
            (0..i)
                .map(|j| {
                    [
                        at(&mut x, &[(i, h[i]), (j, h[j])]),
                        at(&mut x, &[(i, h[i]), (j, -h[j])]),
                        at(&mut x, &[(i, -h[i]), (j, h[j])]),
                        at(&mut x, &[(i, -h[i]), (j, -h[j])]),
                    ]
                })
                .collect()
        })
        .collect();
    covariance_from_differences(mode, &h, f0, &axis, &pairs, fallback_sd)
}

/// The steps of the second differences: ε^(1/4) balances truncation (h²) against rounding
/// (ε/h²).
pub(super) fn hessian_steps(mode: &[f64]) -> Vec<f64> {
    mode.iter()
        .map(|x| f64::EPSILON.powf(0.25) * x.abs().max(1.0))
        .collect()
}

/// [`laplace_covariance`] of a density, each difference point evaluated by the block of the
/// coordinates moved and in parallel ([`Probe`]): the same numbers.
fn probe_covariance<D: LogDensity + ?Sized>(
    probe: &Probe<'_, D>,
    mode: &[f64],
    fallback_sd: f64,
) -> (Vec<f64>, bool) {
    let h = hessian_steps(mode);
    let d = probe.second_differences(mode, &h);
    covariance_from_differences(mode, &h, d.at_x, &d.axis, &d.pairs, fallback_sd)
}

/// The covariance from the central second differences of `log f` at `mode` with steps `h`
/// ([`hessian_steps`]): `f0 = f(mode)`,
/// `axis[i] = [f(+h_i), f(−h_i)]`, `pairs[i][j] = f` at (±h_i, ±h_j) for `j < i` in the order
/// (+, +), (+, −), (−, +), (−, −).
fn covariance_from_differences(
    mode: &[f64],
    h: &[f64],
    f0: f64,
    axis: &[[f64; 2]],
    pairs: &[Vec<[f64; 4]>],
    fallback_sd: f64,
) -> (Vec<f64>, bool) {
    let n = mode.len();
    let mut hess = DMatrix::<f64>::zeros(n, n);
    let mut finite = f0.is_finite();
    for i in 0..n {
        let [fp, fm] = axis[i];
        finite &= fp.is_finite() && fm.is_finite();
        hess[(i, i)] = -(fp - 2.0 * f0 + fm) / (h[i] * h[i]);
        for j in 0..i {
            let [fpp, fpm, fmp, fmm] = pairs[i][j];
            finite &= fpp.is_finite() && fpm.is_finite() && fmp.is_finite() && fmm.is_finite();
            let v = -(fpp - fpm - fmp + fmm) / (4.0 * h[i] * h[j]);
            hess[(i, j)] = v;
            hess[(j, i)] = v;
        }
    }
    let fallback = |i: usize| (fallback_sd * mode[i].abs().max(1.0)).powi(2);
    if !finite {
        let mut cov = vec![0.0; n * n];
        for i in 0..n {
            cov[i * n + i] = fallback(i);
        }
        return (cov, false);
    }
    let eig = SymmetricEigen::new(hess);
    let lmax = eig.eigenvalues.iter().copied().fold(0.0f64, f64::max);
    let mut pd = true;
    let mut inv = DVector::<f64>::zeros(n);
    for (k, &l) in eig.eigenvalues.iter().enumerate() {
        // Curvature this small relative to the largest is numerically zero.
        if l > lmax * 1e-12 && l > 0.0 {
            inv[k] = 1.0 / l;
        } else {
            pd = false;
            // Spread along this eigenvector as the fallback would along an axis.
            let v = eig.eigenvectors.column(k);
            inv[k] = (0..n).map(|i| v[i] * v[i] * fallback(i)).sum();
        }
    }
    let cov = &eig.eigenvectors * DMatrix::from_diagonal(&inv) * eig.eigenvectors.transpose();
    let mut out = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            out[i * n + j] = cov[(i, j)];
        }
    }
    (out, pd)
}

/// The mode of a log-density and the curvature there.
#[derive(Debug, Clone, PartialEq)]
pub struct Optimum {
    /// Position of the mode.
    pub x: Vec<f64>,
    /// Log-density there.
    pub log_density: f64,
    /// Covariance of the Laplace approximation.
    pub covariance: Covariance,
    /// Whether the Hessian was positive definite (otherwise a fallback spread was used).
    pub positive_definite: bool,
    /// Log-density evaluations spent (optimisation and Hessian).
    pub evaluations: usize,
}

/// The covariance of a Laplace approximation: dense, or by independent blocks for a density
/// searched by them ([`BY_BLOCKS_FROM`]), whose dense covariance would take O(d²) memory.
#[derive(Debug, Clone, PartialEq)]
pub enum Covariance {
    /// Row-major `ndim × ndim`.
    Dense(Vec<f64>),
    /// The Cholesky factor of its inverse, an arrowhead.
    Arrowhead(ArrowheadFactor),
}

impl Covariance {
    /// Row-major `ndim × ndim` (computed from the factor of an arrowhead: O(d²) memory).
    pub fn to_dense(&self, ndim: usize) -> Vec<f64> {
        match self {
            Self::Dense(c) => c.clone(),
            Self::Arrowhead(factor) => factor.to_dense(ndim),
        }
    }
}

/// Initial walkers and how they were found.
#[derive(Debug, Clone, PartialEq)]
pub struct Start {
    /// `walkers[ensemble][walker]`, ready for the ensemble sampler.
    pub walkers: Vec<Vec<Vec<f64>>>,
    /// The mode and curvature.
    pub optimum: Optimum,
}

/// Relative fallback spread along directions without positive curvature.
pub const FALLBACK_SPREAD: f64 = 1e-3;
/// Attempts to draw a walker inside the support before giving up.
pub const MAX_DRAW_ATTEMPTS: usize = 1000;

/// The negative log-density that L-BFGS minimises, its axis points evaluated by the probe.
struct Minus<'p, 'd, D: ?Sized>(&'p Probe<'d, D>);

impl<D: LogDensity + ?Sized> Objective for Minus<'_, '_, D> {
    fn value(&mut self, x: &[f64]) -> f64 {
        -self.0.value(x)
    }

    fn axis_values(&mut self, x: &[f64], h: &[f64]) -> Vec<[f64; 2]> {
        self.0
            .axis(x, h)
            .into_iter()
            .map(|v| v.map(|f| -f))
            .collect()
    }
}

/// Most rounds of L-BFGS and Nelder–Mead in [`find_mode`].
const MODE_ROUNDS: usize = 6;

/// A round of [`find_mode`] that raises the log-density by less than this ends the search.
const MODE_ROUND_GAIN: f64 = 1e-3;

/// The mode of `density` from `start` (rounds of L-BFGS, each with a Nelder–Mead polish) and the covariance
/// of the Laplace approximation there. A density of at least [`BY_BLOCKS_FROM`] coordinates
/// seen through blocks, independent blocks among them, is searched by those blocks instead
/// (damped Newton steps on its arrowhead curvature, [`ArrowheadFactor`]), at a cost
/// linear in their number.
///
/// # Errors
/// [`OptimizeError::Shape`] for a start of the wrong length, [`OptimizeError::StartNotFinite`]
/// when `start` is not inside the support, [`OptimizeError::NoFiniteMode`] when the search
/// ends where the density is not finite.
pub fn find_mode<'d, D: LogDensity + ?Sized + 'd>(
    target: impl Into<Target<'d, D>>,
    start: &[f64],
) -> Result<Optimum, OptimizeError> {
    let target = target.into();
    let n = target.density().dim();
    if start.len() != n {
        return Err(OptimizeError::Shape {
            expected: n,
            got: start.len(),
        });
    }
    if n >= BY_BLOCKS_FROM {
        if let Some(by_blocks) = target.blocked_density().and_then(ByBlocks::new) {
            return by_blocks.find_mode(start);
        }
    }
    let probe = Probe::new(target);
    if !probe.value(start).is_finite() {
        return Err(OptimizeError::StartNotFinite {
            start: start.to_vec(),
        });
    }
    // L-BFGS gets close cheaply in many dimensions; Nelder–Mead then polishes without
    // trusting finite-difference gradients at the end. On a narrow curved ridge one L-BFGS
    // run can stop far below the mode (an SBC draw: −675 where the mode is at +1,939, reached
    // by a second round), so the pair is repeated until a round gains less than
    // `MODE_ROUND_GAIN`.
    let (mode, neg) = climb(|| Minus(&probe), |x| -probe.value(x), start, f64::INFINITY);
    if !neg.is_finite() {
        return Err(OptimizeError::NoFiniteMode {
            at: mode,
            log_density: -neg,
        });
    }
    let (covariance, positive_definite) = probe_covariance(&probe, &mode, FALLBACK_SPREAD);
    Ok(Optimum {
        x: mode,
        log_density: -neg,
        covariance: Covariance::Dense(covariance),
        positive_definite,
        evaluations: probe.evaluations(),
    })
}

/// The minimum of `minus` (minus a log-density) from `start`, where it is `at_start` (+∞ to
/// take the first round's point whatever it gains), and its value there: rounds of L-BFGS
/// on the finite differences of `objective()`, each polished by Nelder–Mead on `minus`, until
/// a round gains less than [`MODE_ROUND_GAIN`]. The dense search's, and each block's
/// conditional mode in the search by blocks.
pub(super) fn climb<O: Objective>(
    mut objective: impl FnMut() -> O,
    mut minus: impl FnMut(&[f64]) -> f64,
    start: &[f64],
    at_start: f64,
) -> (Vec<f64>, f64) {
    let polish = NelderMeadOptions {
        initial_step: 1e-3,
        max_evals: 30 * start.len(),
        restarts: 1,
        ..NelderMeadOptions::default()
    };
    let (mut mode, mut neg) = (start.to_vec(), at_start);
    for _ in 0..MODE_ROUNDS {
        let (near, _) = lbfgs(objective(), &mode, &LbfgsOptions::default());
        let (polished, value, _) = nelder_mead(&mut minus, &near, &polish);
        let gain = neg - value;
        if value < neg {
            (mode, neg) = (polished, value);
        }
        // NaN when no round has found a finite density: nothing to build on.
        if gain.is_nan() || gain <= MODE_ROUND_GAIN {
            break;
        }
    }
    (mode, neg)
}

/// `ensembles × walkers` walkers drawn from the Laplace approximation `N(mode, Σ)` of
/// `optimum`, redrawing points the density refuses, with a narrower spread as refusals
/// mount.
///
/// # Errors
/// [`OptimizeError::NoWalkerInSupport`] when a walker cannot be drawn inside the support,
/// [`OptimizeError::DegenerateWalkers`] when an ensemble's walkers do not span the space.
pub fn laplace_walkers<'d, D: LogDensity + ?Sized + 'd, R: Rng>(
    target: impl Into<Target<'d, D>>,
    optimum: &Optimum,
    walkers: usize,
    ensembles: usize,
    rng: &mut R,
) -> Result<Vec<Vec<Vec<f64>>>, OptimizeError> {
    let target = target.into();
    let span = span_blocks(target.blocked_density(), walkers, optimum.x.len());
    walkers_around(target.density(), optimum, &span, walkers, ensembles, rng)
}

/// The blocks whose subspaces the walkers must span: too few walkers to span the whole space
/// is fine for a sampler updating the density's blocks one at a time, which then needs each
/// block's subspace spanned. None (the whole space) otherwise.
fn span_blocks(
    blocked: Option<&dyn BlockedDensity>,
    walkers: usize,
    dim: usize,
) -> Vec<Vec<usize>> {
    match blocked {
        Some(blocked) if walkers <= dim => blocked.block_plan().coords(),
        _ => Vec::new(),
    }
}

/// [`laplace_walkers`] of `density`, each ensemble spanning the subspace of each of `span`
/// (the whole space when empty).
fn walkers_around<D: LogDensity + ?Sized, R: Rng>(
    density: &D,
    optimum: &Optimum,
    span: &[Vec<usize>],
    walkers: usize,
    ensembles: usize,
    rng: &mut R,
) -> Result<Vec<Vec<Vec<f64>>>, OptimizeError> {
    let mode = &optimum.x;
    let n = mode.len();
    let probe = Probe::new(Target::joint(density));
    let spread = Spread::of(&optimum.covariance, n);
    let mut z = DVector::<f64>::zeros(n);
    let mut all = Vec::with_capacity(ensembles);
    for e in 0..ensembles {
        let mut ens = Vec::with_capacity(walkers);
        for w in 0..walkers {
            let mut attempts = 0;
            let x = loop {
                attempts += 1;
                z.iter_mut().for_each(|v| *v = rng.sample(StandardNormal));
                // A mode pressed against the edge of the support (a posterior the data do not
                // identify) refuses many Laplace draws: narrow the spread as refusals mount,
                // halving it every tenth of the attempts.
                let shrink = 0.5_f64.powi((attempts * 10 / MAX_DRAW_ATTEMPTS) as i32);
                let d = spread.draw(&z) * shrink;
                let x: Vec<f64> = mode.iter().zip(d.iter()).map(|(m, d)| m + d).collect();
                if probe.value(&x).is_finite() {
                    break x;
                }
                if attempts >= MAX_DRAW_ATTEMPTS {
                    return Err(OptimizeError::NoWalkerInSupport {
                        ensemble: e,
                        walker: w,
                        mode: mode.clone(),
                        attempts,
                    });
                }
            };
            ens.push(x);
        }
        let flat: Vec<f64> = ens.iter().flatten().copied().collect();
        let condition = blockwise_condition_number(&flat, n, span);
        if condition.is_nan() || condition > WALKER_CONDITION_LIMIT {
            return Err(OptimizeError::DegenerateWalkers {
                mode: mode.clone(),
                condition,
            });
        }
        all.push(ens);
    }
    Ok(all)
}

/// How a draw from `N(0, Σ)` is made from a standard normal `z`.
enum Spread<'o> {
    /// `Σ = V Λ Vᵀ`, so `V Λ^{1/2} z`.
    Root(DMatrix<f64>),
    /// `L⁻ᵀ z` with `L Lᵀ = Σ⁻¹`.
    Arrowhead(&'o ArrowheadFactor),
}

impl<'o> Spread<'o> {
    fn of(covariance: &'o Covariance, n: usize) -> Self {
        match covariance {
            Covariance::Dense(c) => {
                let eig = SymmetricEigen::new(DMatrix::from_row_slice(n, n, c));
                let root = eig.eigenvalues.map(|l| l.max(0.0).sqrt());
                Self::Root(&eig.eigenvectors * DMatrix::from_diagonal(&root))
            }
            Covariance::Arrowhead(factor) => Self::Arrowhead(factor),
        }
    }

    fn draw(&self, z: &DVector<f64>) -> DVector<f64> {
        match self {
            Self::Root(root) => root * z,
            Self::Arrowhead(factor) => factor.draw(z),
        }
    }
}

/// Where to search for the mode that the first walkers are drawn around: a starting point,
/// and for a density that has no mode in its own coordinates, the coordinates to search in.
#[derive(Clone, Copy)]
pub struct SearchStart<'a> {
    /// Where the search starts, in the density's coordinates.
    pub point: &'a [f64],
    /// Coordinates in which to search for the mode and draw the walkers around it: a centred
    /// hierarchical model is unbounded where a population's spread vanishes with its members
    /// at its mean, and has a mode in the non-centred coordinates. `None`: the density's own.
    pub map: Option<&'a dyn SearchMap>,
}

impl<'a> From<&'a [f64]> for SearchStart<'a> {
    fn from(point: &'a [f64]) -> Self {
        Self { point, map: None }
    }
}

impl<'a> From<&'a Vec<f64>> for SearchStart<'a> {
    fn from(point: &'a Vec<f64>) -> Self {
        Self { point, map: None }
    }
}

impl<'a, const N: usize> From<&'a [f64; N]> for SearchStart<'a> {
    fn from(point: &'a [f64; N]) -> Self {
        Self { point, map: None }
    }
}

/// A bijection between a density's coordinates x and the coordinates y in which the
/// optimiser searches for a mode ([`SearchStart::map`]). The density of y is
/// p(x(y)) |det ∂x/∂y|.
pub trait SearchMap: Sync {
    /// y of `x`, written into `y`.
    fn search_point(&self, x: &[f64], y: &mut [f64]);
    /// x of `y`, written into `x`; returns ln |det ∂x/∂y| at `y`.
    fn density_point(&self, y: &[f64], x: &mut [f64]) -> f64;
}

/// Finds the mode of the density of `target` from `start` ([`find_mode`]) and draws
/// `ensembles × walkers` walkers from the Laplace approximation there ([`laplace_walkers`]).
/// When the start names a [`map`](SearchStart::map), both happen in its coordinates (the
/// optimum and its covariance are reported there) and the walkers are mapped back.
///
/// # Errors
/// As [`find_mode`] and [`laplace_walkers`].
pub fn initial_around_optimum<'d, D: LogDensity + ?Sized + 'd, R: Rng>(
    target: impl Into<Target<'d, D>>,
    start: impl Into<SearchStart<'d>>,
    walkers: usize,
    ensembles: usize,
    rng: &mut R,
) -> Result<Start, OptimizeError> {
    let (target, start) = (target.into(), start.into());
    let Some(map) = start.map else {
        let optimum = find_mode(target, start.point)?;
        let walkers = laplace_walkers(target, &optimum, walkers, ensembles, rng)?;
        return Ok(Start { walkers, optimum });
    };
    let searched = Searched {
        density: target.density(),
        map,
    };
    let mut y = vec![0.0; start.point.len()];
    map.search_point(start.point, &mut y);
    let optimum = find_mode(&searched, &y)?;
    let span = span_blocks(target.blocked_density(), walkers, y.len());
    let mut walkers = walkers_around(&searched, &optimum, &span, walkers, ensembles, rng)?;
    for w in walkers.iter_mut().flatten() {
        y.copy_from_slice(w);
        map.density_point(&y, w);
    }
    Ok(Start { walkers, optimum })
}

/// A density seen in the coordinates of its search map, with the map's Jacobian.
struct Searched<'d, D: ?Sized> {
    density: &'d D,
    map: &'d dyn SearchMap,
}

impl<D: LogDensity + ?Sized> LogDensity for Searched<'_, D> {
    fn dim(&self) -> usize {
        self.density.dim()
    }

    fn derived_names(&self) -> Vec<String> {
        self.density.derived_names()
    }

    fn log_density(&self, y: &[f64], derived: &mut [f64]) -> Result<f64, LogDensityError> {
        let mut x = vec![0.0; y.len()];
        let ln_jacobian = self.map.density_point(y, &mut x);
        Ok(self.density.log_density(&x, derived)? + ln_jacobian)
    }

    fn explain(&self, y: &[f64]) -> Option<String> {
        let mut x = vec![0.0; y.len()];
        self.map.density_point(y, &mut x);
        self.density.explain(&x)
    }
}
