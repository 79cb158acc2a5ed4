//! Priors on the natural (SI) scale of a parameter, evaluated on the scale it is sampled on.
//!
//! Positive parameters are sampled as u = ln θ, so the density of u carries the Jacobian:
//! ln p(u) = ln p(θ) + ln θ. A log-uniform prior is then flat in u.

use serde::{Deserialize, Serialize};

/// Log of √(2π).
const LN_SQRT_2PI: f64 = 0.918_938_533_204_672_8;

/// Draws in a row outside a truncated prior's bounds before [`Prior::sample`] gives up.
pub const MAX_REJECTIONS: usize = 10_000;

/// A prior distribution, with optional hard bounds, on a parameter's natural scale.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "dist", rename_all = "kebab-case", deny_unknown_fields)]
pub enum Prior {
    /// Uniform on [low, high].
    Uniform {
        /// Lower bound.
        low: f64,
        /// Upper bound.
        high: f64,
    },
    /// Uniform in ln θ on [low, high] (both > 0): scale-free, the weakly informative default.
    LogUniform {
        /// Lower bound (> 0).
        low: f64,
        /// Upper bound.
        high: f64,
    },
    /// Normal(mean, sd), optionally truncated to [low, high].
    Normal {
        /// Mean.
        mean: f64,
        /// Standard deviation (> 0).
        sd: f64,
        /// Optional lower bound.
        #[serde(default)]
        low: Option<f64>,
        /// Optional upper bound.
        #[serde(default)]
        high: Option<f64>,
    },
    /// ln θ ~ Normal(ln median, sd_log), optionally truncated.
    LogNormal {
        /// Median of θ (> 0).
        median: f64,
        /// Standard deviation of ln θ (> 0).
        sd_log: f64,
        /// Optional lower bound.
        #[serde(default)]
        low: Option<f64>,
        /// Optional upper bound.
        #[serde(default)]
        high: Option<f64>,
    },
    /// |Normal(0, sd)| on θ ≥ 0, optionally bounded above.
    HalfNormal {
        /// Scale (> 0).
        sd: f64,
        /// Optional upper bound.
        #[serde(default)]
        high: Option<f64>,
    },
}

impl Prior {
    /// Checks the prior's own numbers; `what` names the parameter in the message.
    ///
    /// # Errors
    /// A sentence naming the parameter and the faulty field.
    pub fn validate(&self, what: &str) -> Result<(), String> {
        let bad = |field: &str, why: &str| Err(format!("prior of {what}: {field} {why}"));
        let finite = |v: f64| v.is_finite();
        match *self {
            Self::Uniform { low, high } => {
                if !(finite(low) && finite(high) && low < high) {
                    return bad("low/high", "must be finite with low < high");
                }
            }
            Self::LogUniform { low, high } => {
                if !(finite(low) && finite(high) && low > 0.0 && low < high) {
                    return bad("low/high", "must be finite with 0 < low < high");
                }
            }
            Self::Normal {
                mean,
                sd,
                low,
                high,
            } => {
                if !finite(mean) {
                    return bad("mean", "must be finite");
                }
                if !(finite(sd) && sd > 0.0) {
                    return bad("sd", "must be finite and > 0");
                }
                if let (Some(l), Some(h)) = (low, high) {
                    if l.partial_cmp(&h) != Some(std::cmp::Ordering::Less) {
                        return bad("low/high", "need low < high");
                    }
                }
            }
            Self::LogNormal {
                median,
                sd_log,
                low,
                high,
            } => {
                if !(finite(median) && median > 0.0) {
                    return bad("median", "must be finite and > 0");
                }
                if !(finite(sd_log) && sd_log > 0.0) {
                    return bad("sd_log", "must be finite and > 0");
                }
                if let (Some(l), Some(h)) = (low, high) {
                    if l.partial_cmp(&h) != Some(std::cmp::Ordering::Less) {
                        return bad("low/high", "need low < high");
                    }
                }
            }
            Self::HalfNormal { sd, high } => {
                if !(finite(sd) && sd > 0.0) {
                    return bad("sd", "must be finite and > 0");
                }
                if high.is_some_and(|h| h.is_nan() || h <= 0.0) {
                    return bad("high", "must be > 0");
                }
            }
        }
        Ok(())
    }

    /// Whether the prior allows only θ > 0 (so the parameter can be sampled as ln θ).
    pub(crate) fn positive_support(&self) -> bool {
        match *self {
            Self::Uniform { low, .. } => low >= 0.0,
            Self::Normal { low, .. } => low.is_some_and(|l| l >= 0.0),
            Self::LogUniform { .. } | Self::LogNormal { .. } | Self::HalfNormal { .. } => true,
        }
    }

    /// Hard bounds implied by the prior.
    pub fn bounds(&self) -> (f64, f64) {
        match *self {
            Self::Uniform { low, high } | Self::LogUniform { low, high } => (low, high),
            Self::Normal { low, high, .. } | Self::LogNormal { low, high, .. } => (
                low.unwrap_or(f64::NEG_INFINITY),
                high.unwrap_or(f64::INFINITY),
            ),
            Self::HalfNormal { high, .. } => (0.0, high.unwrap_or(f64::INFINITY)),
        }
    }

    /// ln p(θ) up to a constant that does not depend on θ; −∞ outside the support.
    pub(crate) fn ln_density(&self, theta: f64) -> f64 {
        let (low, high) = self.bounds();
        if !(theta >= low && theta <= high) {
            return f64::NEG_INFINITY;
        }
        match *self {
            Self::Uniform { .. } => 0.0,
            Self::LogUniform { .. } => -theta.ln(),
            Self::Normal { mean, sd, .. } => {
                let z = (theta - mean) / sd;
                -0.5 * z * z - sd.ln() - LN_SQRT_2PI
            }
            Self::LogNormal { median, sd_log, .. } => {
                if theta <= 0.0 {
                    return f64::NEG_INFINITY;
                }
                let z = (theta / median).ln() / sd_log;
                -0.5 * z * z - theta.ln() - sd_log.ln() - LN_SQRT_2PI
            }
            Self::HalfNormal { sd, .. } => {
                let z = theta / sd;
                -0.5 * z * z - sd.ln()
            }
        }
    }

    /// Draws θ from the prior (truncation by rejection), for simulation-based calibration.
    /// `None` when [`MAX_REJECTIONS`] draws in a row fall outside the bounds (a prior whose
    /// bounds hold almost none of its mass).
    pub fn sample<R: rand::Rng + ?Sized>(&self, rng: &mut R) -> Option<f64> {
        use rand_distr::{Distribution, StandardNormal};
        let (low, high) = self.bounds();
        for _ in 0..MAX_REJECTIONS {
            let u: f64 = rng.random();
            let z: f64 = StandardNormal.sample(rng);
            let theta = match *self {
                Self::Uniform { low, high } => low + u * (high - low),
                Self::LogUniform { low, high } => (low.ln() + u * (high / low).ln()).exp(),
                Self::Normal { mean, sd, .. } => mean + sd * z,
                Self::LogNormal { median, sd_log, .. } => median * (sd_log * z).exp(),
                Self::HalfNormal { sd, .. } => (sd * z).abs(),
            };
            if theta >= low && theta <= high {
                return Some(theta);
            }
        }
        None
    }

    /// A sentence for the record, e.g. `log-uniform on [1e3, 1e9]`.
    pub fn describe(&self) -> String {
        match *self {
            Self::Uniform { low, high } => format!("uniform on [{low:e}, {high:e}]"),
            Self::LogUniform { low, high } => format!("log-uniform on [{low:e}, {high:e}]"),
            Self::Normal { mean, sd, .. } => format!("normal(mean {mean:e}, sd {sd:e})"),
            Self::LogNormal { median, sd_log, .. } => {
                format!("log-normal(median {median:e}, sd of ln {sd_log})")
            }
            Self::HalfNormal { sd, .. } => format!("half-normal(sd {sd:e})"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The density on the sampled scale u = ln θ integrates to one: checks the Jacobian.
    fn mass_on_log_scale(prior: &Prior, lo: f64, hi: f64) -> f64 {
        let n = 200_000;
        let (a, b) = (lo.ln(), hi.ln());
        let h = (b - a) / n as f64;
        (0..n)
            .map(|i| {
                let u = a + (i as f64 + 0.5) * h;
                (prior.ln_density(u.exp()) + u).exp() * h
            })
            .sum()
    }

    #[test]
    fn log_scale_densities_with_jacobian_are_normalised() {
        let ln_range = (1e9_f64 / 1e3).ln();
        let lu = Prior::LogUniform {
            low: 1e3,
            high: 1e9,
        };
        // ln_density omits the normalising constant ln(ln(high/low)).
        assert!((mass_on_log_scale(&lu, 1e3, 1e9) / ln_range - 1.0).abs() < 1e-9);
        let ln = Prior::LogNormal {
            median: 2.0,
            sd_log: 0.5,
            low: None,
            high: None,
        };
        assert!(
            (mass_on_log_scale(&ln, 2.0 * (-6.0_f64).exp(), 2.0 * 6.0_f64.exp()) - 1.0).abs()
                < 1e-6
        );
        let hn = Prior::HalfNormal {
            sd: 3.0,
            high: None,
        };
        let mass = mass_on_log_scale(&hn, 1e-12, 60.0) * (2.0 / std::f64::consts::PI).sqrt();
        assert!((mass - 1.0).abs() < 1e-6, "{mass}");
    }

    #[test]
    fn bounds_reject() {
        let p = Prior::Uniform {
            low: 0.0,
            high: 1.0,
        };
        assert!(p.ln_density(1.5).is_infinite());
        assert!(p.ln_density(f64::NAN).is_infinite());
        assert!(Prior::LogUniform {
            low: 0.0,
            high: 1.0
        }
        .validate("k")
        .unwrap_err()
        .contains("k"));
    }

    /// Draws follow the prior: the mean of ln θ and the truncation bounds match.
    #[test]
    fn samples_follow_the_prior() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let p = Prior::LogNormal {
            median: 2.0,
            sd_log: 0.5,
            low: Some(1.0),
            high: None,
        };
        let n = 20_000;
        let draws: Vec<f64> = (0..n).map(|_| p.sample(&mut rng).unwrap()).collect();
        assert!(draws.iter().all(|&d| d >= 1.0));
        // ln θ is a normal(ln 2, 0.5) truncated below at 0: mean ln 2 + 0.5 φ(a)/(1 − Φ(a)),
        // a = −ln 2 / 0.5; the Monte-Carlo error of the mean is about 0.5/√n ≈ 0.0035.
        let a = -(2.0_f64.ln()) / 0.5;
        let phi = (-0.5 * a * a).exp() / (2.0 * std::f64::consts::PI).sqrt();
        let tail = 0.5 * statrs::function::erf::erfc(a / std::f64::consts::SQRT_2);
        let expected = 2.0_f64.ln() + 0.5 * phi / tail;
        let mean = draws.iter().map(|d| d.ln()).sum::<f64>() / n as f64;
        assert!(
            (mean - expected).abs() < 5.0 * 0.5 / (n as f64).sqrt(),
            "{mean} vs {expected}"
        );
        let lu = Prior::LogUniform {
            low: 1e3,
            high: 1e9,
        };
        let mean = (0..n)
            .map(|_| lu.sample(&mut rng).unwrap().log10())
            .sum::<f64>()
            / n as f64;
        // log10 θ is uniform on [3, 9]: mean 6, sd √3.
        assert!(
            (mean - 6.0).abs() < 5.0 * 3f64.sqrt() / (n as f64).sqrt(),
            "{mean}"
        );
        let impossible = Prior::Normal {
            mean: 0.0,
            sd: 1.0,
            low: Some(50.0),
            high: None,
        };
        assert!(impossible.sample(&mut rng).is_none());
    }
}
