//! The followers of a block carried along when it moves, by their regression on the block:
//! fitted to the complement at every half-step, or tuned on the draws of every ensemble and
//! then frozen ([`CarryTuning`]).

use serde::{Deserialize, Serialize};

use super::complement::Regression;

/// The followers of a block carried along when it moves: each follower shifted by its
/// regression on the block's coordinates times the block's step. The map `(x_b, x_f) → (y_b,
/// x_f + B (y_b − x_b))` has unit Jacobian and is undone by the reverse step, so every move
/// keeps its acceptance ratio; it leaves a Gaussian target's conditional of the followers
/// given the block unchanged, so a block that many others depend on moves as if it were
/// alone.
///
/// `B` is either fitted to the complement at every half-step (valid because the complement
/// does not move during it), or fitted once to every ensemble's draws of the tuning steps
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

/// The followers' regression on a block fitted to the draws of every ensemble over the
/// tuning steps, then frozen (see `Followers`): the cross moments being gathered, and the
/// last frozen coefficients. Each ensemble saves a copy, so a resumed run continues the same
/// tuning.
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
    pub(crate) fn freeze(&mut self) {
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
pub(crate) mod tests {
    use super::*;

    /// Six walkers in 3-D with x1 = 2 x0 + 1 exactly and x2 = −x0/2 + e, where e has mean 0,
    /// variance 0.8 and is uncorrelated with x0: every regression on x0 is known exactly.
    pub(crate) fn linear_complement() -> Vec<f64> {
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
}
