//! The sections of figures: the fit to the data, the peak static friction, the materials
//! and contacts.

use super::diagnostics::quartiles;
use super::overview::{aggregates, mean_draws, MaterialComparison};
use super::*;

pub(super) fn fit_section(ctx: &Context) -> Result<Vec<Block>, ReportError> {
    let mut blocks = vec![
        heading(1, "fit", "Fit to the data"),
        Block::Paragraph(
            "Each run: data (open circles; at most 500 points shown), the posterior median of the model and its 50 % and 95 % posterior predictive bands (model plus noise) in the instrument's time. First and fast slides also in interface time τ = t − F/(kv), with the elastic part of the machine removed as in the paper's Fig. 1(b): the data are moved to their interface time with the posterior median k, and the law F(τ) is redrawn from 200 posterior draws.".into(),
        ),
    ];
    let shown = shown_contacts(ctx);
    if let Some(shown) = &shown {
        blocks.push(Block::Paragraph(shown.sentence.clone()));
    }
    let drawn = |contact: &str| shown.as_ref().is_none_or(|s| s.contacts.contains(contact));
    for (i, run) in ctx.runs.iter().enumerate() {
        if !drawn(&run.contact) {
            continue;
        }
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
    for contact in contacts.into_iter().filter(|c| drawn(c)) {
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

/// Contacts whose figures a report draws when it has more than this many: each contact's
/// figures are about 0.5 MB of SVG, and 200 contacts made a report of 105 MB that a browser
/// opens slowly and nobody reads to the end.
pub(super) const FIGURED_CONTACTS: usize = 12;

/// The contacts a report of many contacts draws, and the sentence that says which.
pub(super) struct ShownContacts {
    pub contacts: std::collections::HashSet<String>,
    pub sentence: String,
}

/// With more than [`FIGURED_CONTACTS`] contacts, which to draw: the half whose data fall
/// outside their 95 % posterior predictive band most often (a contact the model does not
/// describe is what a scientist must see), and the other half spread evenly over the rest in
/// model order (what a typical contact looks like). `None`: every contact is drawn.
pub(super) fn shown_contacts(ctx: &Context) -> Option<ShownContacts> {
    let mut order: Vec<&str> = Vec::new();
    for r in &ctx.runs {
        if !order.contains(&r.contact.as_str()) {
            order.push(&r.contact);
        }
    }
    if order.len() <= FIGURED_CONTACTS {
        return None;
    }
    // Per contact, the largest fraction of any of its runs' points outside the band.
    let outside = |contact: &str| {
        ctx.runs
            .iter()
            .zip(&ctx.predictive)
            .filter(|(r, _)| r.contact == contact)
            .map(|(_, band)| 1.0 - coverage_95(band))
            .fold(0.0, f64::max)
    };
    let mut by_misfit: Vec<(usize, f64)> = order
        .iter()
        .enumerate()
        .map(|(k, c)| (k, outside(c)))
        .collect();
    by_misfit.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
    let worst: Vec<(usize, f64)> = by_misfit[..FIGURED_CONTACTS / 2].to_vec();
    let rest: Vec<usize> = (0..order.len())
        .filter(|k| worst.iter().all(|(w, _)| w != k))
        .collect();
    let spread = FIGURED_CONTACTS - worst.len();
    let typical: Vec<usize> = (0..spread)
        .map(|j| rest[j * (rest.len() - 1) / (spread - 1).max(1)])
        .collect();
    let named = |list: &mut dyn Iterator<Item = String>| list.collect::<Vec<_>>().join(", ");
    let sentence = format!(
        "{} contacts: the figures below are of {FIGURED_CONTACTS} of them, the {} whose data fall outside their 95 % posterior predictive band most often ({}; about 5 % of the points of a contact the model describes fall outside it) and {spread} spread evenly over the others in model order ({}). Every contact's parameters are in summary.csv and in the forest plot.",
        order.len(),
        worst.len(),
        named(&mut worst.iter().map(|&(k, f)| format!("{} {:.0} %", order[k], 100.0 * f))),
        named(&mut typical.iter().map(|&k| order[k].to_owned())),
    );
    let contacts = worst
        .iter()
        .map(|&(k, _)| k)
        .chain(typical)
        .map(|k| order[k].to_owned())
        .collect();
    Some(ShownContacts { contacts, sentence })
}

pub(super) fn peak_section(ctx: &Context) -> Result<Vec<Block>, ReportError> {
    let mut blocks = vec![
        heading(1, "peak", "Peak static friction"),
        Block::Paragraph(
            "The peak of F(τ), where a/τ = αv (F − F_d), per posterior draw. Its credible interval carries the uncertainty of every parameter, t0 included.".into(),
        ),
    ];
    let mut density: Vec<PeakDraws> = Vec::new();
    let mut versus_t0: Vec<(String, Vec<(String, PeakVsT0)>)> = Vec::new();
    let mut rows = Vec::new();
    // A report of many contacts draws the panels of the contacts its fit section draws (the
    // table lists every run).
    let shown = shown_contacts(ctx);
    let drawn = |contact: &str| shown.as_ref().is_none_or(|s| s.contacts.contains(contact));
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
            if drawn(&run.contact) {
                density.push((
                    format!("{} ({material})", run.name),
                    peak_density(&values),
                    [s.ci_low, s.median, s.ci_high],
                ));
                if let Some(curve) = ctx.peaks_vs_t0[i] {
                    v.push((run.name.clone(), curve.clone()));
                }
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
        format!("Posterior density of the peak static friction per run and, where a material has several first slides, of their mean per draw: the shade is the 95 % interval, the dashed line the median.{}", if shown.is_some() { " Runs of the contacts whose fits are drawn above only." } else { "" }),
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

pub(super) fn materials_section(
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
        let many = panels
            .iter()
            .any(|p| p.rows.iter().filter(|r| !r.material).count() > FOREST_LISTED_ROWS);
        let caterpillar = if many {
            " A panel of more than 40 contacts or runs is a caterpillar plot instead: the contacts side by side, sorted by their median, each a vertical 95 % bar under its 50 % bar, and each material a black line at its median over the light band of its 95 % interval."
        } else {
            ""
        };
        blocks.push(figure(
            "forest.svg".to_owned(),
            format!("Forest plot: for each quantity, per material (black) and per contact or run (grey), \
             the 50 % interval as a thick bar, the 95 % interval as a thin bar and the median as \
             a white dot; the numbers beside each row are the median and the 95 % interval (where \
             an interval is narrower than the dot, it is narrower than the figure can show). F_d \
             and F_peak are not material parameters; their material rows are the mean of the \
             material's contacts and the mean of its first slides, per draw.{caterpillar}"),
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
