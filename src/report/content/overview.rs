//! The sections a reader meets first: at a glance, how the run was made, the data.

use super::*;
use crate::fit::FitSummary;

/// One material comparison as the report words it: the quantity (its symbol, and what a mean
/// is over), A, B, P(A > B), and the difference's and ratio's median with 95 % interval.
pub(super) struct MaterialComparison {
    pub(super) name: String,
    pub(super) symbol: String,
    pub(super) a: String,
    pub(super) b: String,
    pub(super) p_a_greater: f64,
    pub(super) difference: String,
    pub(super) ratio: String,
}

/// Per kept draw, the mean of `columns` (the draws behind an aggregate's density), read one
/// column at a time: each draw's sum is taken in column order from -0.0, as `.sum()`.
pub(super) fn mean_draws(ctx: &Context, columns: &[String]) -> Option<Vec<f64>> {
    let mut sum = vec![-0.0; ctx.kept.len()];
    for c in columns {
        for (s, v) in sum.iter_mut().zip(ctx.kept_column(c)?) {
            *s += v;
        }
    }
    (!columns.is_empty()).then(|| sum.into_iter().map(|s| s / columns.len() as f64).collect())
}

/// The aggregates of the summary named `name` (one per material that has one).
pub(super) fn aggregates<'a>(
    ctx: &'a Context,
    name: &'a str,
) -> impl Iterator<Item = &'a AggregateSummary> {
    ctx.inputs
        .summary
        .aggregates
        .iter()
        .filter(move |a| a.name == name)
}

/// The fit's material comparisons, in words.
pub(super) fn material_comparisons(ctx: &Context) -> Vec<MaterialComparison> {
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

pub(super) fn glance(ctx: &Context, comparisons: &[MaterialComparison]) -> Vec<Block> {
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
    let lines = problem_lines(
        problems,
        sampler.steps,
        sampler.burn_in,
        sampler.walkers * sampler.ensembles,
    );
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
    blocks.extend(cross_validation(summary));
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

/// How well the fit predicts points it has not seen: leave-one-out, k-fold, or why
/// leave-one-out was not computed.
fn cross_validation(summary: &FitSummary) -> Vec<Block> {
    let mut blocks = Vec::new();
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
    blocks
}

pub(super) fn provenance(ctx: &Context) -> Vec<Block> {
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

pub(super) fn data_section(ctx: &Context) -> Vec<Block> {
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
