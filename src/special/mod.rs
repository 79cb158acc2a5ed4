//! The special functions of the crate, to (nearly) full double precision, with no allocation
//! and no dependence on the rest of the crate: x, s, a, b are plain dimensionless numbers.
//!
//! The exponential integral, for the friction law:
//! - [`ei`]: Ei(x) = −PV∫_{−x}^{∞} e^(−t)/t dt.
//! - [`ei_scaled`]: S(x) = e^(−x) Ei(x), finite for every finite x > 0.
//! - [`ei_scaled_diff`] and [`ScaledEiDiff`]: D(x, x0) = e^(−x) [Ei(x) − Ei(x0)] for
//!   0 < x0 ≤ x, formed without cancellation, which is what the law
//!   F = a D(αvτ, αvt0) + F_d (1 − e^(−αvτ)) evaluates.
//!
//! Ei and S come from published rational minimax fits (see `fits`); the root of Ei at
//! x ≈ 0.3725 is carried explicitly, so even there the error is a few ε relative.
//! Accuracy against 50-digit mpmath references (`tests/special.rs`,
//! `tests/reference/make_ei_reference.py`) is stated in [`crate::prec`].
//!
//! The regularised incomplete gamma function, for the noise level σ integrated out of the
//! likelihood under a log-uniform prior:
//! - [`gamma_p`], [`gamma_q`]: P(s, x) and Q(s, x) = 1 − P(s, x), each without cancellation.
//! - [`ln_gamma_p`], [`ln_gamma_q`]: their logarithms, finite however deep in the tails.
//! - [`ln_gamma_p_diff`]: ln[P(s, x_hi) − P(s, x_lo)], the log mass of an interval.
//!
//! For ArviZ's diagnostics: [`norm_ppf`] (rank normalisation), and [`beta_reg`] and
//! [`beta_ppf`], the regularised incomplete beta function and its quantile (the MCSE of a
//! quantile). The upper incomplete gamma function and the incomplete beta function share one
//! continued-fraction evaluator (`cf`). Their accuracy against 50-digit mpmath
//! (`tests/special_gamma_beta.rs`, `tests/reference/make_special_reference.py`) is stated in
//! each function's documentation and in [`crate::prec`].
//!
//! ```
//! use slipbayes::special::{ei, ei_scaled, ei_scaled_diff, ScaledEiDiff};
//! assert!((ei(1.0) - 1.895_117_816_355_936_8).abs() < 1e-15);
//! assert!((ei_scaled(1e12) * 1e12 - 1.000_000_000_001).abs() < 1e-15);
//! // Pure logarithmic aging as αv → 0: D(αvτ, αvt0) → ln(τ/t0).
//! let d = ei_scaled_diff(1e-12 * 1e8, 1e-12 * 1e-3);
//! assert!((d / (1e11f64).ln() - 1.0).abs() < 1e-3);
//! let prepared = ScaledEiDiff::new(1e-15);
//! assert_eq!(prepared.eval(1e-4).to_bits(), ei_scaled_diff(1e-4, 1e-15).to_bits());
//! ```
//!
//! ```
//! use slipbayes::special::{beta_ppf, gamma_p, gamma_q, ln_gamma_q, norm_ppf};
//! // P(1, x) = 1 − e^(−x); Q far in the upper tail, where it underflows, in log space.
//! assert!((gamma_p(1.0, 2.0) - (1.0 - (-2.0f64).exp())).abs() < 1e-15);
//! assert!(gamma_q(10.0, 2000.0) < f64::MIN_POSITIVE && ln_gamma_q(10.0, 2000.0) < -1900.0);
//! assert!((norm_ppf(0.975) - 1.959_963_984_540_054).abs() < 1e-14);
//! assert!((beta_ppf(0.5, 3.0, 3.0) - 0.5).abs() < 1e-15);
//! ```

mod beta;
mod cf;
mod diff;
mod fits;
mod gamma;
pub(crate) mod lanes;
mod normal;

pub use beta::{beta_ppf, beta_reg};
pub use diff::{ei_scaled_diff, ScaledEiDiff};
pub(crate) use diff::{in_series_apart, in_series_close, in_subtraction};
pub use gamma::{gamma_p, gamma_q, ln_gamma_p, ln_gamma_p_diff, ln_gamma_q};
pub use normal::norm_ppf;

/// Ei(x) for x > 0: −∞ at 0, +∞ past its overflow point (x ≈ 716.35), NaN for x < 0 or NaN.
///
/// # Formula
/// Rational fits: Ei(x) = ln(x/r) + (x − r) R(x) on (0, 6] (r the root of Ei), and
/// Ei(x) = e^x g(x) + x beyond, with g a rational fit of e^(−x)(Ei(x) − x).
#[inline]
pub fn ei(x: f64) -> f64 {
    if x > 6.0 {
        fits::ei_large(x)
    } else if x > 0.0 {
        fits::ei_small(x)
    } else if x < 0.0 || x.is_nan() {
        f64::NAN
    } else {
        f64::NEG_INFINITY
    }
}

/// S(x) = e^(−x) Ei(x) for x > 0; finite for all finite x > 0, S(∞) = 0, S(0) = −∞, NaN for
/// x < 0 or NaN. For large x, S(x) ≈ (1/x)(1 + 1/x + 2/x² + …): no e^x is ever formed.
#[inline]
pub fn ei_scaled(x: f64) -> f64 {
    if x > 6.0 {
        let g = fits::g_large(x);
        if x < fits::X_DROP_EXP {
            g + x * (-x).exp()
        } else {
            g
        }
    } else if x > 0.0 {
        (-x).exp() * fits::ei_small(x)
    } else if x < 0.0 || x.is_nan() {
        f64::NAN
    } else {
        f64::NEG_INFINITY
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn root_is_a_sign_change() {
        let r = fits::ROOT;
        assert!(ei(r * (1.0 - 1e-15)) < 0.0 && ei(r * (1.0 + 1e-15)) > 0.0);
    }

    #[test]
    fn limits_and_domain() {
        assert!(ei(0.0).is_infinite() && ei(0.0) < 0.0);
        assert!(ei(-1.0).is_nan() && ei(f64::NAN).is_nan());
        assert!(ei(f64::INFINITY).is_infinite());
        assert!(ei(717.0).is_infinite() && ei(716.0).is_finite());
        assert!(ei_scaled(f64::INFINITY).abs() < f64::MIN_POSITIVE);
        assert!(ei_scaled(-1.0).is_nan() && ei_scaled(f64::NAN).is_nan());
    }
}
