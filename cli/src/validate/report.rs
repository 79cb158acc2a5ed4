//! What a calibration run concludes: each quantity's rank uniformity and interval coverage
//! over the successful replications ([`SbcReport`], by [`summarise`]), and the files a person
//! reads ([`write_report`]: `validation.json`, `rank_histograms.svg`, `validation.md`).

use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{io, svg, Coverage, Replication, SbcSettings, Uniformity, ValidateError};
use slipbayes::data::write_atomically;

/// Calibration of one quantity over all successful replications.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QuantityCalibration {
    /// Chain column, e.g. `alpha[PTFE]`.
    pub column: String,
    /// χ² test of uniform ranks.
    pub uniformity: Uniformity,
    /// χ² test of uniform posterior quantiles of the truth (the fraction of all post-burn-in
    /// draws below it, in 100 steps of 1 %): the same question without thinning, so it does
    /// not depend on how far apart the L ranked draws are. Absent in reports of earlier
    /// versions.
    #[serde(default)]
    pub quantile_uniformity: Option<Uniformity>,
    /// Coverage of the central 50 % interval.
    pub coverage50: Coverage,
    /// Coverage of the central 95 % interval.
    pub coverage95: Coverage,
}

/// The result of a validation run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SbcReport {
    /// The settings.
    pub settings: SbcSettings,
    /// Replications that produced ranks.
    pub succeeded: usize,
    /// Replications whose fit failed, with the reasons.
    pub failures: Vec<(usize, String)>,
    /// Fits that passed every convergence check.
    pub converged: usize,
    /// Largest R̂ over all replications and tracked quantities.
    pub r_hat_max: Option<f64>,
    /// Median of τ_max over the replications (steps).
    pub tau_max_median: Option<f64>,
    /// Smallest gap between ranked draws of one walker, in units of that fit's τ_max.
    pub min_gap_over_tau: Option<f64>,
    /// Prior draws rejected for stick-slip, in all.
    pub redraws: usize,
    /// Median seconds per replication.
    pub wall_s_median: f64,
    /// Per quantity.
    pub quantities: Vec<QuantityCalibration>,
}

/// Thresholds of gross miscalibration (the CI gate).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GrossLimits {
    /// Smallest acceptable coverage of the 95 % interval.
    pub min_coverage95: f64,
    /// Acceptable range of the coverage of the 50 % interval.
    pub coverage50: [f64; 2],
    /// Smallest acceptable χ² p-value of the ranks.
    pub min_p_value: f64,
    /// Largest acceptable fraction of failed replications.
    pub max_failed_fraction: f64,
}

impl Default for GrossLimits {
    fn default() -> Self {
        Self {
            min_coverage95: 0.80,
            coverage50: [0.2, 0.8],
            min_p_value: 1e-4,
            max_failed_fraction: 0.05,
        }
    }
}

impl SbcReport {
    /// Every sign of gross miscalibration, in words; empty when there is none.
    pub fn gross_problems(&self, limits: &GrossLimits) -> Vec<String> {
        let mut problems = Vec::new();
        let total = self.succeeded + self.failures.len();
        if self.failures.len() as f64 > limits.max_failed_fraction * total as f64 {
            problems.push(format!(
                "{} of {total} replications failed (first: {:?})",
                self.failures.len(),
                self.failures.first()
            ));
        }
        for q in &self.quantities {
            if q.coverage95.rate < limits.min_coverage95 {
                problems.push(format!(
                    "{}: 95 % intervals cover the truth in {:.0} % of replications, below {:.0} %",
                    q.column,
                    100.0 * q.coverage95.rate,
                    100.0 * limits.min_coverage95
                ));
            }
            let [lo, hi] = limits.coverage50;
            if !(q.coverage50.rate >= lo && q.coverage50.rate <= hi) {
                problems.push(format!(
                    "{}: 50 % intervals cover the truth in {:.0} % of replications, outside [{:.0} %, {:.0} %]",
                    q.column,
                    100.0 * q.coverage50.rate,
                    100.0 * lo,
                    100.0 * hi
                ));
            }
            if q.uniformity.p_value < limits.min_p_value {
                problems.push(format!(
                    "{}: ranks are not uniform (χ² = {:.1} on {} dof, p = {:.1e})",
                    q.column, q.uniformity.chi2, q.uniformity.dof, q.uniformity.p_value
                ));
            }
        }
        problems
    }
}

fn median(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// Summarises replications (in any order) into the report.
pub fn summarise(settings: &SbcSettings, reps: &[Replication]) -> SbcReport {
    let ok: Vec<&Replication> = reps.iter().filter(|r| r.failure.is_none()).collect();
    let columns: Vec<String> = ok
        .first()
        .map(|r| r.ranks.keys().cloned().collect())
        .unwrap_or_default();
    let quantities = columns
        .iter()
        .map(|c| {
            let ranks: Vec<usize> = ok.iter().filter_map(|r| r.ranks.get(c).copied()).collect();
            let q: Vec<f64> = ok
                .iter()
                .filter_map(|r| r.quantiles.get(c).copied())
                .collect();
            QuantityCalibration {
                column: c.clone(),
                uniformity: Uniformity::test(&ranks, settings.rank_draws),
                quantile_uniformity: Some(Uniformity::test(
                    &q.iter()
                        .map(|&q| ((q * 100.0).floor() as usize).min(99))
                        .collect::<Vec<_>>(),
                    99,
                )),
                coverage50: Coverage::from_quantiles(0.5, &q),
                coverage95: Coverage::from_quantiles(0.95, &q),
            }
        })
        .collect();
    SbcReport {
        settings: settings.clone(),
        succeeded: ok.len(),
        failures: reps
            .iter()
            .filter_map(|r| r.failure.clone().map(|f| (r.index, f)))
            .collect(),
        converged: ok.iter().filter(|r| r.converged).count(),
        r_hat_max: ok
            .iter()
            .filter_map(|r| r.r_hat_max)
            .fold(None, |m: Option<f64>, r| Some(m.map_or(r, |m| m.max(r)))),
        tau_max_median: median(ok.iter().filter_map(|r| r.tau_max).collect()),
        min_gap_over_tau: ok
            .iter()
            .filter_map(|r| r.min_gap_over_tau)
            .fold(None, |m: Option<f64>, g| Some(m.map_or(g, |m| m.min(g)))),
        redraws: reps.iter().map(|r| r.redraws).sum(),
        wall_s_median: median(reps.iter().map(|r| r.wall_s).collect()).unwrap_or(f64::NAN),
        quantities,
    }
}

/// Writes `validation.json` (the report), `rank_histograms.svg` and `validation.md` (a table
/// for people) into `out`; `command` is recorded in the Markdown.
///
/// # Errors
/// [`ValidateError::Io`] when a file cannot be written.
pub fn write_report(
    report: &SbcReport,
    limits: &GrossLimits,
    out: &Path,
    command: &str,
) -> Result<(), ValidateError> {
    let json_path = out.join("validation.json");
    let json = serde_json::to_vec_pretty(report).unwrap_or_default();
    write_atomically(&json_path, &json).map_err(io("write", &json_path))?;
    let panels: Vec<(String, &Uniformity)> = report
        .quantities
        .iter()
        .map(|q| (q.column.clone(), &q.uniformity))
        .collect();
    let title = format!(
        "SBC ranks, {} replications, L = {} (grey: 99 % band under uniformity)",
        report.succeeded, report.settings.rank_draws
    );
    let svg_path = out.join("rank_histograms.svg");
    let histograms = svg::rank_histograms(&panels, report.succeeded, &title);
    write_atomically(&svg_path, histograms.as_bytes()).map_err(io("write", &svg_path))?;
    let md_path = out.join("validation.md");
    write_atomically(&md_path, markdown(report, limits, command).as_bytes())
        .map_err(io("write", &md_path))
}

fn markdown(r: &SbcReport, limits: &GrossLimits, command: &str) -> String {
    use std::fmt::Write;
    let s = &r.settings;
    let mut md = String::new();
    let _ = writeln!(md, "## Simulation-based calibration\n");
    let _ = writeln!(md, "Command: `{command}` (seed {}).\n", s.seed);
    let _ = writeln!(
        md,
        "Model `{}`; per replication a first slide of {} s every {} s and a repeat slide of {} s every {} s, \
         fitted with {} ensembles × {} walkers × {} steps; truths ranked among L = {} thinned draws.\n",
        s.model.display(), s.first_duration_s, s.first_interval_s, s.repeat_duration_s,
        s.repeat_interval_s, s.ensembles, s.walkers, s.steps, s.rank_draws
    );
    let _ = writeln!(
        md,
        "Replications: {} with ranks, {} failed; {} fits passed every convergence check; \
         largest R̂ {}; median τ_max {} steps; ranked draws of one walker at least {} τ_max apart; \
         {} prior draws redrawn for stick-slip; median {:.1} s per replication.\n",
        r.succeeded,
        r.failures.len(),
        r.converged,
        r.r_hat_max.map_or("n/a".into(), |v| format!("{v:.4}")),
        r.tau_max_median.map_or("n/a".into(), |v| format!("{v:.0}")),
        r.min_gap_over_tau
            .map_or("n/a".into(), |v| format!("{v:.1}")),
        r.redraws,
        r.wall_s_median
    );
    let _ = writeln!(
        md,
        "| quantity | bins | χ² | dof | p (uniform) | p (quantiles uniform) | 50 % coverage [95 % Wilson] | 95 % coverage [95 % Wilson] |\n|---|---|---|---|---|---|---|---|"
    );
    for q in &r.quantities {
        let c = |c: &Coverage| {
            format!(
                "{:.3} ({}/{}) [{:.3}, {:.3}]",
                c.rate, c.covered, c.n, c.wilson95[0], c.wilson95[1]
            )
        };
        let _ = writeln!(
            md,
            "| `{}` | {} | {:.1} | {} | {:.3} | {} | {} | {} |",
            q.column,
            q.uniformity.counts.len(),
            q.uniformity.chi2,
            q.uniformity.dof,
            q.uniformity.p_value,
            q.quantile_uniformity
                .as_ref()
                .map_or("n/a".into(), |u| format!("{:.3}", u.p_value)),
            c(&q.coverage50),
            c(&q.coverage95)
        );
    }
    let problems = r.gross_problems(limits);
    let _ = writeln!(
        md,
        "\nGross miscalibration (95 % coverage < {:.0} %, 50 % coverage outside [{:.0} %, {:.0} %], p < {:e}, more than {:.0} % failed fits): {}",
        100.0 * limits.min_coverage95,
        100.0 * limits.coverage50[0],
        100.0 * limits.coverage50[1],
        limits.min_p_value,
        100.0 * limits.max_failed_fraction,
        if problems.is_empty() { "none.".to_string() } else { problems.join("; ") }
    );
    for (i, f) in &r.failures {
        let _ = writeln!(md, "\n- replication {i} failed: {f}");
    }
    md
}
