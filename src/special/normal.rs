//! The standard normal quantile.

use statrs::function::erf::erfc_inv;

/// Standard normal quantile Φ⁻¹(p) for p in (0, 1); −∞ for p ≤ 0, +∞ for p ≥ 1, NaN for NaN.
///
/// −√2 erfc⁻¹(2p), with statrs' `erfc_inv` (Boost's rational approximations, as scipy's
/// `ndtri` is accurate to a few ulps): 2p is exact, so nothing is lost for p near 0, and
/// for p near 1 the input 2 − 2p reaches the approximation without rounding either.
///
/// # Accuracy
/// Against 50-digit mpmath on p from 10⁻³⁰⁰ to 1 − 2⁻⁵³ (`tests/special_gamma_beta.rs`):
/// relative error below 1.4 ε ([`crate::prec::NORM_PPF_REL_TOL`] allows 3).
pub fn norm_ppf(p: f64) -> f64 {
    -std::f64::consts::SQRT_2 * erfc_inv(2.0 * p)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn norm_ppf_known_values() {
        // Φ⁻¹(0.975) and Φ⁻¹(0.8413447460685429) = 1 (mpmath).
        assert!((norm_ppf(0.975) - 1.959_963_984_540_054).abs() < 1e-14);
        assert!((norm_ppf(0.841_344_746_068_542_9) - 1.0).abs() < 1e-14);
        assert!(norm_ppf(0.5).abs() < 1e-15);
        assert!((norm_ppf(0.025) + norm_ppf(0.975)).abs() < 1e-14);
    }
}
