//! Named numerical tolerances, in one place.
//!
//! Compare relatively when the quantity has a natural scale of its own, absolutely when it can
//! pass through zero (Ei near its root, a force near t0), and never with `==`.

/// Machine epsilon of `f64`.
pub const EPS: f64 = f64::EPSILON;

/// Relative error allowed for Ei(x) and S(x) = e^(−x) Ei(x) against 50-digit references.
/// Measured worst case on 5509 points over [5e−324, 1e12]: 2.98 ε for Ei, 2.93 ε for S
/// (both near x = 6, the end of the first rational fit).
pub const EI_REL_TOL: f64 = 5.0 * EPS;

/// Half-width of the band around the root of Ei (x ≈ 0.3725) where Ei is compared absolutely.
pub const EI_ROOT_BAND: f64 = 1e-3;

/// Absolute error allowed for Ei(x) inside [`EI_ROOT_BAND`] (relative accuracy there is kept
/// too in practice, but a value that passes through zero is judged absolutely). Measured:
/// 0.004 ε absolute, 1.7 ε relative.
pub const EI_ROOT_ABS_TOL: f64 = 5.0 * EPS;

/// Relative error allowed for D(x, x0) = e^(−x) [Ei(x) − Ei(x0)] against 50-digit references.
/// Measured worst case on 4566 pairs (both tiny, both huge, ulps apart, far apart, every
/// branch boundary): 2.96 ε, on the subtraction path; series and quadrature stay below 2 ε.
pub const EI_DIFF_REL_TOL: f64 = 6.0 * EPS;

/// Relative error allowed for the regularised incomplete gamma functions P(s, x) and Q(s, x)
/// against 50-digit references, in units of ε·max(1, |ln v|) for a value v: a tail value
/// far from the bulk is the exponential of a logarithm that large, whose rounding alone
/// costs ε|ln v| (the `ln_` functions have no such loss). Measured worst case on 2542 points,
/// s ∈ [1e−3, 1e4], x ∈ [1e−300, 1e8]: 3.9 for P, 6.2 for Q (s = 500, x ≈ s + ½√s).
pub const GAMMA_REL_TOL: f64 = 10.0 * EPS;

/// Relative error allowed for ln P(s, x) and ln Q(s, x) against 50-digit references (where
/// the value is close to 1, so that its logarithm is ≈ −t for the other tail t, in units of
/// ε·max(1, |ln t|) as for [`GAMMA_REL_TOL`]). Measured on the same grid: 7.5 for ln P,
/// 5.9 for ln Q, down to ln P ≈ −7·10⁶.
pub const LN_GAMMA_REL_TOL: f64 = 12.0 * EPS;

/// Relative error allowed for ln[P(s, x_hi) − P(s, x_lo)] against 50-digit references, as
/// for [`LN_GAMMA_REL_TOL`]. Measured worst case on 56 intervals (the noise model's
/// truncations and intervals around the bulk): 4.7, for ends ±0.1 σ apart at s = 150.
pub const LN_GAMMA_DIFF_REL_TOL: f64 = 8.0 * EPS;

/// Relative error allowed for the regularised incomplete beta function I_x(a, b) against
/// 50-digit references, in units of ε·max(1, |ln I|) as for [`GAMMA_REL_TOL`]. Measured worst
/// case on 1622 points (a, b ∈ [0.5, 1e4], x from 1e−10 to 1 − 1e−10, where I ≥ 1e−300):
/// 2.1.
pub const BETA_REL_TOL: f64 = 4.0 * EPS;

/// Relative error allowed for the beta quantile against 50-digit references. Measured worst
/// case on 32 points (ArviZ's quantile-MCSE parameters for effective sample sizes 10 to 5e4,
/// closed forms): 1.2.
pub const BETA_PPF_REL_TOL: f64 = 3.0 * EPS;

/// Relative error allowed for the standard normal quantile against 50-digit references.
/// Measured worst case on 112 points, p ∈ [1e−300, 1 − 2^−53]: 1.4.
pub const NORM_PPF_REL_TOL: f64 = 3.0 * EPS;

/// Relative error allowed between an imported instrument export and the file's own numbers
/// converted to SI (issue 21's target). Both sides parse the same digits with a correctly
/// rounded parser and apply the same factor, so the fixtures agree exactly in practice; the
/// margin covers a unit factor computed in another order by the oracle.
pub const IMPORT_REL_TOL: f64 = 1e-12;

/// Relative error allowed for the rate-and-state spring-slider's forces (src/law/rate_state.rs)
/// at its default tolerance against a scipy Radau reference at rtol = 1e−13, relative to the
/// force scale max(|F|, a). Measured worst case over the six reference slides: 1.57e−8 (the
/// slow first slide, aging law); the forces between solver steps come from the collocation
/// polynomial, which keeps the error from falling further.
pub const RATE_STATE_REL_TOL: f64 = 3e-8;

/// Relative error allowed for the same forces at the tolerance a fit's likelihood solves them
/// to ([`crate::law::rate_state::LIKELIHOOD_TOLERANCE`], 1e−7), on the same scale. Measured
/// worst case over the six reference slides: 1.59e−6 (the stiff machine, both laws).
pub const RATE_STATE_LIKELIHOOD_REL_TOL: f64 = 3e-6;
