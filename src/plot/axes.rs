//! Charts and their axes: the frame around a plot, ranges that are never empty, tick text.

use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

use super::style::{grid, CAPTION_SIZE, FONT, LABEL_SIZE};
use super::{Area, Chart, DrawError, Drawn, LinearChart};

/// The frame of a chart: room for labels, text sizes and how many ticks each axis gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Frame {
    /// Margin around the chart (pixels).
    pub margin: u32,
    /// Height of the x-axis label area (pixels).
    pub x_label_area: u32,
    /// Width of the y-axis label area (pixels).
    pub y_label_area: u32,
    /// Caption font size.
    pub caption_size: u32,
    /// Tick label font size.
    pub label_size: u32,
    /// Axis description font size.
    pub desc_size: u32,
    /// Ticks on the x axis (at most).
    pub x_labels: usize,
    /// Ticks on the y axis (at most).
    pub y_labels: usize,
}

impl Frame {
    /// A standard panel ([`PANEL`](super::PANEL)-sized).
    pub const PANEL: Self = Self {
        margin: 10,
        x_label_area: 48,
        y_label_area: 70,
        caption_size: CAPTION_SIZE,
        label_size: LABEL_SIZE,
        desc_size: LABEL_SIZE + 1,
        x_labels: 6,
        y_labels: 6,
    };

    /// A small panel of a grid of many (about 300 × 220 pixels).
    pub const SMALL: Self = Self {
        margin: 12,
        x_label_area: 38,
        y_label_area: 46,
        caption_size: 13,
        label_size: 11,
        desc_size: 12,
        x_labels: 5,
        y_labels: 4,
    };
}

/// A chart on `area` in `frame`, with a caption, the light and bold grid, and each axis given
/// as its range (linear `a..b` or logarithmic `(a..b).log_scale()`) and its description.
/// Ticks are written by [`tick`].
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn chart<'a, 'b, X, Y>(
    area: &'a Area<'b>,
    name: &str,
    frame: &Frame,
    caption: &str,
    (x, x_desc): (X, &str),
    (y, y_desc): (Y, &str),
) -> Result<Chart<'a, 'b, X::CoordDescType, Y::CoordDescType>, DrawError>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, frame.caption_size))
        .margin(frame.margin)
        .x_label_area_size(frame.x_label_area)
        .y_label_area_size(frame.y_label_area)
        .build_cartesian_2d(x, y)
        .drawn(name)?;
    let (light, bold) = grid();
    chart
        .configure_mesh()
        .light_line_style(light)
        .bold_line_style(bold)
        .x_desc(x_desc)
        .y_desc(y_desc)
        .x_labels(frame.x_labels)
        .y_labels(frame.y_labels)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style((FONT, frame.label_size))
        .axis_desc_style((FONT, frame.desc_size))
        .draw()
        .drawn(name)?;
    Ok(chart)
}

/// A linear chart on `area` in the standard [`Frame::PANEL`], with a caption and axis
/// descriptions; degenerate ranges are widened.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn linear_chart<'a, 'b>(
    area: &'a Area<'b>,
    name: &str,
    caption: &str,
    x: (f64, f64),
    y: (f64, f64),
    x_desc: &str,
    y_desc: &str,
) -> Result<LinearChart<'a, 'b>, DrawError> {
    let (x, y) = (widen(x), widen(y));
    chart(
        area,
        name,
        &Frame::PANEL,
        caption,
        (x.0..x.1, x_desc),
        (y.0..y.1, y_desc),
    )
}

/// A range that is not empty: a degenerate one is widened around its value, a non-finite one
/// becomes (0, 1).
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
    padded(
        values
            .into_iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |b, &v| {
                extend_bounds(b, v)
            }),
        pad,
    )
}

/// `(lo, hi)` extended to take in `v` when it is finite: folded from (∞, −∞) over values,
/// their finite range, as [`range_of`] takes it (so that a figure can take the range of
/// values it does not keep).
pub fn extend_bounds((lo, hi): (f64, f64), v: f64) -> (f64, f64) {
    if v.is_finite() {
        (lo.min(v), hi.max(v))
    } else {
        (lo, hi)
    }
}

/// The range `(lo, hi)` made non-empty ([`widen`]) and padded by `pad` of its width on each
/// side.
pub fn padded((lo, hi): (f64, f64), pad: f64) -> (f64, f64) {
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
    let s = significant(v, 4);
    match s.split_once('e') {
        Some((mantissa, exponent)) => {
            let m = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{exponent}")
        }
        None if s.contains('.') => s.trim_end_matches('0').trim_end_matches('.').to_owned(),
        None => s,
    }
}

/// `x` with `digits` significant digits, in plain notation between 1e-3 and 1e5 and in
/// scientific notation (`1.23e-7`) outside; `–` for a missing (NaN) value.
pub fn significant(x: f64, digits: usize) -> String {
    if x.is_nan() {
        return "–".to_owned();
    }
    if x.is_infinite() {
        return if x > 0.0 { "∞" } else { "−∞" }.to_owned();
    }
    if x == 0.0 {
        return "0".to_owned();
    }
    let digits = digits.max(1);
    let magnitude = x.abs().log10().floor() as i32;
    if (-3..5).contains(&magnitude) {
        let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = digits - 1)
    }
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
    fn significant_digits() {
        assert_eq!(significant(12.345, 3), "12.3");
        assert_eq!(significant(0.0123456, 3), "0.0123");
        assert_eq!(significant(921691.2, 4), "9.217e5");
        assert_eq!(significant(1.0094, 4), "1.009");
        assert_eq!(significant(-0.5, 2), "-0.50");
        assert_eq!(significant(f64::NAN, 3), "–");
        assert_eq!(significant(0.0, 3), "0");
        assert_eq!(significant(2.5e-7, 2), "2.5e-7");
    }

    #[test]
    fn degenerate_ranges_still_draw() {
        assert_eq!(widen((1.0, 1.0)), (0.95, 1.05));
        assert_eq!(widen((f64::NAN, 1.0)), (0.0, 1.0));
        assert_eq!(widen((0.0, 0.0)), (-1.0, 1.0));
        assert_eq!(range_of(&[1.0, f64::NAN, 3.0], 0.5), (0.0, 4.0));
    }
}
