//! The two special functions the ArviZ diagnostics need: the standard normal quantile (for
//! rank normalisation) and the beta quantile (for the MCSE of a quantile).

use statrs::function::{erf::erfc_inv, gamma::ln_gamma};

/// Standard normal quantile, `Phi^{-1}(p)` for `p` in (0, 1).
///
/// `-sqrt(2) erfc^{-1}(2p)`; statrs' `erfc_inv` is Boost's rational approximation, accurate
/// to a few ulps, as scipy's `ndtri` is.
pub(crate) fn norm_ppf(p: f64) -> f64 {
    -std::f64::consts::SQRT_2 * erfc_inv(2.0 * p)
}

/// Regularised incomplete beta `I_x(a, b)` by the continued fraction (modified Lentz),
/// evaluated on the side where it converges fast. Unlike statrs' `beta_reg` there is no cap
/// of 140 terms: the number needed grows like `sqrt(max(a, b))`, and `a`, `b` here are
/// effective sample sizes that reach 10^5 and more.
fn beta_reg(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    let ln_front = ln_beta_front(a, b, x);
    if x < (a + 1.0) / (a + b + 2.0) {
        ln_front.exp() * beta_cf(a, b, x) / a
    } else {
        1.0 - ln_front.exp() * beta_cf(b, a, 1.0 - x) / b
    }
}

/// Stirling remainder `ln Gamma(z) - [(z - 1/2) ln z - z + ln(2 pi)/2]`, for `z >= 20`
/// (the first omitted term is below 2e-15).
fn stirling_delta(z: f64) -> f64 {
    let r = 1.0 / z;
    let r2 = r * r;
    r * (1.0 / 12.0 - r2 * (1.0 / 360.0 - r2 * (1.0 / 1260.0 - r2 / 1680.0)))
}

/// `ln[x^a (1 - x)^b / B(a, b)]`. For large `a`, `b` the log-gammas are each of order
/// `a ln a` and cancel; the Stirling form keeps only the small differences (as TOMS 708's
/// `brcomp` does), which matters for the beta quantiles of effective sample sizes.
fn ln_beta_front(a: f64, b: f64, x: f64) -> f64 {
    const LARGE: f64 = 20.0;
    if a < LARGE || b < LARGE {
        return ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * x.ln() + b * (-x).ln_1p();
    }
    let s = a + b;
    let u = (s * x - a) / a; // x / (a / s) - 1
    let v = (a - s * x) / b; // (1 - x) / (b / s) - 1
    a * u.ln_1p() + b * v.ln_1p() + 0.5 * (a * b / s).ln()
        - 0.5 * (2.0 * std::f64::consts::PI).ln()
        - (stirling_delta(a) + stirling_delta(b) - stirling_delta(s))
}

/// The continued fraction of the incomplete beta function (Numerical Recipes `betacf`).
fn beta_cf(a: f64, b: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    const MAX_TERMS: usize = 100_000;
    let qab = a + b;
    let qap = a + 1.0;
    let qam = a - 1.0;
    let mut c = 1.0;
    let mut d = 1.0 - qab * x / qap;
    if d.abs() < TINY {
        d = TINY;
    }
    d = 1.0 / d;
    let mut h = d;
    for m in 1..=MAX_TERMS {
        let m = m as f64;
        let m2 = 2.0 * m;
        let aa = m * (b - m) * x / ((qam + m2) * (a + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        h *= d * c;
        let aa = -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2));
        d = 1.0 + aa * d;
        if d.abs() < TINY {
            d = TINY;
        }
        c = 1.0 + aa / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let del = d * c;
        h *= del;
        if (del - 1.0).abs() < f64::EPSILON {
            break;
        }
    }
    h
}

/// Quantile of the Beta(a, b) distribution at probability `q`, by bisection on the CDF down
/// to adjacent floats (the CDF is monotone, so bisection cannot fail).
pub(crate) fn beta_ppf(q: f64, a: f64, b: f64) -> f64 {
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    for _ in 0..1100 {
        let mid = 0.5 * (lo + hi);
        if mid <= lo || mid >= hi {
            break;
        }
        if beta_reg(a, b, mid) < q {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn norm_ppf_known_values() {
        // Phi^{-1}(0.975) and Phi^{-1}(0.8413447460685429) = 1 (mpmath).
        assert!((norm_ppf(0.975) - 1.959_963_984_540_054).abs() < 1e-14);
        assert!((norm_ppf(0.841_344_746_068_542_9) - 1.0).abs() < 1e-14);
        assert!(norm_ppf(0.5).abs() < 1e-15);
        assert!((norm_ppf(0.025) + norm_ppf(0.975)).abs() < 1e-14);
    }

    /// The Stirling form and the plain log-gamma form agree where both are accurate.
    #[test]
    fn beta_front_forms_agree() {
        for (a, b, x) in [(30.0, 45.0, 0.4), (25.0, 25.0, 0.5), (60.0, 21.0, 0.8)] {
            let plain =
                ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * f64::ln(x) + b * f64::ln_1p(-x);
            assert!(
                (ln_beta_front(a, b, x) - plain).abs() < 1e-12,
                "{a} {b} {x}"
            );
        }
    }

    #[test]
    fn beta_ppf_inverts_closed_forms() {
        // Beta(1, 1) is uniform; Beta(2, 1) has CDF x^2; Beta(1, 3) has CDF 1 - (1 - x)^3.
        assert!((beta_ppf(0.3, 1.0, 1.0) - 0.3).abs() < 1e-14);
        assert!((beta_ppf(0.25, 2.0, 1.0) - 0.5).abs() < 1e-14);
        let x = 1.0 - (1.0_f64 - 0.6).cbrt();
        assert!((beta_ppf(0.6, 1.0, 3.0) - x).abs() < 1e-14);
        // Large parameters converge (statrs' 140-term cap would not): the median of
        // Beta(a, a) is 1/2 by symmetry.
        let med = beta_ppf(0.5, 2.0e5, 2.0e5);
        assert!((med - 0.5).abs() < 1e-12, "{med}");
    }
}
