//! The static friction peak (docs/model.md §6) and the steepest weakening on a path.
//!
//! With a > 0 the law has exactly one interior maximum: at any stationary point
//! d²F/dτ² = −a/τ² < 0, so every stationary point is a maximum and there can be only one.
//! dF/dτ is positive and decreasing before it, so the peak is found by doubling τ from t0 until
//! dF/dτ changes sign, then refining on that bracket. Likewise dF/dτ has a single minimum after
//! the peak (where d²F/dτ² = 0, d³F/dτ³ = 2a/τ³ > 0), which decides stick-slip.

use super::root::increasing_root;
use super::Law;

/// The peak of F(τ).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Peak {
    /// Interface time of the peak, τ_peak (s).
    pub tau_s: f64,
    /// Peak force, F_peak (N).
    pub force_n: f64,
}

impl Peak {
    /// Slip distance at the peak, s_peak = v τ_peak (m).
    pub fn slip_m(&self, velocity_m_per_s: f64) -> f64 {
        velocity_m_per_s * self.tau_s
    }

    /// Instrument time of the peak, t_peak = τ_peak + F_peak/(kv) (s); `kv = None` for a stiff
    /// slide.
    pub fn observed_time_s(&self, kv: Option<f64>) -> f64 {
        match kv {
            Some(kv) => self.tau_s + self.force_n / kv,
            None => self.tau_s,
        }
    }
}

/// Whether the law has an interior peak.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub enum PeakOutcome {
    /// The unique maximum of F.
    Interior(Peak),
    /// a = 0 (F rises monotonically to F_d), or pure logarithmic aging (F rises for ever):
    /// there is no interior peak.
    NoInteriorPeak,
}

impl PeakOutcome {
    /// The peak, if there is one.
    pub fn interior(self) -> Option<Peak> {
        match self {
            Self::Interior(p) => Some(p),
            Self::NoInteriorPeak => None,
        }
    }
}

impl Law {
    /// The peak of F(τ): where a/τ = αv (F − F_d).
    pub fn peak(&self) -> PeakOutcome {
        match self.peak_bracket() {
            Some((lo, hi)) => {
                // −dF/dτ increases through zero at the peak; its slope is −d²F/dτ².
                let root = increasing_root(
                    |tau| {
                        let r = self.rate(tau);
                        (-r, -self.curvature(tau, r))
                    },
                    lo,
                    hi,
                    lo + 0.5 * (hi - lo),
                );
                match root {
                    Some(root) => {
                        let tau = root;
                        PeakOutcome::Interior(Peak {
                            tau_s: tau,
                            force_n: self.force(tau),
                        })
                    }
                    None => PeakOutcome::NoInteriorPeak,
                }
            }
            None => PeakOutcome::NoInteriorPeak,
        }
    }

    /// A bracket [lo, hi] with dF/dτ(lo) > 0 ≥ dF/dτ(hi), or `None` when there is no peak.
    fn peak_bracket(&self) -> Option<(f64, f64)> {
        // With a = 0, dF/dτ = αv F_d e^(−x) > 0 everywhere.
        if self.a() <= 0.0 {
            return None;
        }
        let mut lo = self.t0();
        let mut hi = 2.0 * lo;
        while self.rate(hi) > 0.0 {
            lo = hi;
            hi *= 2.0;
            if !hi.is_finite() {
                return None;
            }
        }
        Some((lo, hi))
    }

    /// The most negative dF/dτ on [t0, τ_end], and where it occurs.
    pub fn min_rate_up_to(&self, tau_end: f64) -> (f64, f64) {
        let at_end = (tau_end, self.rate(tau_end));
        let Some(peak) = self.peak().interior() else {
            return at_end;
        };
        // Before the peak dF/dτ is still falling; after it, it falls until the inflection.
        if tau_end <= peak.tau_s || self.curvature(tau_end, at_end.1) <= 0.0 {
            return at_end;
        }
        let root = increasing_root(
            |tau| {
                let r = self.rate(tau);
                let c = self.curvature(tau, r);
                // d³F/dτ³ = 2a/τ³ − αv d²F/dτ².
                (c, 2.0 * self.a() / (tau * tau * tau) - self.alpha_v() * c)
            },
            peak.tau_s,
            tau_end,
            peak.tau_s * 1.5,
        );
        match root {
            Some(root) => (root, self.rate(root)),
            None => at_end,
        }
    }
}
