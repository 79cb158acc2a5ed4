//! Series on a chart: lines, markers, filled bands, bars, and the legend naming them.
//!
//! Points that are not finite are left out rather than failing the figure.

use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::style::{ink, Dash, FONT, LEGEND_SIZE};
use super::{DrawError, Drawn};

/// A chart of an SVG figure in any coordinates of `(f64, f64)` points.
type SvgChart<'a, 'b, CT> = ChartContext<'a, SVGBackend<'b>, CT>;

/// Draws a line through `points` in the style of series `k` (its [`ink`] and [`Dash::of`]),
/// `width` pixels wide, with a legend entry when `label` is given.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn line<CT>(
    chart: &mut SvgChart<'_, '_, CT>,
    name: &str,
    points: Vec<(f64, f64)>,
    k: usize,
    width: u32,
    label: Option<&str>,
) -> Result<(), DrawError>
where
    CT: CoordTranslate<From = (f64, f64)>,
{
    styled_line(
        chart,
        name,
        points,
        ink(k).stroke_width(width),
        Dash::of(k),
        label,
    )
}

/// Draws a line through `points` in `style` and `dash`, with a legend entry when `label` is
/// given: for lines that are not one of a figure's series (reference levels, fronts).
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn styled_line<CT>(
    chart: &mut SvgChart<'_, '_, CT>,
    name: &str,
    points: Vec<(f64, f64)>,
    style: ShapeStyle,
    dash: Dash,
    label: Option<&str>,
) -> Result<(), DrawError>
where
    CT: CoordTranslate<From = (f64, f64)>,
{
    let points: Vec<(f64, f64)> = points
        .into_iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let anno = match dash.pattern() {
        None => chart
            .draw_series(LineSeries::new(points, style))
            .drawn(name)?,
        Some((dash, gap)) => chart
            .draw_series(DashedLineSeries::new(points, dash, gap, style))
            .drawn(name)?,
    };
    if let Some(label) = label {
        match dash.pattern() {
            None => {
                anno.label(label)
                    .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 24, y)], style));
            }
            Some((dash, gap)) => {
                anno.label(label).legend(move |(x, y)| {
                    DashedPathElement::new(vec![(x, y), (x + 24, y)], dash, gap, style)
                });
            }
        }
    }
    Ok(())
}

/// Draws `points` as markers of series `k`: open circle, triangle, cross, square (then
/// again), in its [`ink`], with a legend entry when `label` is given.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn markers<CT>(
    chart: &mut SvgChart<'_, '_, CT>,
    name: &str,
    points: &[(f64, f64)],
    k: usize,
    label: Option<&str>,
) -> Result<(), DrawError>
where
    CT: CoordTranslate<From = (f64, f64)>,
{
    let style = ink(k).stroke_width(1);
    let pts = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let anno =
        match k % 4 {
            0 => chart
                .draw_series(pts.map(|p| Circle::new(p, 3, style)))
                .drawn(name)?,
            1 => chart
                .draw_series(pts.map(|p| TriangleMarker::new(p, 4, style)))
                .drawn(name)?,
            2 => chart
                .draw_series(pts.map(|p| Cross::new(p, 3, style)))
                .drawn(name)?,
            _ => chart
                .draw_series(pts.map(|(x, y)| {
                    EmptyElement::at((x, y)) + Rectangle::new([(-3, -3), (3, 3)], style)
                }))
                .drawn(name)?,
        };
    if let Some(label) = label {
        let anno = anno.label(label);
        match k % 4 {
            0 => {
                anno.legend(move |(x, y)| Circle::new((x + 12, y), 3, style));
            }
            1 => {
                anno.legend(move |(x, y)| TriangleMarker::new((x + 12, y), 4, style));
            }
            2 => {
                anno.legend(move |(x, y)| Cross::new((x + 12, y), 3, style));
            }
            _ => {
                anno.legend(move |(x, y)| Rectangle::new([(x + 9, y - 3), (x + 15, y + 3)], style));
            }
        }
    }
    Ok(())
}

/// Fills the band between `low` and `high` over `xs` with `fill` (e.g. one of
/// [`band_fills`](super::band_fills) or a [`tint`](super::tint)), with a legend swatch when
/// `label` is given. Nothing is drawn when fewer than three finite corners remain.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn band<CT>(
    chart: &mut SvgChart<'_, '_, CT>,
    name: &str,
    xs: &[f64],
    low: &[f64],
    high: &[f64],
    fill: RGBAColor,
    label: Option<&str>,
) -> Result<(), DrawError>
where
    CT: CoordTranslate<From = (f64, f64)>,
{
    let mut outline: Vec<(f64, f64)> = Vec::with_capacity(2 * xs.len());
    for j in 0..xs.len() {
        if xs[j].is_finite() && low[j].is_finite() {
            outline.push((xs[j], low[j]));
        }
    }
    for j in (0..xs.len()).rev() {
        if xs[j].is_finite() && high[j].is_finite() {
            outline.push((xs[j], high[j]));
        }
    }
    if outline.len() < 3 {
        return Ok(());
    }
    let anno = chart
        .draw_series(std::iter::once(Polygon::new(outline, fill.filled())))
        .drawn(name)?;
    if let Some(label) = label {
        anno.label(label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 24, y + 5)], fill.filled()));
    }
    Ok(())
}

/// Draws bars from zero: each `((left, right), height)` a rectangle filled with `fill`, one
/// pixel narrower on each side so that neighbouring bars stay apart, with a legend swatch
/// when `label` is given.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn bars<CT>(
    chart: &mut SvgChart<'_, '_, CT>,
    name: &str,
    bars: &[((f64, f64), f64)],
    fill: RGBColor,
    label: Option<&str>,
) -> Result<(), DrawError>
where
    CT: CoordTranslate<From = (f64, f64)>,
{
    let anno = chart
        .draw_series(
            bars.iter()
                .filter(|((l, r), h)| l.is_finite() && r.is_finite() && h.is_finite())
                .map(|&((left, right), height)| {
                    let mut bar = Rectangle::new([(left, 0.0), (right, height)], fill.filled());
                    bar.set_margin(0, 0, 1, 1);
                    bar
                }),
        )
        .drawn(name)?;
    if let Some(label) = label {
        anno.label(label)
            .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 24, y + 5)], fill.filled()));
    }
    Ok(())
}

/// Draws the legend of `chart` at `position`: the labelled series, on a translucent white box.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn legend<'a, 'b: 'a, CT>(
    chart: &mut SvgChart<'a, 'b, CT>,
    name: &str,
    position: SeriesLabelPosition,
) -> Result<(), DrawError>
where
    CT: CoordTranslate<From = (f64, f64)>,
{
    chart
        .configure_series_labels()
        .position(position)
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(120, 120, 120))
        .label_font((FONT, LEGEND_SIZE))
        .draw()
        .drawn(name)
}
