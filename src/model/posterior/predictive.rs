//! Curves of single runs at posterior draws: model forces at the data times, the law of a
//! slide (for curves the data do not sample), and the posterior and posterior predictive bands
//! that `predictive.csv` holds, and the same bands beyond a record (a forecast).

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::layout::{SigmaSource, Source};
use super::likelihood::RunModel;
use super::Posterior;
use crate::density::LogDensity;
use crate::diagnostics::pointwise_quantiles;
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
    /// comes from a ChaCha8 stream seeded with `seed`, so the bands are reproducible. A draw
    /// at which the density or the law fails is left out rather than failing the bands (the
    /// law's stick-slip check failed at a posterior draw of a 20-point first slide).
    ///
    /// # Errors
    /// The law's error when it fails at every draw.
    pub fn predictive_bands(
        &self,
        draws: &[Vec<f64>],
        stride: usize,
        seed: u64,
    ) -> Result<Vec<Band>, LawError> {
        let stride = stride.max(1);
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut derived = vec![0.0; self.sources.len()];
        // forces[run][draw][point], noisy[run][draw][point]
        let mut model: Vec<Vec<Vec<f64>>> = vec![Vec::with_capacity(draws.len()); self.runs.len()];
        let mut noisy: Vec<Vec<Vec<f64>>> = vec![Vec::with_capacity(draws.len()); self.runs.len()];
        let mut failed = None;
        for x in draws {
            // Fills the derived values, σ of marginalised groups among them.
            if self.log_density(x, &mut derived).is_err() {
                continue;
            }
            let forces = self.first_slide_ends(x).and_then(|f_end| {
                (0..self.runs.len())
                    .map(|i| self.forces_every(x, &f_end, i, stride))
                    .collect::<Result<Vec<_>, _>>()
            });
            let forces = match forces {
                Ok(f) => f,
                Err(e) => {
                    failed = Some(e);
                    continue;
                }
            };
            for (i, (r, f)) in self.runs.iter().zip(forces).enumerate() {
                noisy[i].push(with_noise(&f, self.run_sigma(x, r, &derived), &mut rng));
                model[i].push(f);
            }
        }
        if let (Some(e), true) = (failed, model.first().is_none_or(Vec::is_empty)) {
            return Err(e);
        }
        Ok(self
            .runs
            .iter()
            .enumerate()
            .map(|(i, r)| {
                let idx: Vec<usize> = (0..r.data.n_obs).step_by(stride).collect();
                band(
                    &r.name,
                    idx.iter().map(|&j| r.data.model_times[j]).collect(),
                    idx.iter().map(|&j| r.data.force[j]).collect(),
                    &model[i],
                    &noisy[i],
                )
            })
            .collect())
    }

    /// Posterior and posterior predictive bands of run `run` at `times` (instrument time,
    /// increasing), which may lie beyond its record: what the rest of a slide still being
    /// recorded will look like. Its observed forces are NaN; the noise as in
    /// [`predictive_bands`](Self::predictive_bands).
    ///
    /// A draw whose slide has no quasi-static solution up to the last of `times` (it would
    /// slip in stick-slip before) is left out.
    ///
    /// # Errors
    /// The law's error when it fails at every draw.
    pub fn forecast_band(
        &self,
        draws: &[Vec<f64>],
        run: usize,
        times: &[f64],
        seed: u64,
    ) -> Result<Band, LawError> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut derived = vec![0.0; self.sources.len()];
        let r = &self.runs[run];
        let (mut model, mut noisy) = (Vec::new(), Vec::new());
        let mut failed = None;
        for x in draws {
            if self.log_density(x, &mut derived).is_err() {
                continue;
            }
            let mut f = Vec::with_capacity(times.len());
            let solved = self.first_slide_ends(x).and_then(|f_end| {
                r.visit_forces_at(x, r.follows.and_then(|j| f_end[j]), times, |_, v| f.push(v))
            });
            if let Err(e) = solved {
                failed = Some(e);
                continue;
            }
            noisy.push(with_noise(&f, self.run_sigma(x, r, &derived), &mut rng));
            model.push(f);
        }
        if let (Some(e), true) = (failed, model.is_empty()) {
            return Err(e);
        }
        Ok(band(
            &r.name,
            times.to_vec(),
            vec![f64::NAN; times.len()],
            &model,
            &noisy,
        ))
    }

    /// The noise sd of run `r` at `x`, whose derived values (σ of marginalised groups among
    /// them) are `derived`.
    fn run_sigma(&self, x: &[f64], r: &RunModel, derived: &[f64]) -> f64 {
        match r.sigma {
            SigmaSource::Coord(c) => x[c].exp(),
            SigmaSource::Marginal(g) => self
                .sources
                .iter()
                .position(|s| *s == Source::Sigma(g))
                .map_or(f64::NAN, |k| derived[k]),
        }
    }
}

/// `forces` plus Gaussian noise of sd `sigma`, one draw of `rng` per force.
fn with_noise(forces: &[f64], sigma: f64, rng: &mut ChaCha8Rng) -> Vec<f64> {
    forces
        .iter()
        .map(|v| {
            let e: f64 = StandardNormal.sample(rng);
            v + sigma * e
        })
        .collect()
}

/// The band of run `run` at `time_s` from the model forces and noisy forces of each draw
/// (`[draw][point]`): their pointwise quantiles.
fn band(
    run: &str,
    time_s: Vec<f64>,
    observed_n: Vec<f64>,
    model: &[Vec<f64>],
    noisy: &[Vec<f64>],
) -> Band {
    let points = time_s.len();
    let model_n = pointwise_quantiles(model, points, &[0.025, 0.5, 0.975]);
    let predictive_n = pointwise_quantiles(noisy, points, &[0.025, 0.25, 0.75, 0.975]);
    Band {
        run: run.to_owned(),
        model_n: model_n.try_into().expect("three quantiles"),
        predictive_n: predictive_n.try_into().expect("four quantiles"),
        time_s,
        observed_n,
    }
}
