//! The verdict on convergence: the thresholds, and one typed list of the reasons not to trust
//! a run. The sampler, the fit's summary and the report all judge with these and print these;
//! none re-judges with rules of its own.

use serde::{Deserialize, Serialize};

use super::summary::Summary;

/// Largest R̂ between ensembles of a converged quantity (ArviZ's threshold).
pub const RHAT_MAX: f64 = 1.01;
/// Smallest bulk and tail ESS of a converged quantity (ArviZ's threshold).
pub const ESS_MIN: f64 = 400.0;
/// The precision asked of τ, as emcee's `tol`: chains longer than this many autocorrelation
/// times on [`TAU_REFERENCE_WALKERS`](super::TAU_REFERENCE_WALKERS) walkers, or as many
/// walker-steps per τ pooled over any number of walkers
/// ([`tau_trusted_length`](super::tau_trusted_length)).
pub const TAU_FACTOR: f64 = 50.0;
/// Acceptance fraction below which a walker is reported as stuck.
pub const STUCK_ACCEPTANCE: f64 = 0.01;
/// Steps before stuck walkers are reported (earlier, a low fraction is noise).
pub const STUCK_MIN_STEPS: u64 = 100;

/// Which effective sample size.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum EssKind {
    /// Of the rank-normalised draws (the bulk of the distribution).
    Bulk,
    /// The smaller of the 5 % and 95 % quantile ESS.
    Tail,
}

impl EssKind {
    /// `"bulk"` or `"tail"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Bulk => "bulk",
            Self::Tail => "tail",
        }
    }
}

/// One reason not to trust a run's draws. Per-quantity problems name the quantity
/// (`name[group]`); the others concern the whole run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Problem {
    /// R̂ between ensembles at or above [`RHAT_MAX`]: the ensembles disagree.
    RHat {
        /// The quantity.
        quantity: String,
        /// Its R̂.
        r_hat: f64,
    },
    /// R̂ undefined although there are several ensembles: every draw is equal.
    RHatUndefined {
        /// The quantity.
        quantity: String,
    },
    /// R̂ between ensembles could not be computed for the run (too few draws after burn-in).
    RHatNotComputed,
    /// One ensemble only: nothing independent to compare.
    SingleEnsemble,
    /// An effective sample size at or below [`ESS_MIN`].
    Ess {
        /// The quantity.
        quantity: String,
        /// Bulk or tail.
        which: EssKind,
        /// The ESS.
        ess: f64,
    },
    /// The quantity's autocorrelation time cannot be trusted (fewer post-burn-in steps per
    /// walker than [`tau_trusted_length`](super::tau_trusted_length) τ).
    TauUnreliable {
        /// The quantity.
        quantity: String,
        /// τ in steps.
        tau: f64,
    },
    /// The quantity's autocorrelation time is undefined: a walker never moved.
    TauUndefined {
        /// The quantity.
        quantity: String,
    },
    /// The chains are shorter than [`tau_trusted_length`](super::tau_trusted_length)
    /// τ_max: τ, and the burn-in taken from it, cannot be trusted.
    ChainsTooShort {
        /// Steps in the chains.
        steps: u64,
        /// The longest autocorrelation time (steps).
        tau_max: f64,
        /// The steps, burn-in included, that τ_max needs to be trusted over this many walkers
        /// (0 in summaries written before it was recorded).
        #[serde(default)]
        needed: u64,
    },
    /// No autocorrelation time could be estimated at all.
    NoAutocorrelationTime {
        /// Steps in the chains.
        steps: u64,
    },
    /// The burn-in of a τ_max that is not trusted was more than half the run and was cut to
    /// half.
    BurnInCapped {
        /// The burn-in asked for (steps).
        burn_in: u64,
        /// The burn-in used (steps).
        used: u64,
    },
    /// Walkers that accepted less than [`STUCK_ACCEPTANCE`] of their proposals.
    StuckWalkers {
        /// The ensemble.
        ensemble: usize,
        /// How many of its walkers.
        walkers: usize,
    },
}

impl Problem {
    /// The quantity a per-quantity problem names; `None` for problems of the whole run.
    pub fn quantity(&self) -> Option<&str> {
        match self {
            Self::RHat { quantity, .. }
            | Self::RHatUndefined { quantity }
            | Self::Ess { quantity, .. }
            | Self::TauUnreliable { quantity, .. }
            | Self::TauUndefined { quantity } => Some(quantity),
            _ => None,
        }
    }
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::RHat { quantity, r_hat } => write!(
                f,
                "{quantity}: R-hat {r_hat:.3} ≥ {RHAT_MAX} (the ensembles disagree: not mixed or multimodal)"
            ),
            Self::RHatUndefined { quantity } => write!(
                f,
                "{quantity}: R-hat undefined (every draw is equal: a stuck or constant quantity)"
            ),
            Self::RHatNotComputed => write!(
                f,
                "R-hat between ensembles could not be computed (too few draws after burn-in); run longer"
            ),
            Self::SingleEnsemble => write!(
                f,
                "only 1 ensemble: R-hat between independent ensembles cannot be computed; run at least 2"
            ),
            Self::Ess {
                quantity,
                which,
                ess,
            } => write!(
                f,
                "{quantity}: ESS {} {ess:.0} < {ESS_MIN:.0}",
                which.as_str()
            ),
            Self::TauUnreliable { quantity, tau } => write!(
                f,
                "{quantity}: autocorrelation time {tau:.1} steps is unreliable (too few post-burn-in steps per walker for its precision); run longer"
            ),
            Self::TauUndefined { quantity } => write!(
                f,
                "{quantity}: autocorrelation time undefined (a walker never moved)"
            ),
            Self::ChainsTooShort {
                steps,
                tau_max,
                needed,
            } => write!(
                f,
                "τ_max {tau_max:.1} steps needs {needed} steps of chains to be trusted, burn-in included, and they have {steps}: the autocorrelation time, and the burn-in taken from it, are unreliable; run longer"
            ),
            Self::NoAutocorrelationTime { steps } => write!(
                f,
                "no autocorrelation time could be estimated from {steps} steps (too short, or a stuck parameter); run longer"
            ),
            Self::BurnInCapped { burn_in, used } => write!(
                f,
                "burn-in of 2 τ_max = {burn_in} steps is more than half the run; discarded only the first {used} steps"
            ),
            Self::StuckWalkers { ensemble, walkers } => write!(
                f,
                "{walkers} walker(s) of ensemble {ensemble} accepted less than {:.0}% of proposals (stuck)",
                100.0 * STUCK_ACCEPTANCE
            ),
        }
    }
}

/// The problems of a run of `steps` steps (the first `burn_in` discarded) in a few lines: one
/// per kind of problem, naming the quantities it affects and, where it can be estimated, the
/// length of run that would fix it (ESS grows in proportion to the post-burn-in draws; τ needs
/// [`tau_trusted_length`](super::tau_trusted_length) τ of them over `walkers` walkers in all).
pub fn problem_lines(
    problems: &[Problem],
    steps: u64,
    burn_in: u64,
    walkers: usize,
) -> Vec<String> {
    let kept = steps.saturating_sub(burn_in).max(1) as f64;
    let listed = |v: &[&str]| {
        const SHOWN: usize = 6;
        let mut text = v[..v.len().min(SHOWN)].join(", ");
        if v.len() > SHOWN {
            text.push_str(&format!(" and {} more", v.len() - SHOWN));
        }
        let n = v.len();
        let count = if n == 1 {
            "1 quantity".to_owned()
        } else {
            format!("{n} quantities")
        };
        format!("{count}: {text}")
    };
    // Run-level problems as they are.
    let mut lines: Vec<String> = problems
        .iter()
        .filter(|p| p.quantity().is_none())
        .map(ToString::to_string)
        .collect();
    let (r_hat, worst) = of_kind(problems, f64::max, |p| match p {
        Problem::RHat { r_hat, .. } => Some(*r_hat),
        Problem::RHatUndefined { .. } => Some(f64::NAN),
        _ => None,
    });
    if !r_hat.is_empty() {
        lines.push(format!(
            "R-hat ≥ {RHAT_MAX} (worst {worst:.4}) for {}; the ensembles disagree, run longer or look for several modes",
            listed(&r_hat)
        ));
    }
    let (ess, lowest) = of_kind(problems, f64::min, |p| match p {
        Problem::Ess { ess, .. } => Some(*ess),
        _ => None,
    });
    if !ess.is_empty() {
        // ESS grows in proportion to the post-burn-in draws.
        let need = if lowest.is_finite() && lowest > 0.0 {
            let steps_needed = steps_for_ess(burn_in, kept, lowest);
            format!(
                "; about {:.0} steps would reach ESS {ESS_MIN:.0}",
                steps_needed.ceil()
            )
        } else {
            String::new()
        };
        lines.push(format!(
            "ESS ≤ {ESS_MIN:.0} (lowest {lowest:.0}) for {}{need}",
            listed(&ess)
        ));
    }
    let (tau, longest) = of_kind(problems, f64::max, |p| match p {
        Problem::TauUnreliable { tau, .. } => Some(*tau),
        _ => None,
    });
    if !tau.is_empty() {
        let length = super::tau_trusted_length(walkers, TAU_FACTOR);
        lines.push(format!(
            "autocorrelation time not yet trusted (longest τ = {longest:.0} steps, fewer than {length:.1} τ of post-burn-in steps) for {}; about {:.0} steps would do",
            listed(&tau),
            steps_for_tau(burn_in, walkers, longest).ceil()
        ));
    }
    let (undefined, _) = of_kind(problems, f64::max, |p| {
        matches!(p, Problem::TauUndefined { .. }).then_some(f64::NAN)
    });
    if !undefined.is_empty() {
        lines.push(format!(
            "autocorrelation time undefined (a walker never moved) for {}",
            listed(&undefined)
        ));
    }
    lines
}

/// The run length, burn-in included, at which an ESS of `ess` over `kept` post-burn-in steps
/// reaches [`ESS_MIN`]: ESS grows in proportion to the post-burn-in draws.
fn steps_for_ess(burn_in: u64, kept: f64, ess: f64) -> f64 {
    burn_in as f64 + kept * ESS_MIN / ess
}

/// The run length, burn-in included, at which a τ of `tau` steps is trusted over `walkers`
/// walkers in all ([`tau_trusted_length`](super::tau_trusted_length) τ after the burn-in).
fn steps_for_tau(burn_in: u64, walkers: usize, tau: f64) -> f64 {
    burn_in as f64 + super::tau_trusted_length(walkers, TAU_FACTOR) * tau
}

impl Problem {
    /// The run length, burn-in included, at which this problem would pass, for a run whose
    /// first `burn_in` of `steps` steps are discarded, over `walkers` walkers in all; `None`
    /// where the problem does not say (an R̂, stuck walkers, no τ at all). The same estimate
    /// [`problem_lines`] shows.
    pub fn steps_needed(&self, steps: u64, burn_in: u64, walkers: usize) -> Option<f64> {
        let kept = steps.saturating_sub(burn_in).max(1) as f64;
        match self {
            Self::TauUnreliable { tau, .. } => Some(steps_for_tau(burn_in, walkers, *tau)),
            Self::ChainsTooShort { needed, .. } if *needed > 0 => Some(*needed as f64),
            Self::Ess { ess, .. } if *ess > 0.0 => Some(steps_for_ess(burn_in, kept, *ess)),
            _ => None,
        }
    }
}

/// The quantities named by the problems `value` picks (each once, in order), and the
/// extreme (`f64::max` or `f64::min`, which skip NaN) of the values it picks them with.
fn of_kind(
    problems: &[Problem],
    extreme: fn(f64, f64) -> f64,
    value: impl Fn(&Problem) -> Option<f64>,
) -> (Vec<&str>, f64) {
    let mut names: Vec<&str> = Vec::new();
    let mut out = f64::NAN;
    for p in problems {
        if let (Some(v), Some(q)) = (value(p), p.quantity()) {
            if !names.contains(&q) {
                names.push(q);
            }
            out = extreme(out, v);
        }
    }
    (names, out)
}

/// Every convergence problem of one quantity's summary: R̂ (with two or more ensembles), bulk
/// and tail ESS, and its autocorrelation time.
pub fn quantity_problems(quantity: &str, s: &Summary, ensembles: usize) -> Vec<Problem> {
    let mut out = Vec::new();
    let quantity = || quantity.to_owned();
    match s.r_hat {
        Some(r) if r < RHAT_MAX => {}
        Some(r) => out.push(Problem::RHat {
            quantity: quantity(),
            r_hat: r,
        }),
        None if ensembles >= 2 => out.push(Problem::RHatUndefined {
            quantity: quantity(),
        }),
        None => {}
    }
    for (which, ess) in [(EssKind::Bulk, s.ess_bulk), (EssKind::Tail, s.ess_tail)] {
        if ess.is_nan() || ess <= ESS_MIN {
            out.push(Problem::Ess {
                quantity: quantity(),
                which,
                ess,
            });
        }
    }
    match (s.tau, s.tau_reliable) {
        (Some(_), Some(true)) => {}
        (Some(tau), _) => out.push(Problem::TauUnreliable {
            quantity: quantity(),
            tau,
        }),
        (None, _) => out.push(Problem::TauUndefined {
            quantity: quantity(),
        }),
    }
    out
}

/// A [`Problem::StuckWalkers`] for each ensemble with walkers that accepted less than
/// [`STUCK_ACCEPTANCE`] of their proposals (`acceptance[ensemble][walker]`), once the run has
/// at least [`STUCK_MIN_STEPS`] steps.
pub(crate) fn stuck_walkers<'a>(
    acceptance: impl IntoIterator<Item = &'a [f64]>,
    steps: u64,
) -> Vec<Problem> {
    if steps < STUCK_MIN_STEPS {
        return Vec::new();
    }
    acceptance
        .into_iter()
        .enumerate()
        .filter_map(|(ensemble, walkers)| {
            let stuck = walkers.iter().filter(|&&a| a < STUCK_ACCEPTANCE).count();
            (stuck > 0).then_some(Problem::StuckWalkers {
                ensemble,
                walkers: stuck,
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn summary(r_hat: Option<f64>, ess_bulk: f64, ess_tail: f64, tau: Option<f64>) -> Summary {
        Summary {
            mean: 0.0,
            sd: 1.0,
            median: 0.0,
            ci_low: -2.0,
            ci_high: 2.0,
            ci_prob: 0.95,
            hdi_low: -2.0,
            hdi_high: 2.0,
            hdi_prob: 0.95,
            ess_bulk,
            ess_tail,
            r_hat,
            mcse_mean: 0.01,
            mcse_sd: 0.01,
            ess_mean: ess_bulk,
            tau,
            tau_reliable: tau.map(|t| t < 10.0),
        }
    }

    #[test]
    fn a_quantity_passes_only_every_threshold() {
        assert!(
            quantity_problems("x", &summary(Some(1.005), 800.0, 900.0, Some(2.0)), 4).is_empty()
        );
        let p = quantity_problems("x", &summary(Some(1.02), 350.0, 400.0, Some(20.0)), 4);
        let kinds: Vec<String> = p.iter().map(ToString::to_string).collect();
        assert_eq!(p.len(), 4, "{kinds:?}");
        assert!(kinds[0].starts_with("x: R-hat 1.020"), "{kinds:?}");
        assert!(kinds[1].contains("ESS bulk 350"), "{kinds:?}");
        // ESS exactly at the threshold fails: it must exceed it.
        assert!(kinds[2].contains("ESS tail 400"), "{kinds:?}");
        assert!(kinds[3].contains("unreliable"), "{kinds:?}");
        assert!(p.iter().all(|q| q.quantity() == Some("x")));
        // One ensemble: no R̂ and no problem for it (the run-level SingleEnsemble says so).
        assert!(quantity_problems("x", &summary(None, 800.0, 900.0, Some(2.0)), 1).is_empty());
        let p = quantity_problems("x", &summary(None, 800.0, 900.0, None), 2);
        assert_eq!(
            p,
            vec![
                Problem::RHatUndefined {
                    quantity: "x".into()
                },
                Problem::TauUndefined {
                    quantity: "x".into()
                }
            ]
        );
    }

    #[test]
    fn problems_are_grouped_one_line_per_kind_with_the_steps_that_would_fix_them() {
        let mut problems = vec![Problem::ChainsTooShort {
            steps: 1000,
            tau_max: 96.0,
            needed: 1200,
        }];
        for (q, ess, tau) in [("a", 300.0, 40.0), ("b", 200.0, 96.0), ("c", 800.0, 10.0)] {
            let s = summary(Some(1.001), ess, 900.0, Some(tau));
            problems.extend(quantity_problems(q, &s, 4));
        }
        // 32 walkers in all: τ is trusted on 50 τ, as emcee's rule.
        let lines = problem_lines(&problems, 1000, 200, 32);
        assert_eq!(lines.len(), 3, "{lines:#?}");
        assert!(
            lines[0].starts_with("τ_max 96.0 steps needs 1200 steps"),
            "{lines:#?}"
        );
        // ESS 200 on 800 kept steps: 1600 kept steps, 1800 in all.
        assert!(
            lines[1].contains("for 2 quantities: a, b") && lines[1].contains("about 1800 steps"),
            "{lines:#?}"
        );
        // τ = 96 steps: 4800 kept steps after the 200 of burn-in.
        assert!(
            lines[2].contains("for 3 quantities: a, b, c") && lines[2].contains("about 5000 steps"),
            "{lines:#?}"
        );
    }

    #[test]
    fn stuck_walkers_are_counted_per_ensemble_after_enough_steps() {
        let acc: Vec<Vec<f64>> = vec![vec![0.3, 0.005, 0.001], vec![0.4, 0.5, 0.2]];
        let refs = || acc.iter().map(Vec::as_slice);
        assert!(stuck_walkers(refs(), STUCK_MIN_STEPS - 1).is_empty());
        assert_eq!(
            stuck_walkers(refs(), STUCK_MIN_STEPS),
            vec![Problem::StuckWalkers {
                ensemble: 0,
                walkers: 2
            }]
        );
    }

    #[test]
    fn problems_round_trip_through_json_with_their_kind() {
        let p = Problem::Ess {
            quantity: "alpha[PTFE]".into(),
            which: EssKind::Tail,
            ess: 123.0,
        };
        let json = serde_json::to_string(&p).unwrap();
        assert!(
            json.contains("\"kind\":\"ess\"") && json.contains("\"which\":\"tail\""),
            "{json}"
        );
        assert_eq!(serde_json::from_str::<Problem>(&json).unwrap(), p);
    }
}
