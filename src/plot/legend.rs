//! Legends: a framed box of entries placed in a corner of the plot area that no data touch,
//! or beside the plot; or a row of entries in a strip of a figure's own.

use super::axes::GAP_PX;
use super::geometry::{Point, Rect, Shape};
use super::series::{Mark, Marker};
use super::style::{Rgb, TEXT_PX};
use super::svg::{Canvas, Fill, Font, Stroke};
use super::text::{line_height, text_width, Anchor, HPos, VPos};

/// Width of an entry's sample (pixels).
const SWATCH_PX: f64 = 26.0;
/// Inner padding of a legend box (pixels).
const PAD_PX: f64 = 6.0;
/// A legend box keeps this far from the data and the frame (pixels).
const CLEAR_PX: f64 = 3.0;

/// What an entry shows beside its label.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Swatch {
    /// A stretch of line.
    Line(Stroke),
    /// A marker of `radius` pixels in a colour.
    Marker(Marker, Rgb, f64),
    /// A filled block.
    Fill(Fill),
    /// A line over a filled block (a median in its band).
    LineOnFill(Stroke, Fill),
}

/// One legend entry.
#[derive(Debug, Clone, PartialEq)]
pub struct LegendEntry {
    /// Label.
    pub label: String,
    /// Sample.
    pub swatch: Swatch,
}

impl LegendEntry {
    /// An entry.
    pub fn new(label: impl Into<String>, swatch: Swatch) -> Self {
        Self {
            label: label.into(),
            swatch,
        }
    }
}

/// Width and height of the framed box of `entries`.
pub fn box_size(entries: &[LegendEntry]) -> (f64, f64) {
    let widest = entries
        .iter()
        .map(|e| text_width(&e.label, TEXT_PX))
        .fold(0.0, f64::max);
    (
        2.0 * PAD_PX + SWATCH_PX + GAP_PX + widest,
        2.0 * PAD_PX + entries.len() as f64 * line_height(TEXT_PX),
    )
}

/// Where a box of `size` fits inside `area` without touching any of `shapes`: the corners
/// first (upper right, upper left, lower right, lower left), then the middles of the edges.
pub(crate) fn free_spot(area: &Rect, size: (f64, f64), shapes: &[Shape]) -> Option<Rect> {
    let (w, h) = size;
    let inner = area.inflate(-CLEAR_PX);
    if w > inner.width() || h > inner.height() {
        return None;
    }
    let (left, right) = (inner.x0, inner.x1 - w);
    let (top, bottom) = (inner.y0, inner.y1 - h);
    let (middle_x, middle_y) = (0.5 * (left + right), 0.5 * (top + bottom));
    [
        (right, top),
        (left, top),
        (right, bottom),
        (left, bottom),
        (middle_x, top),
        (middle_x, bottom),
        (right, middle_y),
        (left, middle_y),
    ]
    .into_iter()
    .map(|corner| Rect::at(corner, size))
    .find(|spot| {
        let clear = spot.inflate(CLEAR_PX);
        !shapes.iter().any(|s| s.hits(&clear))
    })
}

/// The marks of `swatch` in the sample space starting at `x`, centred on `y`.
fn swatch_marks(swatch: Swatch, x: f64, y: f64) -> Vec<Mark> {
    let line = |s: Stroke| Mark::Polyline(vec![(x, y), (x + SWATCH_PX, y)], s);
    let block = |f: Fill| Mark::Rect(Rect::new(x, y - 5.0, x + SWATCH_PX, y + 5.0), Some(f), None);
    match swatch {
        Swatch::Line(s) => vec![line(s)],
        Swatch::Fill(f) => vec![block(f)],
        Swatch::LineOnFill(s, f) => vec![block(f), line(s)],
        Swatch::Marker(m, color, radius) => {
            let series = super::series::Series::Markers {
                points: vec![(0.5, 0.5)],
                marker: m,
                color,
                radius,
            };
            let at = Rect::new(x, y - SWATCH_PX / 2.0, x + SWATCH_PX, y + SWATCH_PX / 2.0);
            series.marks(&super::axes::Plot {
                rect: at,
                x: super::ticks::Scale::linear((0.0, 1.0)),
                y: super::ticks::Scale::linear((0.0, 1.0)),
            })
        }
    }
}

/// Draws `entries` in a framed white box with its top left corner at `at`; returns the box.
pub fn draw_box(canvas: &mut Canvas, at: Point, entries: &[LegendEntry]) -> Rect {
    let size = box_size(entries);
    let frame = Rect::at(at, size);
    canvas.rect(
        &frame,
        Some(Fill::solid(Rgb::WHITE)),
        Some(Stroke::solid(Rgb(150, 150, 150), 1.0)),
    );
    let font = Font::new(TEXT_PX, Anchor::new(HPos::Left, VPos::Center));
    for (i, e) in entries.iter().enumerate() {
        let y = at.1 + PAD_PX + (i as f64 + 0.5) * line_height(TEXT_PX);
        for mark in swatch_marks(e.swatch, at.0 + PAD_PX, y) {
            mark.draw(canvas);
        }
        canvas.text(&e.label, (at.0 + PAD_PX + SWATCH_PX + GAP_PX, y), font);
    }
    frame
}

/// Height a row legend of `entries` takes in a strip `width` pixels wide.
pub fn row_height(entries: &[LegendEntry], width: f64) -> f64 {
    row_layout(entries, width).1
}

/// Positions (left x, row) of each entry, and the height of the rows.
fn row_layout(entries: &[LegendEntry], width: f64) -> (Vec<(f64, usize)>, f64) {
    let mut places = Vec::with_capacity(entries.len());
    let (mut x, mut row) = (0.0, 0);
    for e in entries {
        let w = SWATCH_PX + GAP_PX + text_width(&e.label, TEXT_PX);
        if x > 0.0 && x + w > width {
            x = 0.0;
            row += 1;
        }
        places.push((x, row));
        x += w + 3.0 * GAP_PX;
    }
    let rows = if entries.is_empty() { 0 } else { row + 1 };
    (places, rows as f64 * line_height(TEXT_PX))
}

/// Draws `entries` in rows across `area` (wrapping as needed), outside any plot area.
pub fn draw_row(canvas: &mut Canvas, area: &Rect, entries: &[LegendEntry]) {
    let (places, _) = row_layout(entries, area.width());
    let font = Font::new(TEXT_PX, Anchor::new(HPos::Left, VPos::Center));
    for (e, &(x, row)) in entries.iter().zip(&places) {
        let y = area.y0 + (row as f64 + 0.5) * line_height(TEXT_PX);
        for mark in swatch_marks(e.swatch, area.x0 + x, y) {
            mark.draw(canvas);
        }
        canvas.text(&e.label, (area.x0 + x + SWATCH_PX + GAP_PX, y), font);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_legend_goes_where_no_data_are() {
        let area = Rect::new(0.0, 0.0, 300.0, 200.0);
        // Data along the top edge: the legend goes to a lower corner.
        let top = Shape::Line {
            points: vec![(0.0, 20.0), (300.0, 20.0)],
            half_width: 1.0,
        };
        let spot = free_spot(&area, (100.0, 40.0), std::slice::from_ref(&top)).unwrap();
        assert!(spot.y0 > 100.0);
        assert!(!top.hits(&spot));
        // Data everywhere: no spot.
        let all = Shape::Block(area);
        assert!(free_spot(&area, (100.0, 40.0), &[all]).is_none());
        assert!(free_spot(&area, (400.0, 40.0), &[]).is_none());
    }

    #[test]
    fn rows_wrap_when_the_strip_is_narrow() {
        let entries = vec![
            LegendEntry::new("ensemble 1", Swatch::Fill(Fill::solid(Rgb::BLACK))),
            LegendEntry::new("ensemble 2", Swatch::Fill(Fill::solid(Rgb::BLACK))),
        ];
        assert!(row_height(&entries, 1000.0) < row_height(&entries, 120.0));
    }
}
