//! The likelihood one observation at a time: the terms that leave-one-out cross-validation
//! (PSIS-LOO) and comparisons between rival models need, where the density itself only needs
//! their sum.

use super::layout::{SigmaSource, Source};
use super::likelihood::{law_rejection, LN_SQRT_2PI};
use super::Posterior;
use crate::density::{LogDensity, LogDensityError};

impl Posterior {
    /// The log-likelihood of every observation at the sampler coordinates `x`: one `Vec` per
    /// run in the model's order, one value per observation, ln N(F_i | model_i(x), σ²).
    ///
    /// σ is the run's noise at `x`: its sampled value, or, where σ is integrated out of the
    /// density (a log-uniform prior), the draw from its conditional posterior that the fit
    /// reports as the `sigma` column. With that draw, (x, σ) is a draw of the joint posterior
    /// over the parameters and σ, and these are the terms of its likelihood. Every observation
    /// is solved, also in a long run whose density uses sufficient statistics of bins.
    ///
    /// # Errors
    /// [`LogDensityError`] where the density is not finite at `x` (outside the prior's
    /// support, stick-slip): a posterior draw never is.
    pub fn pointwise_log_likelihood(&self, x: &[f64]) -> Result<Vec<Vec<f64>>, LogDensityError> {
        let mut derived = vec![0.0; self.quantities.len()];
        self.log_density(x, &mut derived)?;
        let f_end = self.first_slide_ends(x).map_err(law_rejection)?;
        let mut out = Vec::with_capacity(self.runs.len());
        for (i, run) in self.runs.iter().enumerate() {
            let (sigma, ln_sigma) = match run.sigma {
                SigmaSource::Coord(s) => (x[s].exp(), x[s]),
                SigmaSource::Marginal(g) => {
                    let column = self
                        .sources
                        .iter()
                        .position(|s| *s == Source::Sigma(g))
                        .expect("every integrated σ is a reported column");
                    (derived[column], derived[column].ln())
                }
            };
            let model = self.forces_after(x, &f_end, i).map_err(law_rejection)?;
            let observed = &run.data.force[..run.data.n_obs];
            out.push(
                model
                    .iter()
                    .zip(observed)
                    .map(|(m, y)| {
                        let z = (y - m) / sigma;
                        -0.5 * z * z - ln_sigma - LN_SQRT_2PI
                    })
                    .collect(),
            );
        }
        Ok(out)
    }
}
