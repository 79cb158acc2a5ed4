//! Trace plots with rank plots.

use super::*;

/// Rank counts of one parameter (ArviZ's `plot_rank`): its kept draws ranked among all
/// ensembles' kept draws, and per ensemble the count of its draws in each of equal bins of
/// rank.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RankCounts {
    /// Number of ranks (kept draws of all ensembles).
    pub ranks: usize,
    /// `counts[ensemble][bin]`.
    pub counts: Vec<Vec<f64>>,
}

/// One row of the trace figure: a parameter's walkers per ensemble as drawn (every
/// [`trace_stride`]-th step) with the range of every step, and its rank counts.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct TracePanel {
    /// Title (parameter and unit).
    pub title: String,
    /// Steps of the run (the x axis spans them).
    pub steps: usize,
    /// `points[ensemble][walker]`: (step, value in display units) at every
    /// [`trace_stride`]`(steps)`-th step from step 0, for the walkers shown.
    pub points: Vec<Vec<Vec<(f64, f64)>>>,
    /// The finite range of the values of these walkers at every step, in display units
    /// (before padding; [`extend_bounds`](crate::plot::extend_bounds) folded over them).
    pub range: (f64, f64),
    /// Rank counts of the kept draws; `None` with one ensemble.
    pub ranks: Option<RankCounts>,
}

/// Most points drawn per walker line.
const TRACE_POINTS: usize = 150;

/// Steps between the points drawn of a trace of `steps` steps.
pub(crate) fn trace_stride(steps: usize) -> usize {
    steps.div_ceil(TRACE_POINTS).max(1)
}

const TRACE_ROW_PX: f64 = 170.0;
const TRACE_SPLIT: f64 = 0.62;

/// Trace plots beside rank plots, one parameter per row: on the left the walkers shown of
/// every ensemble (ensembles told apart by ink), the burn-in marked; on the right each
/// ensemble's histogram of ranks among all ensembles' kept draws, a dashed line at what
/// uniform ranks give. All rows share the step axis and the rank axis, labelled at the bottom.
pub(crate) fn trace_figure(panels: &[TracePanel], burn_in: u64, ensembles: usize) -> String {
    let mut legend: Vec<LegendEntry> = (0..ensembles)
        .map(|e| {
            LegendEntry::new(
                format!("ensemble {}", e + 1),
                Swatch::Line(Stroke::solid(ink(e), 2.0)),
            )
        })
        .collect();
    legend.push(LegendEntry::new(
        "end of burn-in",
        Swatch::Line(Stroke::solid(MARK, 1.5)),
    ));
    legend.push(LegendEntry::new(
        "uniform ranks (expected count)",
        Swatch::Line(Stroke::solid(Rgb::BLACK, 1.0).dashed(crate::plot::Dash::Short)),
    ));
    let strip = row_height(&legend, FIGURE_WIDTH - 20.0) + 2.0 * GAP_PX;
    let steps = panels.first().map_or(1, |p| p.steps).max(1);
    let step_axis = Axis::linear((0.0, steps as f64), "step");
    let ranks = panels
        .iter()
        .find_map(|p| p.ranks.as_ref())
        .map_or(1, |r| r.ranks);
    let rank_axis = Axis::linear((0.0, ranks as f64), "rank among all ensembles' kept draws");
    let line = line_height(TEXT_PX);
    // Room under the last row for the shared axes' labels and descriptions.
    let foot = TICK_FOOT + 3.0 * line;
    let height = strip + panels.len() as f64 * TRACE_ROW_PX + foot;
    svg_figure((FIGURE_WIDTH as u32, height.ceil() as u32), |c| {
        draw_row(
            c,
            &Rect::new(10.0, GAP_PX, FIGURE_WIDTH - 10.0, strip),
            &legend,
        );
        let trace_right = (FIGURE_WIDTH * TRACE_SPLIT).round();
        // Every row's value axis is labelled; the widest labels set a left edge for all, so
        // that the step axes line up.
        let plot_h = TRACE_ROW_PX - 2.0 * line - 2.0 * GAP_PX;
        let value_axes: Vec<(Axis, Ticks)> = panels
            .iter()
            .map(|p| {
                let axis = Axis::linear(crate::plot::padded(p.range, 0.05), "");
                let ticks = choose_ticks(&axis.scale, plot_h, false);
                (axis, ticks)
            })
            .collect();
        let step_ticks = choose_ticks(&step_axis.scale, trace_right - 140.0, true);
        let left = value_axes
            .iter()
            .map(|(a, t)| axis_margins((&step_axis, &step_ticks), (a, t), 500.0).left)
            .fold(0.0, f64::max)
            + 10.0;
        let trace_x = (left, trace_right - 16.0);
        let rank_ticks = choose_ticks(&rank_axis.scale, FIGURE_WIDTH - trace_right - 100.0, true);
        let rank_label_w = text_width(&ensembles.to_string(), TEXT_PX);
        let rank_x = (
            trace_right + 16.0 + line + 2.0 * GAP_PX + crate::plot::TICK_PX + rank_label_w,
            FIGURE_WIDTH
                - 10.0
                - 0.5
                    * rank_ticks
                        .labels
                        .last()
                        .map_or(0.0, |l| text_width(l, TEXT_PX)),
        );
        let ensemble_axis = Axis::linear((0.0, ensembles as f64), "ensemble");
        let ensemble_ticks = Ticks {
            values: (0..ensembles).map(|e| e as f64 + 0.275).collect(),
            labels: (0..ensembles).map(|e| (e + 1).to_string()).collect(),
            minor: Vec::new(),
            note: String::new(),
        };
        let layout = TraceLayout {
            strip,
            line,
            plot_h,
            trace_x,
            rank_x,
            burn_in,
            last: panels.len().saturating_sub(1),
            step: (&step_axis, &step_ticks),
            rank: (&rank_axis, &rank_ticks),
            ensemble: (&ensemble_axis, &ensemble_ticks),
        };
        for (i, (panel, value)) in panels.iter().zip(&value_axes).enumerate() {
            draw_trace_row(c, &layout, i, panel, value);
        }
    })
}

/// Where the rows of a trace figure go and the axes they share.
struct TraceLayout<'a> {
    /// Height of the legend strip above the rows.
    strip: f64,
    line: f64,
    /// Height of a row's plot area.
    plot_h: f64,
    /// Left and right edges of the traces.
    trace_x: (f64, f64),
    /// Left and right edges of the rank plots.
    rank_x: (f64, f64),
    burn_in: u64,
    /// The last row, whose shared axes are labelled.
    last: usize,
    step: (&'a Axis, &'a Ticks),
    rank: (&'a Axis, &'a Ticks),
    ensemble: (&'a Axis, &'a Ticks),
}

/// Row `i` of a trace figure: the trace of `panel` on its value axis, the burn-in marked, and
/// its rank plot.
fn draw_trace_row(
    c: &mut Canvas,
    layout: &TraceLayout,
    i: usize,
    panel: &TracePanel,
    (value_axis, value_ticks): &(Axis, Ticks),
) {
    let (strip, line, plot_h, last) = (layout.strip, layout.line, layout.plot_h, layout.last);
    let (trace_x, rank_x, burn_in) = (layout.trace_x, layout.rank_x, layout.burn_in);
    let ((step_axis, step_ticks), (rank_axis, rank_ticks)) = (layout.step, layout.rank);
    let (ensemble_axis, ensemble_ticks) = layout.ensemble;
    let top = strip + i as f64 * TRACE_ROW_PX + GAP_PX;
    let shared = if i == last { Show::Labels } else { Show::Ticks };
    let trace = Plot {
        rect: Rect::new(trace_x.0, top + line, trace_x.1, top + line + plot_h),
        x: step_axis.scale,
        y: value_axis.scale,
    };
    // The title over the trace, centred; a scale or offset note sits at its left.
    c.text(
        &panel.title,
        (0.5 * (trace.rect.x0 + trace.rect.x1), top),
        Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Top)).bold(),
    );
    draw_grid(c, &trace, step_ticks, value_ticks);
    let mut series = Vec::new();
    for (e, walkers) in panel.points.iter().enumerate() {
        for pts in walkers {
            series.push(Series::Line {
                points: pts.clone(),
                stroke: Stroke::solid(ink(e), 0.8).faded(0.6),
            });
        }
    }
    let (v0, v1) = value_axis.scale.range();
    series.push(Series::Line {
        points: vec![(burn_in as f64, v0), (burn_in as f64, v1)],
        stroke: Stroke::solid(MARK, 1.5),
    });
    draw_series(c, &trace, &series);
    let step = Axis {
        show: shared,
        ..step_axis.clone()
    };
    draw_axes(c, &trace, (&step, step_ticks), (value_axis, value_ticks));

    if let Some(r) = &panel.ranks {
        let rank = Plot {
            rect: Rect::new(rank_x.0, trace.rect.y0, rank_x.1, trace.rect.y1),
            x: rank_axis.scale,
            y: ensemble_axis.scale,
        };
        c.text(
            &format!("ranks of {}", panel.title),
            (0.5 * (rank.rect.x0 + rank.rect.x1), top),
            Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Top)),
        );
        draw_series(c, &rank, &rank_series(r));
        let rank_show = Axis {
            show: shared,
            ..rank_axis.clone()
        };
        draw_axes(
            c,
            &rank,
            (&rank_show, rank_ticks),
            (ensemble_axis, ensemble_ticks),
        );
    }
}

/// Room under a plot area for tick marks and their labels (pixels).
const TICK_FOOT: f64 = 2.0 * GAP_PX + 5.0;

/// Bars of each ensemble's rank histogram on its own row (row e spans e to e + 1; a bar of
/// the expected count is half a row high) and the dashed expected count.
fn rank_series(r: &RankCounts) -> Vec<Series> {
    let mut out = Vec::new();
    let bins = r.counts.first().map_or(1, Vec::len).max(1);
    let width = r.ranks as f64 / bins as f64;
    for (e, counts) in r.counts.iter().enumerate() {
        let expected = counts.iter().sum::<f64>() / bins as f64;
        let base = e as f64 + 0.05;
        let scale = if expected > 0.0 { 0.45 / expected } else { 0.0 };
        let bars: Vec<((f64, f64), f64)> = counts
            .iter()
            .enumerate()
            .map(|(b, &n)| {
                (
                    (b as f64 * width, (b + 1) as f64 * width),
                    (base + n * scale).min(e as f64 + 0.97),
                )
            })
            .collect();
        out.push(Series::Bars {
            bars,
            base,
            fill: Fill::translucent(ink(e), 0.75),
        });
        out.push(Series::Line {
            points: vec![(0.0, base + 0.45), (r.ranks as f64, base + 0.45)],
            stroke: Stroke::solid(Rgb::BLACK, 1.0).dashed(crate::plot::Dash::Short),
        });
    }
    out
}
