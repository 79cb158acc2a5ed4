//! The SVG writer: a canvas of pixels that elements are written onto, in drawing order.
//!
//! The markup follows a few conventions that [`check`](super::check) reads back: grid lines
//! are `<line>` elements spanning their plot area; axis lines and tick marks are black
//! two-point `<polyline>`s; legend boxes are white `<rect>`s with their entries inside; text is
//! placed by `text-anchor` and a `dy` of `0.76em` (hanging), `0.5ex` (centred) or `-0.5ex`
//! (resting on the point), rotated by a `transform`.

use std::fmt::Write as _;

use super::geometry::{Point, Rect};
use super::style::{Rgb, FONT};
use super::text::{text_box, Anchor, Rotation};

/// How a line is stroked.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Stroke {
    /// Colour.
    pub color: Rgb,
    /// Width in pixels.
    pub width: f64,
    /// Dash pattern.
    pub dash: super::Dash,
    /// Opacity, 0 to 1.
    pub opacity: f64,
}

impl Stroke {
    /// A solid, opaque stroke.
    pub fn solid(color: Rgb, width: f64) -> Self {
        Self {
            color,
            width,
            dash: super::Dash::Solid,
            opacity: 1.0,
        }
    }

    /// The same stroke with `dash`.
    pub fn dashed(self, dash: super::Dash) -> Self {
        Self { dash, ..self }
    }

    /// The same stroke with `opacity`.
    pub fn faded(self, opacity: f64) -> Self {
        Self { opacity, ..self }
    }

    fn attributes(&self) -> String {
        let mut a = format!(
            " stroke=\"{}\" stroke-width=\"{}\"",
            self.color,
            num(self.width)
        );
        if self.opacity < 1.0 {
            let _ = write!(a, " stroke-opacity=\"{}\"", num3(self.opacity));
        }
        if let Some((on, off)) = self.dash.pattern() {
            let _ = write!(a, " stroke-dasharray=\"{} {}\"", num(on), num(off));
        }
        a
    }
}

/// How an area is filled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fill {
    /// Colour.
    pub color: Rgb,
    /// Opacity, 0 to 1.
    pub opacity: f64,
}

impl Fill {
    /// An opaque fill.
    pub fn solid(color: Rgb) -> Self {
        Self {
            color,
            opacity: 1.0,
        }
    }

    /// A translucent fill.
    pub fn translucent(color: Rgb, opacity: f64) -> Self {
        Self { color, opacity }
    }

    fn attributes(&self) -> String {
        let mut a = format!(" fill=\"{}\"", self.color);
        if self.opacity < 1.0 {
            let _ = write!(a, " fill-opacity=\"{}\"", num3(self.opacity));
        }
        a
    }
}

/// How a text is written: size in CSS pixels, anchor, rotation, colour, weight.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Font {
    /// Font size in CSS pixels at scale 1.
    pub px: f64,
    /// Which point of the text sits at its position.
    pub anchor: Anchor,
    /// Rotation about that point.
    pub rotation: Rotation,
    /// Colour.
    pub color: Rgb,
    /// Bold.
    pub bold: bool,
}

impl Font {
    /// Black upright text of `px` pixels anchored at `anchor`.
    pub fn new(px: f64, anchor: Anchor) -> Self {
        Self {
            px,
            anchor,
            rotation: Rotation::None,
            color: Rgb::BLACK,
            bold: false,
        }
    }

    /// The same font rotated.
    pub fn rotated(self, rotation: Rotation) -> Self {
        Self { rotation, ..self }
    }

    /// The same font in bold.
    pub fn bold(self) -> Self {
        Self { bold: true, ..self }
    }
}

/// An SVG document being drawn: `width` × `height` pixels on a white background.
///
/// The markup follows a few conventions that [`check`](super::check) reads back: grid lines
/// are `<line>` elements spanning their plot area; axis lines and tick marks are black
/// two-point `<polyline>`s; legend boxes are white `<rect>`s with their entries inside; text
/// is placed by `text-anchor` and a `dy` of `0.76em` (hanging), `0.5ex` (centred) or
/// `-0.5ex` (resting on the point), rotated by a `transform`.
#[derive(Debug)]
pub struct Canvas {
    size: (f64, f64),
    svg: String,
}

impl Canvas {
    /// A blank white canvas of `width` × `height` pixels.
    pub fn new((width, height): (u32, u32)) -> Self {
        let mut svg = String::with_capacity(64 * 1024);
        let _ = writeln!(
            svg,
            "<svg width=\"{width}\" height=\"{height}\" viewBox=\"0 0 {width} {height}\" xmlns=\"http://www.w3.org/2000/svg\">"
        );
        let _ = writeln!(
            svg,
            "<rect x=\"0\" y=\"0\" width=\"{width}\" height=\"{height}\" fill=\"#FFFFFF\" stroke=\"none\"/>"
        );
        Self {
            size: (f64::from(width), f64::from(height)),
            svg,
        }
    }

    /// The whole canvas.
    pub fn bounds(&self) -> Rect {
        Rect::of_size(self.size)
    }

    /// The finished document.
    pub fn finish(mut self) -> String {
        self.svg.push_str("</svg>\n");
        self.svg
    }

    /// A straight `<line>`: grid lines only (see the module documentation).
    pub(crate) fn grid_line(&mut self, a: Point, b: Point, stroke: Stroke) {
        let _ = writeln!(
            self.svg,
            "<line x1=\"{}\" y1=\"{}\" x2=\"{}\" y2=\"{}\"{}/>",
            num(a.0),
            num(a.1),
            num(b.0),
            num(b.1),
            stroke.attributes()
        );
    }

    /// An open polyline through `points` (nothing for fewer than two).
    pub fn polyline(&mut self, points: &[Point], stroke: Stroke) {
        if points.len() < 2 {
            return;
        }
        let _ = writeln!(
            self.svg,
            "<polyline fill=\"none\"{} points=\"{}\"/>",
            stroke.attributes(),
            point_list(points)
        );
    }

    /// A closed polygon, filled and optionally outlined (nothing for fewer than three points).
    pub fn polygon(&mut self, points: &[Point], fill: Option<Fill>, stroke: Option<Stroke>) {
        if points.len() < 3 {
            return;
        }
        let _ = writeln!(
            self.svg,
            "<polygon{}{} points=\"{}\"/>",
            fill.map_or_else(|| " fill=\"none\"".to_owned(), |f| f.attributes()),
            stroke.map_or_else(|| " stroke=\"none\"".to_owned(), |s| s.attributes()),
            point_list(points)
        );
    }

    /// A circle of radius `r`.
    pub fn circle(&mut self, center: Point, r: f64, fill: Option<Fill>, stroke: Option<Stroke>) {
        let _ = writeln!(
            self.svg,
            "<circle cx=\"{}\" cy=\"{}\" r=\"{}\"{}{}/>",
            num(center.0),
            num(center.1),
            num(r),
            fill.map_or_else(|| " fill=\"none\"".to_owned(), |f| f.attributes()),
            stroke.map_or_else(|| " stroke=\"none\"".to_owned(), |s| s.attributes()),
        );
    }

    /// A rectangle.
    pub fn rect(&mut self, r: &Rect, fill: Option<Fill>, stroke: Option<Stroke>) {
        let _ = writeln!(
            self.svg,
            "<rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"{}\"{}{}/>",
            num(r.x0),
            num(r.y0),
            num(r.width()),
            num(r.height()),
            fill.map_or_else(|| " fill=\"none\"".to_owned(), |f| f.attributes()),
            stroke.map_or_else(|| " stroke=\"none\"".to_owned(), |s| s.attributes()),
        );
    }

    /// Text at `at` in `font`; returns the box it is estimated to cover
    /// ([`text_box`](super::text::text_box)). Empty text writes nothing.
    pub fn text(&mut self, text: &str, at: Point, font: Font) -> Rect {
        let covered = text_box(text, font.px, at, font.anchor, font.rotation);
        if text.is_empty() {
            return covered;
        }
        let anchor = match font.anchor.h {
            super::text::HPos::Left => "start",
            super::text::HPos::Center => "middle",
            super::text::HPos::Right => "end",
        };
        let dy = match font.anchor.v {
            super::text::VPos::Top => "0.76em",
            super::text::VPos::Center => "0.5ex",
            super::text::VPos::Bottom => "-0.5ex",
        };
        let mut attrs = format!(
            "x=\"{}\" y=\"{}\" dy=\"{dy}\" text-anchor=\"{anchor}\" font-family=\"{FONT}\" font-size=\"{}\" fill=\"{}\"",
            num(at.0),
            num(at.1),
            num(font.px),
            font.color
        );
        if font.bold {
            attrs.push_str(" font-weight=\"bold\"");
        }
        if let Some(deg) = font.rotation.degrees() {
            let _ = write!(
                attrs,
                " transform=\"rotate({deg}, {}, {})\"",
                num(at.0),
                num(at.1)
            );
        }
        let _ = writeln!(self.svg, "<text {attrs}>{}</text>", escape(text));
        covered
    }
}

/// Draws a figure of `size` pixels into an SVG string. Drawing cannot fail: a figure that
/// needs data it may lack checks for them before it draws, and says so with a
/// [`DrawError`](super::DrawError).
pub fn svg_figure(size: (u32, u32), draw: impl FnOnce(&mut Canvas)) -> String {
    let mut canvas = Canvas::new(size);
    draw(&mut canvas);
    canvas.finish()
}

fn point_list(points: &[Point]) -> String {
    let mut s = String::with_capacity(points.len() * 10);
    for (i, &(x, y)) in points.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{},{}", num(x), num(y));
    }
    s
}

/// A pixel coordinate to a tenth of a pixel, without a trailing `.0`.
fn num(v: f64) -> String {
    let tenths = (v * 10.0).round() as i64;
    if tenths % 10 == 0 {
        format!("{}", tenths / 10)
    } else {
        format!("{:.1}", tenths as f64 / 10.0)
    }
}

fn num3(v: f64) -> String {
    format!("{:.3}", v.clamp(0.0, 1.0))
        .trim_end_matches('0')
        .trim_end_matches('.')
        .to_owned()
}

/// Text escaped for XML.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            _ => out.push(c),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::text::{HPos, VPos};

    #[test]
    fn elements_are_written_in_order_and_escaped() {
        let svg = svg_figure((100, 50), |c| {
            c.polyline(&[(0.0, 0.0), (10.25, 5.0)], Stroke::solid(Rgb::BLACK, 1.0));
            c.text(
                "a<b & c",
                (50.0, 10.0),
                Font::new(12.0, Anchor::new(HPos::Center, VPos::Top)),
            );
        });
        assert!(svg.starts_with("<svg width=\"100\" height=\"50\""));
        assert!(svg.contains("points=\"0,0 10.3,5\""), "{svg}");
        assert!(svg.contains(">a&lt;b &amp; c</text>"));
        assert!(svg.contains("font-size=\"12\""));
        assert!(svg.trim_end().ends_with("</svg>"));
        assert_eq!(num(-0.04), "0");
        assert_eq!(num(2.0), "2");
    }
}
