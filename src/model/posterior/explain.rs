//! Why no start could be found, in the model's terms: the coordinates outside their prior,
//! the runs whose law cannot be evaluated, and the priors that exclude what the data say, each
//! named with its run, contact or material, its value and prior in SI units, and what to
//! change in the model file.

use std::collections::BTreeSet;

use super::layout::{CoordPrior, SigmaSource, Source};
use super::Posterior;
use crate::density::Quantity;

/// Reasons listed before the rest are counted.
const SHOWN: usize = 5;

/// How far (a factor) a run's residual noise may lie outside the bounds of an integrated σ's
/// prior before it is named as excluded: within it the truncation merely shapes the posterior.
const NOISE_OUTSIDE_FACTOR: f64 = 10.0;

impl Posterior {
    /// What fails at `x`, and what to change: coordinates outside their prior (with the value
    /// the data gave for them), runs whose model cannot be evaluated (with their contact and the
    /// law's reason), coordinates whose prior excludes the data's value, and runs whose noise
    /// an integrated σ's prior excludes; at most [`SHOWN`] of them, then a count, then the
    /// priors to change. `None` when nothing is wrong at `x`.
    pub(super) fn failures_at(&self, x: &[f64]) -> Option<String> {
        let estimates = self.start.get().map(|s| s.estimates.as_slice());
        let estimate = |c: usize| {
            estimates
                .and_then(|e| e.get(c).copied())
                .filter(|v| v.is_finite() && *v > 0.0)
        };
        let mut failures = Vec::new();
        // Parameters whose prior the model file should change.
        let mut priors = BTreeSet::new();
        for (c, (coord, &u)) in self.coords.iter().zip(x).enumerate() {
            let Some(q) = self.quantity_of(c) else {
                continue;
            };
            let CoordPrior::Log(prior) = &coord.prior else {
                if !coord.prior_contains(u) {
                    failures.push(format!(
                        "{} ({}): {} = {u:.4} is not finite",
                        q.label(),
                        self.place(&q.group),
                        coord.name
                    ));
                }
                continue;
            };
            let unit = &q.unit;
            let prior_text = format!("{} {unit}", prior.describe());
            if !coord.prior_contains(u) {
                let data = estimate(c)
                    .map(|v| format!(" (the data say about {v:.3e} {unit})"))
                    .unwrap_or_default();
                failures.push(format!(
                    "{} ({}) = {:.4e} {unit} ({} = {u:.4}) is outside its prior, {prior_text}{data}",
                    q.label(),
                    self.place(&q.group),
                    u.exp(),
                    coord.name
                ));
                priors.insert(q.name.clone());
            } else if let Some(v) =
                estimate(c).filter(|&v| prior.ln_density(v) == f64::NEG_INFINITY)
            {
                failures.push(format!(
                    "the data say {} ({}) is about {v:.3e} {unit}, which its prior, {prior_text}, \
                     excludes (the start took {:.4e} {unit})",
                    q.label(),
                    self.place(&q.group),
                    u.exp()
                ));
                priors.insert(q.name.clone());
            }
        }
        let fits: Vec<_> = self.fits_at(&self.order, x).collect();
        for (i, fit) in &fits {
            if let Err(e) = fit {
                failures.push(format!("{}: {e}", self.place(&self.runs[*i].name)));
            }
        }
        for (i, fit) in &fits {
            let (Ok(fit), SigmaSource::Marginal(g)) = (fit, self.runs[*i].sigma) else {
                continue;
            };
            let r = &self.runs[*i];
            let group = &self.sigma_groups[g];
            let noise_n = (fit.ssr / r.data.n_obs as f64).sqrt();
            let outside = noise_n > NOISE_OUTSIDE_FACTOR * group.high
                || noise_n < group.low / NOISE_OUTSIDE_FACTOR;
            if noise_n.is_finite() && outside {
                failures.push(format!(
                    "the noise of {} is about {noise_n:.3e} N (rms residual at this point), which \
                     the prior of sigma, log-uniform on [{:e}, {:e}] N, excludes",
                    self.place(&r.name),
                    group.low,
                    group.high
                ));
                priors.insert("sigma".to_owned());
            }
        }
        if failures.is_empty() {
            return None;
        }
        let more = failures.len().saturating_sub(SHOWN);
        failures.truncate(SHOWN);
        if more > 0 {
            failures.push(format!("and {more} more"));
        }
        if !priors.is_empty() {
            failures.push(self.prior_advice(&priors));
        }
        Some(failures.join("; "))
    }

    /// The reported quantity a coordinate is the logarithm of.
    fn quantity_of(&self, coord: usize) -> Option<&Quantity> {
        self.quantities
            .iter()
            .zip(&self.sources)
            .find(|(_, s)| matches!(s, Source::Coord(c) if *c == coord))
            .map(|(q, _)| q)
    }

    /// Where a group lies in the model: `run R of contact C`, `contact C` or `material M`.
    fn place(&self, group: &str) -> String {
        let file = &self.spec.file;
        if let Some(r) = file.runs.iter().position(|r| r.name == group) {
            let contact = &file.contacts[self.spec.run_contact[r]].name;
            return format!("run {group} of contact {contact}");
        }
        if file.contacts.iter().any(|c| c.name == group) {
            return format!("contact {group}");
        }
        format!("material {group}")
    }

    /// What to change: the priors named, in the model file (the quick path has none).
    fn prior_advice(&self, priors: &BTreeSet<String>) -> String {
        let keys: Vec<String> = priors.iter().map(|p| format!("`{p}`")).collect();
        let (keys, they, them, defaults) = if keys.len() == 1 {
            (
                format!("the prior of {}", keys[0]),
                "it holds",
                "it",
                "the default",
            )
        } else {
            let keys = format!("the priors of {}", keys.join(", "));
            (keys, "they hold", "them", "the defaults")
        };
        let source = self.spec.source.display().to_string();
        if source.starts_with('<') {
            format!(
                "the quick path uses the default priors: fit with a model file whose \
                 `[priors]` give {keys} a range that holds what the data say"
            )
        } else {
            format!(
                "to fix: in {source}, change {keys} under `[priors]` so that {they} what the \
                 data say, or remove {them} for {defaults}"
            )
        }
    }
}
