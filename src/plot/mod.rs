//! The crate's one plotting layer: SVG figures shared by the report, the speed-against-error
//! plots of `bench` and the rank histograms of `validate`.
//!
//! Figures are SVG text written here, without font or image libraries. Layout estimates how
//! wide a text is in the browser's sans-serif ([`text`]) and leaves that much room: every
//! axis of any range gets at least two tick labels (scaled or offset when plain numbers would
//! be long, [`ticks`]), labels are never cut off at a figure's edge, and legends go where no
//! data are. [`check`] reads a figure back and lists what breaks these rules; the report's
//! tests run it on every figure. Every figure must still read when printed in grey: series
//! differ by line style and marker shape, not by colour alone, and bands are grey fills of
//! two weights.
//!
//! - [`svg_figure`] draws a figure on a [`Canvas`]; [`Rect`] lays out panels ([`panel_grid`]).
//! - [`Panel`] is a captioned plot with two [`Axis`]es, [`Series`] and a legend, laid out and
//!   drawn in one go; [`fit_axes`], [`draw_axes`], [`draw_grid`] and [`draw_series`] do the
//!   same by hand for figures with a layout of their own (a corner plot).
//! - [`ink`], [`tint`], [`band_fills`], [`grid`], [`Dash`] and the text sizes are the one
//!   palette.
//!
//! Every failure to draw a figure is a [`DrawError`] naming it.

mod axes;
pub mod check;
mod geometry;
mod legend;
mod panel;
mod series;
mod style;
mod svg;
pub mod text;
pub mod ticks;

pub use axes::{
    axis_margins, choose_ticks, draw_axes, draw_grid, fit_axes, Axis, Margins, Plot, Show, GAP_PX,
    TICK_PX,
};
pub use geometry::{point_in_polygon, Point, Rect, Shape};
pub use legend::{box_size, draw_box, draw_row, row_height, LegendEntry, Swatch};
pub use panel::{LegendAt, Panel};
pub use series::{draw_series, Marker, Series};
pub use style::{
    band_fills, grid, ink, series_stroke, tint, Dash, Rgb, CAPTION_PX, MARK, PANEL, TEXT_PX,
};
pub use svg::{escape, svg_figure, Canvas, Fill, Font, Stroke};
pub use ticks::{extend_bounds, padded, range_of, significant, tick, widen, Scale, Ticks};

/// A figure could not be drawn.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("drawing figure {figure}: {message}")]
pub struct DrawError {
    /// The figure (usually its file name).
    pub figure: String,
    /// The cause.
    pub message: String,
}

impl DrawError {
    /// A failure to draw `figure` for the reason `message`.
    pub fn new(figure: &str, message: impl Into<String>) -> Self {
        Self {
            figure: figure.to_owned(),
            message: message.into(),
        }
    }
}

/// Rows and columns of a grid of `panels` panels, at most `max_columns` wide: as wide as
/// needed up to that, and never empty.
pub fn panel_grid(panels: usize, max_columns: usize) -> (usize, usize) {
    let columns = panels.clamp(1, max_columns.max(1));
    (panels.div_ceil(columns).max(1), columns)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_figure_is_svg_with_its_text() {
        let svg = svg_figure(PANEL, |c| {
            let mut p = Panel::new(
                "a caption",
                Axis::linear((0.0, 1.0), "time t (s)"),
                Axis::linear((0.0, 2.0), "force F (mN)"),
            );
            p.line(
                vec![(0.0, 0.0), (1.0, 2.0)],
                series_stroke(1, 2.0),
                Some("median"),
            );
            p.markers(vec![(0.5, 1.0)], Marker::Circle, ink(0), Some("data"));
            let whole = c.bounds();
            p.draw(c, whole);
        });
        assert!(svg.starts_with("<svg"), "{}", &svg[..60]);
        for text in ["a caption", "time t (s)", "force F (mN)", "median", "data"] {
            assert!(svg.contains(text), "{text} missing");
        }
        assert!(check::check_svg(&svg).problems.is_empty());
    }

    #[test]
    fn a_failed_drawing_names_its_figure() {
        let err = DrawError::new("fig.svg", "no data");
        assert_eq!(err.to_string(), "drawing figure fig.svg: no data");
    }

    #[test]
    fn panels_fill_rows_of_at_most_max_columns() {
        assert_eq!(panel_grid(0, 3), (1, 1));
        assert_eq!(panel_grid(2, 3), (1, 2));
        assert_eq!(panel_grid(3, 3), (1, 3));
        assert_eq!(panel_grid(7, 3), (3, 3));
        assert_eq!(panel_grid(4, 0), (4, 1));
    }
}
