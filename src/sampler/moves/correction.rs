//! The proposal's factor in the Metropolis–Hastings acceptance ratio.

/// What a proposal multiplies the acceptance ratio by: `q(x | y) / q(y | x)` for a walker at
/// `x` proposed to `y` (with the Jacobian of a deterministic map of `x`, as the stretch
/// move's `z^(ndim−1)`). The sampler accepts with probability `min(1, factor · π(y)/π(x))`.
///
/// The factor is kept as it is while it is a normal number, so that the acceptance test of
/// most proposals needs no logarithm; its logarithm is kept where it under- or overflows.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correction {
    /// The factor (`z^(ndim−1)` for the stretch move, 1 for a symmetric proposal).
    pub(super) factor: f64,
    /// ln factor; only read when `factor` is not normal.
    pub(super) log_factor: f64,
}

impl Correction {
    /// A symmetric proposal: `q(x | y) = q(y | x)`.
    pub const SYMMETRIC: Self = Self {
        factor: 1.0,
        log_factor: 0.0,
    };

    /// The factor `e^log_factor`, from its logarithm (`ln q(x) − ln q(y)` for an independence
    /// proposal `q`).
    pub(crate) fn from_log(log_factor: f64) -> Self {
        Self {
            factor: log_factor.exp(),
            log_factor,
        }
    }

    /// The factor `z^n`, the Jacobian of a stretch by `z` along a line in `n + 1` dimensions;
    /// computed by binary powering (`f64::powi` with a run-time exponent is a library call),
    /// its logarithm only where the power under- or overflows.
    #[inline]
    pub fn power(z: f64, n: u64) -> Self {
        let (mut x, mut k, mut factor) = (z, n, 1.0);
        while k > 0 {
            if k & 1 == 1 {
                factor *= x;
            }
            x *= x;
            k >>= 1;
        }
        let log_factor = if factor.is_normal() {
            0.0
        } else {
            n as f64 * z.ln()
        };
        Self { factor, log_factor }
    }

    /// ln of the factor.
    pub fn ln(&self) -> f64 {
        if self.factor.is_normal() {
            self.factor.ln()
        } else {
            self.log_factor
        }
    }
}
