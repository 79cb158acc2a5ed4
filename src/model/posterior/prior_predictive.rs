//! Draws from the prior predictive distribution: every sampled coordinate from the prior the
//! density uses (a population before its members, each member from its population), σ of every
//! run, and each run's forces at its data times with Gaussian noise of that σ. Simulation-based
//! calibration (`slipbayes validate`) makes its data sets this way, so it checks the posterior
//! of any model, pooled or not, against exactly the prior the fit assumes.
//!
//! Parameters for which some slide has no quasi-static path (stick-slip) have zero likelihood
//! for any data, so they are redrawn: the draw is from the prior restricted to parameters the
//! law can follow, which is what the fit's posterior is proportional to.

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};

use super::layout::{CoordPrior, SigmaSource, Source};
use super::Posterior;
use crate::law::LawError;

/// One draw of parameters and data from the prior predictive distribution.
#[derive(Debug, Clone, PartialEq)]
pub struct PriorDraw {
    /// The sampler coordinates (ln θ, and each population's ln median and ln sd).
    pub coords: Vec<f64>,
    /// σ of each run (N), in model order.
    pub sigma_n: Vec<f64>,
    /// The true value of every reported column, in column order. σ of a marginalised group
    /// is the σ the noise was drawn with; the peak of a new contact is the peak of a contact
    /// drawn afresh from the true populations (a true value for a predictive column).
    pub values: Vec<f64>,
    /// Each run's force at its data times: the model plus Gaussian noise of its σ (N).
    pub forces_n: Vec<Vec<f64>>,
    /// Parameter draws rejected before this one because a slide had no quasi-static path.
    pub redraws: usize,
}

/// Why no prior predictive draw could be made.
#[derive(Debug, thiserror::Error)]
pub enum PriorDrawError {
    /// A prior whose bounds hold almost none of its mass.
    #[error("the prior of {0} keeps almost no mass inside its bounds; widen its bounds")]
    EmptyPrior(String),
    /// Every parameter draw gave a slide the law cannot follow.
    #[error("{tries} prior draws in a row give a slide with no quasi-static path (the last: {last}); the priors of k, α and a hardly allow a quasi-static slide")]
    NoSlide {
        /// Draws made.
        tries: usize,
        /// The law's error at the last one.
        last: LawError,
    },
}

impl Posterior {
    /// Draws parameters from the prior and each run's data at its data times (the forces of
    /// the posterior's own data are not read), redrawing parameters the law cannot follow at
    /// most `max_tries` times.
    ///
    /// # Errors
    /// [`PriorDrawError`] for a prior with no mass inside its bounds, or when every draw gave
    /// stick-slip.
    pub fn draw_prior_predictive<R: Rng + ?Sized>(
        &self,
        rng: &mut R,
        max_tries: usize,
    ) -> Result<PriorDraw, PriorDrawError> {
        let mut last = None;
        for redraws in 0..max_tries.max(1) {
            let coords = self.draw_prior(rng)?;
            let group_sigma: Vec<f64> = self
                .sigma_groups
                .iter()
                .map(|g| (g.low.ln() + rng.random::<f64>() * (g.high / g.low).ln()).exp())
                .collect();
            let sigma_n: Vec<f64> = self
                .runs
                .iter()
                .map(|r| match r.sigma {
                    SigmaSource::Coord(i) => coords[i].exp(),
                    SigmaSource::Marginal(g) => group_sigma[g],
                })
                .collect();
            let clean = match self
                .first_slide_ends(&coords)
                .and_then(|ends| self.all_forces(&coords, &ends))
            {
                Ok(forces) => forces,
                Err(e) => {
                    last = Some(e);
                    continue;
                }
            };
            let forces_n = clean
                .into_iter()
                .zip(&sigma_n)
                .map(|(forces, &sd)| {
                    forces
                        .into_iter()
                        .map(|f| {
                            let z: f64 = StandardNormal.sample(rng);
                            f + sd * z
                        })
                        .collect()
                })
                .collect();
            let values = self.true_values(&coords, &group_sigma, rng);
            return Ok(PriorDraw {
                coords,
                sigma_n,
                values,
                forces_n,
                redraws,
            });
        }
        Err(PriorDrawError::NoSlide {
            tries: max_tries.max(1),
            last: last.expect("at least one draw was made"),
        })
    }

    /// Every sampled coordinate from its prior, in coordinate order (a population's
    /// coordinates come before its members', which are drawn from it).
    fn draw_prior<R: Rng + ?Sized>(&self, rng: &mut R) -> Result<Vec<f64>, PriorDrawError> {
        let mut x = vec![0.0; self.coords.len()];
        for (i, c) in self.coords.iter().enumerate() {
            x[i] = match &c.prior {
                CoordPrior::Log(prior) => prior
                    .sample(rng)
                    .ok_or_else(|| PriorDrawError::EmptyPrior(c.name.clone()))?
                    .ln(),
                &CoordPrior::Population { mu, ln_s } => {
                    debug_assert!(mu < i && ln_s < i, "a population precedes its members");
                    let z: f64 = StandardNormal.sample(rng);
                    x[mu] + x[ln_s].exp() * z
                }
            };
        }
        Ok(x)
    }

    /// Noiseless forces of every run at its data times.
    fn all_forces(&self, x: &[f64], ends: &[Option<f64>]) -> Result<Vec<Vec<f64>>, LawError> {
        (0..self.runs.len())
            .map(|run| self.forces_after(x, ends, run))
            .collect()
    }

    /// The reported columns at `x`, with σ of each marginalised group as drawn and a new
    /// contact's peak drawn from the true populations with `rng`.
    fn true_values<R: Rng + ?Sized>(
        &self,
        x: &[f64],
        group_sigma: &[f64],
        rng: &mut R,
    ) -> Vec<f64> {
        let mut values = vec![0.0; self.sources.len()];
        // σ's conditional draw reads the residuals; it is replaced below, so any positive
        // sums do.
        let ssr = vec![1.0; self.runs.len()];
        self.derived_values(x, &ssr, &mut values, super::blocks::Changed::All);
        for (value, source) in values.iter_mut().zip(&self.sources) {
            match *source {
                Source::Sigma(g) => *value = group_sigma[g],
                Source::PeakNew(m) => {
                    *value = self.new_contact_peak_with(x, m, &mut |_| {
                        let z: f64 = StandardNormal.sample(rng);
                        z
                    });
                }
                _ => {}
            }
        }
        values
    }
}
