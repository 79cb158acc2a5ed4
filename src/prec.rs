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
