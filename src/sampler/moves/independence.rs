//! The independence proposal fitted to the complement: a Gaussian or a Student-t.

use super::complement::{complement_cov, ComplementFit, Regression};
use super::{ActiveHalf, Correction, MoveSpec, ProposalMove, Proposed};
use crate::sampler::SamplerError;

/// Independence proposal fitted to the complement: a Gaussian (or Student-t) with the
/// complement's sample mean and covariance, drawn afresh for every walker of the active half.
/// Valid because the complement stays fixed while the active half is updated, and
/// affine-invariant because the mean and covariance transform with the walkers. Where the
/// posterior is close to Gaussian, however badly conditioned, it decorrelates in a few steps;
/// it needs more complement walkers than dimensions (with fewer, or walkers in a subspace,
/// every walker is proposed where it is).
///
/// In a block whose conditional depends on other coordinates (hierarchical updates), the
/// proposal is the block's conditional given the walker's own values of them (see
/// `ConditionalFit`).
///
/// # Formula
/// `Y = μ + L Z / √W`, `L Lᵀ = Ĉ` (the complement's unbiased sample covariance),
/// `Z ~ N(0, I)`, `W ~ χ²_ν/ν` (`W = 1` for the Gaussian); the log acceptance ratio gains
/// `ln q(X) − ln q(Y)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Independence {
    dof: Option<f64>,
}

impl Independence {
    /// The Gaussian independence proposal.
    pub fn gaussian() -> Self {
        Self { dof: None }
    }

    /// The Student-t independence proposal with `dof` degrees of freedom.
    ///
    /// # Errors
    /// [`SamplerError::InvalidMove`] unless `dof` is finite and > 0.
    pub fn student_t(dof: f64) -> Result<Self, SamplerError> {
        if !(dof.is_finite() && dof > 0.0) {
            return Err(SamplerError::InvalidMove {
                detail: format!("independence degrees of freedom {dof} must be finite and > 0"),
            });
        }
        Ok(Self { dof: Some(dof) })
    }

    /// The move a spec of kind `independence` records.
    pub(super) fn from_spec(spec: &MoveSpec) -> Result<Self, SamplerError> {
        match spec.only(&["dof"])?.number("dof")? {
            Some(nu) => Self::student_t(nu),
            None => Ok(Self::gaussian()),
        }
    }

    /// The fit of the block's conditional given the other coordinates it depends on, when
    /// the half-step moves such a block and the complement is large enough.
    fn conditional<'a>(&self, half: &ActiveHalf<'a>) -> Option<(ConditionalFit, &'a [usize])> {
        let (block, positions, ndim) = half.block()?;
        if block.given.is_empty() {
            return None;
        }
        let complement = half.complement().walkers;
        ConditionalFit::new(
            positions,
            ndim,
            complement,
            block.coords,
            block.given,
            self.dof,
        )
        .map(|fit| (fit, block.given))
    }
}

impl ProposalMove for Independence {
    fn spec(&self) -> MoveSpec {
        MoveSpec::new("independence").with("dof", self.dof)
    }

    fn min_complement(&self, dim: usize) -> usize {
        // A full-rank sample covariance needs dim + 1 points.
        dim + 1
    }

    fn propose(&self, half: ActiveHalf<'_>) -> Proposed {
        if let Some((mut fit, given)) = self.conditional(&half) {
            return half.propose_each(|walker, rng, out| {
                let fit = fit.given(walker.position, given);
                Correction::from_log(fit.propose(walker.x, rng, out))
            });
        }
        let c = half.complement();
        match ComplementFit::new(c.rows, c.walkers, c.dim, self.dof) {
            Some(mut fit) => half.propose_each(|walker, rng, out| {
                Correction::from_log(fit.propose(walker.x, rng, out))
            }),
            // The complement lies in a subspace.
            None => half.stay(),
        }
    }
}

/// The independence proposal for a block whose conditional depends on other coordinates only
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

#[cfg(test)]
mod tests {
    use super::super::followers::tests::linear_complement;
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn the_conditional_proposal_is_centred_on_the_walkers_given_coordinates() {
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
