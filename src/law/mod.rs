//! The aging–rejuvenation friction law of Farain and Bonn, evaluated exactly.
//!
//! `dF/dτ = a/τ − αv (F − F_d)` (paper Eq. 2) has the published solution (Eq. 3), for τ ≥ t0,
//!
//! ```text
//! F(τ) = a e^(−x) [Ei(x) − Ei(x0)] + F_d (1 − e^(−x)),   x = αvτ, x0 = αv t0,
//! ```
//!
//! and F = 0 before t0. It is evaluated through the scaled difference of
//! [`crate::special::ScaledEiDiff`], so no e^x or Ei(x) is ever formed and no digits are lost
//! to cancellation, from αv = 1e−12 s⁻¹ (pure logarithmic aging) to x beyond 1e6.
//!
//! The parts:
//! - [`Law`]: F(τ) and dF/dτ in interface time.
//! - [`log_aging`]: its α → 0 limit, F = a ln(τ/t0), evaluated exactly.
//! - [`InterfaceLaw`]: the law a slide follows, one of the [`LawKind`]s a model may choose.
//! - [`observed`]: the elastic correction t = τ + F(τ)/(kv), solved per data point, with a typed
//!   stick-slip error when the quasi-static path does not exist.
//! - [`peak`]: the static friction peak, found by bracketing the sign change of dF/dτ.
//! - [`repeat`]: the repeat-slide model F = min(kvt, F_end).
//! - [`rate_state`]: the rival model, rate-and-state friction (aging or slip law) on a
//!   spring-slider, integrated by a stiff ODE solver.
//!
//! This module knows nothing of files, data sets or sampling. All quantities are SI.

pub mod kernel;
pub mod log_aging;
pub mod observed;
pub mod peak;
pub mod rate_state;
pub mod repeat;
mod root;

pub use kernel::{KernelCounts, Simd, SIMD_ENV};
pub use log_aging::LogAging;
pub use observed::{Elastic, ObservedSlide};
pub use peak::{Peak, PeakOutcome};
pub use rate_state::{
    InitialState, RateStateError, RateStateParams, SliderState, SpringSlider, StateLaw,
};
pub use repeat::RepeatSlide;

use crate::special::ScaledEiDiff;

/// Errors of the friction law and its scenes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum LawError {
    /// A parameter is outside its domain.
    #[error("parameter {name} = {value:e} is invalid: {expected}")]
    InvalidParameter {
        /// Parameter name as users write it (`alpha`, `a`, `F_d`, `t0`, `k`, `v`, ...).
        name: &'static str,
        /// The offending value.
        value: f64,
        /// What a valid value looks like.
        expected: &'static str,
    },
    /// Friction weakens faster than the spring unloads: no quasi-static solution exists.
    #[error(
        "stick-slip: dF/dτ = {rate:e} N/s at τ = {tau:e} s is below −kv = {limit:e} N/s; \
         the elastic correction has no quasi-static solution (raise k or check α, a)"
    )]
    StickSlip {
        /// Interface time where the rate is most negative on the path.
        tau: f64,
        /// dF/dτ there.
        rate: f64,
        /// −kv.
        limit: f64,
    },
    /// The law gave a non-finite value (parameters far outside any physical range).
    #[error("the law is not finite at τ = {tau:e} s; check the parameters")]
    NotFinite {
        /// Interface time of the evaluation.
        tau: f64,
    },
    /// Observation times must increase.
    #[error("time[{index}] = {time:e} s is not after the previous time; times must increase")]
    UnsortedTimes {
        /// Index of the offending time.
        index: usize,
        /// Its value.
        time: f64,
    },
    /// The rate-and-state forward model could not be integrated at these parameters
    /// ([`RateStateError::Solver`] or [`RateStateError::Unbounded`]): in a fit, a rejected
    /// proposal.
    #[error("rate-and-state: {message}")]
    RateState {
        /// Time (s) of the failure.
        time_s: f64,
        /// The solver's account and what to check.
        message: String,
    },
    /// Output and input slices differ in length.
    #[error("output has {got} elements, expected {expected} (one per time)")]
    LengthMismatch {
        /// Expected length.
        expected: usize,
        /// Actual length.
        got: usize,
    },
}

/// What kind of slide a run is, which decides the physics that applies (docs/model.md §4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Scene {
    /// A first slide on a fresh contact: aging, rejuvenation and the elastic correction.
    First,
    /// A repeat slide right after a first one: elastic loading up to the previous end force.
    Repeat,
    /// A fast slide declared stiff: aging and rejuvenation with τ = t.
    StiffFast,
}

impl std::fmt::Display for Scene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::First => "first",
            Self::Repeat => "repeat",
            Self::StiffFast => "stiff-fast",
        })
    }
}

/// Which law a first or fast slide follows in interface time: the model file's `law` key.
///
/// A law decides the parameters a slide needs (`crate::model::spec::ForwardModel`); a new
/// law is a new variant here and in [`InterfaceLaw`].
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case", try_from = "String")]
pub enum LawKind {
    /// The aging–rejuvenation law (α, a, F_d, t0): the default.
    #[default]
    AgingRejuvenation,
    /// Its α → 0 limit, pure logarithmic aging F = a ln(τ/t0) (a, t0): no rejuvenation, no
    /// peak.
    LogAging,
    /// Rate-and-state friction on the spring-slider ([`rate_state`]; a, b, D_c, F_d as F0,
    /// t0 as the hold age θ(0)): not a law in interface time but an ODE over the whole slide,
    /// with the state law of the model file's `state_law`.
    RateState,
}

impl LawKind {
    /// Every law, in the order the documentation lists them.
    pub const ALL: [LawKind; 3] = [Self::AgingRejuvenation, Self::LogAging, Self::RateState];

    /// The name written in model files.
    pub fn name(self) -> &'static str {
        match self {
            Self::AgingRejuvenation => "aging-rejuvenation",
            Self::LogAging => "log-aging",
            Self::RateState => "rate-state",
        }
    }

    /// Whether the law has an interior static-friction peak that the fit reports (F_peak,
    /// τ_peak, ...). A rate-and-state first slide peaks too, but its peak is a point of an
    /// ODE solution with no interface time: it is not among the derived quantities.
    pub(crate) fn has_peak(self) -> bool {
        match self {
            Self::AgingRejuvenation => true,
            Self::LogAging | Self::RateState => false,
        }
    }

    /// Whether the law is solved in interface time through the elastic correction
    /// ([`InterfaceLaw`], [`ObservedSlide`]); rate-and-state is an ODE over the slide instead.
    pub(crate) fn in_interface_time(self) -> bool {
        !matches!(self, Self::RateState)
    }
}

impl std::fmt::Display for LawKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for LawKind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                let accepted: Vec<String> = Self::ALL.iter().map(|k| format!("\"{k}\"")).collect();
                format!(
                    "`law = \"{s}\"` is not a law slipbayes knows; write one of {}",
                    accepted.join(", ")
                )
            })
    }
}

impl TryFrom<String> for LawKind {
    type Error = String;

    fn try_from(s: String) -> Result<Self, String> {
        s.parse()
    }
}

/// The law a first or fast slide follows in interface time, of any [`LawKind`].
#[derive(Debug, Clone)]
pub enum InterfaceLaw {
    /// The aging–rejuvenation law.
    AgingRejuvenation(Law),
    /// Pure logarithmic aging.
    LogAging(LogAging),
}

impl From<Law> for InterfaceLaw {
    fn from(law: Law) -> Self {
        Self::AgingRejuvenation(law)
    }
}

impl From<LogAging> for InterfaceLaw {
    fn from(law: LogAging) -> Self {
        Self::LogAging(law)
    }
}

impl InterfaceLaw {
    /// Which law this is.
    pub fn kind(&self) -> LawKind {
        match self {
            Self::AgingRejuvenation(_) => LawKind::AgingRejuvenation,
            Self::LogAging(_) => LawKind::LogAging,
        }
    }

    /// The aging–rejuvenation law, when this is one.
    pub fn as_aging_rejuvenation(&self) -> Option<&Law> {
        match self {
            Self::AgingRejuvenation(law) => Some(law),
            Self::LogAging(_) => None,
        }
    }

    /// t0 (s): the force is zero before it.
    pub fn t0(&self) -> f64 {
        match self {
            Self::AgingRejuvenation(law) => law.t0(),
            Self::LogAging(law) => law.t0(),
        }
    }

    /// F(τ) in newtons.
    pub fn force(&self, tau: f64) -> f64 {
        self.force_and_rate(tau).0
    }

    /// F(τ) and dF/dτ.
    pub fn force_and_rate(&self, tau: f64) -> (f64, f64) {
        match self {
            Self::AgingRejuvenation(law) => law.force_and_rate(tau),
            Self::LogAging(law) => law.force_and_rate(tau),
        }
    }

    /// The static friction peak; pure logarithmic aging rises for ever and has none.
    pub fn peak(&self) -> PeakOutcome {
        match self {
            Self::AgingRejuvenation(law) => law.peak(),
            Self::LogAging(_) => PeakOutcome::NoInteriorPeak,
        }
    }

    /// The same law with its cut-off moved to `t0_s` (the peak against t0).
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] for a t0 that is not finite and positive.
    pub fn with_t0(&self, t0_s: f64) -> Result<Self, LawError> {
        Ok(match self {
            Self::AgingRejuvenation(law) => {
                Law::from_rate(law.alpha_v(), law.a(), law.f_d(), t0_s)?.into()
            }
            Self::LogAging(law) => LogAging::new(law.a(), t0_s)?.into(),
        })
    }
}

/// The law's parameters, in SI units. Construct with [`LawParams::new`], which validates them.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct LawParams {
    /// Shear-rejuvenation constant α (1/m).
    pub alpha_per_m: f64,
    /// Logarithmic aging amplitude a (N).
    pub a_n: f64,
    /// Steady-state (dynamic) friction F_d (N).
    pub f_d_n: f64,
    /// Short-time cut-off t0 (s).
    pub t0_s: f64,
}

impl LawParams {
    /// Validated parameters.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] when α ≤ 0, a < 0, F_d < 0, t0 ≤ 0 or any is not finite.
    pub fn new(alpha_per_m: f64, a_n: f64, f_d_n: f64, t0_s: f64) -> Result<Self, LawError> {
        positive("alpha", alpha_per_m)?;
        non_negative("a", a_n)?;
        non_negative("F_d", f_d_n)?;
        positive("t0", t0_s)?;
        Ok(Self {
            alpha_per_m,
            a_n,
            f_d_n,
            t0_s,
        })
    }
}

impl LawParams {
    /// The parameters of pure logarithmic aging, the α → 0 limit: α is 0 (that limit), F_d
    /// only the force a repeat slide slides at.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] when a < 0, F_d < 0, t0 ≤ 0 or any is not finite.
    pub fn log_aging(a_n: f64, f_d_n: f64, t0_s: f64) -> Result<Self, LawError> {
        non_negative("a", a_n)?;
        non_negative("F_d", f_d_n)?;
        positive("t0", t0_s)?;
        Ok(Self {
            alpha_per_m: 0.0,
            a_n,
            f_d_n,
            t0_s,
        })
    }
}

pub(crate) fn positive(name: &'static str, value: f64) -> Result<f64, LawError> {
    if value.is_finite() && value > 0.0 {
        Ok(value)
    } else {
        Err(LawError::InvalidParameter {
            name,
            value,
            expected: "a finite number > 0",
        })
    }
}

pub(crate) fn non_negative(name: &'static str, value: f64) -> Result<f64, LawError> {
    if value.is_finite() && value >= 0.0 {
        Ok(value)
    } else {
        Err(LawError::InvalidParameter {
            name,
            value,
            expected: "a finite number ≥ 0",
        })
    }
}

/// The friction law at one sliding velocity, ready to evaluate in interface time τ.
///
/// Everything that depends only on the parameters (αv, x0 and the Ei terms at x0) is computed
/// once here, because a fit evaluates the law at thousands of τ per parameter set.
#[derive(Debug, Clone)]
pub struct Law {
    alpha_v: f64,
    a: f64,
    f_d: f64,
    t0: f64,
    diff: ScaledEiDiff,
}

impl Law {
    /// The law for parameters `params` at sliding velocity `velocity_m_per_s`.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] when the velocity is not finite and positive or when
    /// αv·t0 underflows to zero.
    pub fn new(params: &LawParams, velocity_m_per_s: f64) -> Result<Self, LawError> {
        positive("v", velocity_m_per_s)?;
        Self::from_rate(
            params.alpha_per_m * velocity_m_per_s,
            params.a_n,
            params.f_d_n,
            params.t0_s,
        )
    }

    /// The law from the rejuvenation rate αv (1/s) directly, as in the paper's Fig. 4.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] for a non-positive or non-finite αv, t0 or αv·t0, or a
    /// negative a or F_d.
    pub fn from_rate(
        alpha_v_per_s: f64,
        a_n: f64,
        f_d_n: f64,
        t0_s: f64,
    ) -> Result<Self, LawError> {
        positive("alpha*v", alpha_v_per_s)?;
        non_negative("a", a_n)?;
        non_negative("F_d", f_d_n)?;
        positive("t0", t0_s)?;
        let x0 = positive("alpha*v*t0", alpha_v_per_s * t0_s)?;
        Ok(Self {
            alpha_v: alpha_v_per_s,
            a: a_n,
            f_d: f_d_n,
            t0: t0_s,
            diff: ScaledEiDiff::new(x0),
        })
    }

    /// αv (1/s).
    pub fn alpha_v(&self) -> f64 {
        self.alpha_v
    }
    /// a (N).
    pub fn a(&self) -> f64 {
        self.a
    }
    /// F_d (N).
    pub fn f_d(&self) -> f64 {
        self.f_d
    }
    /// t0 (s).
    pub fn t0(&self) -> f64 {
        self.t0
    }

    /// F(τ) in newtons (0 before t0).
    #[inline]
    pub fn force(&self, tau: f64) -> f64 {
        self.force_and_rate(tau).0
    }

    /// dF/dτ in N/s (0 before t0).
    #[inline]
    pub fn rate(&self, tau: f64) -> f64 {
        self.force_and_rate(tau).1
    }

    /// F(τ) and dF/dτ together, sharing the work.
    ///
    /// # Formula
    /// dF/dτ = a/τ − αv (F − F_d), with F − F_d = a e^(−x)[Ei(x) − Ei(x0)] − F_d e^(−x) formed
    /// directly so that it keeps its digits when F is close to F_d.
    #[inline]
    pub fn force_and_rate(&self, tau: f64) -> (f64, f64) {
        if tau < self.t0 {
            return (0.0, 0.0);
        }
        let x = self.alpha_v * tau;
        let d = self.diff.eval(x);
        let e = (-x).exp();
        // 1 − e^(−x) loses digits for small x; expm1 keeps them, and costs nothing extra where
        // e^(−x) is small.
        let one_minus_e = if x < 0.5 { -(-x).exp_m1() } else { 1.0 - e };
        let aging = self.a * d;
        let force = aging + self.f_d * one_minus_e;
        let excess = aging - self.f_d * e;
        (force, self.a / tau - self.alpha_v * excess)
    }

    /// d²F/dτ² given τ and dF/dτ there (from differentiating Eq. 2).
    #[inline]
    pub(crate) fn curvature(&self, tau: f64, rate: f64) -> f64 {
        -self.a / (tau * tau) - self.alpha_v * rate
    }
}
