//! From chains to posterior summaries: the burn-in and thinning, one [`Stats`] per quantity
//! and per comparison, and the verdict on convergence.

use std::collections::{BTreeMap, HashSet};
use std::path::Path;
use std::time::Instant;

use rayon::prelude::*;
use serde::{Deserialize, Deserializer, Serialize};

use super::{ComparisonSpec, FitError, FitSettings, Quantity, QuantityKind};
use crate::diagnostics::{
    hdi, mcse_mean, summarize, EnsembleDraws, Summary, MIN_DRAWS, TAU_RELIABLE_FACTOR,
};
use crate::sampler::{stuck_walker_problems, RunReport, StopReason, RHAT_CONVERGED};
use crate::storage::Chains;

/// Largest R̂ between ensembles of a converged quantity (ArviZ's threshold).
pub const RHAT_MAX: f64 = RHAT_CONVERGED;
/// Smallest bulk and tail ESS of a converged quantity (ArviZ's threshold).
pub const ESS_MIN: f64 = 400.0;
/// Tolerance under which `hdi_prob` counts as equal to `ci_prob` (the HDI then comes with the
/// summary instead of a second sort).
const PROB_TOL: f64 = 1e-12;

/// Posterior statistics of one scalar, with ArviZ's meaning for every field. NaN values are
/// written as JSON `null` and read back as NaN.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stats {
    /// Posterior mean.
    #[serde(deserialize_with = "nullable")]
    pub mean: f64,
    /// Posterior standard deviation (`ddof = 1`).
    #[serde(deserialize_with = "nullable")]
    pub sd: f64,
    /// Posterior median.
    #[serde(deserialize_with = "nullable")]
    pub median: f64,
    /// Lower end of the equal-tailed interval of probability `ci_prob`.
    #[serde(deserialize_with = "nullable")]
    pub ci_low: f64,
    /// Upper end of the equal-tailed interval.
    #[serde(deserialize_with = "nullable")]
    pub ci_high: f64,
    /// Probability of the equal-tailed interval.
    pub ci_prob: f64,
    /// Lower end of the highest-density interval of probability `hdi_prob` (unimodal).
    #[serde(deserialize_with = "nullable")]
    pub hdi_low: f64,
    /// Upper end of the highest-density interval.
    #[serde(deserialize_with = "nullable")]
    pub hdi_high: f64,
    /// Probability of the HDI.
    pub hdi_prob: f64,
    /// Bulk ESS (every walker of every ensemble as a chain).
    #[serde(deserialize_with = "nullable")]
    pub ess_bulk: f64,
    /// Tail ESS (smaller of the 5 % and 95 % quantile ESS).
    #[serde(deserialize_with = "nullable")]
    pub ess_tail: f64,
    /// Rank-normalised split R̂ between ensembles; `null` with one ensemble or constant draws.
    pub r_hat: Option<f64>,
    /// Monte-Carlo standard error of the mean.
    #[serde(deserialize_with = "nullable")]
    pub mcse_mean: f64,
    /// Monte-Carlo standard error of the sd.
    #[serde(deserialize_with = "nullable")]
    pub mcse_sd: f64,
    /// ESS of the mean.
    #[serde(deserialize_with = "nullable")]
    pub ess_mean: f64,
    /// Integrated autocorrelation time of the kept draws, in kept draws (multiply by `thin`
    /// for steps); `null` when a walker is constant.
    pub tau: Option<f64>,
    /// Whether the kept draws are longer than 50 τ.
    pub tau_reliable: Option<bool>,
}

fn nullable<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

impl Stats {
    fn new(s: Summary, hdi_interval: (f64, f64), hdi_prob: f64) -> Self {
        Self {
            mean: s.mean,
            sd: s.sd,
            median: s.median,
            ci_low: s.ci_low,
            ci_high: s.ci_high,
            ci_prob: s.ci_prob,
            hdi_low: hdi_interval.0,
            hdi_high: hdi_interval.1,
            hdi_prob,
            ess_bulk: s.ess_bulk,
            ess_tail: s.ess_tail,
            r_hat: s.r_hat.filter(|r| !r.is_nan()),
            mcse_mean: s.mcse_mean,
            mcse_sd: s.mcse_sd,
            ess_mean: s.ess_mean,
            tau: s.tau,
            tau_reliable: s.tau_reliable,
        }
    }
}

/// The summary of one reported quantity.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QuantitySummary {
    /// Reported name.
    pub name: String,
    /// Group (may be empty).
    pub group: String,
    /// Unit (may be empty).
    pub unit: String,
    /// The chain column the draws came from.
    pub column: String,
    /// The statistics.
    #[serde(flatten)]
    pub stats: Stats,
}

/// The posterior comparison of one quantity between groups A and B.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// Quantity name.
    pub name: String,
    /// Unit of the difference (the ratio has none).
    pub unit: String,
    /// Group A.
    pub group_a: String,
    /// Group B.
    pub group_b: String,
    /// Posterior of A − B.
    pub difference: Stats,
    /// Posterior of A / B; `null` when a draw of B is zero (or a ratio is not finite).
    pub ratio: Option<Stats>,
    /// Posterior probability that A > B (fraction of paired draws).
    pub p_a_greater: f64,
    /// Monte-Carlo standard error of `p_a_greater`; `null` when every draw agrees.
    pub p_a_greater_mcse: Option<f64>,
}

/// How the run went and how the draws were selected.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SamplerSummary {
    /// Walkers per ensemble.
    pub walkers: usize,
    /// Steps in the chains (all runs of a resumed fit).
    pub steps: u64,
    /// Independent ensembles.
    pub ensembles: usize,
    /// Steps discarded at the start.
    pub burn_in: u64,
    /// One kept step in `thin`.
    pub thin: u64,
    /// Steps kept per walker after burn-in and thinning.
    pub kept_steps: usize,
    /// Draws per quantity (`ensembles × walkers × kept_steps`).
    pub draws: usize,
    /// Mean acceptance fraction over all walkers.
    #[serde(deserialize_with = "nullable")]
    pub acceptance: f64,
    /// Largest integrated autocorrelation time of the sampled parameters, in steps.
    pub tau_max: Option<f64>,
    /// Smallest one.
    pub tau_min: Option<f64>,
    /// Whether the chains are longer than 50 τ_max.
    pub tau_reliable: bool,
    /// Log-density evaluations (all runs).
    pub log_density_evals: u64,
    /// Wall-clock seconds of this invocation (a resumed fit counts only its own part).
    pub wall_s: f64,
    /// Whether every reported quantity converged (see `problems`).
    pub converged: bool,
    /// Every reason not to trust the draws, in words.
    pub problems: Vec<String>,
    /// Proposals the density refused, per reason, over all ensembles.
    pub rejections: BTreeMap<String, u64>,
    /// The seed of the run.
    pub seed: u64,
    /// Why the sampler stopped.
    pub stopped_by: StopReason,
    /// Steps run by this invocation.
    pub steps_run: u64,
}

/// Everything `summary.json` holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    /// Sampled parameters, in the order of the quantities given.
    pub parameters: Vec<QuantitySummary>,
    /// Derived quantities, in the order given.
    pub derived: Vec<QuantitySummary>,
    /// Comparisons, by name, then group A, then group B, in the order of the spec.
    pub comparisons: Vec<Comparison>,
    /// The run.
    pub sampler: SamplerSummary,
    /// Where each run's data came from and what was done to them (empty when the density is
    /// not a friction model; filled by [`crate::fit::FitOutcome::record_data`]).
    #[serde(default)]
    pub data: Vec<crate::data::Provenance>,
}

/// A validated plan: which columns to summarise and which pairs to compare.
#[derive(Debug)]
pub(crate) struct Plan {
    quantities: Vec<Quantity>,
    /// (name, unit, index of A, index of B) into `quantities`.
    pairs: Vec<(String, String, usize, usize)>,
}

fn spec(what: &'static str, problem: String) -> FitError {
    FitError::InvalidSpec { what, problem }
}

impl Plan {
    pub(crate) fn new(
        param_names: &[String],
        derived_names: &[String],
        quantities: &[Quantity],
        comparisons: &ComparisonSpec,
    ) -> Result<Self, FitError> {
        if quantities.is_empty() {
            return Err(spec(
                "quantity",
                "no quantities to report: give at least one".into(),
            ));
        }
        let mut seen = HashSet::new();
        for q in quantities {
            // The kind decides the list a quantity is reported in; its column may be a
            // sampled coordinate or a derived value (e.g. a parameter in SI units computed
            // from its log-scale coordinate).
            if !param_names.contains(&q.column) && !derived_names.contains(&q.column) {
                return Err(spec(
                    "quantity",
                    format!(
                        "{} reads column {:?}, which the density does not have; its columns are {param_names:?} and {derived_names:?}",
                        q.label(),
                        q.column
                    ),
                ));
            }
            if q.name.is_empty() {
                return Err(spec(
                    "quantity",
                    format!("the quantity of column {:?} has an empty name", q.column),
                ));
            }
            if !seen.insert((q.name.as_str(), q.group.as_str())) {
                return Err(spec(
                    "quantity",
                    format!(
                        "{} is reported twice; give each name and group once",
                        q.label()
                    ),
                ));
            }
        }
        let find = |name: &str, group: &str| {
            quantities
                .iter()
                .position(|q| q.name == name && q.group == group)
        };
        for (list, what) in [(&comparisons.names, "name"), (&comparisons.groups, "group")] {
            let mut unique = HashSet::new();
            if let Some(dup) = list.iter().find(|n| !unique.insert(n.as_str())) {
                return Err(spec(
                    "comparison",
                    format!("{what} {dup:?} is listed twice"),
                ));
            }
        }
        let mut pairs = Vec::new();
        for name in &comparisons.names {
            let present: Vec<(&String, usize)> = comparisons
                .groups
                .iter()
                .filter_map(|g| find(name, g).map(|i| (g, i)))
                .collect();
            if present.len() < 2 {
                return Err(spec(
                    "comparison",
                    format!(
                        "{name:?} is reported in {} of the groups {:?}; a comparison needs it in at least two",
                        present.len(),
                        comparisons.groups
                    ),
                ));
            }
            for (k, &(_, a)) in present.iter().enumerate() {
                for &(_, b) in &present[k + 1..] {
                    if quantities[a].unit != quantities[b].unit {
                        return Err(spec(
                            "comparison",
                            format!(
                                "{} is in {:?} but {} in {:?}; compare quantities of one unit",
                                quantities[a].label(),
                                quantities[a].unit,
                                quantities[b].label(),
                                quantities[b].unit
                            ),
                        ));
                    }
                    pairs.push((name.clone(), quantities[a].unit.clone(), a, b));
                }
            }
        }
        Ok(Self {
            quantities: quantities.to_vec(),
            pairs,
        })
    }

    /// Summaries of the chains of a finished run.
    pub(crate) fn summarise(
        &self,
        chains: &Chains,
        report: &RunReport,
        settings: &FitSettings,
        dir: &Path,
        started: Instant,
    ) -> Result<FitSummary, FitError> {
        let total = report.total_steps;
        let layout = Layout::check(chains, settings.ensembles, settings.walkers, total, dir)?;
        let mut problems = Vec::new();
        let selection = Selection::new(report, &mut problems)?;

        let columns: Vec<&[f64]> = self
            .quantities
            .iter()
            .map(|q| {
                chains
                    .column(&q.column)
                    .map_err(|source| FitError::Storage {
                        context: format!("reading column {:?} of {}", q.column, dir.display()),
                        source,
                    })
            })
            .collect::<Result<_, _>>()?;
        let kept = |column: &[f64]| {
            let col = column;
            EnsembleDraws::from_fn(
                layout.ensembles,
                layout.walkers,
                selection.kept,
                move |e, w, t| col[layout.row(selection.step(t), e, w)],
            )
        };
        let probs = (settings.ci_prob, settings.hdi_prob);

        let stats: Vec<Stats> = self
            .quantities
            .par_iter()
            .zip(columns.par_iter())
            .map(|(q, column)| {
                let diag = |source| FitError::Diagnostics {
                    quantity: q.label(),
                    source,
                };
                stats_of(&kept(column).map_err(diag)?, probs).map_err(diag)
            })
            .collect::<Result<_, _>>()?;

        let comparisons: Vec<Comparison> = self
            .pairs
            .par_iter()
            .map(|(name, unit, a, b)| {
                let (qa, qb) = (&self.quantities[*a], &self.quantities[*b]);
                let what = format!("{} − {}", qa.label(), qb.label());
                let diag = |source| FitError::Diagnostics {
                    quantity: what.clone(),
                    source,
                };
                let (ca, cb) = (columns[*a], columns[*b]);
                let paired = |f: fn(f64, f64) -> f64| {
                    EnsembleDraws::from_fn(
                        layout.ensembles,
                        layout.walkers,
                        selection.kept,
                        |e, w, t| {
                            let row = layout.row(selection.step(t), e, w);
                            f(ca[row], cb[row])
                        },
                    )
                };
                let difference =
                    stats_of(&paired(|x, y| x - y).map_err(diag)?, probs).map_err(diag)?;
                // A zero or non-finite ratio draw leaves the ratio undefined, not the fit.
                let ratio = paired(|x, y| x / y)
                    .ok()
                    .and_then(|r| stats_of(&r, probs).ok());
                let above = paired(|x, y| if x > y { 1.0 } else { 0.0 }).map_err(diag)?;
                let (p, p_mcse) = probability(&above);
                Ok(Comparison {
                    name: name.clone(),
                    unit: unit.clone(),
                    group_a: qa.group.clone(),
                    group_b: qb.group.clone(),
                    difference,
                    ratio,
                    p_a_greater: p,
                    p_a_greater_mcse: p_mcse,
                })
            })
            .collect::<Result<_, FitError>>()?;

        if settings.ensembles < 2 {
            problems.push(format!(
                "only {} ensemble: R-hat between independent ensembles cannot be computed; run at least 2",
                settings.ensembles
            ));
        }
        for (q, s) in self.quantities.iter().zip(&stats) {
            quantity_problems(&q.label(), s, settings.ensembles, &mut problems);
        }
        problems.extend(stuck_walker_problems(&report.ensembles, total));
        let mut rejections = BTreeMap::new();
        for ens in &report.ensembles {
            for (reason, n) in &ens.rejections {
                *rejections.entry(reason.clone()).or_insert(0) += n;
            }
        }

        let mut parameters = Vec::new();
        let mut derived = Vec::new();
        for (q, s) in self.quantities.iter().zip(stats) {
            let summary = QuantitySummary {
                name: q.name.clone(),
                group: q.group.clone(),
                unit: q.unit.clone(),
                column: q.column.clone(),
                stats: s,
            };
            match q.kind {
                QuantityKind::Parameter => parameters.push(summary),
                QuantityKind::Derived => derived.push(summary),
            }
        }
        let tau = report.tau.as_ref();
        Ok(FitSummary {
            parameters,
            derived,
            comparisons,
            sampler: SamplerSummary {
                walkers: layout.walkers,
                steps: total,
                ensembles: layout.ensembles,
                burn_in: selection.burn_in,
                thin: selection.thin,
                kept_steps: selection.kept,
                draws: layout.ensembles * layout.walkers * selection.kept,
                acceptance: report.mean_acceptance(),
                tau_max: tau.map(|t| t.max),
                tau_min: tau.map(|t| t.min),
                tau_reliable: tau.is_some_and(|t| t.reliable),
                log_density_evals: report.evaluations(),
                wall_s: started.elapsed().as_secs_f64(),
                converged: problems.is_empty(),
                problems,
                rejections,
                seed: settings.seed,
                stopped_by: report.stopped_by,
                steps_run: report.steps_run,
            },
            data: Vec::new(),
        })
    }
}

/// Statistics of one set of draws, with the HDI at its own probability.
fn stats_of(
    draws: &EnsembleDraws,
    (ci_prob, hdi_prob): (f64, f64),
) -> Result<Stats, crate::diagnostics::DiagnosticsError> {
    let s = summarize(draws, ci_prob)?;
    let interval = if (hdi_prob - ci_prob).abs() <= PROB_TOL {
        (s.hdi_low, s.hdi_high)
    } else {
        let all: Vec<f64> = (0..draws.ensembles())
            .flat_map(|e| (0..draws.walkers()).map(move |w| (e, w)))
            .flat_map(|(e, w)| draws.series(e, w).iter().copied())
            .collect();
        hdi(&all, hdi_prob)?
    };
    Ok(Stats::new(s, interval, hdi_prob))
}

/// Mean of 0/1 indicator draws and its MCSE (`None` when every draw agrees, where the MCSE
/// estimate is undefined).
fn probability(indicator: &EnsembleDraws) -> (f64, Option<f64>) {
    let series: Vec<&[f64]> = (0..indicator.ensembles())
        .flat_map(|e| (0..indicator.walkers()).map(move |w| (e, w)))
        .map(|(e, w)| indicator.series(e, w))
        .collect();
    let n: usize = series.iter().map(|s| s.len()).sum();
    let ones: f64 = series.iter().flat_map(|s| s.iter()).sum();
    let p = ones / n as f64;
    let mcse = mcse_mean(&series)
        .ok()
        .filter(|m| m.is_finite() && *m > 0.0);
    (p, mcse)
}

/// Every convergence failure of one quantity, in words.
fn quantity_problems(label: &str, s: &Stats, ensembles: usize, problems: &mut Vec<String>) {
    match s.r_hat {
        Some(r) if r < RHAT_MAX => {}
        Some(r) => problems.push(format!(
            "{label}: R-hat {r:.3} ≥ {RHAT_MAX} (the ensembles disagree: not mixed or multimodal)"
        )),
        None if ensembles >= 2 => problems.push(format!(
            "{label}: R-hat undefined (every draw is equal: a stuck or constant quantity)"
        )),
        None => {}
    }
    for (what, ess) in [("bulk", s.ess_bulk), ("tail", s.ess_tail)] {
        if ess.is_nan() || ess <= ESS_MIN {
            problems.push(format!("{label}: ESS {what} {ess:.0} < {ESS_MIN:.0}"));
        }
    }
    match (s.tau, s.tau_reliable) {
        (Some(_), Some(true)) => {}
        (Some(tau), _) => problems.push(format!(
            "{label}: autocorrelation time {tau:.1} kept draws is unreliable (fewer than {TAU_RELIABLE_FACTOR} τ kept draws per walker); run longer"
        )),
        (None, _) => problems.push(format!(
            "{label}: autocorrelation time undefined (a walker never moved)"
        )),
    }
}

/// Rows of a complete run are in recording order: step, then ensemble, then walker.
#[derive(Debug, Clone, Copy)]
struct Layout {
    ensembles: usize,
    walkers: usize,
}

impl Layout {
    fn check(
        chains: &Chains,
        ensembles: usize,
        walkers: usize,
        steps: u64,
        dir: &Path,
    ) -> Result<Self, FitError> {
        let inconsistent = |problem: String| FitError::Inconsistent {
            dir: dir.to_path_buf(),
            problem,
        };
        let expected = ensembles as u64 * walkers as u64 * steps;
        if chains.len() as u64 != expected {
            return Err(inconsistent(format!(
                "{} rows, but {ensembles} ensembles × {walkers} walkers × {steps} steps make {expected}",
                chains.len()
            )));
        }
        let layout = Self { ensembles, walkers };
        for step in 0..steps {
            for e in 0..ensembles {
                for w in 0..walkers {
                    let row = layout.row(step, e, w);
                    if chains.step[row] != step
                        || chains.ensemble[row] as usize != e
                        || chains.walker[row] as usize != w
                    {
                        return Err(inconsistent(format!(
                            "row {row} holds step {}, ensemble {}, walker {} where step {step}, ensemble {e}, walker {w} was expected",
                            chains.step[row], chains.ensemble[row], chains.walker[row]
                        )));
                    }
                }
            }
        }
        Ok(layout)
    }

    fn row(&self, step: u64, e: usize, w: usize) -> usize {
        (step as usize * self.ensembles + e) * self.walkers + w
    }
}

/// Which steps are kept: `burn_in, burn_in + thin, …` below the total.
#[derive(Debug, Clone, Copy)]
struct Selection {
    burn_in: u64,
    thin: u64,
    kept: usize,
}

impl Selection {
    fn new(report: &RunReport, problems: &mut Vec<String>) -> Result<Self, FitError> {
        let total = report.total_steps;
        let half = total / 2;
        let (mut burn_in, mut thin) = match &report.tau {
            Some(t) => {
                if !t.reliable {
                    problems.push(format!(
                        "chains of {total} steps are shorter than {TAU_RELIABLE_FACTOR} τ_max = {:.0} steps: the autocorrelation time, and the burn-in and thinning taken from it, are unreliable; run longer",
                        TAU_RELIABLE_FACTOR * t.max
                    ));
                }
                (t.burn_in, t.thin)
            }
            None => {
                problems.push(format!(
                    "no autocorrelation time could be estimated from {total} steps: discarded the first half as burn-in and kept every step; run longer"
                ));
                (half, 1)
            }
        };
        if burn_in > half {
            problems.push(format!(
                "burn-in of 2 τ_max = {burn_in} steps is more than half the run; discarded only the first {half} steps"
            ));
            burn_in = half;
        }
        let count = |thin: u64| ((total - burn_in).div_ceil(thin.max(1))) as usize;
        if count(thin) < MIN_DRAWS && thin > 1 {
            thin = 1;
        }
        let kept = count(thin);
        if kept < MIN_DRAWS {
            return Err(FitError::TooFewDraws {
                kept,
                burn_in,
                total,
                needed: MIN_DRAWS,
            });
        }
        Ok(Self {
            burn_in,
            thin,
            kept,
        })
    }

    fn step(&self, t: usize) -> u64 {
        self.burn_in + t as u64 * self.thin
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn q(column: &str, name: &str, group: &str, kind: QuantityKind) -> Quantity {
        Quantity {
            column: column.into(),
            name: name.into(),
            group: group.into(),
            unit: String::new(),
            kind,
        }
    }

    fn names(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn plan_refuses_what_it_cannot_report() {
        let params = names(&["a", "b"]);
        let derived = names(&["d_a", "d_b"]);
        let none = ComparisonSpec::default();
        let p = QuantityKind::Parameter;
        let d = QuantityKind::Derived;
        let err = |qs: &[Quantity], c: &ComparisonSpec| {
            Plan::new(&params, &derived, qs, c)
                .expect_err("must be refused")
                .to_string()
        };
        assert!(err(&[], &none).contains("no quantities"));
        // A parameter may be reported from a derived column (e.g. in SI units).
        assert!(Plan::new(&params, &derived, &[q("d_a", "x", "", p)], &none).is_ok());
        assert!(err(&[q("zz", "x", "", d)], &none).contains("\"zz\""));
        assert!(err(&[q("a", "x", "g", p), q("b", "x", "g", p)], &none).contains("twice"));
        let spec = ComparisonSpec {
            names: names(&["x"]),
            groups: names(&["A", "B"]),
        };
        assert!(err(&[q("a", "x", "A", p), q("b", "x", "C", p)], &spec).contains("1 of the groups"));
        let ok = Plan::new(
            &params,
            &derived,
            &[
                q("a", "x", "A", p),
                q("b", "x", "B", p),
                q("d_a", "y", "A", d),
            ],
            &spec,
        )
        .expect("valid plan");
        assert_eq!(ok.pairs.len(), 1);
        assert_eq!((ok.pairs[0].2, ok.pairs[0].3), (0, 1));
    }
}
