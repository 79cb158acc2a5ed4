//! Whether the sampler converged (traces, rank plots, the corner plot) and the summary of
//! every quantity.

use super::*;
use crate::report::contours::{bin, Histogram2d, BINS};

pub(super) fn diagnostics_section(ctx: &Context) -> Result<Vec<Block>, ReportError> {
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
                "autocorrelation time τ: max {} steps, min {} steps, trusted (post-burn-in chains of 1,600 walker-steps per τ): {}",
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

/// Trace panels a report draws at most: beyond them (a campaign of 200 contacts has 600
/// parameters, 100 figures of traces), those of the materials and the worst mixed.
pub(super) const TRACED_PARAMETERS: usize = 36;

/// The parameters whose traces are drawn: every one up to [`TRACED_PARAMETERS`]; beyond, the
/// materials' (their groups are no contact's or run's) and then the lowest bulk ESS of the
/// rest, in the summary's order; with the sentence that says so.
fn traced<'a>(ctx: &'a Context<'a>) -> (Vec<&'a QuantitySummary>, Option<String>) {
    let all: Vec<&QuantitySummary> = ctx
        .inputs
        .summary
        .parameters
        .iter()
        .filter(|q| q.name != "sigma")
        .collect();
    if all.len() <= TRACED_PARAMETERS {
        return (all, None);
    }
    let material = |q: &QuantitySummary| ctx.materials.contains(&q.group);
    let mut rest: Vec<usize> = (0..all.len()).filter(|&k| !material(all[k])).collect();
    rest.sort_by(|&a, &b| {
        all[a]
            .stats
            .ess_bulk
            .total_cmp(&all[b].stats.ess_bulk)
            .then(a.cmp(&b))
    });
    let room = TRACED_PARAMETERS.saturating_sub(all.len() - rest.len());
    let mut keep: Vec<usize> = (0..all.len()).filter(|&k| material(all[k])).collect();
    keep.extend(rest.into_iter().take(room));
    keep.sort_unstable();
    let sentence = format!(
        "{} parameters: the traces below are of {} of them, the materials' and those of the lowest bulk ESS (the slowest to mix); every parameter's R̂ and ESS are in the table above and in summary.csv.",
        all.len(),
        keep.len()
    );
    (keep.into_iter().map(|k| all[k]).collect(), Some(sentence))
}

fn trace_blocks(ctx: &Context) -> Result<Vec<Block>, ReportError> {
    let chains = &ctx.inputs.chains;
    let mut panels = Vec::new();
    let (quantities, sentence) = traced(ctx);
    for q in quantities {
        let u = DisplayUnit::of_si(&q.unit);
        let Ok(mut panel) =
            trace_panel(chains, &q.column, format!("{}{}", label(q), u.suffix()), &u)
        else {
            continue;
        };
        panel.ranks = rank_counts(ctx, &q.column);
        panels.push(panel);
    }
    let mut blocks: Vec<Block> = sentence.into_iter().map(Block::Paragraph).collect();
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
pub(super) fn quartiles(mut values: Vec<f64>) -> (f64, f64) {
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

pub(super) fn summary_section(ctx: &Context) -> Vec<Block> {
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
