//! The likelihood of each observation at a posterior draw, the model's leave-one-out
//! predictive accuracy from it (PSIS-LOO, [`crate::diagnostics::loo`]), and replicated
//! observations (posterior predictive draws) from the same model and σ.
//!
//! A draw's σ is the one the chains report: its sampled coordinate, or, for σ integrated out
//! of the likelihood, the exact conditional draw of the derived column (seeded by the same
//! residuals, so the same bits). Given σ the observations are independent Gaussians around the
//! model, so each has its own log-likelihood ln N(y_i | F_i(θ), σ²).

use std::ops::Range;

use rand::Rng;
use rand_distr::{Distribution, StandardNormal};
use rayon::prelude::*;

use super::layout::SigmaSource;
use super::likelihood::LN_SQRT_2PI;
use super::{Posterior, PosteriorError};
use crate::density::LogDensityError;
use crate::diagnostics::loo::{psis_loo, Loo, LooError};
use crate::law::{LawError, Scene};

/// Why pointwise log-likelihoods or LOO could not be computed.
#[derive(Debug, thiserror::Error)]
pub enum PointwiseError {
    /// The run is evaluated on sufficient statistics: its points have no likelihood each.
    #[error(
        "run {run:?} has {points} points and is evaluated on sufficient statistics, which keep \
         no likelihood per point: leave-one-out needs runs of at most [likelihood] exact_up_to \
         points (thin the record with every = N to compare models on it)"
    )]
    Reduced {
        /// The run.
        run: String,
        /// Its observations.
        points: usize,
    },
    /// A draw where the model cannot be evaluated (not a posterior draw).
    #[error("draw {draw}: the model cannot be evaluated there ({reason})")]
    Draw {
        /// The draw's index.
        draw: usize,
        /// What the density said.
        reason: String,
    },
    /// PSIS-LOO refused the matrix of a run.
    #[error("leave-one-out of run {run:?}: {source}")]
    Loo {
        /// The run.
        run: String,
        /// The reason.
        #[source]
        source: LooError,
    },
}

/// PSIS-LOO of a whole model: every run's and all of them together.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelLoo {
    /// Per run, in file order: its name and its LOO.
    pub runs: Vec<(String, Loo)>,
    /// All observations together (elpd and p_loo the runs' sums, se over every point).
    pub total: Loo,
    /// Relative efficiency of the draws used.
    pub r_eff: f64,
}

/// What a draw fixes of every run besides its law: σ and, for the slide a repeat slide follows,
/// the force at which it stopped.
struct DrawNoise {
    sigma: Vec<f64>,
    f_end: Vec<Option<f64>>,
}

impl Posterior {
    /// ln N(y_i | F_i(x), σ²) of every observation at sampler coordinates `x`: one `Vec` per
    /// run in the model's order. σ is the draw's: its sampled coordinate, or, where σ is
    /// integrated out of the density, the conditional draw the fit reports as the run's
    /// `sigma` column (the same bits), so that (x, σ) is a draw of the joint posterior.
    ///
    /// # Errors
    /// [`PointwiseError::Reduced`] for a run evaluated on sufficient statistics,
    /// [`PointwiseError::Draw`] where the model cannot be evaluated at `x` (outside the
    /// prior's support, stick-slip: a posterior draw never is).
    pub fn pointwise_log_likelihood(&self, x: &[f64]) -> Result<Vec<Vec<f64>>, PointwiseError> {
        self.pointwise_available()?;
        let noise = self.draw_noise(x, 0)?;
        (0..self.runs.len())
            .map(|run| self.run_log_likelihood(x, run, &noise, 0))
            .collect()
    }

    /// The posterior of the same model over these data without the observations
    /// `held_out[run]` of each run (increasing, disjoint ranges of indices into its
    /// observations; none keeps them all): what a fold of cross-validation fits. A first slide is still evaluated where its
    /// record ends, so the repeat slide that follows it loads up to the same force.
    ///
    /// # Errors
    /// [`PosteriorError::Data`] when a run would keep fewer than
    /// [`MIN_POINTS`](crate::model::data::MIN_POINTS) observations; [`PosteriorError::Model`] when
    /// `held_out` does not have one range per run.
    pub fn without(&self, held_out: &[Vec<Range<usize>>]) -> Result<Posterior, PosteriorError> {
        if held_out.len() != self.runs.len() {
            return Err(PosteriorError::Model {
                source_file: self.spec.source.clone(),
                message: format!(
                    "{} ranges of left-out points for {} runs",
                    held_out.len(),
                    self.runs.len()
                ),
            });
        }
        let data = self
            .runs
            .iter()
            .zip(held_out)
            .map(|(r, ranges)| r.data.without(ranges, r.scene == Scene::First))
            .collect::<Result<Vec<_>, _>>()?;
        Self::from_data(&self.spec, self.blocking, data)
    }

    /// ln N(y_i | F_i(x), σ²) of every observation of this posterior at a draw `x` of `fold`,
    /// a posterior of the same model over part of these data (K-fold cross-validation). σ and
    /// the force where each first slide stopped are `fold`'s at `x`, so nothing of the points
    /// `fold` left out enters; the model is evaluated at every observation.
    ///
    /// # Errors
    /// As [`Posterior::pointwise_log_likelihood`]; [`PointwiseError::Draw`] when `fold` has
    /// other coordinates than this posterior (another model).
    pub fn log_likelihood_under(
        &self,
        fold: &Posterior,
        x: &[f64],
    ) -> Result<Vec<Vec<f64>>, PointwiseError> {
        self.pointwise_available()?;
        // Called once per draw: compare the coordinates' names in place, without the two
        // `Vec<String>`s of `param_names`.
        let same_coords = fold.coords.len() == self.coords.len()
            && fold
                .coords
                .iter()
                .zip(&self.coords)
                .all(|(a, b)| a.name == b.name);
        if !same_coords {
            return Err(PointwiseError::Draw {
                draw: 0,
                reason: "the fold's posterior is of another model than the full data's".into(),
            });
        }
        let noise = fold.draw_noise(x, 0)?;
        (0..self.runs.len())
            .map(|run| self.run_log_likelihood(x, run, &noise, 0))
            .collect()
    }

    /// PSIS-LOO of every run and of the whole model from posterior `draws` (sampler
    /// coordinates), whose relative efficiency (ESS / draws) is `r_eff`. Memory: one run's
    /// observations × draws at a time.
    ///
    /// # Errors
    /// As [`Posterior::pointwise_log_likelihood`]; [`PointwiseError::Loo`] for too few draws.
    pub fn psis_loo(&self, draws: &[Vec<f64>], r_eff: f64) -> Result<ModelLoo, PointwiseError> {
        self.pointwise_available()?;
        // Each draw is evaluated on its own, in parallel (two solves of the model per draw
        // and run: most of a small fit's time after sampling); every value lands where its
        // draw and point say, so the result is the same on any number of threads.
        let noise = draws
            .par_iter()
            .enumerate()
            .map(|(s, x)| self.draw_noise(x, s))
            .collect::<Result<Vec<_>, _>>()?;
        let mut runs = Vec::with_capacity(self.runs.len());
        for (run, model) in self.runs.iter().enumerate() {
            let points = model.data.n_obs;
            let columns = draws
                .par_iter()
                .zip(&noise)
                .enumerate()
                .map(|(s, (x, noise))| self.run_log_likelihood(x, run, noise, s))
                .collect::<Result<Vec<_>, _>>()?;
            // Point-major, as PSIS reads it: each observation's draws in a row.
            let mut matrix = vec![0.0; points * draws.len()];
            for (s, values) in columns.into_iter().enumerate() {
                for (i, v) in values.into_iter().enumerate() {
                    matrix[i * draws.len() + s] = v;
                }
            }
            let loo =
                psis_loo(&matrix, draws.len(), r_eff).map_err(|source| PointwiseError::Loo {
                    run: model.name.clone(),
                    source,
                })?;
            runs.push((model.name.clone(), loo));
        }
        let total = Loo::concatenate(runs.iter().map(|(_, loo)| loo));
        Ok(ModelLoo { runs, total, r_eff })
    }

    /// Every run's name and number of observations, in the model's order.
    pub fn run_points(&self) -> Vec<(&str, usize)> {
        self.runs
            .iter()
            .map(|r| (r.name.as_str(), r.data.n_obs))
            .collect()
    }

    /// Whether every run keeps the likelihood of each of its points, as
    /// [`Posterior::pointwise_log_likelihood`] and [`Posterior::psis_loo`] need.
    ///
    /// # Errors
    /// [`PointwiseError::Reduced`] naming the first run evaluated on sufficient statistics.
    pub fn pointwise_available(&self) -> Result<(), PointwiseError> {
        match self.runs.iter().find(|r| r.reduction.is_some()) {
            Some(r) => Err(PointwiseError::Reduced {
                run: r.name.clone(),
                points: r.data.n_obs,
            }),
            None => Ok(()),
        }
    }

    /// Replicated observations at sampler coordinates `x`: y_i = F_i(x) + σ ε_i at every data
    /// time of every run (one `Vec` per run in the model's order), the ε_i standard normal
    /// from `rng`, drawn run after run and point after point. σ is the draw's, as in
    /// [`Posterior::pointwise_log_likelihood`]. A run evaluated on sufficient statistics has
    /// its model solved at every data time here, so it gets replicates too.
    ///
    /// # Errors
    /// [`PointwiseError::Draw`] where the model cannot be evaluated at `x` (a posterior draw
    /// never is).
    pub fn replicated_observations<R: Rng + ?Sized>(
        &self,
        x: &[f64],
        rng: &mut R,
    ) -> Result<Vec<Vec<f64>>, PointwiseError> {
        let noise = self.draw_noise(x, 0)?;
        (0..self.runs.len())
            .map(|run| {
                let forces =
                    self.forces_after(x, &noise.f_end, run)
                        .map_err(|e| PointwiseError::Draw {
                            draw: 0,
                            reason: e.to_string(),
                        })?;
                let sigma = noise.sigma[run];
                Ok(forces
                    .into_iter()
                    .map(|f| {
                        let e: f64 = StandardNormal.sample(rng);
                        f + sigma * e
                    })
                    .collect())
            })
            .collect()
    }

    /// Every run's σ and F_end at draw `x` (number `draw`), as the density and the derived
    /// columns compute them.
    fn draw_noise(&self, x: &[f64], draw: usize) -> Result<DrawNoise, PointwiseError> {
        let n = self.runs.len();
        let (mut ssr, mut last) = (vec![0.0; n], vec![0.0; n]);
        for &i in &self.order {
            self.fit_run(i, x, &mut ssr, &mut last)
                .map_err(|e: LogDensityError| PointwiseError::Draw {
                    draw,
                    reason: e.to_string(),
                })?;
        }
        let sigma = self
            .runs
            .iter()
            .map(|r| match r.sigma {
                SigmaSource::Coord(s) => x[s].exp(),
                SigmaSource::Marginal(g) => self.sigma_draw(g, |i| ssr[i]),
            })
            .collect();
        let f_end = self
            .runs
            .iter()
            .zip(&last)
            .map(|(r, &last)| (r.scene == crate::law::Scene::First).then_some(last))
            .collect();
        Ok(DrawNoise { sigma, f_end })
    }

    fn run_log_likelihood(
        &self,
        x: &[f64],
        run: usize,
        noise: &DrawNoise,
        draw: usize,
    ) -> Result<Vec<f64>, PointwiseError> {
        let forces = self
            .forces_after(x, &noise.f_end, run)
            .map_err(|e: LawError| PointwiseError::Draw {
                draw,
                reason: e.to_string(),
            })?;
        let sigma = noise.sigma[run];
        let ln_norm = -sigma.ln() - LN_SQRT_2PI;
        Ok(self.runs[run]
            .data
            .force
            .iter()
            .zip(forces)
            .map(|(y, f)| {
                let z = (y - f) / sigma;
                ln_norm - 0.5 * z * z
            })
            .collect())
    }
}
