//! The report's figures, drawn as SVG text with plotters.
//!
//! Every figure must still read when printed in grey: series differ by line style (solid,
//! dashed, dotted, dash-dot) and marker shape, not by colour alone; bands are grey fills of
//! two weights. Text is laid out with plotters' naive font metrics (no font library), so
//! labels are kept short and given room.

use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::ReportError;

/// Width and height of one panel, in pixels.
pub const PANEL: (u32, u32) = (560, 380);
const FONT: &str = "sans-serif";
const CAPTION_SIZE: u32 = 17;
const LABEL_SIZE: u32 = 14;
const LEGEND_SIZE: u32 = 13;

/// Series inks: dark to light, so that they also differ in grey.
const INKS: [RGBColor; 4] = [
    RGBColor(0, 0, 0),
    RGBColor(0, 90, 170),
    RGBColor(205, 110, 0),
    RGBColor(110, 110, 110),
];
/// The 95 % band (light) and the 50 % band (darker).
const BAND_95: RGBColor = RGBColor(215, 215, 215);
const BAND_50: RGBColor = RGBColor(160, 160, 160);
const GRID_LIGHT: RGBColor = RGBColor(246, 246, 246);
const GRID_BOLD: RGBColor = RGBColor(215, 215, 215);

/// Turns a plotters error into a report error naming the figure.
pub(super) trait Drawn<T> {
    fn drawn(self, figure: &str) -> Result<T, ReportError>;
}

impl<T, E: std::fmt::Display> Drawn<T> for Result<T, E> {
    fn drawn(self, figure: &str) -> Result<T, ReportError> {
        self.map_err(|e| ReportError::Draw {
            figure: figure.to_owned(),
            message: e.to_string(),
        })
    }
}

/// Line style of series `k`: solid, dashed, dotted, dash-dot (then again).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dash {
    /// Solid.
    Solid,
    /// Long dashes.
    Dashed,
    /// Dots.
    Dotted,
    /// Short dashes.
    Short,
}

impl Dash {
    /// The style of series `k`.
    pub fn of(k: usize) -> Self {
        [Self::Solid, Self::Dashed, Self::Dotted, Self::Short][k % 4]
    }

    /// Dash length and gap in pixels; `None` for solid.
    fn pattern(self) -> Option<(u32, u32)> {
        match self {
            Self::Solid => None,
            Self::Dashed => Some((9, 5)),
            Self::Dotted => Some((2, 4)),
            Self::Short => Some((5, 3)),
        }
    }
}

/// Ink of series `k`.
pub fn ink(k: usize) -> RGBColor {
    INKS[k % INKS.len()]
}

/// A drawing area of an SVG figure.
pub type Area<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// Draws a figure of `size` into an SVG string.
///
/// # Errors
/// Whatever `draw` returns, or [`ReportError::Draw`] when the backend fails.
pub fn svg_figure(
    name: &str,
    size: (u32, u32),
    draw: impl FnOnce(&Area) -> Result<(), ReportError>,
) -> Result<String, ReportError> {
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).drawn(name)?;
        draw(&root)?;
        root.present().drawn(name)?;
    }
    Ok(svg)
}

/// A linear chart on `area` with a caption and axis descriptions.
///
/// # Errors
/// [`ReportError::Draw`].
pub fn linear_chart<'a, 'b>(
    area: &'a Area<'b>,
    name: &str,
    caption: &str,
    x: (f64, f64),
    y: (f64, f64),
    x_desc: &str,
    y_desc: &str,
) -> Result<
    ChartContext<'a, SVGBackend<'b>, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    ReportError,
> {
    let (x, y) = (widen(x), widen(y));
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, CAPTION_SIZE))
        .margin(10)
        .x_label_area_size(48)
        .y_label_area_size(70)
        .build_cartesian_2d(x.0..x.1, y.0..y.1)
        .drawn(name)?;
    chart
        .configure_mesh()
        .light_line_style(GRID_LIGHT)
        .bold_line_style(GRID_BOLD)
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_labels(6)
        .y_labels(6)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style((FONT, LABEL_SIZE))
        .axis_desc_style((FONT, LABEL_SIZE + 1))
        .draw()
        .drawn(name)?;
    Ok(chart)
}

/// A range that is not empty: a degenerate one is widened around its value.
pub fn widen((lo, hi): (f64, f64)) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi > lo {
        (lo, hi)
    } else {
        let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.05 };
        (lo - pad, hi + pad)
    }
}

/// The finite range of `values`, padded by `pad` of its width on each side.
pub fn range_of<'v>(values: impl IntoIterator<Item = &'v f64>, pad: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for &v in values {
        if v.is_finite() {
            lo = lo.min(v);
            hi = hi.max(v);
        }
    }
    let (lo, hi) = widen((lo, hi));
    let w = hi - lo;
    (lo - pad * w, hi + pad * w)
}

/// Axis tick text: four significant digits at most, without float noise or trailing zeros
/// (neighbouring ticks such as 0.00405 and 0.0041 stay distinct).
pub fn tick(v: f64) -> String {
    // Ticks at zero come out as float noise such as -2.8e-17.
    if v.abs() < 1e-12 {
        return "0".to_owned();
    }
    let s = super::units::significant(v, 4);
    match s.split_once('e') {
        Some((mantissa, exponent)) => {
            let m = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{exponent}")
        }
        None if s.contains('.') => s.trim_end_matches('0').trim_end_matches('.').to_owned(),
        None => s,
    }
}

/// Draws a line through `points` in the style of series `k`, with a legend entry when
/// `label` is given.
///
/// # Errors
/// [`ReportError::Draw`].
pub fn line<CT>(
    chart: &mut ChartContext<'_, SVGBackend<'_>, CT>,
    name: &str,
    points: Vec<(f64, f64)>,
    k: usize,
    width: u32,
    label: Option<&str>,
) -> Result<(), ReportError>
where
    CT: CoordTranslate<From = (f64, f64)>,
{
    let points: Vec<(f64, f64)> = points
        .into_iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let style = ink(k).stroke_width(width);
    let anno = match Dash::of(k).pattern() {
        None => chart
            .draw_series(LineSeries::new(points, style))
            .drawn(name)?,
        Some((dash, gap)) => chart
            .draw_series(DashedLineSeries::new(points, dash, gap, style))
            .drawn(name)?,
    };
    if let Some(label) = label {
        match Dash::of(k).pattern() {
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

/// Marker shape of series `k`: open circle, triangle, cross, square.
pub fn markers<CT>(
    chart: &mut ChartContext<'_, SVGBackend<'_>, CT>,
    name: &str,
    points: &[(f64, f64)],
    k: usize,
    label: Option<&str>,
) -> Result<(), ReportError>
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

/// Fills the band between `low` and `high` over `xs`, grey of the given weight, with a
/// legend swatch when `label` is given.
pub fn band<CT>(
    chart: &mut ChartContext<'_, SVGBackend<'_>, CT>,
    name: &str,
    xs: &[f64],
    low: &[f64],
    high: &[f64],
    fill: RGBAColor,
    label: Option<&str>,
) -> Result<(), ReportError>
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

/// The light (95 %) and darker (50 %) band fills.
pub fn band_fills() -> (RGBAColor, RGBAColor) {
    (BAND_95.to_rgba(), BAND_50.to_rgba())
}

/// A translucent fill of series `k`'s ink, for overlapping bands.
pub fn tint(k: usize) -> RGBAColor {
    ink(k).mix(0.16)
}

/// Draws the legend of `chart` at `position`.
///
/// # Errors
/// [`ReportError::Draw`].
pub fn legend<'a, 'b: 'a, CT>(
    chart: &mut ChartContext<'a, SVGBackend<'b>, CT>,
    name: &str,
    position: SeriesLabelPosition,
) -> Result<(), ReportError>
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

/// Font of small panels (corner plots, traces).
pub fn small_font() -> (&'static str, u32) {
    (FONT, 12)
}

/// Font of captions.
pub fn caption_font() -> (&'static str, u32) {
    (FONT, CAPTION_SIZE)
}

/// Font of axis labels.
pub fn label_font() -> (&'static str, u32) {
    (FONT, LABEL_SIZE)
}

/// Grid line styles (light, bold).
pub fn grid() -> (RGBColor, RGBColor) {
    (GRID_LIGHT, GRID_BOLD)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_short() {
        assert_eq!(tick(0.0), "0");
        assert_eq!(tick(-2.8e-17), "0");
        assert_eq!(tick(12.5), "12.5");
        assert_eq!(tick(3000.0), "3000");
        assert_eq!(tick(0.25), "0.25");
        assert_eq!(tick(2e-7), "2e-7");
        assert_eq!(tick(0.00405), "0.00405");
        assert_eq!(tick(-1.25e6), "-1.25e6");
    }

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
        // Degenerate ranges still draw.
        assert_eq!(widen((1.0, 1.0)), (0.95, 1.05));
        assert_eq!(widen((f64::NAN, 1.0)), (0.0, 1.0));
    }
}
