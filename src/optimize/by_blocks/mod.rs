//! The mode and the Laplace approximation of a density with many independent blocks (a
//! campaign's contacts, each independent of the others given the parameters its material
//! shares), at a cost linear in the number of blocks.
//!
//! Such a density is `ln p(x) = G(x_S) + Σ_j T_j(x_S, x_j)`: `x_S` the coordinates of no
//! independent block (the *shared* ones), `x_j` block j's own, `T_j` its terms
//! ([`IndependentBlocks::block_terms`]). Its curvature `K = −∇² ln p` is an arrowhead: a block
//! couples with itself and with the shared coordinates, never with another block. So
//!
//! - every finite difference that moves a block's coordinate re-evaluates that block's terms
//!   alone ([`IndependentBlocks::update_block_state`]), from a full evaluation at the shared
//!   coordinates it needs (the point itself, and the point with one shared coordinate moved):
//!   the gradient and the Hessian cost a fixed number of evaluations per block, plus a few
//!   full evaluations per shared coordinate;
//! - a step solves the arrowhead system through the Schur complement on the shared
//!   coordinates, and the walkers are drawn from `N(mode, K⁻¹)` through the same factor:
//!   O(blocks) work and memory, where the dense search ([`super::laplace`]) needs O(d²)
//!   evaluations for its Hessian and O(d³) for its eigendecomposition.
//!
//! The mode is found by Newton steps on that curvature, damped à la Levenberg–Marquardt: a
//! step that does not raise the log-density is retried with more damping (a shorter step
//! along a direction closer to the gradient's), one that does lowers the damping again.

mod factor;
#[cfg(test)]
mod tests;

use std::cell::RefCell;
use std::sync::atomic::{AtomicUsize, Ordering};

use nalgebra::{Cholesky, DMatrix};
use rayon::prelude::*;

pub use factor::ArrowheadFactor;
use factor::{diagonal, positive_part, FactorBlock};

use super::laplace::{climb, hessian_steps, Covariance, Optimum};
use super::OptimizeError;
use crate::density::{sort, BlockUpdate, BlockedDensity, Eval, IndependentBlocks, OwnEntries};

/// Densities of at least this many coordinates whose plan has independent blocks are searched
/// by blocks. Below it the dense search costs little (its Hessian at most 2·64² block
/// evaluations), makes no use of the blocks' structure, and polishes its mode with
/// Nelder–Mead, which tolerates the rejections a density may return near the edge of its
/// support better than finite-difference curvature does.
pub const BY_BLOCKS_FROM: usize = 64;

/// Most rounds of conditional modes before the Newton steps.
const MAX_ROUNDS: usize = 20;

/// A round of conditional modes that raises the log-density by less than this, or by less
/// than [`ROUND_GAIN_PER_BLOCK`] per independent block, hands over to the Newton steps.
const ROUND_GAIN: f64 = 1.0;

/// A round's gain is a sum over the blocks, so the bar for handing over grows with them: past
/// the first round or two, the rounds crawl along the coupling of the blocks with the shared
/// coordinates (each gaining a little less than the one before), which the Newton steps
/// resolve at once. A bar that does not grow with the blocks keeps a large campaign crawling
/// through every one of [`MAX_ROUNDS`].
const ROUND_GAIN_PER_BLOCK: f64 = 0.02;

/// Most Newton steps of the search.
const MAX_STEPS: usize = 200;

/// A step that raises the log-density by less than this per coordinate ends the search. At
/// a quadratic mode, a remaining gain of δ per coordinate is a distance of about √(2δ)
/// posterior standard deviations per coordinate (here 0.0014), where the walkers are drawn
/// from the Laplace approximation a standard deviation wide. A bar that does not grow with
/// the coordinates asks a density of many contacts for a gain below what its
/// finite-difference curvature resolves, and the damped steps then chase rounding.
const STEP_GAIN_PER_COORDINATE: f64 = 1e-6;

/// Damping beyond which no step is tried: the step is then shorter than the finite
/// differences can resolve.
const MAX_DAMPING: f64 = 1e12;

/// One independent block of the plan.
struct Independent<'d> {
    /// Its index in the plan.
    block: usize,
    coords: Vec<usize>,
    own: &'d dyn IndependentBlocks,
    entries: OwnEntries,
}

/// A density seen through its independent blocks and the coordinates they share.
pub(crate) struct ByBlocks<'d> {
    density: &'d dyn BlockedDensity,
    shared: Vec<usize>,
    blocks: Vec<Independent<'d>>,
    nderived: usize,
    evaluations: AtomicUsize,
}

/// A full evaluation: the log-density, with the derived values and state a block's terms are
/// re-evaluated from.
struct Base {
    log_density: f64,
    derived: Vec<f64>,
    state: Vec<f64>,
}

/// The gradient and curvature of the log-density at a point, by blocks.
struct Local {
    log_density: f64,
    /// `∂ ln p / ∂x_i`, every coordinate.
    gradient: Vec<f64>,
    /// `K_SS`, shared × shared.
    shared: DMatrix<f64>,
    blocks: Vec<BlockCurvature>,
    /// Whether every difference point was inside the support.
    finite: bool,
}

/// A block's rows of the curvature: `K_jj` (own × own) and `K_jS` (own × shared).
struct BlockCurvature {
    own: DMatrix<f64>,
    cross: DMatrix<f64>,
    finite: bool,
}

impl<'d> ByBlocks<'d> {
    /// The density's independent blocks, when its plan has at least two.
    pub(crate) fn new(density: &'d dyn BlockedDensity) -> Option<Self> {
        let dim = density.dim();
        let mut in_block = vec![false; dim];
        let mut blocks = Vec::new();
        for (block, planned) in density.block_plan().blocks.into_iter().enumerate() {
            if let BlockUpdate::Independent { own, entries } = planned.update {
                for &i in &planned.coords {
                    in_block[i] = true;
                }
                blocks.push(Independent {
                    block,
                    coords: planned.coords,
                    own,
                    entries,
                });
            }
        }
        (blocks.len() >= 2).then(|| Self {
            density,
            shared: (0..dim).filter(|&i| !in_block[i]).collect(),
            blocks,
            nderived: density.derived_names().len(),
            evaluations: AtomicUsize::new(0),
        })
    }

    fn count(&self, n: usize) {
        self.evaluations.fetch_add(n, Ordering::Relaxed);
    }

    /// The density at `x` in full, `None` outside its support.
    fn full(&self, x: &[f64]) -> Option<Base> {
        self.count(1);
        let mut derived = vec![0.0; self.nderived];
        let mut state = vec![0.0; self.density.state_len()];
        match sort(
            self.density
                .log_density_with_state(x, &mut derived, &mut state),
        ) {
            Eval::Finite(log_density) => Some(Base {
                log_density,
                derived,
                state,
            }),
            _ => None,
        }
    }

    /// The log-density at `x`, −∞ outside the support.
    fn value(&self, x: &[f64]) -> f64 {
        self.full(x).map_or(f64::NEG_INFINITY, |b| b.log_density)
    }

    /// Block `j`'s own entries of `base`'s state and derived values, in the block's order.
    fn own_entries(&self, j: usize, base: &Base) -> (Vec<f64>, Vec<f64>) {
        let e = &self.blocks[j].entries;
        (
            e.state.iter().map(|&k| base.state[k]).collect(),
            e.derived.iter().map(|&k| base.derived[k]).collect(),
        )
    }

    /// Block `j`'s terms at `x`, a point that differs from `base`'s only in the block's own
    /// coordinates: re-evaluated from `base`'s entries (−∞ outside the support).
    fn terms(&self, j: usize, base: &Base, x: &[f64]) -> f64 {
        let b = &self.blocks[j];
        let (mut state, mut derived) = self.own_entries(j, base);
        self.count(1);
        match sort(
            b.own
                .update_block_state(b.block, x, &mut derived, &mut state),
        ) {
            Eval::Finite(v) => v,
            _ => f64::NEG_INFINITY,
        }
    }

    /// The gradient and curvature at `x` from central differences with steps
    /// [`hessian_steps`]; `None` when `x` is outside the support.
    fn local(&self, x: &[f64]) -> Option<Local> {
        let (h, hg) = (hessian_steps(x), gradient_steps(x));
        let base = self.full(x)?;
        let at = |moves: &[(usize, f64)]| {
            let mut y = x.to_vec();
            for &(i, d) in moves {
                y[i] = x[i] + d;
            }
            self.full(&y)
        };
        // The full evaluations: the point with each shared coordinate moved either way, and
        // with each pair of them moved.
        let axis: Vec<[Option<Base>; 2]> = self
            .shared
            .par_iter()
            .map(|&i| [at(&[(i, h[i])]), at(&[(i, -h[i])])])
            .collect();
        let value = |b: Option<Base>| b.map_or(f64::NEG_INFINITY, |b| b.log_density);
        let slopes: Vec<f64> = self
            .shared
            .par_iter()
            .map(|&i| {
                slope(
                    value(at(&[(i, hg[i])])),
                    value(at(&[(i, -hg[i])])),
                    base.log_density,
                    hg[i],
                )
            })
            .collect();
        let s = self.shared.len();
        let pairs: Vec<(usize, usize)> = (0..s).flat_map(|a| (0..a).map(move |c| (a, c))).collect();
        let pair_values: Vec<[f64; 4]> = pairs
            .par_iter()
            .map(|&(a, c)| {
                let (i, k) = (self.shared[a], self.shared[c]);
                let f = |si: f64, sk: f64| {
                    at(&[(i, si * h[i]), (k, sk * h[k])])
                        .map_or(f64::NEG_INFINITY, |b| b.log_density)
                };
                [f(1.0, 1.0), f(1.0, -1.0), f(-1.0, 1.0), f(-1.0, -1.0)]
            })
            .collect();
        let f0 = base.log_density;
        let value = |b: &Option<Base>| b.as_ref().map_or(f64::NEG_INFINITY, |b| b.log_density);
        let mut gradient = vec![0.0; x.len()];
        for (&i, g) in self.shared.iter().zip(slopes) {
            gradient[i] = g;
        }
        let mut shared = DMatrix::zeros(s, s);
        let mut finite = true;
        for (a, &i) in self.shared.iter().enumerate() {
            let (fp, fm) = (value(&axis[a][0]), value(&axis[a][1]));
            finite &= fp.is_finite() && fm.is_finite();
            shared[(a, a)] = -(fp - 2.0 * f0 + fm) / (h[i] * h[i]);
        }
        for (&(a, c), v) in pairs.iter().zip(&pair_values) {
            finite &= v.iter().all(|f| f.is_finite());
            let (i, k) = (self.shared[a], self.shared[c]);
            let k_ac = -(v[0] - v[1] - v[2] + v[3]) / (4.0 * h[i] * h[k]);
            shared[(a, c)] = k_ac;
            shared[(c, a)] = k_ac;
        }
        let blocks: Vec<(Vec<f64>, BlockCurvature)> = (0..self.blocks.len())
            .into_par_iter()
            .map_init(
                || x.to_vec(),
                |scratch, j| self.block_local(j, x, [&h, &hg], &base, &axis, scratch),
            )
            .collect();
        let blocks = blocks
            .into_iter()
            .enumerate()
            .map(|(j, (g, curvature))| {
                for (&i, g) in self.blocks[j].coords.iter().zip(g) {
                    gradient[i] = g;
                }
                finite &= curvature.finite;
                curvature
            })
            .collect();
        Some(Local {
            log_density: f0,
            gradient,
            shared,
            blocks,
            finite,
        })
    }

    /// Block `j`'s gradient and rows of the curvature at `x`: each difference point moves
    /// one or two of the block's coordinates (from `base`) or one of them and one shared
    /// coordinate (from that shared coordinate's `axis` evaluation). `scratch` holds `x` and
    /// is handed back holding it.
    fn block_local(
        &self,
        j: usize,
        x: &[f64],
        [h, hg]: [&[f64]; 2],
        base: &Base,
        axis: &[[Option<Base>; 2]],
        scratch: &mut [f64],
    ) -> (Vec<f64>, BlockCurvature) {
        let coords = &self.blocks[j].coords;
        let (nb, s) = (coords.len(), self.shared.len());
        let mut at = |base: &Base, moves: &[(usize, f64)]| {
            for &(i, d) in moves {
                scratch[i] = x[i] + d;
            }
            let v = self.terms(j, base, scratch);
            for &(i, _) in moves {
                scratch[i] = x[i];
            }
            v
        };
        let (state, _) = self.own_entries(j, base);
        let b = &self.blocks[j];
        let t0 = b.own.block_terms(b.block, x, &state);
        let mut finite = t0.is_finite();
        let mut gradient = vec![0.0; nb];
        let mut own = DMatrix::zeros(nb, nb);
        let mut cross = DMatrix::zeros(nb, s);
        let four = |v: [f64; 4], hi: f64, hk: f64| -(v[0] - v[1] - v[2] + v[3]) / (4.0 * hi * hk);
        for (a, &i) in coords.iter().enumerate() {
            let (tp, tm) = (at(base, &[(i, h[i])]), at(base, &[(i, -h[i])]));
            finite &= tp.is_finite() && tm.is_finite();
            let (gp, gm) = (at(base, &[(i, hg[i])]), at(base, &[(i, -hg[i])]));
            gradient[a] = slope(gp, gm, t0, hg[i]);
            own[(a, a)] = -(tp - 2.0 * t0 + tm) / (h[i] * h[i]);
            for (c, &k) in coords[..a].iter().enumerate() {
                let v = [
                    at(base, &[(i, h[i]), (k, h[k])]),
                    at(base, &[(i, h[i]), (k, -h[k])]),
                    at(base, &[(i, -h[i]), (k, h[k])]),
                    at(base, &[(i, -h[i]), (k, -h[k])]),
                ];
                finite &= v.iter().all(|t| t.is_finite());
                own[(a, c)] = four(v, h[i], h[k]);
                own[(c, a)] = own[(a, c)];
            }
            // With a shared coordinate moved, the block's terms are re-evaluated from the
            // full evaluation there; the terms at the shared move alone cancel.
            for (c, &k) in self.shared.iter().enumerate() {
                let [Some(plus), Some(minus)] = &axis[c] else {
                    finite = false;
                    continue;
                };
                let v = [
                    at(plus, &[(k, h[k]), (i, h[i])]),
                    at(plus, &[(k, h[k]), (i, -h[i])]),
                    at(minus, &[(k, -h[k]), (i, h[i])]),
                    at(minus, &[(k, -h[k]), (i, -h[i])]),
                ];
                finite &= v.iter().all(|t| t.is_finite());
                cross[(a, c)] = four(v, h[k], h[i]);
            }
        }
        (gradient, BlockCurvature { own, cross, finite })
    }

    /// The mode from `start` and the Laplace approximation there: rounds of each block's
    /// conditional mode (every independent block given the shared coordinates, in parallel,
    /// then the shared coordinates given the blocks) until a round gains less than
    /// [`ROUND_GAIN`] (or [`ROUND_GAIN_PER_BLOCK`] per block), then damped Newton steps on
    /// the arrowhead curvature until a step gains less than [`STEP_GAIN_PER_COORDINATE`] per
    /// coordinate. Newton alone from a rough start meets curvature that is far from positive
    /// definite and crawls (damped to steps of the gradient's length); the rounds bring it
    /// where it converges.
    pub(crate) fn find_mode(&self, start: &[f64]) -> Result<Optimum, OptimizeError> {
        let round_gain = ROUND_GAIN.max(ROUND_GAIN_PER_BLOCK * self.blocks.len() as f64);
        let step_gain = STEP_GAIN_PER_COORDINATE * start.len() as f64;
        let mut x = start.to_vec();
        let Some(mut value) = self.full(&x).map(|b| b.log_density) else {
            return Err(OptimizeError::StartNotFinite {
                start: start.to_vec(),
            });
        };
        for _ in 0..MAX_ROUNDS {
            let after = self.round(&mut x, value);
            let gain = after - value;
            value = after;
            // NaN (no finite value) ends the rounds too.
            if gain.is_nan() || gain < round_gain {
                break;
            }
        }
        let Some(mut local) = self.local(&x) else {
            return Err(OptimizeError::NoFiniteMode {
                at: x,
                log_density: value,
            });
        };
        let mut damping = 0.0;
        for _ in 0..MAX_STEPS {
            let Some((y, value)) = self.step(&x, &local, &mut damping) else {
                break;
            };
            let gain = value - local.log_density;
            x = y;
            local = match self.local(&x) {
                Some(local) => local,
                // The step's own evaluation was finite: this cannot happen but through a
                // density whose values change between calls.
                None => {
                    return Err(OptimizeError::NoFiniteMode {
                        at: x,
                        log_density: value,
                    })
                }
            };
            if gain < step_gain {
                break;
            }
        }
        let (factor, positive_definite) = self.laplace_factor(&local, &x);
        Ok(Optimum {
            log_density: local.log_density,
            x,
            covariance: Covariance::Arrowhead(factor),
            positive_definite,
            evaluations: self.evaluations.load(Ordering::Relaxed),
        })
    }

    /// One round of conditional modes from `x` (log-density `value`): each independent
    /// block's given the rest, then the shared coordinates' given the blocks. Returns the
    /// log-density at the new `x` (never lower than `value`).
    fn round(&self, x: &mut Vec<f64>, value: f64) -> f64 {
        let Some(base) = self.full(x) else {
            return value;
        };
        let moved: Vec<Vec<f64>> = (0..self.blocks.len())
            .into_par_iter()
            .map_init(
                || x.clone(),
                |scratch, j| {
                    let coords = &self.blocks[j].coords;
                    let start: Vec<f64> = coords.iter().map(|&i| x[i]).collect();
                    // One point for both of the climb's uses: its L-BFGS and its polish.
                    let point = RefCell::new(&mut *scratch);
                    let minus = |y: &[f64]| {
                        let mut point = point.borrow_mut();
                        coords.iter().zip(y).for_each(|(&i, &v)| point[i] = v);
                        -self.terms(j, &base, &point)
                    };
                    let (best, _) = climb(|| &minus, &minus, &start, minus(&start));
                    coords.iter().for_each(|&i| scratch[i] = x[i]);
                    best
                },
            )
            .collect();
        let mut y = x.clone();
        for (b, m) in self.blocks.iter().zip(moved) {
            b.coords.iter().zip(m).for_each(|(&i, v)| y[i] = v);
        }
        if !self.shared.is_empty() {
            let start: Vec<f64> = self.shared.iter().map(|&i| y[i]).collect();
            let point = RefCell::new(y.clone());
            let minus = |s: &[f64]| {
                let mut point = point.borrow_mut();
                self.shared.iter().zip(s).for_each(|(&i, &v)| point[i] = v);
                -self.value(&point)
            };
            let (best, _) = climb(|| &minus, &minus, &start, minus(&start));
            self.shared.iter().zip(best).for_each(|(&i, v)| y[i] = v);
        }
        let after = self.value(&y);
        if after > value {
            *x = y;
            after
        } else {
            value
        }
    }

    /// A step from `x` that raises the log-density, with the damping it took (lowered for
    /// the next step); `None` when no damping up to [`MAX_DAMPING`] finds one.
    fn step(&self, x: &[f64], local: &Local, damping: &mut f64) -> Option<(Vec<f64>, f64)> {
        let scale = self.damping_scale(local);
        while *damping <= MAX_DAMPING {
            if let Some(factor) = self.factor(local, Some((*damping, &scale))) {
                let step = factor.solve(&self.gradient_of_finite(local));
                let y: Vec<f64> = x.iter().zip(&step).map(|(x, d)| x + d).collect();
                let value = self.value(&y);
                if value > local.log_density {
                    *damping = if *damping < 1e-6 {
                        0.0
                    } else {
                        *damping / 10.0
                    };
                    return Some((y, value));
                }
            }
            *damping = if *damping == 0.0 {
                1e-6
            } else {
                *damping * 10.0
            };
        }
        None
    }

    /// The gradient with the coordinates of blocks whose differences left the support set
    /// to zero: such a block is not moved by the step.
    fn gradient_of_finite(&self, local: &Local) -> Vec<f64> {
        let mut g = local.gradient.clone();
        for (b, c) in self.blocks.iter().zip(&local.blocks) {
            if !c.finite {
                b.coords.iter().for_each(|&i| g[i] = 0.0);
            }
        }
        g.iter_mut().for_each(|v| {
            if !v.is_finite() {
                *v = 0.0
            }
        });
        g
    }

    /// The diagonal the damping adds in proportion: each coordinate's own curvature where
    /// positive, else the largest curvature's 1e-12 (or 1).
    fn damping_scale(&self, local: &Local) -> Vec<f64> {
        let mut diag = vec![0.0; local.gradient.len()];
        for (a, &i) in self.shared.iter().enumerate() {
            diag[i] = local.shared[(a, a)];
        }
        for (b, c) in self.blocks.iter().zip(&local.blocks) {
            for (a, &i) in b.coords.iter().enumerate() {
                diag[i] = c.own[(a, a)];
            }
        }
        let largest = diag
            .iter()
            .copied()
            .filter(|v| v.is_finite())
            .fold(0.0f64, f64::max);
        let floor = if largest > 0.0 { largest * 1e-12 } else { 1.0 };
        diag.iter()
            .map(|&v| if v.is_finite() && v > floor { v } else { floor })
            .collect()
    }

    /// The arrowhead Cholesky factor of `K + λ·diag(scale)` (`λ = 0` without damping); a
    /// block whose differences left the support is replaced by its damping diagonal alone.
    /// `None` when the matrix is not positive definite.
    fn factor(&self, local: &Local, damping: Option<(f64, &[f64])>) -> Option<ArrowheadFactor> {
        let damped = |m: &mut DMatrix<f64>, coords: &[usize]| {
            if let Some((lambda, scale)) = damping {
                for (a, &i) in coords.iter().enumerate() {
                    m[(a, a)] += lambda * scale[i];
                }
            }
        };
        let blocks: Option<Vec<FactorBlock>> = self
            .blocks
            .par_iter()
            .zip(&local.blocks)
            .map(|(b, c)| {
                let (mut own, cross) = if c.finite {
                    (c.own.clone(), c.cross.clone())
                } else {
                    let scale = damping.map(|(_, scale)| scale);
                    let diag = b.coords.iter().map(|&i| scale.map_or(1.0, |s| s[i]));
                    (
                        diagonal(diag),
                        DMatrix::zeros(b.coords.len(), self.shared.len()),
                    )
                };
                damped(&mut own, &b.coords);
                FactorBlock::new(&b.coords, own, &cross)
            })
            .collect();
        let blocks = blocks?;
        let mut schur = local.shared.clone();
        damped(&mut schur, &self.shared);
        for b in &blocks {
            schur -= b.m.transpose() * &b.m;
        }
        let schur = Cholesky::new(schur)?.l();
        Some(ArrowheadFactor {
            shared: self.shared.clone(),
            blocks,
            schur,
        })
    }

    /// The factor of the Laplace approximation at the mode, and whether `K` was positive
    /// definite there. Otherwise, as the dense search does, each block's (and then the
    /// Schur complement's) eigenvalues without positive curvature are replaced by the
    /// fallback curvature ([`FALLBACK_SPREAD`](super::FALLBACK_SPREAD) relative to each
    /// coordinate), and a block whose differences left the support gets the fallback alone.
    fn laplace_factor(&self, local: &Local, mode: &[f64]) -> (ArrowheadFactor, bool) {
        if local.finite {
            if let Some(factor) = self.factor(local, None) {
                return (factor, true);
            }
        }
        let fallback = |i: usize| (super::FALLBACK_SPREAD * mode[i].abs().max(1.0)).powi(-2);
        let fallback_block = |coords: &[usize]| {
            let own = diagonal(coords.iter().map(|&i| fallback(i)));
            let cross = DMatrix::zeros(coords.len(), self.shared.len());
            FactorBlock::new(coords, own, &cross).expect("a positive diagonal has a factor")
        };
        let blocks: Vec<FactorBlock> = self
            .blocks
            .iter()
            .zip(&local.blocks)
            .map(|(b, c)| {
                c.finite
                    .then(|| {
                        let own = positive_part(&c.own, &b.coords, fallback);
                        FactorBlock::new(&b.coords, own, &c.cross)
                    })
                    .flatten()
                    .unwrap_or_else(|| fallback_block(&b.coords))
            })
            .collect();
        let mut schur = local.shared.clone();
        for b in &blocks {
            schur -= b.m.transpose() * &b.m;
        }
        let schur = Some(schur)
            .filter(|m| m.iter().all(|v| v.is_finite()))
            .and_then(|m| Cholesky::new(positive_part(&m, &self.shared, fallback)))
            .map_or_else(
                || diagonal(self.shared.iter().map(|&i| fallback(i).sqrt())),
                |c| c.l(),
            );
        let factor = ArrowheadFactor {
            shared: self.shared.clone(),
            blocks,
            schur,
        };
        (factor, false)
    }
}

/// The steps of the gradient's central differences: ε^(1/3) balances truncation (h²) against
/// rounding (ε/h). The curvature's, ε^(1/4) ([`hessian_steps`]), are too long for a gradient
/// that must vanish at the mode: on the demo the Newton steps stopped 0.4 below its
/// log-density with them.
fn gradient_steps(x: &[f64]) -> Vec<f64> {
    x.iter()
        .map(|v| f64::EPSILON.cbrt() * v.abs().max(1.0))
        .collect()
}

/// The central difference of `f` at the point of value `f0` from its values `fp`, `fm` a step
/// `h` either side; one-sided where a side is refused, 0 where both are.
fn slope(fp: f64, fm: f64, f0: f64, h: f64) -> f64 {
    match (fp.is_finite(), fm.is_finite()) {
        (true, true) => (fp - fm) / (2.0 * h),
        (true, false) => (fp - f0) / h,
        (false, true) => (f0 - fm) / h,
        (false, false) => 0.0,
    }
}
