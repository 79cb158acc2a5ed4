//! Priors of a model: the documented defaults, the names a file may set, and the lookup that
//! gives every quantity its prior.

use super::ModelSpec;
use crate::model::prior::Prior;

/// The documented, weakly informative default prior of a parameter (natural scale, SI):
/// log-uniform over many decades around anything physical, so the data decide.
pub fn default_prior(name: &str) -> Option<Prior> {
    let lu = |low, high| Some(Prior::LogUniform { low, high });
    match name {
        // 1/m: rejuvenation over 1 nm to 1 mm of sliding.
        "alpha" => lu(1e3, 1e9),
        // N: aging amplitude (rate-and-state: direct effect) from 1 µN to 10 N.
        "a" => lu(1e-6, 10.0),
        // N: rate-and-state evolution effect, as a.
        "b" => lu(1e-6, 10.0),
        // m: rate-and-state critical slip distance from 1 pm to 1 mm.
        "D_c" => lu(1e-12, 1e-3),
        // a/F_d from 1e-3 to 100.
        "a_over_F_d" => lu(1e-3, 1e2),
        // N: dynamic friction from 1 µN to 10 N.
        "F_d" => lu(1e-6, 10.0),
        // s: from 1 ns to about 3 h.
        "t0" => lu(1e-9, 1e4),
        // N/m.
        "k" => lu(1e1, 1e8),
        // N: noise from 10 nN to 1 N.
        "sigma" => lu(1e-8, 1.0),
        // Pooled t0: median of the material's t0 population (s) and sd of ln t0.
        "t0_pop_median" => Some(Prior::LogNormal {
            median: 1.0,
            sd_log: 5.0,
            low: Some(1e-9),
            high: Some(1e4),
        }),
        // Any pooled parameter: sd of its ln over the material's contacts, up to a factor e^5.
        "t0_pop_log_sd"
        | "F_d_pop_log_sd"
        | "k_pop_log_sd"
        | "a_pop_log_sd"
        | "a_over_F_d_pop_log_sd" => Some(Prior::HalfNormal {
            sd: 1.0,
            high: Some(5.0),
        }),
        // The median of a pooled F_d, k or a (a/F_d) population has the parameter's own
        // default prior ([`ModelSpec::prior`] follows a prior the file gives the parameter).
        "F_d_pop_median" => default_prior("F_d"),
        "k_pop_median" => default_prior("k"),
        "a_pop_median" => default_prior("a"),
        "a_over_F_d_pop_median" => default_prior("a_over_F_d"),
        _ => None,
    }
}

/// Names a model file may give priors for.
pub const PRIOR_NAMES: [&str; 19] = [
    "alpha",
    "a",
    "b",
    "D_c",
    "a_over_F_d",
    "F_d",
    "t0",
    "k",
    "sigma",
    "t0_pop_median",
    "t0_pop_log_sd",
    "F_d_pop_median",
    "F_d_pop_log_sd",
    "k_pop_median",
    "k_pop_log_sd",
    "a_pop_median",
    "a_pop_log_sd",
    "a_over_F_d_pop_median",
    "a_over_F_d_pop_log_sd",
];

impl ModelSpec {
    /// Prior of a named quantity: the model file's, else the default.
    pub fn prior(&self, name: &str) -> Prior {
        // The median of a pooled F_d, k or a population follows the parameter's prior.
        let follows = name
            .strip_suffix("_pop_median")
            .filter(|p| *p != "t0" && self.file.priors.contains_key(*p));
        self.file
            .priors
            .get(name)
            .cloned()
            .or_else(|| follows.map(|p| self.prior(p)))
            .or_else(|| default_prior(name))
            .unwrap_or(Prior::LogUniform {
                low: 1e-300,
                high: 1e300,
            })
    }
}
