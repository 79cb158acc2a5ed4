//! The report's sections, from the run's files (the curves the data do not sample included,
//! which the fit redrew from the posterior).

use std::collections::BTreeMap;

use super::contours::{bin, Histogram2d, BINS};
use super::document::Block;
use super::inputs::{coverage_95, RunInputs};
use super::plots::{
    corner_figure, distance_figure, fit_figure, forest_figure, peak_density, peak_density_figure,
    peak_t0_figure, trace_figure, trace_stride, velocity_text, CornerColumn, CornerData,
    ForestPanel, ForestRow, PeakDraws, RankCounts, RunView, TracePanel,
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
pub struct Content {
    /// Title.
    pub title: String,
    /// Blocks in order (figures included).
    pub blocks: Vec<Block>,
}

/// Greek and sub-scripted names for the quantities slipbayes reports.
pub fn symbol(name: &str) -> String {
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
pub fn run_views(spec: &ModelSpec) -> Vec<RunView> {
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

/// One material comparison as the report words it: the quantity (its symbol, and what a mean
/// is over), A, B, P(A > B), and the difference's and ratio's median with 95 % interval.
struct MaterialComparison {
    name: String,
    symbol: String,
    a: String,
    b: String,
    p_a_greater: f64,
    difference: String,
    ratio: String,
}

/// Per kept draw, the mean of `columns` (the draws behind an aggregate's density), read one
/// column at a time: each draw's sum is taken in column order from -0.0, as `.sum()`.
fn mean_draws(ctx: &Context, columns: &[String]) -> Option<Vec<f64>> {
    let mut sum = vec![-0.0; ctx.kept.len()];
    for c in columns {
        for (s, v) in sum.iter_mut().zip(ctx.kept_column(c)?) {
            *s += v;
        }
    }
    (!columns.is_empty()).then(|| sum.into_iter().map(|s| s / columns.len() as f64).collect())
}

/// The aggregates of the summary named `name` (one per material that has one).
fn aggregates<'a>(ctx: &'a Context, name: &'a str) -> impl Iterator<Item = &'a AggregateSummary> {
    ctx.inputs
        .summary
        .aggregates
        .iter()
        .filter(move |a| a.name == name)
}

/// The fit's material comparisons, in words.
fn material_comparisons(ctx: &Context) -> Vec<MaterialComparison> {
    let stats_text = |s: &Summary, u: &DisplayUnit| {
        format!(
            "{} [{}, {}]",
            significant(u.show(s.median), 4),
            significant(u.show(s.ci_low), 4),
            significant(u.show(s.ci_high), 4)
        )
    };
    ctx.inputs
        .summary
        .comparisons
        .iter()
        .map(|c| {
            let u = DisplayUnit::of_si(&c.unit);
            MaterialComparison {
                name: c.name.clone(),
                symbol: if c.note.is_empty() {
                    symbol(&c.name)
                } else {
                    format!("{} ({})", symbol(&c.name), c.note)
                },
                a: c.group_a.clone(),
                b: c.group_b.clone(),
                p_a_greater: c.p_a_greater,
                difference: format!("{}{}", stats_text(&c.difference, &u), u.suffix()),
                ratio: c.ratio.as_ref().map_or_else(
                    || "–".to_owned(),
                    |r| stats_text(r, &DisplayUnit::of_si("1")),
                ),
            }
        })
        .collect()
}

fn glance(ctx: &Context, comparisons: &[MaterialComparison]) -> Vec<Block> {
    let sampler = &ctx.inputs.summary.sampler;
    let n = ctx.quantities.len();
    let problems = &sampler.problems;
    let title = if sampler.converged {
        format!(
            "converged: all {n} reported quantities have R̂ < {RHAT_MAX}, ESS bulk and tail > {ESS_MIN:.0} and a trusted autocorrelation time"
        )
    } else {
        let flagged = ctx.quantities.iter().filter(|q| ctx.flagged(q)).count();
        format!(
            "not converged: {} problem(s), {flagged} of {n} reported quantities affected; do not trust them yet",
            problems.len()
        )
    };
    // One line per kind of problem; every single one is listed under Diagnostics.
    let lines = problem_lines(problems, sampler.steps, sampler.burn_in);
    let mut blocks = vec![
        heading(1, "glance", "At a glance"),
        Block::Verdict {
            ok: sampler.converged,
            title,
            lines,
        },
    ];
    let coverage: Vec<String> = ctx
        .runs
        .iter()
        .zip(&ctx.predictive)
        .map(|(r, p)| {
            format!(
                "{}: {:.1} % of {} data points inside the 95 % predictive band",
                r.name,
                100.0 * coverage_95(p),
                p.time_s.len()
            )
        })
        .collect();
    blocks.push(Block::Paragraph(
        "Does the model fit the data? About 95 % of the points should fall inside the 95 % posterior predictive band of their run:".into(),
    ));
    blocks.push(Block::List(coverage));
    let peaks: Vec<String> = ctx
        .slides()
        .filter_map(|(_, r)| ctx.find("F_peak", &r.name))
        .map(|q| format!("{} = {} (median, 95 % interval)", label(q), interval(q)))
        .chain(
            ctx.quantities
                .iter()
                .filter(|q| q.name == "F_peak_new")
                .map(|q| format!("{} (a new contact) = {}", label(q), interval(q))),
        )
        .collect();
    if !peaks.is_empty() {
        blocks.push(Block::Paragraph("Peak static friction:".into()));
        blocks.push(Block::List(peaks));
    }
    let summary = &ctx.inputs.summary;
    if let Some(loo) = &summary.loo {
        let points: usize = loo.runs.iter().map(|r| r.points).sum();
        blocks.push(Block::Paragraph(format!(
            "How well does it predict a point it has not seen? Leave-one-out (PSIS-LOO, {} draws): \
             elpd_loo = {:.1} ± {:.1}, p_loo = {:.1} effective parameters; {} of {} points have a \
             Pareto k̂ above {:.2} (their estimates are unreliable); slipbayes compare ranks \
             fits of the same data by it.",
            loo.draws, loo.elpd_loo, loo.se, loo.p_loo, loo.unreliable_points, points, loo.good_k
        )));
        if loo.unreliable_points > 0 && summary.kfold.is_none() {
            blocks.push(Block::Paragraph(
                "Where points have a Pareto k̂ above the good k̂, their leave-one-out estimate \
                 is unreliable: slipbayes kfold DIR cross-validates the fit by refitting it \
                 without blocks of its points, and compare then ranks by that."
                    .into(),
            ));
        }
    }
    if let Some(k) = &summary.kfold {
        blocks.push(Block::Paragraph(format!(
            "K-fold cross-validation by time blocks ({} folds, each leaving out blocks of time \
             spread over every run and refitted): elpd_kfold = {:.1} ± {:.1}{}.",
            k.folds,
            k.elpd_kfold,
            k.se,
            k.p_kfold
                .map_or(String::new(), |p| format!(", p_kfold = {p:.1}"))
        )));
    }
    if let (None, Some(reason)) = (&summary.loo, &summary.loo_not_computed) {
        blocks.push(Block::Paragraph(format!(
            "Leave-one-out (PSIS-LOO) was not computed: {reason}."
        )));
    }
    if let Some(model) = summary.model.as_ref().filter(|m| !m.unread.is_empty()) {
        blocks.push(Block::Paragraph(format!(
            "Settings of the model file not read by this model (law = \"{}\", elastic = {}; \
             their parameters are not sampled): {}.",
            model.law,
            model.elastic,
            model.unread.join(", ")
        )));
    }
    let notes = &summary.notes;
    if !notes.is_empty() {
        blocks.push(Block::Paragraph("What the data do not show:".into()));
        blocks.push(Block::List(notes.clone()));
    }
    if !comparisons.is_empty() {
        blocks.push(Block::Paragraph("Do the materials differ?".into()));
        blocks.push(Block::List(
            comparisons
                .iter()
                .map(|c| {
                    format!(
                        "P({}[{}] > {}[{}]) = {:.3}",
                        c.symbol, c.a, c.symbol, c.b, c.p_a_greater
                    )
                })
                .collect(),
        ));
    }
    blocks
}

fn provenance(ctx: &Context) -> Vec<Block> {
    let record = &ctx.inputs.record;
    let s = &ctx.inputs.summary.sampler;
    let command = record
        .command
        .iter()
        .map(|a| {
            if a.contains(char::is_whitespace) {
                format!("'{a}'")
            } else {
                a.clone()
            }
        })
        .collect::<Vec<_>>()
        .join(" ");
    vec![
        heading(1, "provenance", "How this was produced"),
        Block::List(vec![
            format!("command: {command}"),
            format!("model file: {} (the exact model fitted is model.toml beside this report)", record.model_file),
            format!("seed: {}", s.seed),
            format!("slipbayes version: {}", record.slipbayes_version),
            format!(
                "sampler: {} ensembles × {} walkers × {} steps, burn-in {}, {} draws kept (every post-burn-in step), {} sampled dimensions",
                s.ensembles, s.walkers, s.steps, s.burn_in, s.draws, record.dimension
            ),
            format!("wall time: {:.1} s", s.wall_s),
        ]),
    ]
}

fn data_section(ctx: &Context) -> Vec<Block> {
    let records = &ctx.inputs.summary.data;
    if records.is_empty() {
        return Vec::new();
    }
    let rows: Vec<Vec<String>> = records
        .iter()
        .map(|d| {
            vec![
                d.run.clone(),
                d.file.clone(),
                d.format.clone(),
                d.points_read.to_string(),
                d.points_used.to_string(),
                d.dropped_invalid.to_string(),
                d.window_s.map_or_else(
                    || "all".to_owned(),
                    |[lo, hi]| format!("{} – {} s", significant(lo, 4), significant(hi, 4)),
                ),
                d.binning.as_ref().map_or_else(
                    || "none".to_owned(),
                    |b| {
                        format!(
                            "{} bins of {} points (degree {}), {} points exact; |Δ log L| ≤ {} \
                             (asked ≤ {})",
                            b.bins,
                            significant(b.points_per_bin, 3),
                            b.degree,
                            b.exact_points,
                            significant(b.bound, 2),
                            significant(b.tolerance, 2)
                        )
                    },
                ),
                if d.conversions.is_empty() {
                    "none".to_owned()
                } else {
                    d.conversions.join("; ")
                },
            ]
        })
        .collect();
    let flagged = records.iter().map(|d| d.dropped_invalid > 0).collect();
    vec![
        heading(1, "data", "Data"),
        Block::Paragraph(
            "How each run's file was read; rows with dropped invalid points are marked.".into(),
        ),
        table(
            &[
                "run",
                "file",
                "format",
                "points read",
                "points used",
                "dropped invalid",
                "window",
                "binning",
                "conversions",
            ],
            rows,
            flagged,
        ),
    ]
}

fn figure(file: String, caption: String, svg: String) -> Block {
    Block::Figure { file, caption, svg }
}

fn fit_section(ctx: &Context) -> Result<Vec<Block>, ReportError> {
    let mut blocks = vec![
        heading(1, "fit", "Fit to the data"),
        Block::Paragraph(
            "Each run: data (open circles; at most 500 points shown), the posterior median of the model and its 50 % and 95 % posterior predictive bands (model plus noise) in the instrument's time. First and fast slides also in interface time τ = t − F/(kv), with the elastic part of the machine removed as in the paper's Fig. 1(b): the data are moved to their interface time with the posterior median k, and the law F(τ) is redrawn from 200 posterior draws.".into(),
        ),
    ];
    for (i, run) in ctx.runs.iter().enumerate() {
        let file = format!("fit-{}.svg", run.name);
        let svg = fit_figure(run, ctx.predictive[i], ctx.curves[i]);
        let caption = match run.scene {
            Scene::Repeat => format!(
                "{}: repeat slide at {}; elastic loading up to where the previous slide stopped.",
                run.name,
                velocity_text(run.velocity_m_per_s)
            ),
            Scene::StiffFast => format!(
                "{}: fast slide at {}, declared stiff (τ = t).",
                run.name,
                velocity_text(run.velocity_m_per_s)
            ),
            Scene::First => format!(
                "{}: first slide at {}; left in observed time, right in interface time.",
                run.name,
                velocity_text(run.velocity_m_per_s)
            ),
        };
        blocks.push(figure(file, caption, svg));
    }
    // Contacts with slides, in model order.
    let mut contacts: Vec<&str> = Vec::new();
    for (_, r) in ctx.slides() {
        if !contacts.contains(&r.contact.as_str()) {
            contacts.push(&r.contact);
        }
    }
    for contact in contacts {
        let slides: Vec<(&RunView, &Band, &InterfaceCurve)> = ctx
            .slides()
            .filter(|(_, r)| r.contact == contact)
            .filter_map(|(i, r)| ctx.curves[i].map(|c| (r, ctx.predictive[i], c)))
            .collect();
        let file = format!("distance-{contact}.svg");
        // Data that never slide (no positive distance) have nothing to show on a log axis.
        let Some(svg) = distance_figure(contact, &slides) else {
            continue;
        };
        blocks.push(figure(
            file,
            format!(
                "Contact {contact} against sliding distance x = vτ on a logarithmic axis (the paper's Fig. 2), from the first positive distance of the data to the end of the longest slide: the rise while the interface barely slides, the peak, and the relaxation to F_d. Slides at different velocities coincide when the state of the interface depends on distance alone."
            ),
            svg,
        ));
    }
    Ok(blocks)
}

fn peak_section(ctx: &Context) -> Result<Vec<Block>, ReportError> {
    let mut blocks = vec![
        heading(1, "peak", "Peak static friction"),
        Block::Paragraph(
            "The peak of F(τ), where a/τ = αv (F − F_d), per posterior draw. Its credible interval carries the uncertainty of every parameter, t0 included.".into(),
        ),
    ];
    let mut density: Vec<PeakDraws> = Vec::new();
    let mut versus_t0: Vec<(String, Vec<(String, PeakVsT0)>)> = Vec::new();
    let mut rows = Vec::new();
    for material in &ctx.materials {
        let mut v = Vec::new();
        for (i, run) in ctx.slides().filter(|(_, r)| &r.material == material) {
            let Some(q) = ctx.find("F_peak", &run.name) else {
                continue;
            };
            let Some(values) = ctx.kept_column(&q.column) else {
                continue;
            };
            let s = &q.stats;
            density.push((
                format!("{} ({material})", run.name),
                peak_density(&values),
                [s.ci_low, s.median, s.ci_high],
            ));
            if let Some(curve) = ctx.peaks_vs_t0[i] {
                v.push((run.name.clone(), curve.clone()));
            }
            let cell = |name: &str| {
                ctx.find(name, &run.name)
                    .map_or_else(|| "–".to_owned(), interval)
            };
            rows.push(vec![
                run.name.clone(),
                velocity_text(run.velocity_m_per_s),
                cell("F_peak"),
                cell("tau_peak"),
                cell("s_peak"),
                cell("t_peak"),
                cell("mu_s"),
            ]);
        }
        if let Some(agg) = aggregates(ctx, "F_peak").find(|a| &a.group == material) {
            if agg.of.len() > 1 {
                if let Some(mean) = mean_draws(ctx, &agg.of) {
                    let s = &agg.stats;
                    let label = format!("{material}: {}", agg.note);
                    density.push((label, peak_density(&mean), [s.ci_low, s.median, s.ci_high]));
                }
            }
        }
        if !v.is_empty() {
            versus_t0.push((material.clone(), v));
        }
    }
    if density.is_empty() {
        blocks.push(Block::Paragraph(
            "No slide of this model has a peak (no first or fast slides).".into(),
        ));
        return Ok(blocks);
    }
    let flagged = vec![false; rows.len()];
    blocks.push(table(
        &[
            "run",
            "velocity",
            "F_peak",
            "τ_peak (interface time)",
            "s_peak = vτ_peak",
            "t_peak (observed)",
            "μ_s = F_peak/F_N",
        ],
        rows,
        flagged,
    ));
    blocks.push(figure(
        "peak-density.svg".to_owned(),
        "Posterior density of the peak static friction per run and, where a material has several first slides, of their mean per draw: the shade is the 95 % interval, the dashed line the median.".to_owned(),
        peak_density_figure(&density),
    ));
    if !versus_t0.is_empty() {
        blocks.push(figure(
            "peak-t0.svg".to_owned(),
            format!(
                "The peak against t0, as in the paper's Fig. 4: for each slide, t0 is varied over {}× below and above its 95 % interval while αv, a and F_d come from {} posterior draws (line: median, shade: 95 %); the markers are the posterior draws of (t0, F_peak) themselves. F_peak grows as ln(1/t0): an uncertain t0 widens the peak's interval.",
                ctx.inputs.curves.t0_span,
                ctx.inputs.curves.draws
            ),
            peak_t0_figure(&versus_t0),
        ));
    }
    Ok(blocks)
}

fn materials_section(
    ctx: &Context,
    comparisons: &[MaterialComparison],
) -> Result<Vec<Block>, ReportError> {
    let mut blocks = vec![heading(1, "materials", "Materials and contacts")];
    let p_text = |name: &str| {
        comparisons
            .iter()
            .filter(|c| c.name == name)
            .map(|c| {
                format!(
                    "P({}[{}] > {}[{}]) = {:.3}",
                    symbol(name),
                    c.a,
                    symbol(name),
                    c.b,
                    c.p_a_greater
                )
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let mut panels = Vec::new();
    for name in ["alpha", "a", "a_over_F_d", "F_d", "F_peak"] {
        let mut rows: Vec<ForestRow> = Vec::new();
        let mut unit = String::new();
        for q in ctx.quantities.iter().filter(|q| q.name == name) {
            let u = DisplayUnit::of_si(&q.unit);
            unit = q.unit.clone();
            let quartiles = ctx
                .kept_column(&q.column)
                .map_or((f64::NAN, f64::NAN), quartiles);
            rows.push(ForestRow {
                label: q.group.clone(),
                median: u.show(q.stats.median),
                low: u.show(q.stats.ci_low),
                high: u.show(q.stats.ci_high),
                quartiles: (u.show(quartiles.0), u.show(quartiles.1)),
                material: ctx.materials.contains(&q.group),
            });
        }
        if rows.is_empty() {
            continue;
        }
        // F_d and F_peak are not material parameters: show the material's mean per draw.
        for agg in aggregates(ctx, name) {
            let u = DisplayUnit::of_si(&agg.unit);
            let quartiles = mean_draws(ctx, &agg.of).map_or((f64::NAN, f64::NAN), quartiles);
            rows.push(ForestRow {
                label: format!("{} (mean)", agg.group),
                median: u.show(agg.stats.median),
                low: u.show(agg.stats.ci_low),
                high: u.show(agg.stats.ci_high),
                quartiles: (u.show(quartiles.0), u.show(quartiles.1)),
                material: true,
            });
        }
        // Materials first, then their contacts and runs, in model order.
        rows.sort_by_key(|r| !r.material);
        let u = DisplayUnit::of_si(&unit);
        let p = p_text(name);
        panels.push(ForestPanel {
            title: if p.is_empty() {
                symbol(name)
            } else {
                format!("{}: {p}", symbol(name))
            },
            axis: format!("{}{}", symbol(name), u.suffix()),
            rows,
        });
    }
    if !panels.is_empty() {
        blocks.push(figure(
            "forest.svg".to_owned(),
            "Forest plot: for each quantity, per material (black) and per contact or run (grey), \
             the 50 % interval as a thick bar, the 95 % interval as a thin bar and the median as \
             a white dot; the numbers beside each row are the median and the 95 % interval (where \
             an interval is narrower than the dot, it is narrower than the figure can show). F_d \
             and F_peak are not material parameters; their material rows are the mean of the \
             material's contacts and the mean of its first slides, per draw."
                .to_owned(),
            forest_figure(&panels),
        ));
    }
    if !comparisons.is_empty() {
        let rows: Vec<Vec<String>> = comparisons
            .iter()
            .map(|c| {
                vec![
                    c.symbol.clone(),
                    c.a.clone(),
                    c.b.clone(),
                    format!("{:.3}", c.p_a_greater),
                    c.difference.clone(),
                    c.ratio.clone(),
                ]
            })
            .collect();
        let flagged = vec![false; rows.len()];
        blocks.push(table(
            &[
                "quantity",
                "A",
                "B",
                "P(A > B)",
                "A − B, median [95 %]",
                "A / B, median [95 %]",
            ],
            rows,
            flagged,
        ));
    }
    Ok(blocks)
}

fn diagnostics_section(ctx: &Context) -> Result<Vec<Block>, ReportError> {
    let s = &ctx.inputs.summary.sampler;
    let mut blocks = vec![
        heading(1, "diagnostics", "Diagnostics"),
        Block::List(vec![
            if s.acceptance.is_nan() {
                // Slice updates always move and are not proposals.
                "acceptance fraction (all walkers): none, every update was a slice update".into()
            } else {
                format!("acceptance fraction (all walkers): {:.3}", s.acceptance)
            },
            format!(
                "autocorrelation time τ: max {} steps, min {} steps, reliable (chains longer than 50 τ): {}",
                s.tau_max.map_or_else(|| "–".into(), |t| significant(t, 3)),
                s.tau_min.map_or_else(|| "–".into(), |t| significant(t, 3)),
                if s.tau_reliable { "yes" } else { "no" }
            ),
            format!("log-density evaluations: {}", s.log_density_evals),
            format!(
                "rejected proposals by reason: {}",
                if s.rejections.is_empty() {
                    "none".to_owned()
                } else {
                    s.rejections
                        .iter()
                        .map(|(k, v)| format!("{k} {v}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                }
            ),
        ]),
    ];
    if !s.problems.is_empty() {
        blocks.push(Block::Details {
            summary: format!("The sampler reports {} problem(s):", s.problems.len()),
            items: s.problems.iter().map(ToString::to_string).collect(),
        });
    }
    let rows: Vec<Vec<String>> = ctx
        .quantities
        .iter()
        .map(|q| {
            let st = &q.stats;
            let u = DisplayUnit::of_si(&q.unit);
            vec![
                label(q),
                st.r_hat.map_or_else(|| "–".into(), |r| format!("{r:.4}")),
                format!("{:.0}", st.ess_bulk),
                format!("{:.0}", st.ess_tail),
                format!("{} {}", significant(u.show(st.mcse_mean), 3), u.label)
                    .trim_end()
                    .to_owned(),
                st.tau.map_or_else(|| "–".into(), |t| significant(t, 3)),
            ]
        })
        .collect();
    let flagged = ctx.quantities.iter().map(|q| ctx.flagged(q)).collect();
    blocks.push(Block::Paragraph(format!(
        "Per quantity: R̂ between ensembles (rank-normalised), ESS bulk and tail, MCSE of the mean, and τ in steps, all on every post-burn-in draw. Rows of quantities the fit's verdict names (R̂ < {RHAT_MAX}, ESS > {ESS_MIN:.0}, τ trusted) are marked."
    )));
    blocks.push(table(
        &[
            "quantity",
            "R̂",
            "ESS bulk",
            "ESS tail",
            "MCSE mean",
            "τ (steps)",
        ],
        rows,
        flagged,
    ));
    blocks.extend(trace_blocks(ctx)?);
    blocks.extend(corner_blocks(ctx)?);
    Ok(blocks)
}

fn trace_blocks(ctx: &Context) -> Result<Vec<Block>, ReportError> {
    let chains = &ctx.inputs.chains;
    let mut panels = Vec::new();
    for q in ctx
        .inputs
        .summary
        .parameters
        .iter()
        .filter(|q| q.name != "sigma")
    {
        let u = DisplayUnit::of_si(&q.unit);
        let Ok(mut panel) =
            trace_panel(chains, &q.column, format!("{}{}", label(q), u.suffix()), &u)
        else {
            continue;
        };
        panel.ranks = rank_counts(ctx, &q.column);
        panels.push(panel);
    }
    let mut blocks = Vec::new();
    let figures = panels.len().div_ceil(TRACES_PER_FIGURE);
    let s = &ctx.inputs.summary.sampler;
    let shown = chains.walkers().min(TRACE_WALKERS);
    for (k, chunk) in panels.chunks(TRACES_PER_FIGURE).enumerate() {
        let file = format!("trace-{}.svg", k + 1);
        let svg = trace_figure(chunk, s.burn_in, chains.ensembles());
        let ranks = if chains.ensembles() > 1 {
            format!(
                " Right: rank plots (ArviZ's plot_rank): each kept draw is ranked among the kept draws of all {} ensembles, and each ensemble's ranks are counted in {RANK_BINS} bins; when the ensembles sample the same distribution every bar is near the dashed line (what uniform ranks give), while an ensemble stuck high or low piles its bars at one end.",
                chains.ensembles()
            )
        } else {
            String::new()
        };
        blocks.push(figure(
            file,
            format!(
                "Trace plots ({} of {figures}). Left: {shown} of the {} walkers of each ensemble (spread evenly over the ensemble), ensembles told apart by ink; the red line ends the burn-in ({} steps).{ranks} Noise levels σ are left out (they are drawn from their conditional posterior, not sampled).",
                k + 1,
                chains.walkers(),
                s.burn_in
            ),
            svg,
        ));
    }
    Ok(blocks)
}

/// The walkers a trace shows: [`TRACE_WALKERS`] of `walkers`, spread evenly (all of them
/// when there are fewer).
fn shown_walkers(walkers: usize) -> Vec<usize> {
    let n = walkers.min(TRACE_WALKERS);
    (0..n).map(|i| i * walkers / n.max(1)).collect()
}

/// The trace panel of column `column`: the [`shown_walkers`] of every ensemble, read one row
/// group at a time, keeping the points drawn and the range of all (so that memory holds a
/// few hundred points per walker, whatever the length of the run).
fn trace_panel(
    chains: &ChainReader,
    column: &str,
    title: String,
    u: &DisplayUnit,
) -> Result<TracePanel, StorageError> {
    let ensembles = chains.ensembles();
    let shown = shown_walkers(chains.walkers());
    // Position of each walker among those shown.
    let mut slot = vec![None; chains.walkers()];
    for (i, &w) in shown.iter().enumerate() {
        slot[w] = Some(i);
    }
    let steps = chains.steps() as usize;
    let stride = trace_stride(steps);
    let mut points = vec![vec![Vec::new(); shown.len()]; ensembles];
    let empty = (f64::INFINITY, f64::NEG_INFINITY);
    let mut bounds = vec![vec![empty; shown.len()]; ensembles];
    chains.for_each_chunk::<StorageError>(&[column], 0, |first, chunks| {
        for (k, &x) in chunks[0].iter().enumerate() {
            let (step, e, w) = chains.locate(first + k);
            if let Some(i) = slot[w] {
                let v = u.show(x);
                bounds[e][i] = extend_bounds(bounds[e][i], v);
                if step as usize % stride == 0 {
                    points[e][i].push((step as f64, v));
                }
            }
        }
        Ok(())
    })?;
    // Walker after walker, each in step order, as the range of all values is folded.
    let range = bounds.iter().flatten().fold(empty, |b, &(lo, hi)| {
        extend_bounds(extend_bounds(b, lo), hi)
    });
    Ok(TracePanel {
        title,
        steps,
        points,
        range,
        ranks: None,
    })
}

/// The rank counts of `column` (ArviZ's rank plot): its kept draws, one column in memory,
/// ranked among all ensembles' (ties share their mean rank), counted per ensemble in
/// [`RANK_BINS`] bins. `None` with one ensemble or when the column cannot be read.
fn rank_counts(ctx: &Context, column: &str) -> Option<RankCounts> {
    let chains = &ctx.inputs.chains;
    let ensembles = chains.ensembles();
    if ensembles < 2 {
        return None;
    }
    let values = ctx.kept_column(column)?;
    let n = values.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| values[a].total_cmp(&values[b]));
    let mut counts = vec![vec![0.0; RANK_BINS]; ensembles];
    let mut start = 0;
    while start < n {
        let mut end = start + 1;
        while end < n && values[order[end]].total_cmp(&values[order[start]]).is_eq() {
            end += 1;
        }
        // Ranks start..end share their mean, (start + end - 1) / 2 counted from 0.
        let rank = 0.5 * (start + end - 1) as f64;
        let b = ((rank / n as f64 * RANK_BINS as f64) as usize).min(RANK_BINS - 1);
        for &i in &order[start..end] {
            let (_, e, _) = chains.locate(ctx.kept[i]);
            counts[e][b] += 1.0;
        }
        start = end;
    }
    Some(RankCounts { ranks: n, counts })
}

/// The 25 and 75 % quantiles of `values` (NaN when none is finite).
fn quartiles(mut values: Vec<f64>) -> (f64, f64) {
    values.retain(|v| v.is_finite());
    values.sort_by(f64::total_cmp);
    let q = |p| quantile(&values, p).unwrap_or(f64::NAN);
    (q(0.25), q(0.75))
}

fn corner_blocks(ctx: &Context) -> Result<Vec<Block>, ReportError> {
    let mut blocks = Vec::new();
    for material in &ctx.materials {
        let Some((_, run)) = ctx
            .slides()
            .find(|(_, r)| &r.material == material && r.scene == Scene::First)
            .or_else(|| ctx.slides().find(|(_, r)| &r.material == material))
        else {
            continue;
        };
        let groups = [material.as_str(), run.contact.as_str(), run.name.as_str()];
        let chosen: Vec<&QuantitySummary> = ctx
            .inputs
            .summary
            .parameters
            .iter()
            .filter(|q| q.name != "sigma" && groups.contains(&q.group.as_str()))
            .collect();
        let Some(data) = corner_data(ctx, &chosen) else {
            continue;
        };
        let truth = data.columns.iter().all(|c| c.truth.is_some());
        let file = format!("corner-{material}.svg");
        let svg = corner_figure(&file, &data)?;
        let truth_text = if truth {
            format!(
                " The blue lines and squares are the simulation's true values, read from the JSON that `slipbayes simulate` wrote beside each data file ({}).",
                ctx.truths.files.join(", ")
            )
        } else {
            String::new()
        };
        blocks.push(figure(
            file,
            format!(
                "Corner plot of {material}'s main parameters as they enter run {} ({} kept draws): on the diagonal each parameter's histogram, its 16, 50 and 84 % quantiles dashed and, above it, the median with the distances to the 16 and 84 % quantiles; below the diagonal each pair's smoothed histogram with contours enclosing 0.5, 1, 1.5 and 2 σ of a 2-D Gaussian (12, 39, 68 and 86 % of the draws).{truth_text}",
                run.name,
                ctx.kept.len()
            ),
            svg,
        ));
    }
    Ok(blocks)
}

/// The corner plot's numbers for the quantities `chosen`, in two passes over the kept draws:
/// one quantity at a time for its range, histogram and quantiles, then one row group at a time
/// for the 2-D histogram of every pair. `None` for fewer than two readable quantities.
fn corner_data(ctx: &Context, chosen: &[&QuantitySummary]) -> Option<CornerData> {
    let mut columns = Vec::new();
    let mut names = Vec::new();
    let mut units = Vec::new();
    for q in chosen {
        let Some(mut values) = ctx.kept_column(&q.column) else {
            continue;
        };
        let u = DisplayUnit::of_si(&q.unit);
        values.retain(|v| v.is_finite());
        values.iter_mut().for_each(|v| *v = u.show(*v));
        values.sort_by(f64::total_cmp);
        let at = |p| quantile(&values, p).unwrap_or(f64::NAN);
        let truth = ctx.truths.of(&q.name, &q.group).map(|t| u.show(t));
        let mut range = (at(0.0005), at(0.9995));
        if let Some(t) = truth {
            range = (range.0.min(t), range.1.max(t));
        }
        let range = crate::plot::padded(range, 0.06);
        let mut hist = vec![0.0; BINS];
        for &v in &values {
            if let Some(b) = bin(v, range, BINS) {
                hist[b] += 1.0;
            }
        }
        columns.push(CornerColumn {
            name: format!("{}{}", label(q), u.suffix()),
            range,
            hist,
            quantiles: [at(0.16), at(0.5), at(0.84)],
            truth,
        });
        names.push(q.column.as_str());
        units.push(u);
    }
    if columns.len() < 2 {
        return None;
    }
    let mut pairs = Vec::new();
    for i in 1..columns.len() {
        for j in 0..i {
            pairs.push(Histogram2d::new(columns[j].range, columns[i].range, BINS));
        }
    }
    // The kept rows are every `every`-th row from the first kept one.
    let first = *ctx.kept.first()?;
    let every = ctx.kept.get(1).map_or(1, |second| second - first);
    let first_step = ctx.inputs.chains.locate(first).0;
    let read =
        ctx.inputs
            .chains
            .for_each_chunk::<StorageError>(&names, first_step, |start, chunks| {
                for k in 0..chunks[0].len() {
                    let row = start + k;
                    if row < first || (row - first) % every != 0 {
                        continue;
                    }
                    let shown: Vec<f64> = chunks
                        .iter()
                        .zip(&units)
                        .map(|(c, u)| u.show(c[k]))
                        .collect();
                    let mut p = 0;
                    for i in 1..shown.len() {
                        for j in 0..i {
                            pairs[p].add(shown[j], shown[i]);
                            p += 1;
                        }
                    }
                }
                Ok(())
            });
    read.ok()?;
    Some(CornerData { columns, pairs })
}

fn summary_section(ctx: &Context) -> Vec<Block> {
    let hdi_prob = ctx.quantities.first().map_or(0.95, |q| q.stats.hdi_prob);
    let lo = format!("hdi_{}%", crate::plot::tick(50.0 * (1.0 - hdi_prob)));
    let hi = format!("hdi_{}%", crate::plot::tick(50.0 * (1.0 + hdi_prob)));
    let rows: Vec<Vec<String>> = ctx
        .quantities
        .iter()
        .map(|q| {
            let s = &q.stats;
            let u = DisplayUnit::of_si(&q.unit);
            let v = |x: f64| significant(u.show(x), 4);
            vec![
                label(q),
                u.label.clone(),
                v(s.mean),
                v(s.sd),
                v(s.hdi_low),
                v(s.hdi_high),
                v(s.mcse_mean),
                v(s.mcse_sd),
                format!("{:.0}", s.ess_bulk),
                format!("{:.0}", s.ess_tail),
                s.r_hat.map_or_else(|| "–".into(), |r| format!("{r:.4}")),
            ]
        })
        .collect();
    let flagged = ctx.quantities.iter().map(|q| ctx.flagged(q)).collect();
    let header = [
        "quantity",
        "unit",
        "mean",
        "sd",
        &lo,
        &hi,
        "mcse_mean",
        "mcse_sd",
        "ess_bulk",
        "ess_tail",
        "r_hat",
    ];
    let mut units: BTreeMap<String, String> = BTreeMap::new();
    for q in &ctx.quantities {
        let u = DisplayUnit::of_si(&q.unit);
        if !u.label.is_empty() && u.label != q.unit {
            units.insert(q.unit.clone(), u.label.clone());
        }
    }
    vec![
        heading(1, "summary", "Summary table"),
        Block::Paragraph(format!(
            "ArviZ's columns, in the units users think in ({}); summary.csv beside this report holds the same in SI with full precision.",
            units
                .iter()
                .map(|(si, shown)| format!("{si} shown as {shown}"))
                .collect::<Vec<_>>()
                .join(", ")
        )),
        table(&header, rows, flagged),
    ]
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
