//! The report's sections, from the run's files (the curves the data do not sample included,
//! which the fit redrew from the posterior): the context they share and the document they
//! make, here; the sections themselves by concern:
//!
//! - `overview`: at a glance, provenance, data;
//! - `figures`: the fit to the data, the peak, the materials;
//! - `diagnostics`: convergence (traces, ranks, the corner plot) and the summary table.

mod diagnostics;
mod figures;
mod overview;

use diagnostics::{diagnostics_section, summary_section};
use figures::{fit_section, materials_section, peak_section};
use overview::{data_section, glance, material_comparisons, provenance};

use std::collections::BTreeMap;

use super::document::Block;
use super::inputs::{coverage_95, RunInputs};
use super::plots::{
    corner_figure, distance_figure, fit_figure, forest_figure, peak_density, peak_density_figure,
    peak_t0_figure, trace_figure, trace_stride, velocity_text, CornerColumn, CornerData,
    ForestPanel, ForestRow, PeakDraws, RankCounts, RunView, TracePanel, FOREST_LISTED_ROWS,
};
use super::truth::Truths;
use super::units::{significant, DisplayUnit};
use super::ReportError;
use crate::diagnostics::{problem_lines, quantile, Summary, ESS_MIN, RHAT_MAX};
use crate::fit::run_dir::{InterfaceCurve, PeakVsT0};
use crate::fit::{kept_rows, AggregateSummary, QuantitySummary};
use crate::law::Scene;
use crate::model::{Band, ModelSpec};
use crate::plot::extend_bounds;
use crate::storage::{ChainReader, StorageError};

/// Walkers per ensemble shown in the trace plots, spread evenly over the ensemble.
const TRACE_WALKERS: usize = 8;
/// Bins of a rank plot.
const RANK_BINS: usize = 20;
/// Parameters per trace figure.
const TRACES_PER_FIGURE: usize = 8;
/// Draws behind a figure's densities, spread evenly over the kept draws: all of them in runs
/// of ordinary length (the demo keeps 138,240), while the figures of a long campaign hold a
/// bounded number per quantity. The numbers of the report come from the summary, which uses
/// every kept draw.
const FIGURE_DRAWS: usize = 200_000;

/// A finished report: its blocks and, separately, its figures (file name, SVG).
pub(crate) struct Content {
    /// Title.
    pub title: String,
    /// Blocks in order (figures included).
    pub blocks: Vec<Block>,
}

/// Greek and sub-scripted names for the quantities slipbayes reports.
pub(crate) fn symbol(name: &str) -> String {
    match name {
        "alpha" => "α",
        "a_over_F_d" => "a/F_d",
        "sigma" => "σ",
        "tau_peak" => "τ_peak",
        "mu_s" => "μ_s",
        other => other,
    }
    .to_owned()
}

fn label(q: &QuantitySummary) -> String {
    if q.group.is_empty() {
        symbol(&q.name)
    } else {
        format!("{}[{}]", symbol(&q.name), q.group)
    }
}

fn interval(q: &QuantitySummary) -> String {
    interval_of(&q.stats, &q.unit)
}

/// Median and 95 % interval in the units users think in.
fn interval_of(s: &Summary, unit: &str) -> String {
    let u = DisplayUnit::of_si(unit);
    format!(
        "{} [{}, {}]{}",
        significant(u.show(s.median), 4),
        significant(u.show(s.ci_low), 4),
        significant(u.show(s.ci_high), 4),
        if u.label.is_empty() {
            String::new()
        } else {
            format!(" {}", u.label)
        }
    )
}

fn heading(level: u8, id: &str, text: &str) -> Block {
    Block::Heading {
        level,
        id: id.to_owned(),
        text: text.to_owned(),
    }
}

fn table(header: &[&str], rows: Vec<Vec<String>>, flagged: Vec<bool>) -> Block {
    Block::Table {
        header: header.iter().map(|h| (*h).to_owned()).collect(),
        rows,
        flagged,
    }
}

/// Runs of the model as the report names them.
pub(crate) fn run_views(spec: &ModelSpec) -> Vec<RunView> {
    spec.file
        .runs
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let contact = spec.run_contact[i];
            RunView {
                name: r.name.clone(),
                scene: r.scene,
                velocity_m_per_s: r.velocity_m_per_s,
                contact: spec.file.contacts[contact].name.clone(),
                material: spec.file.materials[spec.contact_material[contact]]
                    .name
                    .clone(),
            }
        })
        .collect()
}

/// Everything the sections share.
struct Context<'a> {
    inputs: &'a RunInputs,
    runs: Vec<RunView>,
    materials: Vec<String>,
    predictive: Vec<&'a Band>,
    /// Per run, the law in interface time (first and fast slides).
    curves: Vec<Option<&'a InterfaceCurve>>,
    /// Per run, the peak against t0 (first and fast slides whose t0 is their own).
    peaks_vs_t0: Vec<Option<&'a PeakVsT0>>,
    quantities: Vec<&'a QuantitySummary>,
    /// Kept rows of the chains (all of them).
    kept: Vec<usize>,
    /// True values of synthetic data, where the data files have them beside them.
    truths: Truths,
}

impl Context<'_> {
    fn find(&self, name: &str, group: &str) -> Option<&QuantitySummary> {
        self.quantities
            .iter()
            .copied()
            .find(|q| q.name == name && q.group == group)
    }

    /// Whether the summary names a convergence problem of `q`.
    fn flagged(&self, q: &QuantitySummary) -> bool {
        self.inputs.summary.problems_of(&q.label()).next().is_some()
    }

    /// The kept rows' values of `column`, read one row group at a time.
    fn kept_column(&self, column: &str) -> Option<Vec<f64>> {
        self.inputs.chains.rows_of(column, &self.kept).ok()
    }

    fn slides(&self) -> impl Iterator<Item = (usize, &RunView)> {
        self.runs
            .iter()
            .enumerate()
            .filter(|(_, r)| r.scene != Scene::Repeat)
    }
}

/// Builds the report's content.
///
/// # Errors
/// [`ReportError`] when the run's files do not match its model, or a figure fails.
pub fn build(inputs: &RunInputs) -> Result<Content, ReportError> {
    let spec = &inputs.run.model;
    let runs = run_views(spec);
    let mismatch = |problem: String| ReportError::Mismatch {
        dir: inputs.dir.path().to_path_buf(),
        problem,
    };
    let predictive: Vec<&Band> = runs
        .iter()
        .map(|r| {
            inputs
                .predictive
                .iter()
                .find(|p| p.run == r.name && !p.time_s.is_empty())
                .ok_or_else(|| {
                    mismatch(format!(
                        "predictive.csv has no rows for run {:?} of model.toml; re-run the fit",
                        r.name
                    ))
                })
        })
        .collect::<Result<_, _>>()?;
    if inputs.curves.draws == 0 {
        return Err(mismatch(
            "curves.json was redrawn from no posterior draw".into(),
        ));
    }
    let curves = runs
        .iter()
        .map(|r| {
            inputs
                .curves
                .runs
                .iter()
                .find(|c| c.run == r.name)
                .ok_or_else(|| {
                    mismatch(format!(
                        "curves.json has no curves for run {:?} of model.toml; re-run the fit",
                        r.name
                    ))
                })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let ctx = Context {
        inputs,
        materials: spec.file.materials.iter().map(|m| m.name.clone()).collect(),
        truths: Truths::new(&runs, &inputs.truths),
        runs,
        predictive,
        curves: curves.iter().map(|c| c.interface.as_ref()).collect(),
        peaks_vs_t0: curves.iter().map(|c| c.peak_vs_t0.as_ref()).collect(),
        quantities: inputs.summary.quantities().collect(),
        kept: kept_rows(&inputs.chains, &inputs.summary.sampler, FIGURE_DRAWS),
    };
    let run_name = inputs.dir.path().file_name().map_or_else(
        || inputs.dir.path().display().to_string(),
        |f| f.to_string_lossy().into_owned(),
    );
    let title = format!("slipbayes report: {run_name}");
    let comparisons = material_comparisons(&ctx);
    let mut blocks = glance(&ctx, &comparisons);
    blocks.extend(provenance(&ctx));
    blocks.extend(data_section(&ctx));
    blocks.extend(fit_section(&ctx)?);
    blocks.extend(peak_section(&ctx)?);
    blocks.extend(materials_section(&ctx, &comparisons)?);
    blocks.extend(diagnostics_section(&ctx)?);
    blocks.extend(summary_section(&ctx));
    Ok(Content { title, blocks })
}

fn figure(file: String, caption: String, svg: String) -> Block {
    Block::Figure { file, caption, svg }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals_are_in_user_units() {
        let s = Summary {
            mean: 0.92e6,
            sd: 1e3,
            median: 0.92e6,
            ci_low: 0.91e6,
            ci_high: 0.93e6,
            ci_prob: 0.95,
            hdi_low: 0.91e6,
            hdi_high: 0.93e6,
            hdi_prob: 0.95,
            ess_bulk: 1e3,
            ess_tail: 1e3,
            r_hat: Some(1.0),
            mcse_mean: 10.0,
            mcse_sd: 5.0,
            ess_mean: 1e3,
            tau: Some(2.0),
            tau_reliable: Some(true),
        };
        assert_eq!(interval_of(&s, "1/m"), "0.9200 [0.9100, 0.9300] µm⁻¹");
    }
}
