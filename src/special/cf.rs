//! The one continued-fraction evaluator of the special functions, shared by the upper
//! incomplete gamma function and the incomplete beta function.

/// Lentz's stand-in for a zero denominator: small enough that it changes no value that
/// converges, large enough that its reciprocal is finite.
const TINY: f64 = 1e-300;

/// Most partial fractions evaluated. Both fractions converge in O(√(shape)) terms near their
/// distributions' bulk, a few thousand at the largest shapes met in practice; the cap only
/// stops a fraction fed non-finite terms.
const MAX_TERMS: usize = 100_000;

/// f = b₀ + a₁/(b₁ + a₂/(b₂ + …)), where `terms(j)` returns (a_j, b_j) for j = 1, 2, ….
///
/// The modified Lentz method (Thompson and Barnett 1986; Numerical Recipes §5.2) runs forward
/// until a step changes f by less than ε, which fixes the depth n at which the fraction has
/// converged to working precision; the value is then evaluated backward from depth 2n. Both
/// halves matter: the forward product of n ratios accumulates a rounding per term, and the
/// n-th convergent still differs from the limit by several ε where convergence is slow
/// (x ≈ 1 for the gamma fraction), together 20–30 ε; backward evaluation damps the rounding
/// of each inner level, and the doubled depth leaves a truncation error of order ε², so the
/// result is good to an ε or two for a well-conditioned fraction.
pub(super) fn continued_fraction(b0: f64, terms: impl Fn(usize) -> (f64, f64)) -> f64 {
    let depth = 2 * lentz_depth(b0, &terms);
    let mut tail = 0.0;
    for j in (1..=depth).rev() {
        let (a, b) = terms(j);
        tail = a / nonzero(b + tail);
    }
    b0 + tail
}

/// The number of terms after which the modified Lentz iteration stops changing the value.
fn lentz_depth(b0: f64, terms: &impl Fn(usize) -> (f64, f64)) -> usize {
    let mut c = nonzero(b0);
    let mut d = 0.0;
    for j in 1..=MAX_TERMS / 2 {
        let (a, b) = terms(j);
        d = 1.0 / nonzero(b + a * d);
        c = nonzero(b + a / c);
        if (c * d - 1.0).abs() < f64::EPSILON {
            return j;
        }
    }
    MAX_TERMS / 2
}

fn nonzero(v: f64) -> f64 {
    if v.abs() < TINY {
        TINY
    } else {
        v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOLDEN: f64 = 1.618_033_988_749_895;

    /// Fractions with closed forms: the golden ratio φ = 1 + 1/(1 + 1/(1 + …)), and
    /// tan x = x/(1 − x²/(3 − x²/(5 − …))).
    #[test]
    fn known_fractions() {
        let golden = continued_fraction(1.0, |_| (1.0, 1.0));
        assert!((golden - GOLDEN).abs() < 4.0 * f64::EPSILON);
        for x in [0.1_f64, 0.7, 1.3] {
            let tan = x / continued_fraction(1.0, |j| (-x * x, (2 * j + 1) as f64));
            assert!(
                ((tan - x.tan()) / x.tan()).abs() < 4.0 * f64::EPSILON,
                "{x}"
            );
        }
    }

    /// A zero b₀ is stepped over, not divided by: 0 + 1/(1 + 1/(1 + …)) = 1/φ.
    #[test]
    fn zero_leading_term() {
        let f = continued_fraction(0.0, |_| (1.0, 1.0));
        assert!((f - 1.0 / GOLDEN).abs() < 4.0 * f64::EPSILON);
    }
}
