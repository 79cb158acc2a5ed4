//! The likelihood: independent Gaussian noise of standard deviation σ on each run's force, a
//! sum over runs. Each run's term reads only the coordinates of its own contact and material
//! (and, for a repeat slide, the force where the first slide of the same contact stopped), so
//! a block of one contact's coordinates can be updated by evaluating that contact's runs alone.
//!
//! A repeat slide loads elastically up to F_end, the force where the slide it follows stopped
//! (its model force at its last recorded time), or F_d when it follows none.
//!
//! Under rate-and-state friction every slide, first or repeat, is the spring-slider's ODE
//! solved over the whole slide at the run's times (`RunModel::spring_slider`); a proposal at
//! which it cannot be solved is rejected under [`REJECT_RATE_STATE`].

use super::layout::SigmaSource;
use super::sigma::marginal_sigma_log_likelihood;
use super::Posterior;
use crate::density::LogDensityError;
use crate::law::rate_state::LIKELIHOOD_TOLERANCE;
use crate::law::{
    Elastic, InitialState, InterfaceLaw, Law, LawError, LawKind, LogAging, ObservedSlide,
    RateStateParams, RepeatSlide, Scene, SpringSlider, StateLaw,
};
use crate::model::data::RunData;
use crate::model::sufficient::Reduction;

/// Log of √(2π).
pub(super) const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;

/// Rejection label: the law has no quasi-static solution (stick-slip).
pub const REJECT_STICK_SLIP: &str = "stick_slip";
/// Rejection label: a parameter outside its prior's support.
pub const REJECT_PRIOR: &str = "outside_prior";
/// Rejection label: the law cannot be evaluated at these parameters (e.g. αv·t0 underflows).
pub const REJECT_LAW: &str = "law_invalid";
/// Rejection label: the rate-and-state slide cannot be integrated (its solver gave up, or the
/// slip velocity ran away: an unstable, stick-slipping slide).
pub const REJECT_RATE_STATE: &str = "rate_state_unsolvable";

/// A run with its data and the coordinates of its parameters.
#[derive(Debug, Clone)]
pub(super) struct RunModel {
    pub name: String,
    pub scene: Scene,
    /// The law of a first or fast slide.
    pub law: LawKind,
    pub velocity: f64,
    pub data: RunData,
    pub contact: usize,
    pub alpha: Option<usize>,
    /// Coordinate of ln a (or of ln a/F_d when `ratio`).
    pub a: Option<usize>,
    pub ratio: bool,
    /// Coordinates of ln b and ln D_c (rate-and-state).
    pub b: Option<usize>,
    pub d_c: Option<usize>,
    /// The state law under rate-and-state.
    pub state_law: StateLaw,
    /// The reference velocity V0 of rate-and-state (`None`: the run's velocity).
    pub reference_velocity: Option<f64>,
    /// Coordinate of ln F_d (`None` when neither the law nor the repeat slide needs it).
    pub f_d: Option<usize>,
    pub t0: Option<usize>,
    pub k: Option<usize>,
    pub sigma: SigmaSource,
    /// The first slide a repeat slide follows.
    pub follows: Option<usize>,
    /// Normal force F_N (N), when known.
    pub normal_force: Option<f64>,
    /// A long run's observations as bins of sufficient statistics (`long_records`); `None`:
    /// every observation is evaluated.
    pub reduction: Option<Reduction>,
    /// Whether this process holds the run's data (see `share`): a rank of an MPI job holds
    /// only its share of the contacts', and fitting another's is a fault.
    pub held: bool,
}

/// The fit of one run at a point: its sum of squared residuals and the model force at its last
/// model time (F_end, for the repeat slide that follows it).
#[derive(Debug, Clone, Copy)]
pub(super) struct RunResiduals {
    pub ssr: f64,
    pub last_force: f64,
}

impl RunModel {
    /// The law of this run's slide at `x`.
    pub fn law(&self, x: &[f64]) -> Result<InterfaceLaw, LawError> {
        let f_d = self.f_d.map_or(f64::NAN, |i| x[i].exp());
        let a = match self.a {
            Some(i) if self.ratio => x[i].exp() * f_d,
            Some(i) => x[i].exp(),
            None => 0.0,
        };
        let t0 = self.t0.map_or(f64::NAN, |i| x[i].exp());
        Ok(match self.law {
            LawKind::AgingRejuvenation => {
                let alpha = self.alpha.map_or(f64::NAN, |i| x[i].exp());
                Law::from_rate(alpha * self.velocity, a, f_d, t0)?.into()
            }
            LawKind::LogAging => LogAging::new(a, t0)?.into(),
            LawKind::RateState => {
                return Err(LawError::InvalidParameter {
                    name: "law",
                    value: f64::NAN,
                    expected: "a law in interface time (rate-and-state is a spring_slider)",
                })
            }
        })
    }

    /// The rate-and-state slide of this run at `x`: a first slide starts unloaded from the
    /// hold age θ(0) = t0; a repeat slide starts unloaded from the state steady sliding at
    /// the run's velocity left, θ(0) = D_c/v (the interface does not re-age between the two
    /// slides, docs/model.md §4). F_d is F0, the steady force at the reference velocity.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] naming the parameter out of its domain.
    pub(crate) fn spring_slider(&self, x: &[f64]) -> Result<SpringSlider, LawError> {
        let value = |c: Option<usize>| c.map_or(f64::NAN, |i| x[i].exp());
        let params = RateStateParams::new(
            value(self.a),
            value(self.b),
            value(self.d_c),
            value(self.f_d),
        )?;
        let initial = match self.scene {
            Scene::Repeat => InitialState::Hold {
                hold_s: params.dc_m / self.velocity,
            },
            Scene::First | Scene::StiffFast => InitialState::Hold {
                hold_s: value(self.t0),
            },
        };
        let slider = SpringSlider::new(
            params,
            self.state_law,
            value(self.k),
            self.velocity,
            initial,
        )?
        .with_tolerance(LIKELIHOOD_TOLERANCE)?;
        match self.reference_velocity {
            Some(v0) => slider.with_reference_velocity(v0),
            None => Ok(slider),
        }
    }

    /// Visits (index, force) of the rate-and-state slide at `x` at each of `times`: zero
    /// before driving starts (t < 0), the spring-slider's force from t = 0.
    fn visit_rate_state(
        &self,
        x: &[f64],
        times: &[f64],
        mut visit: impl FnMut(usize, f64),
    ) -> Result<(), LawError> {
        let slider = self.spring_slider(x)?;
        let driven = times.partition_point(|&t| t < 0.0);
        for i in 0..driven {
            visit(i, 0.0);
        }
        slider.for_each_state(&times[driven..], |i, state| {
            visit(driven + i, state.force_n)
        })?;
        Ok(())
    }

    /// The machine's elasticity for this run at `x` (none for a slide declared stiff, or
    /// without k under `elastic = false`).
    pub fn elastic(&self, x: &[f64]) -> Result<Elastic, LawError> {
        match (self.scene, self.k) {
            (Scene::StiffFast, _) | (_, None) => Ok(Elastic::Stiff),
            (_, Some(k)) => Elastic::spring(x[k].exp(), self.velocity),
        }
    }

    /// Visits (index, force) of the model at every model time; `f_end` is where the slide a
    /// repeat slide follows stopped (`None`: F_d).
    pub(crate) fn visit_forces(
        &self,
        x: &[f64],
        f_end: Option<f64>,
        visit: impl FnMut(usize, f64),
    ) -> Result<(), LawError> {
        self.visit_forces_at(x, f_end, &self.data.model_times, visit)
    }

    /// Visits (index, force) of the model at each of `times` (increasing); `f_end` as for
    /// [`visit_forces`](Self::visit_forces).
    pub(crate) fn visit_forces_at(
        &self,
        x: &[f64],
        f_end: Option<f64>,
        times: &[f64],
        mut visit: impl FnMut(usize, f64),
    ) -> Result<(), LawError> {
        if self.law == LawKind::RateState {
            return self.visit_rate_state(x, times, visit);
        }
        match self.scene {
            Scene::Repeat => {
                let slide = self.repeat_slide(x, f_end)?;
                for (i, &t) in times.iter().enumerate() {
                    visit(i, slide.force(t));
                }
                Ok(())
            }
            Scene::First | Scene::StiffFast => {
                let slide = ObservedSlide::new(self.law(x)?, self.elastic(x)?);
                slide.for_each_force(times, |i, _, f| visit(i, f))
            }
        }
    }

    /// Sum of squared residuals at `x` and the force at the last model time: from every
    /// observation, or from the bins' sufficient statistics of a reduced run.
    pub fn residuals(&self, x: &[f64], f_end: Option<f64>) -> Result<RunResiduals, LawError> {
        if let Some(reduction) = &self.reduction {
            return self.reduced_residuals(reduction, x, f_end);
        }
        let obs = &self.data.force;
        let n = self.data.n_obs;
        let mut ssr = 0.0;
        let mut last = 0.0;
        self.visit_forces(x, f_end, |j, f| {
            if j < n {
                let e = obs[j] - f;
                ssr += e * e;
            }
            last = f;
        })?;
        Ok(RunResiduals {
            ssr,
            last_force: last,
        })
    }

    /// [`residuals`](Self::residuals) of a reduced run: the model at its bins' Chebyshev
    /// points and its exact observations; a bin that a kink of the model at `x` falls in is
    /// evaluated point by point.
    fn reduced_residuals(
        &self,
        reduction: &Reduction,
        x: &[f64],
        f_end: Option<f64>,
    ) -> Result<RunResiduals, LawError> {
        let obs_times = &self.data.model_times[..self.data.n_obs];
        let (ssr, last) = match self.scene {
            Scene::Repeat => {
                let slide = self.repeat_slide(x, f_end)?;
                let layout = reduction.layout(obs_times, &repeat_kinks(&slide));
                let mut sum = reduction.accumulator(&layout, &self.data.force);
                for &t in layout.times() {
                    sum.visit(slide.force(t));
                }
                sum.finish()
            }
            Scene::First | Scene::StiffFast => {
                let slide = ObservedSlide::new(self.law(x)?, self.elastic(x)?);
                let layout = reduction.layout(obs_times, &slide_kinks(&slide));
                let mut sum = reduction.accumulator(&layout, &self.data.force);
                slide.for_each_force(layout.times(), |_, _, f| sum.visit(f))?;
                sum.finish()
            }
        };
        Ok(RunResiduals {
            ssr,
            last_force: last,
        })
    }

    /// The Gaussian log-likelihood of this run's sum of squared residuals `ssr` at `x` when
    /// its σ is sampled; 0 when σ is integrated out (its σ group's term holds it).
    pub(crate) fn gaussian_term(&self, x: &[f64], ssr: f64) -> f64 {
        match self.sigma {
            SigmaSource::Coord(s) => {
                // x[s] is ln σ already.
                let sigma = x[s].exp();
                let n = self.data.n_obs as f64;
                -n * (x[s] + LN_SQRT_2PI) - 0.5 * ssr / (sigma * sigma)
            }
            SigmaSource::Marginal(_) => 0.0,
        }
    }

    /// The repeat slide at `x`, loading up to `f_end` (`None`: F_d).
    pub fn repeat_slide(&self, x: &[f64], f_end: Option<f64>) -> Result<RepeatSlide, LawError> {
        // The layout gives a repeat slide F_d whenever it follows no slide.
        let end = f_end.unwrap_or_else(|| self.f_d.map_or(f64::NAN, |i| x[i].exp()));
        RepeatSlide::from_elastic(self.elastic(x)?, end)
    }

    /// Instrument times where this run's model at `x` has a kink (NaN: none).
    pub fn kinks(&self, x: &[f64], f_end: Option<f64>) -> Result<[f64; 2], LawError> {
        if self.law == LawKind::RateState {
            // The spring starts to load at t = 0; the ODE's solution is smooth after it.
            return Ok([0.0, f64::NAN]);
        }
        match self.scene {
            Scene::Repeat => Ok(repeat_kinks(&self.repeat_slide(x, f_end)?)),
            Scene::First | Scene::StiffFast => Ok(slide_kinks(&ObservedSlide::new(
                self.law(x)?,
                self.elastic(x)?,
            ))),
        }
    }
}

/// A first slide's kinks: t0, where the force leaves zero, and (through a spring) the end of
/// the elastic loading that takes up the law's jump at t0 (docs/model.md §3). A slide
/// declared stiff jumps at t0.
fn slide_kinks(slide: &ObservedSlide) -> [f64; 2] {
    let t0 = slide.law().t0();
    match slide.elastic() {
        Elastic::Spring { kv } => [t0, t0 + slide.law().force(t0) / kv],
        Elastic::Stiff => [t0, f64::NAN],
    }
}

/// A repeat slide's kinks: its start, and where the loading line meets the plateau (the
/// start again on a rigid machine).
fn repeat_kinks(slide: &RepeatSlide) -> [f64; 2] {
    [0.0, slide.loading_ends()]
}

/// A law that cannot be evaluated rejects the point, under the label of the reason.
pub(super) fn law_rejection(e: LawError) -> LogDensityError {
    match e {
        LawError::StickSlip { .. } => LogDensityError::rejected(REJECT_STICK_SLIP),
        LawError::RateState { .. } => LogDensityError::rejected(REJECT_RATE_STATE),
        _ => LogDensityError::rejected(REJECT_LAW),
    }
}

impl Posterior {
    /// Fits run `i` at `x` into `ssr[i]` and `last[i]` (its sum of squared residuals and
    /// F_end), reading the F_end of the slide it follows from `last`: a repeat slide must
    /// come after the slide it follows (see `order`).
    pub(super) fn fit_run(
        &self,
        i: usize,
        x: &[f64],
        ssr: &mut [f64],
        last: &mut [f64],
    ) -> Result<(), LogDensityError> {
        let fit = self.run_residuals(i, x, self.runs[i].follows.map(|j| last[j]))?;
        ssr[i] = fit.ssr;
        last[i] = fit.last_force;
        Ok(())
    }

    /// The fit of run `i` at `x`, a repeat slide loading up to `f_end` (the F_end of the slide
    /// it follows).
    pub(super) fn run_residuals(
        &self,
        i: usize,
        x: &[f64],
        f_end: Option<f64>,
    ) -> Result<RunResiduals, LogDensityError> {
        let r = &self.runs[i];
        if !r.held {
            return Err(LogDensityError::fatal(format!(
                "run `{}`: its data are held by another rank of the MPI job; this rank holds \
                 only its share of the contacts",
                r.name
            )));
        }
        r.residuals(x, f_end).map_err(law_rejection)
    }

    /// The likelihood's terms that need no σ integrated out, given every run's sum of squared
    /// residuals `ssr` (indexed by run): the Gaussian term of runs with a sampled σ. Summed in
    /// run order, so that a full evaluation and a block update give the same bits.
    pub(super) fn run_terms(&self, x: &[f64], ssr: &[f64]) -> f64 {
        let mut ll = 0.0;
        for (r, &ssr) in self.runs.iter().zip(ssr) {
            ll += r.gaussian_term(x, ssr);
        }
        ll
    }

    /// (sum of squared residuals, observations) of marginalised σ group `g`, over its runs in
    /// run order, each run's sum of squared residuals from `ssr_of`.
    pub(super) fn group_fit(&self, g: usize, ssr_of: impl Fn(usize) -> f64) -> (f64, usize) {
        let mut fit = (0.0, 0);
        for &i in &self.sigma_groups[g].runs {
            fit.0 += ssr_of(i);
            fit.1 += self.runs[i].data.n_obs;
        }
        fit
    }

    /// The log-likelihood of σ group `g`'s runs with σ integrated out over its prior, each
    /// run's sum of squared residuals from `ssr_of`.
    pub(super) fn group_term(
        &self,
        g: usize,
        ssr_of: impl Fn(usize) -> f64,
    ) -> Result<f64, LogDensityError> {
        let (fit, n) = self.group_fit(g, ssr_of);
        let group = &self.sigma_groups[g];
        marginal_sigma_log_likelihood(fit, n, group.low, group.high)
            .ok_or(LogDensityError::rejected(REJECT_PRIOR))
    }

    /// The F_end of every first slide at `x` (indexed by run), for curves of single runs.
    pub(super) fn first_slide_ends(&self, x: &[f64]) -> Result<Vec<Option<f64>>, LawError> {
        let mut f_end = vec![None; self.runs.len()];
        for &i in &self.order {
            let r = &self.runs[i];
            if r.scene == Scene::First {
                let mut last = 0.0;
                // A reduced run's F_end alone (its record may hold 10⁶ points); a short run
                // is solved along all its times, as its likelihood solves it.
                let times = match r.reduction {
                    Some(_) => &r.data.model_times[r.data.model_times.len() - 1..],
                    None => &r.data.model_times[..],
                };
                r.visit_forces_at(x, None, times, |_, f| last = f)?;
                f_end[i] = Some(last);
            }
        }
        Ok(f_end)
    }
}
