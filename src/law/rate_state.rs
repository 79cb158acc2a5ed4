//! Rate-and-state friction on a spring-slider: the standard rival of the aging–rejuvenation law.
//!
//! # The model
//!
//! The instrument pulls one end of a spring of stiffness k at the load-point velocity v; the
//! other end drags the interface, which slips at velocity V and carries a state θ (a contact
//! age, in seconds). The friction force, in newtons because the normal force is often unknown,
//! is
//!
//! ```text
//! F = F0 + a ln(V/V0) + b ln(V0 θ / D_c)
//! ```
//!
//! with a, b in newtons (a = a'·F_N and b = b'·F_N for the dimensionless parameters a', b' of
//! the friction coefficient, and F0 = μ0·F_N: see [`RateStateParams::from_coefficients`]), D_c
//! the critical slip distance and V0 a reference velocity, by default v itself, so that F0 is
//! the steady force at the driving velocity. The spring is quasi-static,
//!
//! ```text
//! dF/dt = k (v − V),
//! ```
//!
//! and the state evolves by one of two laws ([`StateLaw`]):
//!
//! ```text
//! aging (Dieterich):  dθ/dt = 1 − Vθ/D_c
//! slip (Ruina):       dθ/dt = −(Vθ/D_c) ln(Vθ/D_c)
//! ```
//!
//! Both relax to the steady state θ_ss = D_c/v, where F_ss = F0 + (a − b) ln(v/V0); a sudden
//! change of V by a factor r moves F by a ln r at once (the direct effect) and by (a − b) ln r
//! once the state has followed, after a slip of a few D_c.
//!
//! # Initial state
//!
//! A first slide ([`InitialState::Hold`]) starts at rest with the spring unloaded, F(0) = 0,
//! after a hold of duration t_hold. At rest the aging law ages the state as dθ/dt = 1, so a
//! fresh contact held for t_hold has θ(0) = t_hold; that is the initial state taken for both
//! laws (the slip law does not age at rest, so for it t_hold is the conventional measure of
//! the contact's age rather than a consequence of the law). A contact that slid before the
//! hold carries a memory D_c/v_prev as well; it is negligible when t_hold ≫ D_c/v_prev, and
//! otherwise a hold of t_hold + D_c/v_prev states it. The slip velocity at t = 0 follows from
//! the friction law: V(0) = V0 exp[(0 − F0 − b ln(V0 θ0/D_c))/a], far below v for any
//! realistic F0/a, so the spring first loads elastically, the force peaks where the state has
//! aged beyond steady sliding (θ0 > D_c/v), and then settles to F_ss.
//!
//! [`InitialState::Steady`] starts from steady sliding at another velocity v1 instead
//! (θ = D_c/v1, F = F0 + (a − b) ln(v1/V0)): a velocity step from v1 to v.
//!
//! # Integration
//!
//! The system is integrated in dimensionless variables, which keep every number of order one
//! whatever the units and spread of the parameters:
//!
//! ```text
//! s = t v/D_c,   u = (F − F_ss)/a,   φ = ln(v θ/D_c),   w = ln(V/v) = u − (b/a) φ
//! du/ds = κ (1 − e^w),   κ = k D_c/a
//! dφ/ds = e^(−φ) − e^w            (aging)
//! dφ/ds = −e^w (w + φ)            (slip)
//! ```
//!
//! The logarithms of V and θ are what change smoothly: V spans tens of decades between rest
//! and sliding, while w and φ stay of order F/a. The Jacobian is 2×2 and analytic. The
//! eigenvalue −κ e^w is the spring's elastic relaxation; with a stiff machine (κ up to 1e6 and
//! more) it is many decades faster than the state's evolution over a slip of D_c, so an
//! explicit method would take steps of 1/κ throughout the slide: the problem is stiff.
//!
//! The solver is Radau IIA of order 5 (Hairer & Wanner's RADAU5, with its step-size and Newton
//! control) from the `differential-equations` crate: an implicit, L-stable collocation method
//! whose error is controlled on the end points and interpolated to the observation times by
//! its collocation polynomial. It was chosen because (1) it is pure Rust with one small
//! dependency (simba), no BLAS and no LAPACK, so a clean build stays cheap; (2) Radau IIA is
//! L-stable, so its cost does not grow with k (tests/rate_state.rs integrates κ = 1e6); (3) at
//! order 5 it reaches about 1e−8 relative accuracy in a few hundred steps per slide, where the
//! order 2–4 SDIRK and BDF alternatives would need several times more. `diffsol` (BDF and
//! SDIRK, well kept) was the other candidate; its default build pulls `faer` and `nalgebra`
//! together and it cannot be built without both, too heavy for a 2-state system. `russell_ode`
//! needs a system BLAS; `ode_solvers` has no stiff method.
//!
//! Accuracy: with the default tolerance ([`DEFAULT_TOLERANCE`]) the forces agree with a scipy
//! Radau reference at rtol = 1e−13 to the relative error stated in
//! [`crate::prec::RATE_STATE_REL_TOL`], on slow first slides with a peak, a stiff machine and
//! velocity steps, for both laws (tests/rate_state.rs).
//!
//! # Errors
//! Parameters are checked by the constructors and named in [`LawError::InvalidParameter`];
//! a failure of the solver, or a slip velocity beyond the range of `f64`, is a
//! [`RateStateError`], never a NaN.

use differential_equations::error::Error as OdeError;
use differential_equations::linalg::Matrix;
use differential_equations::prelude::{ImplicitRungeKutta, IVP, ODE};

use super::{non_negative, positive, LawError};

/// The solver's default relative and absolute tolerance, on the dimensionless force u (in units
/// of a) and the log-state φ. RADAU5 turns a requested tolerance `tol` into 0.1·tol^(2/3) for
/// its error estimate, and the forces between steps come from its collocation polynomial, so
/// the forces' error falls slowly below 1e−11: against the reference, worst 3.6e−7 at 1e−10,
/// 4.0e−8 at 1e−12 and 1.6e−8 at 1e−13 (tests/rate_state.rs prints the whole table). The
/// default is the tightest tolerance accepted, 1e−13.
pub const DEFAULT_TOLERANCE: f64 = 1e-13;

/// The tolerance of a fit's likelihood (its runs' slides are solved to it): forces within
/// [`crate::prec::RATE_STATE_LIKELIHOOD_REL_TOL`] of the reference, relative to
/// max(|F|, a) (worst 1.6e−6 over the six reference slides, tests/rate_state.rs) — for a
/// force scale of 10 mN an error of 16 nN, four decades below any realistic noise σ, so the
/// log-likelihood moves by far less than 0.01 — at a fraction of the steps of
/// [`DEFAULT_TOLERANCE`]. The errors do not fall steadily below it (2.5e−6 at 1e−8) because
/// RADAU5's step control and its collocation polynomial between steps set them.
pub const LIKELIHOOD_TOLERANCE: f64 = 1e-7;

/// Exponents of e^w and e^(−φ) are capped here: a Newton trial far off the path then sees a
/// large, finite rate, which the solver rejects by shrinking its step, instead of ∞ or NaN.
/// e^600 ≈ 4e260 leaves room for κ up to 1e40 before overflow.
const EXP_CAP: f64 = 600.0;

/// Most solver steps allowed on one slide; a stable slide of a few hundred D_c needs hundreds.
const MAX_STEPS: usize = 1_000_000;

/// Errors of the rate-and-state forward model.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum RateStateError {
    /// A parameter, the times or the outputs are invalid (the parameter is named).
    #[error(transparent)]
    Law(#[from] LawError),
    /// An observation time before the start of the slide.
    #[error(
        "time[{index}] = {time_s:e} s is before the start of the slide; times are measured \
         from the start of driving (t = 0) and must be ≥ 0"
    )]
    NegativeTime {
        /// Index of the offending time.
        index: usize,
        /// Its value (s).
        time_s: f64,
    },
    /// The stiff solver gave up.
    #[error(
        "the rate-and-state solver failed at t = {time_s:e} s: {reason}; with b > a a spring \
         softer than k_c = (b − a)/D_c stick-slips, which this quasi-static model cannot follow \
         (raise k or check a, b, D_c)"
    )]
    Solver {
        /// Time (s) where the solver stopped.
        time_s: f64,
        /// The solver's own account.
        reason: String,
    },
    /// The slip velocity left the range of `f64` (an unstable slide).
    #[error(
        "the slip velocity is out of range (ln(V/v) = {ln_velocity_ratio:e}) at t = {time_s:e} s; \
         the slide is unstable (stick-slip): raise k above (b − a)/D_c or check a, b, D_c"
    )]
    Unbounded {
        /// Time (s) of the observation.
        time_s: f64,
        /// ln(V/v) there.
        ln_velocity_ratio: f64,
    },
}

/// How the state θ evolves: the model file's `state_law` (`"aging"` or `"slip"`).
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "kebab-case", try_from = "String")]
pub enum StateLaw {
    /// Dieterich's aging law, dθ/dt = 1 − Vθ/D_c: contacts age even at rest (the default).
    #[default]
    Aging,
    /// Ruina's slip law, dθ/dt = −(Vθ/D_c) ln(Vθ/D_c): the state changes only with slip.
    Slip,
}

impl StateLaw {
    /// Both laws, in the order the documentation lists them.
    pub const ALL: [StateLaw; 2] = [Self::Aging, Self::Slip];

    /// The name written in model files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Aging => "aging",
            Self::Slip => "slip",
        }
    }
}

impl std::fmt::Display for StateLaw {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for StateLaw {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .into_iter()
            .find(|k| k.name() == s)
            .ok_or_else(|| {
                format!(
                    "`state_law = \"{s}\"` is not a state law slipbayes knows; write \"aging\" \
                     (Dieterich) or \"slip\" (Ruina)"
                )
            })
    }
}

impl TryFrom<String> for StateLaw {
    type Error = String;

    fn try_from(s: String) -> Result<Self, String> {
        s.parse()
    }
}

impl From<RateStateError> for LawError {
    /// A failure of the slide, as the fit's likelihood reports it: the law's own errors as
    /// they are, the solver's as [`LawError::RateState`].
    fn from(e: RateStateError) -> Self {
        match e {
            RateStateError::Law(e) => e,
            RateStateError::Solver { time_s, .. }
            | RateStateError::Unbounded { time_s, .. }
            | RateStateError::NegativeTime { time_s, .. } => LawError::RateState {
                time_s,
                message: e.to_string(),
            },
        }
    }
}

/// The friction parameters, in force units (N). Construct with [`RateStateParams::new`] or
/// [`RateStateParams::from_coefficients`], which validate them.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct RateStateParams {
    /// Direct-effect amplitude a (N).
    pub a_n: f64,
    /// Evolution-effect amplitude b (N).
    pub b_n: f64,
    /// Critical slip distance D_c (m).
    pub dc_m: f64,
    /// Steady friction force F0 at the reference velocity V0 (N).
    pub f0_n: f64,
}

impl RateStateParams {
    /// Validated parameters in newtons.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] naming `a` (must be > 0), `b` (≥ 0), `D_c` (> 0) or `F0`
    /// (≥ 0), or any that is not finite.
    pub fn new(a_n: f64, b_n: f64, dc_m: f64, f0_n: f64) -> Result<Self, LawError> {
        positive("a", a_n)?;
        non_negative("b", b_n)?;
        positive("D_c", dc_m)?;
        non_negative("F0", f0_n)?;
        Ok(Self {
            a_n,
            b_n,
            dc_m,
            f0_n,
        })
    }

    /// Parameters from the dimensionless friction-coefficient form μ = μ0 + a ln(V/V0) +
    /// b ln(V0θ/D_c) and a known normal force F_N: a_n = a·F_N, b_n = b·F_N, F0 = μ0·F_N.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] naming `F_N` (must be > 0), `a`, `b`, `mu0` or `D_c`.
    pub fn from_coefficients(
        a: f64,
        b: f64,
        dc_m: f64,
        mu0: f64,
        normal_force_n: f64,
    ) -> Result<Self, LawError> {
        let normal = positive("F_N", normal_force_n)?;
        positive("a", a)?;
        non_negative("b", b)?;
        non_negative("mu0", mu0)?;
        Self::new(a * normal, b * normal, dc_m, mu0 * normal)
    }
}

/// Where the slide starts.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum InitialState {
    /// A first slide after a hold: spring unloaded (F = 0), θ = t_hold.
    Hold {
        /// Hold duration t_hold (s), the contact's age at the start.
        hold_s: f64,
    },
    /// Steady sliding at `velocity_m_per_s` before the slide: θ = D_c/v1 and
    /// F = F0 + (a − b) ln(v1/V0) (a velocity step from v1 to the driving velocity).
    Steady {
        /// The earlier velocity v1 (m/s).
        velocity_m_per_s: f64,
    },
}

/// Force, slip velocity and state at one time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SliderState {
    /// Friction force = spring force F (N).
    pub force_n: f64,
    /// Slip velocity V (m/s).
    pub velocity_m_per_s: f64,
    /// State θ (s).
    pub theta_s: f64,
}

/// A rate-and-state slide on a spring driven at a constant velocity, ready to evaluate at the
/// observation times.
#[derive(Debug, Clone)]
pub struct SpringSlider {
    params: RateStateParams,
    law: StateLaw,
    k_n_per_m: f64,
    velocity_m_per_s: f64,
    reference_velocity_m_per_s: f64,
    initial: InitialState,
    tolerance: f64,
}

impl SpringSlider {
    /// The slide of `params` under `law` on a spring of stiffness `k_n_per_m` driven at
    /// `velocity_m_per_s`, starting from `initial`; the reference velocity V0 is the driving
    /// velocity and the tolerance [`DEFAULT_TOLERANCE`].
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] naming `k`, `v`, `t_hold` or `v1` when it is not finite
    /// and positive, or `k*D_c/a` when the dimensionless stiffness is not finite.
    pub fn new(
        params: RateStateParams,
        law: StateLaw,
        k_n_per_m: f64,
        velocity_m_per_s: f64,
        initial: InitialState,
    ) -> Result<Self, LawError> {
        // The fields are public, so a hand-built value is checked again here.
        let params = RateStateParams::new(params.a_n, params.b_n, params.dc_m, params.f0_n)?;
        positive("k", k_n_per_m)?;
        positive("v", velocity_m_per_s)?;
        match initial {
            InitialState::Hold { hold_s } => positive("t_hold", hold_s)?,
            InitialState::Steady { velocity_m_per_s } => positive("v1", velocity_m_per_s)?,
        };
        positive("k*D_c/a", k_n_per_m * params.dc_m / params.a_n)?;
        Ok(Self {
            params,
            law,
            k_n_per_m,
            velocity_m_per_s,
            reference_velocity_m_per_s: velocity_m_per_s,
            initial,
            tolerance: DEFAULT_TOLERANCE,
        })
    }

    /// The same slide with the reference velocity V0 of the friction law set to
    /// `reference_velocity_m_per_s` (F0 is then the steady force at V0, not at v).
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] naming `V0` when it is not finite and positive.
    pub fn with_reference_velocity(
        mut self,
        reference_velocity_m_per_s: f64,
    ) -> Result<Self, LawError> {
        self.reference_velocity_m_per_s = positive("V0", reference_velocity_m_per_s)?;
        Ok(self)
    }

    /// The same slide solved to relative and absolute tolerance `tolerance` on the
    /// dimensionless force (F − F_ss)/a and log-state ln(vθ/D_c).
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] naming `tolerance` outside [1e−13, 1e−2].
    pub fn with_tolerance(mut self, tolerance: f64) -> Result<Self, LawError> {
        if !(1e-13..=1e-2).contains(&tolerance) {
            return Err(LawError::InvalidParameter {
                name: "tolerance",
                value: tolerance,
                expected: "a number in [1e-13, 1e-2]",
            });
        }
        self.tolerance = tolerance;
        Ok(self)
    }

    /// The friction parameters.
    pub fn params(&self) -> &RateStateParams {
        &self.params
    }

    /// The state law.
    pub fn law(&self) -> StateLaw {
        self.law
    }

    /// Steady-state force at the driving velocity, F_ss = F0 + (a − b) ln(v/V0) (N).
    pub fn steady_force_n(&self) -> f64 {
        let p = &self.params;
        p.f0_n + (p.a_n - p.b_n) * (self.velocity_m_per_s / self.reference_velocity_m_per_s).ln()
    }

    /// Recorded force at each time of `times` (seconds from the start of driving, strictly
    /// increasing, ≥ 0), written into `forces`.
    ///
    /// # Errors
    /// [`LawError::UnsortedTimes`] and [`RateStateError::NegativeTime`] for bad times,
    /// [`LawError::LengthMismatch`] for an output of the wrong length, and
    /// [`RateStateError::Solver`] or [`RateStateError::Unbounded`] when the slide cannot be
    /// integrated.
    pub fn forces(&self, times: &[f64], forces: &mut [f64]) -> Result<(), RateStateError> {
        if times.len() != forces.len() {
            return Err(LawError::LengthMismatch {
                expected: times.len(),
                got: forces.len(),
            }
            .into());
        }
        self.for_each_state(times, |i, state| forces[i] = state.force_n)
    }

    /// Force, slip velocity and state at each time of `times`.
    ///
    /// # Errors
    /// As [`SpringSlider::forces`].
    pub fn states(&self, times: &[f64]) -> Result<Vec<SliderState>, RateStateError> {
        let mut out = Vec::with_capacity(times.len());
        self.for_each_state(times, |_, state| out.push(state))?;
        Ok(out)
    }

    /// Calls `visit(i, state_i)` at each time of `times`, in order, after the whole slide has
    /// been integrated (no value is visited when the integration fails).
    ///
    /// # Errors
    /// As [`SpringSlider::forces`].
    pub(crate) fn for_each_state(
        &self,
        times: &[f64],
        mut visit: impl FnMut(usize, SliderState),
    ) -> Result<(), RateStateError> {
        check_times(times)?;
        let Some(&last) = times.last() else {
            return Ok(());
        };
        let p = &self.params;
        let slip_time_s = p.dc_m / self.velocity_m_per_s;
        let system = Dimensionless {
            kappa: self.k_n_per_m * p.dc_m / p.a_n,
            b_over_a: p.b_n / p.a_n,
            law: self.law,
        };
        let start = self.initial_dimensionless();
        let steady_force_n = self.steady_force_n();
        let to_state = |index: usize, y: [f64; 2]| {
            let ln_velocity_ratio = system.ln_velocity_ratio(&y);
            let time_s = times[index];
            if !(ln_velocity_ratio.is_finite() && ln_velocity_ratio < EXP_CAP && y[1].is_finite()) {
                return Err(RateStateError::Unbounded {
                    time_s,
                    ln_velocity_ratio,
                });
            }
            Ok(SliderState {
                force_n: steady_force_n + p.a_n * y[0],
                velocity_m_per_s: self.velocity_m_per_s * ln_velocity_ratio.exp(),
                theta_s: slip_time_s * y[1].exp(),
            })
        };

        let end = last / slip_time_s;
        if end <= 0.0 {
            // Only t = 0 is asked for: the initial state itself.
            let state = to_state(0, start)?;
            visit(0, state);
            return Ok(());
        }
        let scaled: Vec<f64> = times.iter().map(|t| t / slip_time_s).collect();
        let method = ImplicitRungeKutta::radau5()
            .rtol(self.tolerance)
            .atol(self.tolerance)
            .max_steps(MAX_STEPS);
        let solution = IVP::ode(&system, 0.0, end, start)
            .t_eval(&scaled)
            .method(method)
            .solve()
            .map_err(|e| solver_error(e, slip_time_s))?;
        if solution.y.len() != times.len() {
            return Err(RateStateError::Solver {
                time_s: solution.t.last().map_or(0.0, |t| t * slip_time_s),
                reason: format!(
                    "{} of {} observation times were reached",
                    solution.y.len(),
                    times.len()
                ),
            });
        }
        // Convert all before visiting, so that a failure visits nothing.
        let states = solution
            .y
            .iter()
            .enumerate()
            .map(|(i, &y)| to_state(i, y))
            .collect::<Result<Vec<_>, _>>()?;
        for (i, state) in states.into_iter().enumerate() {
            visit(i, state);
        }
        Ok(())
    }

    /// (u, φ) at t = 0.
    fn initial_dimensionless(&self) -> [f64; 2] {
        let p = &self.params;
        let v = self.velocity_m_per_s;
        match self.initial {
            InitialState::Hold { hold_s } => {
                [-self.steady_force_n() / p.a_n, (v * hold_s / p.dc_m).ln()]
            }
            // F1 − F_ss = (a − b) ln(v1/v), formed directly rather than as a difference.
            InitialState::Steady { velocity_m_per_s } => {
                let ln_ratio = (velocity_m_per_s / v).ln();
                [(1.0 - p.b_n / p.a_n) * ln_ratio, -ln_ratio]
            }
        }
    }
}

/// The spring-slider in s = tv/D_c, u = (F − F_ss)/a, φ = ln(vθ/D_c) (module docs).
struct Dimensionless {
    kappa: f64,
    b_over_a: f64,
    law: StateLaw,
}

impl Dimensionless {
    /// w = ln(V/v) = u − (b/a) φ.
    #[inline]
    fn ln_velocity_ratio(&self, y: &[f64; 2]) -> f64 {
        y[0] - self.b_over_a * y[1]
    }
}

#[inline]
fn capped_exp(x: f64) -> f64 {
    x.min(EXP_CAP).exp()
}

impl ODE<f64, [f64; 2]> for Dimensionless {
    fn diff(&self, _s: f64, y: &[f64; 2], dyds: &mut [f64; 2]) {
        let w = self.ln_velocity_ratio(y);
        let velocity_ratio = capped_exp(w);
        dyds[0] = self.kappa * (1.0 - velocity_ratio);
        dyds[1] = match self.law {
            StateLaw::Aging => capped_exp(-y[1]) - velocity_ratio,
            StateLaw::Slip => -velocity_ratio * (w + y[1]),
        };
    }

    fn jacobian(&self, _s: f64, y: &[f64; 2], j: &mut Matrix<f64>) {
        let r = self.b_over_a;
        let w = self.ln_velocity_ratio(y);
        let e = capped_exp(w);
        j[(0, 0)] = -self.kappa * e;
        j[(0, 1)] = self.kappa * r * e;
        match self.law {
            StateLaw::Aging => {
                j[(1, 0)] = -e;
                j[(1, 1)] = -capped_exp(-y[1]) + r * e;
            }
            StateLaw::Slip => {
                let ln_omega = w + y[1];
                j[(1, 0)] = -e * (ln_omega + 1.0);
                j[(1, 1)] = e * (r * (ln_omega + 1.0) - 1.0);
            }
        }
    }
}

fn solver_error(error: OdeError<f64, [f64; 2]>, slip_time_s: f64) -> RateStateError {
    let (s, reason) = match error {
        OdeError::MaxSteps { t, .. } => (t, format!("more than {MAX_STEPS} steps")),
        OdeError::StepSize { t, .. } => (t, "the step size fell below round-off".to_owned()),
        OdeError::Stiffness { t, .. } => (t, "stiffness detected".to_owned()),
        OdeError::LinearAlgebra { t, msg, .. } => (t, msg),
        other => (0.0, format!("{other:?}")),
    };
    RateStateError::Solver {
        time_s: s * slip_time_s,
        reason,
    }
}

/// Times must be ≥ 0 and strictly increasing (NaN fails both).
fn check_times(times: &[f64]) -> Result<(), RateStateError> {
    let mut previous = f64::NEG_INFINITY;
    for (index, &time) in times.iter().enumerate() {
        if time.partial_cmp(&previous) != Some(std::cmp::Ordering::Greater) {
            return Err(LawError::UnsortedTimes { index, time }.into());
        }
        if time < 0.0 {
            return Err(RateStateError::NegativeTime {
                index,
                time_s: time,
            });
        }
        previous = time;
    }
    Ok(())
}
