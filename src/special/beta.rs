//! The regularised incomplete beta function I_x(a, b) and the quantile of the beta
//! distribution (what ArviZ's quantile MCSE needs, at effective sample sizes of 10⁵ and more).
//!
//! I_x(a, b) = x^a (1 − x)^b / B(a, b) divided by the continued fraction of DiDonato and
//! Morris (TOMS 708), for x at or below the mean a/(a + b); beyond it, 1 − I_{1−x}(b, a).
//! Unlike statrs' `beta_reg` there is no cap of 140 terms: the number needed grows like
//! √max(a, b). The fraction of Numerical Recipes §6.4 is ill-conditioned for a large and b
//! small near the mean (its value is then 1/(1 − 0.9997)): 1000 ε off at a = 10⁴.
//!
//! The front x^a (1 − x)^b / B(a, b) is where accuracy is won or lost, since for large a or b
//! the log-gammas of B are each of order a ln a and cancel:
//! - both a, b ≥ 10: Stirling's form, which keeps only the small differences (as TOMS 708's
//!   `brcomp` does): a·ln1pmx(u) + b·ln1pmx(v) + ½ ln(ab/(2π(a + b))) − δ(a) − δ(b) + δ(a + b),
//!   u = (a + b)x/a − 1, v = (a + b)(1 − x)/b − 1, ln1pmx(d) = ln(1 + d) − d;
//! - one below 10: the gamma prefix of the small one at y = (a + b)x (the beta function's
//!   large-b limit) times the Stirling correction of the large one;
//! - both below 10: powers and gamma functions, which neither overflow nor cancel there.

use super::cf::continued_fraction;
use super::gamma::{gamma_below_20, ln1pmx, ln_gamma_prefix, stirling_delta, STIRLING_MIN};

/// The regularised incomplete beta function I_x(a, b) = B(x; a, b)/B(a, b) for a, b > 0:
/// 0 for x ≤ 0, 1 for x ≥ 1, NaN for NaN input or a, b outside (0, ∞).
///
/// # Accuracy
/// Against 50-digit mpmath on a, b ∈ [0.5, 10⁴] and x from 10⁻¹⁰ to 1 − 10⁻¹⁰
/// (`tests/special_gamma_beta.rs`), where I ≥ 10⁻³⁰⁰: relative error below
/// 2.1 ε·max(1, |ln I|) ([`crate::prec::BETA_REL_TOL`] allows 4), i.e. 2 ε in the bulk; far
/// in a tail I is the exponential of a large logarithm, whose rounding alone costs ε|ln I|.
pub fn beta_reg(a: f64, b: f64, x: f64) -> f64 {
    if !(a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite()) || x.is_nan() {
        return f64::NAN;
    }
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    // (a + b)x − a with one rounding. Its sign says on which side of the mean x lies, and it
    // is the λ of the fraction (of either side), which must be accurate however close to the
    // mean x is: an error of ε·a there cost 1000 ε in I for a = 10⁴.
    let excess = (a + b).mul_add(x, -a);
    let front = beta_front(a, b, x, excess);
    if excess <= 0.0 {
        front / fraction(a, b, x, 1.0 - x, -excess)
    } else {
        1.0 - front / fraction(b, a, 1.0 - x, x, excess)
    }
}

/// Quantile of the Beta(a, b) distribution at probability `q` ∈ [0, 1], by bisection on
/// [`beta_reg`] down to adjacent doubles (the CDF is monotone, so bisection cannot fail).
///
/// # Accuracy
/// The x where the computed CDF crosses q, so its error is that of [`beta_reg`] divided by
/// the density: below 1.2 ε relative on the mpmath grid (effective sample sizes 10 to 5·10⁴
/// at ArviZ's ±1σ probabilities, and closed-form cases; [`crate::prec::BETA_PPF_REL_TOL`]
/// allows 3).
pub fn beta_ppf(q: f64, a: f64, b: f64) -> f64 {
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

/// x^a (1 − x)^b / B(a, b) for 0 < x < 1 (module documentation), given
/// `excess` = (a + b)x − a: u and v below are small near the mean, and their absolute error
/// is what the front's logarithm inherits, multiplied by a or b.
fn beta_front(a: f64, b: f64, x: f64, excess: f64) -> f64 {
    let s = a + b;
    if a.min(b) >= STIRLING_MIN {
        let u = excess / a;
        let v = -excess / b;
        let ln = a * ln1pmx(u, s * x / a)
            + b * ln1pmx(v, s * (1.0 - x) / b)
            + 0.5 * (a * b / (std::f64::consts::TAU * s)).ln()
            - (stirling_delta(a) + stirling_delta(b) - stirling_delta(s));
        ln.exp()
    } else if a.max(b) >= STIRLING_MIN {
        // ln[x^a (1−x)^b/B(a, b)] = ln[y^a e^(−y)/Γ(a)] + b·ln1pmx(v) − ½ ln(1 + a/b)
        // + δ(a + b) − δ(b), y = (a + b)x, v = (a − y)/b, for the small a (and mirrored).
        let (small, large, y, v, ratio) = if a < b {
            (a, b, s * x, -excess / b, s * (1.0 - x) / b)
        } else {
            (b, a, s * (1.0 - x), excess / a, s * x / a)
        };
        let ln = ln_gamma_prefix(small, y) + large * ln1pmx(v, ratio)
            - 0.5 * (small / large).ln_1p()
            + stirling_delta(s)
            - stirling_delta(large);
        ln.exp()
    } else {
        let power_x = x.powf(a);
        // (1 − x)^b from ln(1 − x) where 1 − x would be rounded.
        let power_1mx = if x >= 0.5 {
            (1.0 - x).powf(b)
        } else {
            (b * (-x).ln_1p()).exp()
        };
        let inv_beta = gamma_below_20(s) / (gamma_below_20(a) * gamma_below_20(b));
        if power_x >= f64::MIN_POSITIVE && power_1mx >= f64::MIN_POSITIVE {
            power_x * power_1mx * inv_beta
        } else {
            (a * x.ln() + b * (-x).ln_1p() + inv_beta.ln()).exp()
        }
    }
}

/// The continued fraction of DiDonato and Morris (TOMS 708's `bfrac`, Boost's
/// `ibeta_fraction2`), I_x(a, b) = front / (b₀ + α₁/(β₁ + α₂/(β₂ + …))), for x at or below the
/// mean (λ = a − (a + b)x ≥ 0), where it converges in O(√max(a, b)) terms:
/// b₀ = a(λ + 1)/(a + 1),
/// α_m = (a + m − 1)(a + b + m − 1) m (b − m) x² / (a + 2m − 1)²,
/// β_m = m + m(b − m)x/(a + 2m − 1) + (a + m)(λ + 1 + m(1 + y))/(a + 2m + 1).
/// `y` = 1 − x is passed apart from x so that, on the mirrored side, the exact one of the two
/// is used where it matters (λ comes from the caller for the same reason).
fn fraction(a: f64, b: f64, x: f64, y: f64, lambda: f64) -> f64 {
    let b0 = a * (lambda + 1.0) / (a + 1.0);
    continued_fraction(b0, |m| {
        let m = m as f64;
        let odd = a + 2.0 * m - 1.0;
        let alpha = (a + m - 1.0) * (a + b + m - 1.0) * m * (b - m) * x * x / (odd * odd);
        let beta = m
            + m * (b - m) * x / odd
            + (a + m) * (lambda + 1.0 + m * (1.0 + y)) / (a + 2.0 * m + 1.0);
        (alpha, beta)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Stirling form and the plain log-gamma form agree where both are accurate, and
    /// the three forms agree across their switches.
    #[test]
    fn front_forms_agree() {
        for (a, b, x) in [(30.0, 45.0, 0.4), (25.0, 25.0, 0.5), (60.0, 21.0, 0.8)] {
            use statrs::function::gamma::ln_gamma;
            let plain =
                (ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b) + a * f64::ln(x) + b * f64::ln_1p(-x))
                    .exp();
            let front = beta_front(a, b, x, (a + b).mul_add(x, -a));
            assert!(((front - plain) / plain).abs() < 1e-12, "{a} {b} {x}");
        }
        let below = STIRLING_MIN * (1.0 - 1e-15);
        for (b, x) in [(10.0, 0.5), (40.0, 0.2), (1e3, 0.01)] {
            let mixed = beta_front(below, b, x, (below + b).mul_add(x, -below));
            let stirling = beta_front(
                STIRLING_MIN,
                b,
                x,
                (STIRLING_MIN + b).mul_add(x, -STIRLING_MIN),
            );
            assert!(((mixed - stirling) / stirling).abs() < 1e-12, "{b} {x}");
            let direct = beta_front(below, below, x, (2.0 * below).mul_add(x, -below));
            let mixed = beta_front(
                below,
                STIRLING_MIN,
                x,
                (below + STIRLING_MIN).mul_add(x, -below),
            );
            assert!(((direct - mixed) / mixed).abs() < 1e-12, "{x}");
        }
    }

    #[test]
    fn closed_forms_and_symmetry() {
        // I_x(1, 1) = x, I_x(a, 1) = x^a, I_x(1, b) = 1 − (1 − x)^b.
        for x in [1e-9, 0.1, 0.5, 0.9] {
            let got = beta_reg(1.0, 1.0, x);
            assert!(
                (got - x).abs() <= 2.0 * f64::EPSILON * x,
                "I_{x}(1, 1) = {got}"
            );
            let p = f64::powf(x, 2.5);
            assert!(((beta_reg(2.5, 1.0, x) - p) / p).abs() < 8.0 * f64::EPSILON);
            let p = -f64::exp_m1(30.0 * f64::ln_1p(-x));
            assert!(
                ((beta_reg(1.0, 30.0, x) - p) / p).abs() < 8.0 * f64::EPSILON,
                "{x}"
            );
        }
        // I_x(a, b) = 1 − I_{1−x}(b, a).
        for (a, b, x) in [(3.5, 200.0, 0.02), (1e4, 7.0, 0.999), (50.0, 50.0, 0.5)] {
            let sum = beta_reg(a, b, x) + beta_reg(b, a, 1.0 - x);
            assert!((sum - 1.0).abs() < 1e-14, "{a} {b} {x}");
        }
        assert!(beta_reg(0.0, 1.0, 0.5).is_nan() && beta_reg(1.0, 1.0, f64::NAN).is_nan());
        assert!(beta_reg(2.0, 3.0, 0.0).abs() < f64::MIN_POSITIVE);
        assert!((beta_reg(2.0, 3.0, 1.0) - 1.0).abs() < f64::MIN_POSITIVE);
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
