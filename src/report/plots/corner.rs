//! Corner plots: each parameter's histogram and each pair's smoothed 2-D histogram.

use super::forest::{error_decimals, fixed};
use super::*;

/// What a corner plot draws of one quantity's kept draws (display units): its range, its
/// histogram, its 16, 50 and 84 % quantiles and, for synthetic data, its true value. Built
/// one quantity at a time, so that the figure holds a few numbers per quantity, never the
/// draws.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CornerColumn {
    /// Axis label with unit.
    pub name: String,
    /// Range shown: the draws between their 0.05 and 99.95 % quantiles and the true value,
    /// padded.
    pub range: (f64, f64),
    /// Counts of the draws in [`BINS`] equal bins over the range.
    pub hist: Vec<f64>,
    /// 16, 50 and 84 % quantiles.
    pub quantiles: [f64; 3],
    /// The simulation's true value, when known.
    pub truth: Option<f64>,
}

/// A corner plot's numbers: its columns, and the 2-D histogram of every pair.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct CornerData {
    /// One per quantity.
    pub columns: Vec<CornerColumn>,
    /// For rows i > j, in the order (1, 0), (2, 0), (2, 1), (3, 0), …: the histogram of
    /// (quantity j, quantity i).
    pub pairs: Vec<Histogram2d>,
}

impl CornerData {
    /// The histogram of (quantity `j`, quantity `i`), `i > j`.
    pub fn pair(&self, i: usize, j: usize) -> &Histogram2d {
        &self.pairs[i * (i - 1) / 2 + j]
    }
}

/// `median +up −down` with two significant digits of the smaller error, the median to the
/// same decimal place.
fn median_with_errors([q16, q50, q84]: [f64; 3]) -> String {
    let (down, up) = (q50 - q16, q84 - q50);
    match error_decimals(down.min(up)) {
        Some(d) => format!("{} +{} −{}", fixed(q50, d), fixed(up, d), fixed(down, d)),
        None => significant(q50, 4),
    }
}

/// Fills of the 2-D contours, outermost (2 σ) first.
const CONTOUR_FILLS: [Rgb; 4] = [
    Rgb(228, 228, 228),
    Rgb(198, 198, 198),
    Rgb(160, 160, 160),
    Rgb(115, 115, 115),
];
const TRUTH: Rgb = Rgb(0, 100, 200);
const CORNER_GAP: f64 = 24.0;
/// Room for a diagonal panel's two-line title between rows (pixels).
const CORNER_ROW_GAP: f64 = 40.0;

/// A corner plot (corner.py's layout): on the diagonal each quantity's histogram with dashed
/// lines at its 16, 50 and 84 % quantiles and `median +up −down` above it; below the diagonal
/// each pair's smoothed 2-D histogram as filled contours at 0.5, 1, 1.5 and 2 σ; the true
/// values as lines when every one of them is known; equal square panels, the axes labelled
/// on the bottom row and the left column.
///
/// # Errors
/// [`DrawError`] when there are fewer than two quantities.
pub(crate) fn corner_figure(name: &str, data: &CornerData) -> Result<String, DrawError> {
    let cols = &data.columns;
    let n = cols.len();
    if n < 2 {
        return Err(DrawError::new(name, "a corner plot needs two quantities"));
    }
    let truths = cols.iter().all(|c| c.truth.is_some());
    let line = line_height(TEXT_PX);
    let mut legend = vec![
        LegendEntry::new(
            "posterior: 0.5, 1, 1.5, 2σ contours",
            Swatch::Fill(Fill::solid(CONTOUR_FILLS[1])),
        ),
        LegendEntry::new(
            "16, 50, 84 % quantiles",
            Swatch::Line(Stroke::solid(Rgb::BLACK, 1.0).dashed(crate::plot::Dash::Dashed)),
        ),
    ];
    if truths {
        legend.push(LegendEntry::new(
            "simulation's true value",
            Swatch::Line(Stroke::solid(TRUTH, 1.5)),
        ));
    }
    // Equal square panels in the width left by the left column's labels.
    let cell = ((FIGURE_WIDTH - 130.0 - (n - 1) as f64 * CORNER_GAP) / n as f64).min(210.0);
    let x_ticks: Vec<Ticks> = cols
        .iter()
        .map(|c| choose_ticks(&Scale::linear(c.range), cell, true))
        .collect();
    let y_ticks: Vec<Ticks> = cols
        .iter()
        .map(|c| choose_ticks(&Scale::linear(c.range), cell, false))
        .collect();
    // Each quantity's name, wrapped to a cell: under its column and beside its row.
    let descs: Vec<Vec<String>> = cols.iter().map(|c| wrap(&c.name, TEXT_PX, cell)).collect();
    let y_label_w = y_ticks[1..]
        .iter()
        .flat_map(|t| t.labels.iter())
        .map(|l| text_width(l, TEXT_PX))
        .fold(0.0, f64::max);
    let y_desc_lines = descs[1..].iter().map(Vec::len).max().unwrap_or(1) as f64;
    let left = 10.0 + y_desc_lines * line + 2.0 * GAP_PX + y_label_w + crate::plot::TICK_PX;
    let has_x_note = x_ticks.iter().any(|t| !t.note.is_empty());
    let x_desc_lines = descs.iter().map(Vec::len).max().unwrap_or(1) as f64;
    let bottom = crate::plot::TICK_PX
        + GAP_PX
        + line
        + if has_x_note { GAP_PX + line } else { 0.0 }
        + GAP_PX
        + x_desc_lines * line
        + 10.0;
    let top = CORNER_ROW_GAP;
    let size = (
        left + n as f64 * cell + (n - 1) as f64 * CORNER_GAP + 0.5 * cell.min(90.0),
        top + n as f64 * cell + (n - 1) as f64 * CORNER_ROW_GAP + bottom,
    );
    let (legend_w, legend_h) = box_size(&legend);
    // The legend goes into the empty upper triangle when it fits there, else under the plot.
    let triangle = Rect::new(
        left + cell + CORNER_GAP,
        top,
        size.0 - 10.0,
        top + (n - 1) as f64 * (cell + CORNER_ROW_GAP) - CORNER_ROW_GAP,
    );
    let legend_inside = legend_w <= triangle.width() && legend_h <= triangle.height();
    let size = if legend_inside {
        size
    } else {
        (size.0, size.1 + legend_h + 10.0)
    };
    Ok(svg_figure(
        (size.0.ceil() as u32, size.1.ceil() as u32),
        |c| {
            let layout = CornerLayout {
                left,
                top,
                cell,
                line,
                x_ticks: &x_ticks,
                y_ticks: &y_ticks,
                descs: &descs,
                has_x_note,
                truths,
            };
            for i in 0..n {
                for j in 0..=i {
                    draw_cell(c, &layout, data, i, j);
                }
            }
            if legend_inside {
                draw_box(c, (triangle.x1 - legend_w, triangle.y0), &legend);
            } else {
                draw_box(c, (left, size.1 - legend_h - 6.0), &legend);
            }
        },
    ))
}

/// Where the cells of a corner plot go and what they share.
struct CornerLayout<'a> {
    left: f64,
    top: f64,
    cell: f64,
    line: f64,
    x_ticks: &'a [Ticks],
    y_ticks: &'a [Ticks],
    /// Each quantity's name, wrapped to a cell.
    descs: &'a [Vec<String>],
    has_x_note: bool,
    truths: bool,
}

impl CornerLayout<'_> {
    /// The panel of row `i`, column `j`.
    fn rect_of(&self, i: usize, j: usize) -> Rect {
        let x0 = self.left + j as f64 * (self.cell + CORNER_GAP);
        let y0 = self.top + i as f64 * (self.cell + CORNER_ROW_GAP);
        Rect::new(x0, y0, x0 + self.cell, y0 + self.cell)
    }
}

/// The panel of row `i`, column `j` (`j ≤ i`): a histogram on the diagonal, a pair's contours
/// below it; the descriptions beside the left column and under the bottom row.
fn draw_cell(c: &mut Canvas, layout: &CornerLayout, data: &CornerData, i: usize, j: usize) {
    let cols = &data.columns;
    let n = cols.len();
    let (line, truths, has_x_note) = (layout.line, layout.truths, layout.has_x_note);
    let (x_ticks, y_ticks, descs) = (layout.x_ticks, layout.y_ticks, layout.descs);
    let rect = layout.rect_of(i, j);
    let (cx, cy) = (&cols[j], &cols[i]);
    let x_show = if i == n - 1 {
        Show::Labels
    } else {
        Show::Ticks
    };
    let x_axis = Axis {
        scale: Scale::linear(cx.range),
        desc: String::new(),
        show: x_show,
    };
    if i == j {
        let top_count = cx.hist.iter().copied().fold(0.0, f64::max).max(1.0);
        let plot = Plot {
            rect,
            x: Scale::linear(cx.range),
            y: Scale::linear((0.0, 1.1 * top_count)),
        };
        let off = Axis::linear((0.0, 1.0), "").showing(Show::Off);
        draw_series(c, &plot, &diagonal_series(cx, truths));
        draw_axes(c, &plot, (&x_axis, &x_ticks[j]), (&off, &y_ticks[i]));
        let title = [cx.name.clone(), median_with_errors(cx.quantiles)];
        for (k, t) in title.iter().enumerate() {
            c.text(
                t,
                (
                    0.5 * (rect.x0 + rect.x1),
                    rect.y0 - GAP_PX - (1 - k) as f64 * line,
                ),
                Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Bottom)),
            );
        }
    } else {
        let plot = Plot {
            rect,
            x: Scale::linear(cx.range),
            y: Scale::linear(cy.range),
        };
        let y_axis = Axis {
            scale: Scale::linear(cy.range),
            desc: String::new(),
            show: if j == 0 { Show::Labels } else { Show::Ticks },
        };
        draw_series(c, &plot, &pair_series(data.pair(i, j), cx, cy, truths));
        draw_axes(c, &plot, (&x_axis, &x_ticks[j]), (&y_axis, &y_ticks[i]));
    }
    // Descriptions: under the bottom row, left of the left column.
    if i == n - 1 {
        let mut below = rect.y1 + crate::plot::TICK_PX + GAP_PX + line;
        if has_x_note {
            below += GAP_PX + line;
        }
        for (k, l) in descs[j].iter().enumerate() {
            c.text(
                l,
                (0.5 * (rect.x0 + rect.x1), below + GAP_PX + k as f64 * line),
                Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Top)),
            );
        }
    }
    if j == 0 && i > 0 {
        let lines = &descs[i];
        for (k, l) in lines.iter().enumerate() {
            let x = 10.0 + (k as f64 + 0.5) * line;
            c.text(
                l,
                (x, 0.5 * (rect.y0 + rect.y1)),
                Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Center))
                    .rotated(crate::plot::text::Rotation::ThreeQuarters),
            );
        }
    }
}

/// The diagonal: histogram as steps, quantile lines, the true value.
fn diagonal_series(col: &CornerColumn, truth: bool) -> Vec<Series> {
    let (lo, hi) = col.range;
    let w = (hi - lo) / BINS as f64;
    let mut steps = Vec::with_capacity(2 * col.hist.len() + 2);
    steps.push((lo, 0.0));
    for (b, &count) in col.hist.iter().enumerate() {
        steps.push((lo + b as f64 * w, count));
        steps.push((lo + (b + 1) as f64 * w, count));
    }
    steps.push((hi, 0.0));
    let top = col.hist.iter().copied().fold(0.0, f64::max) * 1.05;
    let mut out = vec![
        Series::Area {
            points: steps.clone(),
            fill: Some(Fill::solid(Rgb(232, 232, 232))),
            stroke: None,
        },
        Series::Line {
            points: steps,
            stroke: Stroke::solid(Rgb::BLACK, 1.2),
        },
    ];
    for q in col.quantiles {
        out.push(Series::Line {
            points: vec![(q, 0.0), (q, top)],
            stroke: Stroke::solid(Rgb::BLACK, 1.0).dashed(crate::plot::Dash::Dashed),
        });
    }
    if let (true, Some(t)) = (truth, col.truth) {
        out.push(Series::Line {
            points: vec![(t, 0.0), (t, top * 2.0)],
            stroke: Stroke::solid(TRUTH, 1.5),
        });
    }
    out
}

/// Below the diagonal: filled contours, their outlines, the true values.
fn pair_series(h: &Histogram2d, cx: &CornerColumn, cy: &CornerColumn, truth: bool) -> Vec<Series> {
    let mut out = Vec::new();
    for (k, (_, loops)) in h.contours().into_iter().enumerate() {
        for l in loops {
            out.push(Series::Area {
                points: l,
                fill: Some(Fill::solid(CONTOUR_FILLS[k.min(3)])),
                stroke: Some(Stroke::solid(Rgb(60, 60, 60), 0.8)),
            });
        }
    }
    if let (true, Some(tx), Some(ty)) = (truth, cx.truth, cy.truth) {
        let stroke = Stroke::solid(TRUTH, 1.5);
        out.push(Series::Line {
            points: vec![(tx, cy.range.0), (tx, cy.range.1)],
            stroke,
        });
        out.push(Series::Line {
            points: vec![(cx.range.0, ty), (cx.range.1, ty)],
            stroke,
        });
        out.push(Series::Markers {
            points: vec![(tx, ty)],
            marker: Marker::Square,
            color: TRUTH,
            radius: 4.0,
        });
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn medians_carry_their_errors() {
        assert_eq!(
            median_with_errors([0.9205, 0.9216, 0.9228]),
            "0.9216 +0.0012 −0.0011"
        );
        assert_eq!(
            median_with_errors([11998.1, 12003.4, 12008.9]),
            "12003.4 +5.5 −5.3"
        );
        assert_eq!(median_with_errors([1.0, 1.0, 1.0]), "1.000");
    }
}
