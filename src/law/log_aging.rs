//! Pure logarithmic aging: the α → 0 limit of the aging–rejuvenation law.
//!
//! With no rejuvenation, `dF/dτ = a/τ` and, for τ ≥ t0,
//!
//! ```text
//! F(τ) = a ln(τ/t0),
//! ```
//!
//! and F = 0 before t0. The F_d term of the full law, F_d (1 − e^(−αvτ)), vanishes in this
//! limit, so F_d is not a parameter of this law. F grows without bound and has no interior
//! peak. Evaluating the full [`Law`](super::Law) at a tiny αv gives this only up to relative
//! corrections of order αvτ; this evaluation is exact to rounding.

use super::{non_negative, positive, LawError};

/// F(τ) = a ln(τ/t0) in interface time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LogAging {
    a: f64,
    t0: f64,
}

impl LogAging {
    /// The law with aging amplitude `a_n` (N) and cut-off `t0_s` (s).
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] when a < 0, t0 ≤ 0 or either is not finite.
    pub fn new(a_n: f64, t0_s: f64) -> Result<Self, LawError> {
        Ok(Self {
            a: non_negative("a", a_n)?,
            t0: positive("t0", t0_s)?,
        })
    }

    /// a (N).
    pub fn a(&self) -> f64 {
        self.a
    }

    /// t0 (s).
    pub fn t0(&self) -> f64 {
        self.t0
    }

    /// F(τ) and dF/dτ (0 before t0).
    ///
    /// # Formula
    /// F = a ln(1 + (τ − t0)/t0): τ − t0 is exact within a factor 2 of t0 and `ln_1p` keeps
    /// the digits of a small logarithm, so F is accurate to a few ulps right from t0.
    #[inline]
    pub fn force_and_rate(&self, tau: f64) -> (f64, f64) {
        if tau < self.t0 {
            return (0.0, 0.0);
        }
        (self.a * ((tau - self.t0) / self.t0).ln_1p(), self.a / tau)
    }

    /// F(τ) in newtons.
    #[inline]
    pub fn force(&self, tau: f64) -> f64 {
        self.force_and_rate(tau).0
    }
}
