//! The complementary half a move proposes from, and what is fitted to it: sample moments,
//! the Gaussian (or Student-t) of the independence proposal, and least-squares regressions.
//!
//! The complement stays fixed while the active half moves, so anything fitted to it may
//! shape the proposals of that half-step without breaking detailed balance.

use rand::Rng;
use rand_distr::StandardNormal;

use super::WalkerRng;

/// The complementary half of the ensemble during a half-step, at the coordinates the move
/// acts on (a block's, or all): fixed while the active half moves.
#[derive(Debug, Clone, Copy)]
pub struct Complement<'a> {
    /// Every walker's coordinates the move acts on, `dim` per row.
    pub(crate) rows: &'a [f64],
    pub(crate) dim: usize,
    /// The complement's walkers: rows of `rows`.
    pub(crate) walkers: &'a [usize],
}

impl<'a> Complement<'a> {
    /// The number of walkers in the complement.
    pub fn len(&self) -> usize {
        self.walkers.len()
    }

    /// Whether the complement has no walkers (it never has in a sampler).
    pub fn is_empty(&self) -> bool {
        self.walkers.is_empty()
    }

    /// The number of coordinates a move acts on.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// The coordinates of the complement's `k`-th walker.
    #[inline]
    pub fn walker(&self, k: usize) -> &'a [f64] {
        let w = self.walkers[k];
        &self.rows[w * self.dim..(w + 1) * self.dim]
    }

    /// The complement's walkers in order.
    pub fn iter(&self) -> impl Iterator<Item = &'a [f64]> + 'a {
        let (rows, dim) = (self.rows, self.dim);
        self.walkers
            .iter()
            .map(move |&w| &rows[w * dim..(w + 1) * dim])
    }

    /// One walker of the complement, drawn uniformly.
    #[inline]
    pub fn pick(&self, rng: &mut WalkerRng) -> &'a [f64] {
        self.walker(rng.random_range(0..self.len()))
    }

    /// Two distinct walkers of the complement, drawn uniformly (the complement must have two).
    #[inline]
    pub fn pick_two(&self, rng: &mut WalkerRng) -> (&'a [f64], &'a [f64]) {
        let n = self.len();
        let i1 = rng.random_range(0..n);
        let mut i2 = rng.random_range(0..n - 1);
        if i2 >= i1 {
            i2 += 1;
        }
        (self.walker(i1), self.walker(i2))
    }

    /// The complement's sample mean and unbiased sample covariance.
    pub(crate) fn moments(&self) -> (Vec<f64>, nalgebra::DMatrix<f64>) {
        complement_moments(self.rows, self.dim, self.walkers)
    }
}

/// `K` distinct indices below `n`, uniformly, in the order of the first `K` steps of a
/// Fisher–Yates shuffle of `0..n` (at step `k` swap `k` with a uniform `r ≥ k`); the few
/// entries the steps move are kept aside instead of in an array of `n`.
pub(crate) fn distinct<const K: usize>(rng: &mut WalkerRng, n: usize) -> [usize; K] {
    // (position, value) of every entry moved so far; the latest entry of a position holds.
    let mut moved = [(usize::MAX, 0); K];
    let at = |moved: &[(usize, usize)], p: usize| {
        moved
            .iter()
            .rev()
            .find(|&&(q, _)| q == p)
            .map_or(p, |&(_, v)| v)
    };
    let mut out = [0; K];
    for k in 0..K {
        let r = rng.random_range(k..n);
        out[k] = at(&moved[..k], r);
        // Position k is never read again; position r now holds what k held.
        moved[k] = (r, at(&moved[..k], k));
    }
    out
}

/// A copy of the complement's coordinates a move acts on, for work that outlives the
/// ensemble's borrow (the slice move's walkers, which run as tasks of their own).
#[derive(Debug, Clone)]
pub(crate) struct OwnedComplement {
    /// The complement's walkers at the coordinates, one row each, in the complement's order.
    rows: Vec<f64>,
    dim: usize,
    /// `0..rows`: the rows in order.
    walkers: Vec<usize>,
}

impl OwnedComplement {
    /// Coordinates `coords` of the `complement`'s walkers (`positions` of all, `ndim` per row).
    pub fn new(positions: &[f64], ndim: usize, complement: &[usize], coords: &[usize]) -> Self {
        let rows = complement
            .iter()
            .flat_map(|&w| coords.iter().map(move |&i| positions[w * ndim + i]))
            .collect();
        Self {
            rows,
            dim: coords.len(),
            walkers: (0..complement.len()).collect(),
        }
    }

    /// The complement these rows are.
    pub fn view(&self) -> Complement<'_> {
        Complement {
            rows: &self.rows,
            dim: self.dim,
            walkers: &self.walkers,
        }
    }
}

/// The complement's sample mean of coordinates `coords` (`positions` of all walkers, `ndim`
/// per row).
pub(crate) fn complement_mean(
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
pub(crate) fn complement_cov(
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

/// The Gaussian (or Student-t) fitted to the complementary half for the independence
/// proposal: computed once per half-step, then one proposal per active walker.
#[derive(Debug, Clone)]
pub(crate) struct ComplementFit {
    pub(super) mean: Vec<f64>,
    /// Lower Cholesky factor of the sample covariance, row-major `ndim × ndim`.
    pub(super) chol: Vec<f64>,
    dof: Option<f64>,
    /// χ²_ν of the Student-t's scale, built once per fit.
    chi2: Option<rand_distr::ChiSquared<f64>>,
    /// Scratch for whitened vectors.
    pub(super) u: Vec<f64>,
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
    pub(super) fn from_moments(
        mean: Vec<f64>,
        cov: nalgebra::DMatrix<f64>,
        dof: Option<f64>,
    ) -> Option<Self> {
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
                rand_distr::ChiSquared::new(nu).expect("ν > 0, checked when the move is made")
            }),
            u: vec![0.0; ndim],
        })
    }

    /// Solves `L u = x − μ` into `self.u` by forward substitution and returns `|u|²`.
    pub(super) fn whiten(&mut self, x: &[f64]) -> f64 {
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
    pub(super) fn log_q(&mut self, x: &[f64]) -> f64 {
        let ndim = self.mean.len();
        let r2 = self.whiten(x);
        match self.dof {
            None => -0.5 * r2,
            Some(nu) => -0.5 * (nu + ndim as f64) * (r2 / nu).ln_1p(),
        }
    }

    /// Writes a proposal into `out` and returns ln q(x) − ln q(out).
    pub fn propose(&mut self, x: &[f64], rng: &mut WalkerRng, out: &mut [f64]) -> f64 {
        self.draw(rng, out);
        self.log_q(x) - self.log_q(out)
    }

    /// Writes `L Z` into `out` (the fit's mean and degrees of freedom left aside), drawing
    /// `Z ~ N(0, I)` into `z`; reads the fit only, so one fit serves walkers in parallel.
    pub(super) fn draw_centred(&self, rng: &mut WalkerRng, z: &mut [f64], out: &mut [f64]) {
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
    pub(super) fn draw(&mut self, rng: &mut WalkerRng, out: &mut [f64]) {
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

/// The least-squares regression of coordinates `responses` on coordinates `predictors`,
/// fitted to the complement's walkers: what the independence move's conditional proposal and
/// the carried followers are built on.
#[derive(Debug, Clone)]
pub(crate) struct Regression {
    /// `C_rp C_pp⁻¹`, `responses × predictors`.
    pub coef: nalgebra::DMatrix<f64>,
    pub mean_r: Vec<f64>,
    pub mean_p: Vec<f64>,
    /// `C_pr`, the covariance of the predictors with the responses.
    pub c_pr: nalgebra::DMatrix<f64>,
}

impl Regression {
    /// `None` when the complement has no more walkers than predictors or their covariance
    /// is not positive definite.
    pub fn fit(
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

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn distinct_indices_are_those_of_a_partial_fisher_yates_shuffle() {
        for n in [3, 4, 7, 20] {
            let (mut a, mut b) = (
                WalkerRng::seed_from_u64(n as u64),
                WalkerRng::seed_from_u64(n as u64),
            );
            for _ in 0..200 {
                let mut idx: Vec<usize> = (0..n).collect();
                for k in 0..3 {
                    let r = a.random_range(k..n);
                    idx.swap(k, r);
                }
                assert_eq!(distinct::<3>(&mut b, n), idx[..3]);
            }
        }
    }

    #[test]
    fn the_independence_correction_is_the_ratio_of_proposal_densities() {
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
}
