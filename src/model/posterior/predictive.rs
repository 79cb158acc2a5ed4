//! Curves of single runs at posterior draws: model forces at the data times, the law of a
//! slide (for curves the data do not sample), and the posterior and posterior predictive bands
//! that `predictive.csv` holds.

use super::layout::{SigmaSource, Source};
use super::Posterior;
use crate::density::LogDensity;
use crate::law::{LawError, ObservedSlide, Scene};

/// Posterior and posterior predictive bands of one run at (a subset of) its data times.
#[derive(Debug, Clone, PartialEq)]
pub struct Band {
    /// Run name.
    pub run: String,
    /// Instrument times (s).
    pub time_s: Vec<f64>,
    /// Observed force (N).
    pub observed_n: Vec<f64>,
    /// Model force (no noise): 2.5 %, 50 % and 97.5 % quantiles over the draws (N).
    pub model_n: [Vec<f64>; 3],
    /// Predictive force (model plus noise): 2.5 %, 25 %, 75 % and 97.5 % quantiles (N).
    pub predictive_n: [Vec<f64>; 4],
}

impl Posterior {
    /// The observed forces of run `run` (N), one per data point.
    pub fn observed_forces(&self, run: usize) -> &[f64] {
        let data = &self.runs[run].data;
        &data.force[..data.n_obs]
    }

    /// Model forces of run `run` at its data times, for posterior predictive curves.
    ///
    /// # Errors
    /// A law error (e.g. stick-slip) at these parameters.
    pub fn run_forces(&self, x: &[f64], run: usize) -> Result<Vec<f64>, LawError> {
        self.forces_after(x, &self.first_slide_ends(x)?, run)
    }

    /// Model forces of run `run` at its data times, given where every first slide stopped.
    pub(super) fn forces_after(
        &self,
        x: &[f64],
        f_end: &[Option<f64>],
        run: usize,
    ) -> Result<Vec<f64>, LawError> {
        let r = &self.runs[run];
        let mut out = Vec::with_capacity(r.data.model_times.len());
        r.visit_forces(x, r.follows.and_then(|j| f_end[j]), |_, f| out.push(f))?;
        out.truncate(r.data.n_obs);
        Ok(out)
    }

    /// Model forces of run `run` at every `stride`-th data time, given where every first
    /// slide stopped. A reduced run is solved at those times alone (a band of a 10⁶-point
    /// record needs a few hundred of them); a short run along all its times, as its
    /// likelihood solves it, so that its bands keep their bits.
    fn forces_every(
        &self,
        x: &[f64],
        f_end: &[Option<f64>],
        run: usize,
        stride: usize,
    ) -> Result<Vec<f64>, LawError> {
        let r = &self.runs[run];
        if r.reduction.is_none() {
            return Ok(self
                .forces_after(x, f_end, run)?
                .into_iter()
                .step_by(stride)
                .collect());
        }
        let times: Vec<f64> = r.data.model_times[..r.data.n_obs]
            .iter()
            .step_by(stride)
            .copied()
            .collect();
        let mut out = Vec::with_capacity(times.len());
        r.visit_forces_at(x, r.follows.and_then(|j| f_end[j]), &times, |_, f| {
            out.push(f)
        })?;
        Ok(out)
    }

    /// The first or fast slide of run `run` at the sampler coordinates `x`: its law in
    /// interface time and the machine's elasticity, so that a report can redraw curves the
    /// data do not sample (interface time, sliding distance, the peak against t0). `None` for
    /// a repeat slide, which has no law of its own, and under rate-and-state, which has no
    /// law in interface time.
    ///
    /// # Errors
    /// A law error (invalid parameters) at `x`.
    pub fn run_slide(&self, x: &[f64], run: usize) -> Result<Option<ObservedSlide>, LawError> {
        let r = &self.runs[run];
        if r.scene == Scene::Repeat || !r.law.in_interface_time() {
            return Ok(None);
        }
        Ok(Some(ObservedSlide::new(r.law(x)?, r.elastic(x)?)))
    }

    /// Posterior (model) and posterior predictive (model plus noise) bands of every run at
    /// every `stride`-th data time, from `draws` (sampler coordinates). The noise of each draw
    /// comes from a ChaCha8 stream seeded with `seed`, so the bands are reproducible.
    ///
    /// # Errors
    /// A law error at one of the draws (which a posterior draw cannot produce).
    pub fn predictive_bands(
        &self,
        draws: &[Vec<f64>],
        stride: usize,
        seed: u64,
    ) -> Result<Vec<Band>, LawError> {
        use rand::SeedableRng;
        use rand_distr::{Distribution, StandardNormal};
        let stride = stride.max(1);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let mut derived = vec![0.0; self.sources.len()];
        // forces[run][draw][point], noisy[run][draw][point]
        let mut model: Vec<Vec<Vec<f64>>> = vec![Vec::with_capacity(draws.len()); self.runs.len()];
        let mut noisy: Vec<Vec<Vec<f64>>> = vec![Vec::with_capacity(draws.len()); self.runs.len()];
        for x in draws {
            // Fills the derived values, σ of marginalised groups among them.
            if self.log_density(x, &mut derived).is_err() {
                continue;
            }
            let f_end = self.first_slide_ends(x)?;
            for (i, r) in self.runs.iter().enumerate() {
                let sigma = match r.sigma {
                    SigmaSource::Coord(c) => x[c].exp(),
                    SigmaSource::Marginal(g) => self
                        .sources
                        .iter()
                        .position(|s| *s == Source::Sigma(g))
                        .map_or(f64::NAN, |k| derived[k]),
                };
                let f = self.forces_every(x, &f_end, i, stride)?;
                let z: Vec<f64> = f
                    .iter()
                    .map(|v| {
                        let e: f64 = StandardNormal.sample(&mut rng);
                        v + sigma * e
                    })
                    .collect();
                model[i].push(f);
                noisy[i].push(z);
            }
        }
        let quantiles = |sets: &[Vec<f64>], j: usize, p: f64| {
            let mut column: Vec<f64> = sets.iter().map(|s| s[j]).collect();
            column.sort_by(f64::total_cmp);
            crate::diagnostics::quantile(&column, p).unwrap_or(f64::NAN)
        };
        Ok(self
            .runs
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let idx: Vec<usize> = (0..r.data.n_obs).step_by(stride).collect();
                let q = |sets: &[Vec<f64>], p: f64| {
                    (0..idx.len())
                        .map(|j| quantiles(sets, j, p))
                        .collect::<Vec<f64>>()
                };
                Band {
                    run: r.name.clone(),
                    time_s: idx.iter().map(|&j| r.data.model_times[j]).collect(),
                    observed_n: idx.iter().map(|&j| r.data.force[j]).collect(),
                    model_n: [q(&model[i], 0.025), q(&model[i], 0.5), q(&model[i], 0.975)],
                    predictive_n: [
                        q(&noisy[i], 0.025),
                        q(&noisy[i], 0.25),
                        q(&noisy[i], 0.75),
                        q(&noisy[i], 0.975),
                    ],
                }
            })
            .collect())
    }
}
