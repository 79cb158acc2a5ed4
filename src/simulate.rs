//! Synthetic data sets from known parameters, for testing fits and filling `data/`.
//!
//! A simulated run samples the noiseless scene model on a regular grid of instrument times and
//! adds Gaussian noise of a given standard deviation, all from one seeded random stream, so the
//! same specification always gives the same file.

use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use serde::{Deserialize, Serialize};

use crate::data::Series;
use crate::law::{
    Elastic, InterfaceLaw, Law, LawError, LawKind, LawParams, LogAging, ObservedSlide, RepeatSlide,
    Scene,
};

/// Errors of a simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimulateError {
    /// A setting is invalid.
    #[error("{name} = {value}: {expected}")]
    InvalidSetting {
        /// Setting name as on the command line.
        name: &'static str,
        /// Its value.
        value: String,
        /// What is expected.
        expected: &'static str,
    },
    /// The law rejected the parameters or has no quasi-static path.
    #[error(transparent)]
    Law(#[from] LawError),
}

/// Everything that defines a simulated run; saved beside the data as its true values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SimulationSpec {
    /// Kind of slide.
    pub scene: Scene,
    /// The law of a first or fast slide (the aging–rejuvenation law when absent).
    #[serde(default)]
    pub law: LawKind,
    /// The law's parameters (F_d is also the sliding force of a repeat slide unless
    /// `f_end_n` or `after_first_s` says otherwise). Pure logarithmic aging reads only a and
    /// t0 (the command line records α = 0, the limit it is).
    pub params: LawParams,
    /// Machine stiffness k (N/m); ignored by a stiff fast slide and on a rigid machine.
    pub stiffness_n_per_m: Option<f64>,
    /// A rigid machine (k → ∞): τ = t on a first slide, and a repeat slide is F_end from its
    /// start (`elastic = false` in a model file).
    #[serde(default)]
    pub rigid: bool,
    /// Sliding velocity v (m/s).
    pub velocity_m_per_s: f64,
    /// Length of the record (s).
    pub duration_s: f64,
    /// Sampling interval (s).
    pub interval_s: f64,
    /// Standard deviation of the Gaussian force noise σ (N).
    pub noise_sd_n: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// Repeat slide: the force where the previous slide stopped (N).
    pub f_end_n: Option<f64>,
    /// Repeat slide: instead of `f_end_n`, the duration of the first slide it follows (s);
    /// F_end is that slide's recorded force at its end.
    pub after_first_s: Option<f64>,
    /// Mean normal force (N), recorded as a third column when given.
    pub normal_force_n: Option<f64>,
    /// Standard deviation of the normal-force noise (N).
    pub normal_noise_sd_n: f64,
}

/// A simulated run: the noisy series and the noiseless force at the same times.
#[derive(Debug, Clone)]
pub struct Simulated {
    /// What the instrument would record.
    pub series: Series,
    /// The model force without noise (N).
    pub clean_force_n: Vec<f64>,
    /// F_end used by a repeat slide (N).
    pub f_end_n: Option<f64>,
}

fn setting(
    name: &'static str,
    value: f64,
    ok: bool,
    expected: &'static str,
) -> Result<(), SimulateError> {
    if ok {
        Ok(())
    } else {
        Err(SimulateError::InvalidSetting {
            name,
            value: value.to_string(),
            expected,
        })
    }
}

impl SimulationSpec {
    /// The law of a first or fast slide.
    ///
    /// # Errors
    /// [`SimulateError::Law`] when the parameters are invalid for the law.
    pub fn interface_law(&self) -> Result<InterfaceLaw, SimulateError> {
        let p = &self.params;
        Ok(match self.law {
            LawKind::AgingRejuvenation => Law::new(p, self.velocity_m_per_s)?.into(),
            LawKind::LogAging => LogAging::new(p.a_n, p.t0_s)?.into(),
            LawKind::RateState => {
                return Err(SimulateError::InvalidSetting {
                    name: "law",
                    value: self.law.to_string(),
                    expected: "\"aging-rejuvenation\" or \"log-aging\" (a rate-and-state slide \
                               is simulated with slipbayes::law::SpringSlider)",
                })
            }
        })
    }

    /// The elasticity of the run's machine.
    pub fn elastic(&self) -> Result<Elastic, SimulateError> {
        match (self.scene, self.stiffness_n_per_m) {
            (Scene::StiffFast, _) => Ok(Elastic::Stiff),
            (_, None) if self.rigid => Ok(Elastic::Stiff),
            (_, Some(k)) if self.rigid => Err(SimulateError::InvalidSetting {
                name: "k",
                value: k.to_string(),
                expected: "no stiffness on a rigid machine: drop k or rigid",
            }),
            (_, Some(k)) => Ok(Elastic::spring(k, self.velocity_m_per_s)?),
            (_, None) => Err(SimulateError::InvalidSetting {
                name: "k",
                value: "none".into(),
                expected: "a stiffness in N/m is needed for first and repeat slides",
            }),
        }
    }

    /// Instrument times 0, Δt, 2Δt, … up to the duration.
    pub fn times(&self) -> Result<Vec<f64>, SimulateError> {
        sample_times(self.duration_s, self.interval_s)
    }

    /// The noiseless force at `times` for this scene, and F_end for a repeat slide.
    ///
    /// # Errors
    /// Invalid settings, or a law error (e.g. stick-slip).
    pub fn clean_forces(&self, times: &[f64]) -> Result<(Vec<f64>, Option<f64>), SimulateError> {
        let elastic = self.elastic()?;
        let mut forces = vec![0.0; times.len()];
        match self.scene {
            Scene::First | Scene::StiffFast => {
                let slide = ObservedSlide::new(self.interface_law()?, elastic);
                slide.forces(times, &mut forces, None)?;
                Ok((forces, None))
            }
            Scene::Repeat => {
                let f_end = match (self.f_end_n, self.after_first_s) {
                    (Some(f), None) => f,
                    (None, Some(t)) => {
                        setting(
                            "after-first",
                            t,
                            t.is_finite() && t > 0.0,
                            "a duration > 0 s",
                        )?;
                        ObservedSlide::new(self.interface_law()?, elastic).force_at(t)?
                    }
                    (None, None) if self.law == LawKind::LogAging => {
                        return Err(SimulateError::InvalidSetting {
                            name: "f-end",
                            value: "none".into(),
                            expected: "pure logarithmic aging has no F_d to slide at: give \
                                       --f-end or --after-first",
                        })
                    }
                    (None, None) => self.params.f_d_n,
                    (Some(f), Some(_)) => {
                        return Err(SimulateError::InvalidSetting {
                            name: "f-end",
                            value: f.to_string(),
                            expected: "give either --f-end or --after-first, not both",
                        })
                    }
                };
                RepeatSlide::from_elastic(elastic, f_end)?.forces(times, &mut forces)?;
                Ok((forces, Some(f_end)))
            }
        }
    }
}

/// Instrument times 0, Δt, 2Δt, … up to `duration_s` (with Δt = `interval_s`).
///
/// # Errors
/// [`SimulateError::InvalidSetting`] for a duration or interval that is not positive, an
/// interval longer than the duration, or more than 5e7 points.
pub fn sample_times(duration_s: f64, interval_s: f64) -> Result<Vec<f64>, SimulateError> {
    let (d, dt) = (duration_s, interval_s);
    setting("duration", d, d.is_finite() && d > 0.0, "a duration > 0 s")?;
    setting(
        "interval",
        dt,
        dt.is_finite() && dt > 0.0 && dt <= d,
        "an interval > 0 s, at most the duration",
    )?;
    let n = (d / dt * (1.0 + 4.0 * f64::EPSILON)).floor() as usize;
    setting(
        "duration/interval",
        d / dt,
        n < 50_000_000,
        "at most 5e7 points",
    )?;
    Ok((0..=n).map(|i| i as f64 * dt).collect())
}

/// Simulates the run described by `spec`.
///
/// # Errors
/// [`SimulateError`] for invalid settings or parameters.
pub fn simulate(spec: &SimulationSpec) -> Result<Simulated, SimulateError> {
    let sd = spec.noise_sd_n;
    setting(
        "sigma",
        sd,
        sd.is_finite() && sd >= 0.0,
        "a noise standard deviation ≥ 0 N",
    )?;
    let nsd = spec.normal_noise_sd_n;
    setting(
        "normal-sigma",
        nsd,
        nsd.is_finite() && nsd >= 0.0,
        "a standard deviation ≥ 0 N",
    )?;
    let times = spec.times()?;
    let (clean, f_end_n) = spec.clean_forces(&times)?;
    let mut rng = ChaCha8Rng::seed_from_u64(spec.seed);
    // σ = 0 is allowed (noiseless data); Normal::new accepts it.
    let noise = Normal::new(0.0, sd).map_err(|_| SimulateError::InvalidSetting {
        name: "sigma",
        value: sd.to_string(),
        expected: "a finite standard deviation",
    })?;
    let force_n: Vec<f64> = clean.iter().map(|f| f + noise.sample(&mut rng)).collect();
    let normal_force_n = match spec.normal_force_n {
        Some(fn_mean) => {
            setting(
                "normal-force",
                fn_mean,
                fn_mean.is_finite() && fn_mean > 0.0,
                "a normal force > 0 N",
            )?;
            let normal_noise =
                Normal::new(fn_mean, nsd).map_err(|_| SimulateError::InvalidSetting {
                    name: "normal-sigma",
                    value: nsd.to_string(),
                    expected: "a finite standard deviation",
                })?;
            Some(
                times
                    .iter()
                    .map(|_| normal_noise.sample(&mut rng))
                    .collect(),
            )
        }
        None => None,
    };
    Ok(Simulated {
        series: Series {
            time_s: times,
            force_n,
            normal_force_n,
        },
        clean_force_n: clean,
        f_end_n,
    })
}
