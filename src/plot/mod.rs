//! The crate's one plotting layer: SVG figures drawn with plotters, shared by the report, the
//! speed-against-error plots of `bench` and the rank histograms of `validate`.
//!
//! Figures are SVG text, drawn by plotters' SVG backend without font or image libraries: text
//! is laid out with plotters' naive font metrics, so labels are kept short and given room.
//! Every figure must still read when printed in grey: series differ by line style (solid,
//! dashed, dotted, dash-dot) and marker shape, not by colour alone, and bands are grey fills
//! of two weights.
//!
//! - [`svg_figure`] draws a whole figure into a string; [`panel_grid`] lays panels out.
//! - [`chart`] and [`linear_chart`] set up a [`Chart`] (caption, axes, grid, ticks) in a
//!   [`Frame`] on an [`Area`]; [`widen`], [`range_of`], [`tick`] and [`significant`] choose
//!   ranges and write numbers.
//! - [`line()`], [`styled_line`], [`markers`], [`band`], [`bars`] and [`legend`] draw series.
//! - [`ink`], [`tint`], [`band_fills`], [`grid`], [`Dash`] and the fonts are the one palette.
//!
//! Every failure to draw a figure is a [`DrawError`] naming it.

mod axes;
mod series;
mod style;

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;

pub use axes::{
    chart, extend_bounds, linear_chart, padded, range_of, significant, tick, widen, Frame,
};
pub use series::{band, bars, legend, line, markers, styled_line};
pub use style::{
    band_fills, caption_font, grid, ink, label_font, small_font, tint, Dash, FONT, PANEL,
};

/// A drawing area of an SVG figure.
pub type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// A chart of an SVG figure with x coordinates `X` and y coordinates `Y`.
pub type Chart<'a, 'b, X, Y> = ChartContext<'a, SVGBackend<'b>, Cartesian2d<X, Y>>;

/// A chart of an SVG figure with linear axes, as [`linear_chart`] makes.
pub type LinearChart<'a, 'b> = Chart<'a, 'b, RangedCoordf64, RangedCoordf64>;

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

/// Turns a plotters error into a [`DrawError`] naming the figure.
pub trait Drawn<T> {
    /// The value, or the error as a [`DrawError`] of `figure`.
    ///
    /// # Errors
    /// [`DrawError`] when `self` is an error.
    fn drawn(self, figure: &str) -> Result<T, DrawError>;
}

impl<T, E: std::fmt::Display> Drawn<T> for Result<T, E> {
    fn drawn(self, figure: &str) -> Result<T, DrawError> {
        self.map_err(|e| DrawError::new(figure, e.to_string()))
    }
}

/// Draws a figure of `size` (pixels) named `name` into an SVG string, on a white background.
///
/// # Errors
/// Whatever `draw` returns, or [`DrawError`] when the backend fails.
pub fn svg_figure(
    name: &str,
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<(), DrawError>,
) -> Result<String, DrawError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).drawn(name)?;
        draw(&root)?;
        root.present().drawn(name)?;
    }
    Ok(svg)
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
        let svg = svg_figure("test", PANEL, |root| {
            let mut chart = linear_chart(
                root,
                "test",
                "a caption",
                (0.0, 1.0),
                (0.0, 2.0),
                "time t (s)",
                "force F (mN)",
            )?;
            line(
                &mut chart,
                "test",
                vec![(0.0, 0.0), (1.0, 2.0)],
                1,
                2,
                Some("median"),
            )?;
            markers(&mut chart, "test", &[(0.5, 1.0)], 0, Some("data"))?;
            legend(&mut chart, "test", SeriesLabelPosition::UpperLeft)
        })
        .unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..60]);
        for text in ["a caption", "time t (s)", "force F (mN)", "median", "data"] {
            assert!(svg.contains(text), "{text} missing");
        }
    }

    #[test]
    fn a_failed_drawing_names_its_figure() {
        let err = svg_figure("fig.svg", PANEL, |_| {
            Err(DrawError::new("fig.svg", "no data"))
        })
        .unwrap_err();
        assert_eq!(err.to_string(), "drawing figure fig.svg: no data");
        let plotters: Result<(), &str> = Err("backend");
        assert_eq!(
            plotters.drawn("x").unwrap_err(),
            DrawError::new("x", "backend")
        );
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
