//! `summary.json`: what a fit concluded, as written and as read back by a report.

use std::collections::BTreeMap;

use serde::{Deserialize, Deserializer, Serialize};

use crate::data::Provenance;
use crate::diagnostics::{Problem, Summary};
use crate::sampler::StopReason;

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
    pub stats: Summary,
}

impl QuantitySummary {
    /// `name[group]`, as problems name it.
    pub fn label(&self) -> String {
        crate::density::label(&self.name, &self.group)
    }
}

/// The summary of a mean over several columns, per draw (e.g. F_d over a material's
/// contacts).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AggregateSummary {
    /// Reported name.
    pub name: String,
    /// Group.
    pub group: String,
    /// Unit.
    pub unit: String,
    /// The chain columns averaged.
    pub of: Vec<String>,
    /// What the mean is over, in words.
    pub note: String,
    /// The statistics.
    #[serde(flatten)]
    pub stats: Summary,
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
    /// When A and B are means over several columns (aggregates): what over, in words.
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub note: String,
    /// Posterior of A − B.
    pub difference: Summary,
    /// Posterior of A / B; `null` when a draw of B is zero (or a ratio is not finite).
    pub ratio: Option<Summary>,
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
    /// Steps kept per walker after the burn-in: every one (diagnostics never see thinned
    /// chains).
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
    /// Whether τ_max is trusted: the post-burn-in chains are longer than
    /// [`tau_trusted_length`](crate::diagnostics::tau_trusted_length) τ_max.
    pub tau_reliable: bool,
    /// Log-density evaluations (all runs).
    pub log_density_evals: u64,
    /// Wall-clock seconds of this invocation (a resumed fit counts only its own part).
    pub wall_s: f64,
    /// Whether every reported quantity converged (see `problems`).
    pub converged: bool,
    /// Every reason not to trust the draws.
    pub problems: Vec<Problem>,
    /// Proposals the density refused, per reason, over all ensembles.
    pub rejections: BTreeMap<String, u64>,
    /// The seed of the run.
    pub seed: u64,
    /// Why the sampler stopped.
    pub stopped_by: StopReason,
    /// Steps run by this invocation.
    pub steps_run: u64,
}

fn nullable<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// Everything `summary.json` holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FitSummary {
    /// Sampled parameters, in the order of the quantities given.
    pub parameters: Vec<QuantitySummary>,
    /// Derived quantities, in the order given.
    pub derived: Vec<QuantitySummary>,
    /// Means over several columns per draw, in the order given.
    #[serde(default)]
    pub aggregates: Vec<AggregateSummary>,
    /// Comparisons, by name, then group A, then group B, in the order of the spec.
    pub comparisons: Vec<Comparison>,
    /// The run.
    pub sampler: SamplerSummary,
    /// Where each run's data came from and what was done to them (empty when the density is
    /// not a friction model).
    #[serde(default)]
    pub data: Vec<Provenance>,
    /// The forward model the runs were fitted with (absent when the density is not a
    /// friction model), so that a reader of the summary alone knows which law it describes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub model: Option<ForwardModelRecord>,
    /// What the data do not show, in sentences: a peak beyond the end of its record, whose
    /// height is then extrapolated by the law rather than observed.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
    /// Leave-one-out predictive accuracy (PSIS-LOO), when every run has a likelihood per point.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loo: Option<super::LooSummary>,
    /// Why `loo` is absent, when the fit could not compute it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub loo_not_computed: Option<String>,
    /// K-fold cross-validation by time blocks, once `slipbayes kfold` has run on the fit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub kfold: Option<super::KFoldSummary>,
}

/// The forward model of a fit as model files name it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ForwardModelRecord {
    /// The law of first and fast slides (`law` in the model file).
    pub law: String,
    /// The state law under rate-and-state (`state_law`, `"aging"` or `"slip"`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub state_law: Option<String>,
    /// Whether the machine's spring is modelled (`elastic` in the model file).
    pub elastic: bool,
    /// Keys of the model file (`priors.alpha`, `levels.k`, …) for parameters this model does
    /// not sample, left from the default model's file and not read.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub unread: Vec<String>,
}

impl FitSummary {
    /// Every reported quantity: the parameters, then the derived quantities.
    pub fn quantities(&self) -> impl Iterator<Item = &QuantitySummary> {
        self.parameters.iter().chain(&self.derived)
    }

    /// The quantity `name[group]`, if reported.
    pub fn find(&self, name: &str, group: &str) -> Option<&QuantitySummary> {
        self.quantities()
            .find(|q| q.name == name && q.group == group)
    }

    /// The aggregate `name[group]`, if reported.
    pub fn aggregate(&self, name: &str, group: &str) -> Option<&AggregateSummary> {
        self.aggregates
            .iter()
            .find(|a| a.name == name && a.group == group)
    }

    /// The problems that name the quantity `label` (`name[group]`).
    pub fn problems_of<'a>(&'a self, label: &'a str) -> impl Iterator<Item = &'a Problem> {
        self.sampler
            .problems
            .iter()
            .filter(move |p| p.quantity() == Some(label))
    }
}
