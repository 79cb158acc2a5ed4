//! A panel: caption, two axes, series and a legend, laid out in a rectangle of a figure.
//!
//! The panel is described first and drawn last, so that its layout can use everything it
//! shows: the plot area leaves room for every label, and the legend goes into a corner of the
//! plot area that no data touch, or beside the plot area when there is none.

use super::axes::{draw_axes, draw_grid, fit_axes, Axis, Margins, Plot, GAP_PX};
use super::geometry::{Rect, Shape};
use super::legend::{box_size, draw_box, draw_row, free_spot, row_height, LegendEntry, Swatch};
use super::series::{draw_series, Marker, Series};
use super::style::{Rgb, CAPTION_PX};
use super::svg::{Canvas, Fill, Font, Stroke};
use super::text::{line_height, wrap, Anchor, HPos, VPos};

/// A legend no wider than this share of its panel may go beside the plot area.
const BESIDE_SHARE: f64 = 0.3;

/// Where a panel's legend goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LegendAt {
    /// Inside the plot area where no data are, else beside it (narrow legends) or under it.
    Inside,
    /// Nowhere (the figure explains its series elsewhere).
    Nowhere,
}

/// A panel to be drawn: caption, axes, series and legend, described first and drawn last
/// ([`Panel::draw`]), so that the layout can use everything it shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Panel {
    /// Caption above the plot (wrapped to the panel's width).
    pub caption: String,
    /// Horizontal axis.
    pub x: Axis,
    /// Vertical axis.
    pub y: Axis,
    /// Where the legend goes.
    pub legend_at: LegendAt,
    series: Vec<Series>,
    legend: Vec<LegendEntry>,
}

impl Panel {
    /// An empty panel with a grid and its legend inside.
    pub fn new(caption: &str, x: Axis, y: Axis) -> Self {
        Self {
            caption: caption.to_owned(),
            x,
            y,
            legend_at: LegendAt::Inside,
            series: Vec::new(),
            legend: Vec::new(),
        }
    }

    /// Adds a series and, when given, its legend entry.
    pub fn add(&mut self, series: Series, entry: Option<LegendEntry>) -> &mut Self {
        self.series.push(series);
        self.legend.extend(entry);
        self
    }

    /// A line through `points`, labelled in the legend when `label` is given.
    pub fn line(
        &mut self,
        points: Vec<(f64, f64)>,
        stroke: Stroke,
        label: Option<&str>,
    ) -> &mut Self {
        let entry = label.map(|l| LegendEntry::new(l, Swatch::Line(stroke)));
        self.add(Series::Line { points, stroke }, entry)
    }

    /// Markers at `points`.
    pub fn markers(
        &mut self,
        points: Vec<(f64, f64)>,
        marker: Marker,
        color: Rgb,
        label: Option<&str>,
    ) -> &mut Self {
        let radius = 3.5;
        let entry = label.map(|l| LegendEntry::new(l, Swatch::Marker(marker, color, radius)));
        self.add(
            Series::Markers {
                points,
                marker,
                color,
                radius,
            },
            entry,
        )
    }

    /// The band between `low` and `high` over `xs`.
    pub fn band(
        &mut self,
        xs: Vec<f64>,
        low: Vec<f64>,
        high: Vec<f64>,
        fill: Fill,
        label: Option<&str>,
    ) -> &mut Self {
        let entry = label.map(|l| LegendEntry::new(l, Swatch::Fill(fill)));
        self.add(
            Series::Band {
                xs,
                low,
                high,
                fill,
            },
            entry,
        )
    }

    /// Draws the panel into `area` and returns its plot area.
    pub fn draw(&self, canvas: &mut Canvas, area: Rect) -> Plot {
        const PAD: f64 = 6.0;
        let caption = if self.caption.is_empty() {
            Vec::new()
        } else {
            wrap(&self.caption, CAPTION_PX, area.width() - 2.0 * PAD)
        };
        let top = caption.len() as f64 * line_height(CAPTION_PX);
        let legend = (!self.legend.is_empty() && self.legend_at != LegendAt::Nowhere)
            .then(|| box_size(&self.legend));
        let keep = Margins {
            top,
            ..Margins::default()
        };
        let mut layout = fit_axes(area, &self.x, &self.y, keep);
        let mut legend_spot = None;
        let mut legend_row = None;
        if let Some(size) = legend {
            let shapes: Vec<Shape> = self
                .series
                .iter()
                .flat_map(|s| s.marks(&layout.0))
                .map(|m| m.shape())
                .collect();
            legend_spot = free_spot(&layout.0.rect, size, &shapes).map(|r| (r.x0, r.y0));
            // No room inside: beside the plot area when the legend is narrow, else under it
            // (a wide legend beside a panel would leave the data no room).
            if legend_spot.is_none() && size.0 <= BESIDE_SHARE * area.width() {
                let beside = Margins {
                    right: size.0 + 2.0 * GAP_PX,
                    ..keep
                };
                layout = fit_axes(area, &self.x, &self.y, beside);
                let r = layout.0.rect;
                legend_spot = Some((r.x1 + 2.0 * GAP_PX, r.y0));
            } else if legend_spot.is_none() {
                let width = area.width() - 2.0 * PAD;
                let height = row_height(&self.legend, width);
                let below = Margins {
                    bottom: height + GAP_PX,
                    ..keep
                };
                layout = fit_axes(area, &self.x, &self.y, below);
                legend_row = Some(Rect::new(
                    area.x0 + PAD,
                    area.y1 - PAD - height,
                    area.x1 - PAD,
                    area.y1 - PAD,
                ));
            }
        }
        let (plot, xt, yt) = layout;
        draw_grid(canvas, &plot, &xt, &yt);
        draw_series(canvas, &plot, &self.series);
        draw_axes(canvas, &plot, (&self.x, &xt), (&self.y, &yt));
        let font = Font::new(CAPTION_PX, Anchor::new(HPos::Center, VPos::Top));
        // Centred over the plot area, unless that would run off the panel.
        let centre = 0.5 * (plot.rect.x0 + plot.rect.x1);
        for (i, line) in caption.iter().enumerate() {
            let half = 0.5 * super::text::text_width(line, CAPTION_PX);
            let x = centre.clamp(
                area.x0 + PAD + half,
                (area.x1 - PAD - half).max(area.x0 + PAD + half),
            );
            canvas.text(
                line,
                (x, area.y0 + PAD + i as f64 * line_height(CAPTION_PX)),
                font,
            );
        }
        if let Some(at) = legend_spot {
            draw_box(canvas, at, &self.legend);
        }
        if let Some(row) = legend_row {
            draw_row(canvas, &row, &self.legend);
        }
        plot
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::style::{ink, series_stroke};

    fn svg_of(panel: &Panel) -> String {
        let mut canvas = Canvas::new((560, 380));
        panel.draw(&mut canvas, Rect::new(0.0, 0.0, 560.0, 380.0));
        canvas.finish()
    }

    #[test]
    fn the_legend_moves_out_of_the_way_of_the_data() {
        let mut p = Panel::new(
            "caption",
            Axis::linear((0.0, 1.0), "x"),
            Axis::linear((0.0, 1.0), "y"),
        );
        // A line along the top: the legend sits low.
        p.line(
            vec![(0.0, 0.95), (1.0, 0.95)],
            series_stroke(0, 2.0),
            Some("top"),
        );
        let mut canvas = Canvas::new((560, 380));
        let plot = p.draw(&mut canvas, Rect::new(0.0, 0.0, 560.0, 380.0));
        let svg = canvas.finish();
        let legend_y: f64 = svg
            .lines()
            .find(|l| {
                l.starts_with("<rect")
                    && l.contains("fill=\"#FFFFFF\"")
                    && !l.contains("x=\"0\" y=\"0\"")
            })
            .and_then(|l| l.split("y=\"").nth(1))
            .and_then(|s| s.split('"').next())
            .unwrap()
            .parse()
            .unwrap();
        assert!(legend_y > 0.5 * (plot.rect.y0 + plot.rect.y1), "{svg}");

        // Data everywhere: the legend goes beside the plot area.
        let mut full = Panel::new(
            "",
            Axis::linear((0.0, 1.0), "x"),
            Axis::linear((0.0, 1.0), "y"),
        );
        full.band(
            vec![0.0, 1.0],
            vec![0.0, 0.0],
            vec![1.0, 1.0],
            Fill::solid(ink(3)),
            Some("all"),
        );
        let mut canvas = Canvas::new((560, 380));
        let plot = full.draw(&mut canvas, Rect::new(0.0, 0.0, 560.0, 380.0));
        let check = crate::plot::check::check_svg(&canvas.finish());
        assert!(
            check.legends[0].x0 > plot.rect.x1,
            "{:?} {:?}",
            check.legends,
            plot.rect
        );
        assert!(check.problems.is_empty(), "{:?}", check.problems);
        assert!(svg_of(&full).contains(">all</text>"));
    }
}
