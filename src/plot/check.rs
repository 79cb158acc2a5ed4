//! Reads an SVG figure back and finds what makes it hard to read: an axis without tick
//! labels, text covering data or other text, a legend box over data, text cut off at the
//! figure's edge, text too small, a figure too wide for the report's page.
//!
//! It reads the figures this crate writes and those plotters' SVG backend wrote before them
//! (the same conventions, see [`Canvas`](super::Canvas)): grid lines are `<line>`s longer than a
//! marker; axis lines and tick marks are black, one pixel wide, solid, two-point
//! `<polyline>`s (axis lines at least 20 pixels long, tick marks at most 8 and touching an
//! axis line); a white `<rect>` smaller than the figure is a legend box and what is drawn
//! inside it is its content; every other shape is data. Text boxes are estimated with
//! [`text_box`](super::text::text_box()).
//!
//! An axis needs two tick labels, unless it shares its ticks with a labelled axis: one of the
//! same orientation and extent, with tick marks at the same places (a corner plot's inner
//! panels). An axis without tick marks needs them.

use super::geometry::{Point, Rect, Shape};
use super::style::{MAX_FIGURE_WIDTH, MIN_TEXT_PX};
use super::text::{text_box, Anchor, HPos, Rotation, VPos};

/// Axis lines are at least this long (pixels).
const AXIS_MIN: f64 = 20.0;
/// Tick marks are at most this long (pixels).
const TICK_MAX: f64 = 8.0;
/// Pixels two positions may differ by and still be the same.
const SAME: f64 = 1.5;
/// Estimated boxes are shrunk by this much before overlaps are tested (pixels), so that
/// touching is not overlapping.
const TOUCH: f64 = 0.5;

/// A text element of a figure.
#[derive(Debug, Clone, PartialEq)]
pub struct TextItem {
    /// The text.
    pub text: String,
    /// Font size (CSS pixels).
    pub px: f64,
    /// Estimated box.
    pub bounds: Rect,
    /// Rotation.
    pub rotation: Rotation,
}

/// An axis found in a figure.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisItem {
    /// Whether the axis line is vertical (a y axis).
    pub vertical: bool,
    /// Position across the axis (x of a vertical axis, y of a horizontal one).
    pub at: f64,
    /// Extent along the axis.
    pub from: f64,
    /// End of the extent.
    pub to: f64,
    /// Positions of the tick marks along the axis.
    pub ticks: Vec<f64>,
    /// The tick labels.
    pub labels: Vec<String>,
}

impl AxisItem {
    fn describe(&self) -> String {
        if self.vertical {
            format!(
                "the vertical axis at x = {:.0} (y {:.0}–{:.0})",
                self.at, self.from, self.to
            )
        } else {
            format!(
                "the horizontal axis at y = {:.0} (x {:.0}–{:.0})",
                self.at, self.from, self.to
            )
        }
    }
}

/// What [`check_svg`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct FigureCheck {
    /// Width and height of the figure (pixels).
    pub size: (f64, f64),
    /// Every text.
    pub texts: Vec<TextItem>,
    /// Every axis.
    pub axes: Vec<AxisItem>,
    /// Legend boxes.
    pub legends: Vec<Rect>,
    /// Shapes taken as data.
    pub data: Vec<Shape>,
    /// What is wrong, in words; empty when the figure reads well.
    pub problems: Vec<String>,
}

/// One element of an SVG document, as [`elements`] reads it.
#[derive(Debug, Clone)]
pub struct Element {
    /// Tag name (`polyline`, `text`, …).
    pub tag: String,
    /// Attributes in document order, unescaped.
    pub attrs: Vec<(String, String)>,
    /// The text of a `<text>` element, trimmed and unescaped.
    pub text: String,
}

impl Element {
    /// The attribute `key`.
    pub fn attr(&self, key: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }

    /// The attribute `key` as a number (0 when missing).
    pub fn num(&self, key: &str) -> f64 {
        self.attr(key)
            .and_then(|v| v.trim_end_matches("px").parse().ok())
            .unwrap_or(0.0)
    }

    /// The `points` of a polyline or polygon.
    pub fn points(&self) -> Vec<Point> {
        self.attr("points")
            .unwrap_or("")
            .split_whitespace()
            .filter_map(|p| {
                let (x, y) = p.split_once(',')?;
                Some((x.parse().ok()?, y.parse().ok()?))
            })
            .collect()
    }

    /// Width of the stroke (0 without one).
    pub fn stroke_width(&self) -> f64 {
        if self.attr("stroke").is_none_or(|s| s == "none") {
            0.0
        } else {
            self.attr("stroke-width")
                .and_then(|w| w.parse().ok())
                .unwrap_or(1.0)
        }
    }

    /// Whether the shape is filled.
    pub fn filled(&self) -> bool {
        self.attr("fill").is_some_and(|f| f != "none")
    }

    fn white_fill(&self) -> bool {
        self.attr("fill")
            .is_some_and(|f| f.eq_ignore_ascii_case("#FFFFFF") || f.eq_ignore_ascii_case("white"))
    }
}

fn unescape(s: &str) -> String {
    s.replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&quot;", "\"")
        .replace("&apos;", "'")
        .replace("&amp;", "&")
}

/// The elements of `svg` in document order (a reader for the flat SVG figures are written
/// as, not for XML at large).
pub fn elements(svg: &str) -> Vec<Element> {
    let mut out = Vec::new();
    let mut rest = svg;
    while let Some(start) = rest.find('<') {
        rest = &rest[start + 1..];
        let Some(end) = rest.find('>') else { break };
        let inside = &rest[..end];
        rest = &rest[end + 1..];
        if inside.starts_with('/') || inside.starts_with('?') || inside.starts_with('!') {
            continue;
        }
        let inside = inside.trim_end_matches('/');
        let (tag, mut attrs_text) = inside
            .split_once(char::is_whitespace)
            .unwrap_or((inside, ""));
        let mut attrs = Vec::new();
        while let Some(eq) = attrs_text.find('=') {
            let key = attrs_text[..eq].trim().to_owned();
            let after = attrs_text[eq + 1..].trim_start();
            let Some(quote) = after.chars().next().filter(|c| *c == '"' || *c == '\'') else {
                break;
            };
            let Some(close) = after[1..].find(quote) else {
                break;
            };
            attrs.push((key, unescape(&after[1..=close])));
            attrs_text = &after[close + 2..];
        }
        let mut text = String::new();
        if tag == "text" {
            if let Some(close) = rest.find("</text>") {
                text = unescape(rest[..close].trim());
                rest = &rest[close + 7..];
            }
        }
        out.push(Element {
            tag: tag.to_owned(),
            attrs,
            text,
        });
    }
    out
}

fn text_item(e: &Element) -> TextItem {
    let px = e.num("font-size");
    let h = match e.attr("text-anchor") {
        Some("middle") => HPos::Center,
        Some("end") => HPos::Right,
        _ => HPos::Left,
    };
    let v = match e.attr("dy").map(str::trim) {
        Some(d)
            if d.ends_with("em")
                && d.trim_end_matches("em")
                    .parse::<f64>()
                    .is_ok_and(|x| x > 0.3) =>
        {
            VPos::Top
        }
        Some(d) if d.starts_with('-') => VPos::Bottom,
        Some(d) if d.ends_with("ex") => VPos::Center,
        _ => VPos::Bottom,
    };
    let rotation = e
        .attr("transform")
        .and_then(|t| t.strip_prefix("rotate("))
        .and_then(|t| t.split([',', ' ', ')']).next())
        .and_then(|d| d.parse::<f64>().ok())
        .and_then(Rotation::of_degrees)
        .unwrap_or(Rotation::None);
    let at = (e.num("x"), e.num("y"));
    TextItem {
        text: e.text.clone(),
        px,
        bounds: text_box(&e.text, px, at, Anchor::new(h, v), rotation),
        rotation,
    }
}

/// A black, one-pixel, solid, axis-aligned two-point polyline: an axis line or tick mark.
fn frame_segment(e: &Element) -> Option<(Point, Point)> {
    if e.tag != "polyline"
        || !e
            .attr("stroke")
            .is_some_and(|s| s.eq_ignore_ascii_case("#000000"))
        || (e.stroke_width() - 1.0).abs() > 1e-9
        || e.attr("stroke-dasharray").is_some()
    {
        return None;
    }
    let p = e.points();
    (p.len() == 2 && ((p[0].0 - p[1].0).abs() < 1e-9 || (p[0].1 - p[1].1).abs() < 1e-9))
        .then(|| (p[0], p[1]))
}

fn length((a, b): (Point, Point)) -> f64 {
    (a.0 - b.0).abs() + (a.1 - b.1).abs()
}

/// The shape an element covers, if it is drawn at all.
fn shape_of(e: &Element) -> Option<Shape> {
    let half = e.stroke_width() / 2.0;
    match e.tag.as_str() {
        "polyline" => Some(Shape::Line {
            points: e.points(),
            half_width: half,
        }),
        "line" => Some(Shape::Line {
            points: vec![(e.num("x1"), e.num("y1")), (e.num("x2"), e.num("y2"))],
            half_width: half,
        }),
        "polygon" if e.filled() => Some(Shape::Area(e.points())),
        "polygon" => {
            let mut p = e.points();
            p.extend(p.first().copied());
            Some(Shape::Line {
                points: p,
                half_width: half,
            })
        }
        "circle" => Some(Shape::Disc {
            center: (e.num("cx"), e.num("cy")),
            radius: e.num("r") + half,
        }),
        "rect" => {
            let r = Rect::at((e.num("x"), e.num("y")), (e.num("width"), e.num("height")));
            if e.filled() {
                Some(Shape::Block(r.inflate(half)))
            } else {
                Some(Shape::Line {
                    points: vec![
                        (r.x0, r.y0),
                        (r.x1, r.y0),
                        (r.x1, r.y1),
                        (r.x0, r.y1),
                        (r.x0, r.y0),
                    ],
                    half_width: half,
                })
            }
        }
        _ => None,
    }
}

/// Reads the SVG figure `svg` and lists its problems (see the
/// [module documentation](self)).
pub fn check_svg(svg: &str) -> FigureCheck {
    let elements = elements(svg);
    let size = elements
        .iter()
        .find(|e| e.tag == "svg")
        .map_or((0.0, 0.0), |e| (e.num("width"), e.num("height")));
    let canvas = Rect::of_size(size);
    let mut texts = Vec::new();
    let mut frame: Vec<(Point, Point)> = Vec::new();
    let mut legends: Vec<Rect> = Vec::new();
    let mut data: Vec<Shape> = Vec::new();
    for e in &elements {
        match e.tag.as_str() {
            "text" => texts.push(text_item(e)),
            "rect" if e.white_fill() => {
                let r = Rect::at((e.num("x"), e.num("y")), (e.num("width"), e.num("height")));
                if !r.encloses(&canvas, 0.5) {
                    legends.push(r);
                }
            }
            "line"
                if length(((e.num("x1"), e.num("y1")), (e.num("x2"), e.num("y2")))) > AXIS_MIN => {}
            "svg" => {}
            _ => {
                if let Some(seg) = frame_segment(e) {
                    frame.push(seg);
                    continue;
                }
                let Some(shape) = shape_of(e) else { continue };
                let bounds = shape.bounds();
                if legends.iter().any(|l| l.encloses(&bounds, 1.0)) {
                    continue;
                }
                data.push(shape);
            }
        }
    }
    let axes = find_axes(&frame, &texts);
    let mut problems = Vec::new();
    axis_problems(&axes, &mut problems);
    text_problems(&texts, &data, &legends, canvas, &mut problems);
    if size.0 > f64::from(MAX_FIGURE_WIDTH) {
        problems.push(format!(
            "the figure is {:.0} pixels wide: the report shows at most {MAX_FIGURE_WIDTH} at its own size, so it is scaled down and its text with it",
            size.0
        ));
    }
    FigureCheck {
        size,
        texts,
        axes,
        legends,
        data,
        problems,
    }
}

fn find_axes(frame: &[(Point, Point)], texts: &[TextItem]) -> Vec<AxisItem> {
    let mut axes: Vec<AxisItem> = frame
        .iter()
        .filter(|s| length(**s) >= AXIS_MIN)
        .map(|&(a, b)| {
            let vertical = (a.0 - b.0).abs() < 1e-9;
            let (at, from, to) = if vertical {
                (a.0, a.1.min(b.1), a.1.max(b.1))
            } else {
                (a.1, a.0.min(b.0), a.0.max(b.0))
            };
            AxisItem {
                vertical,
                at,
                from,
                to,
                ticks: Vec::new(),
                labels: Vec::new(),
            }
        })
        .collect();
    for &(a, b) in frame.iter().filter(|s| length(**s) <= TICK_MAX) {
        for axis in &mut axes {
            // A tick mark runs across its axis, touches it, and points away from the plot.
            let (across, along, ends) = if axis.vertical {
                ((a.1 - b.1).abs() < 1e-9, a.1, (a.0, b.0))
            } else {
                ((a.0 - b.0).abs() < 1e-9, a.0, (a.1, b.1))
            };
            let touches = (ends.0 - axis.at).abs() <= SAME || (ends.1 - axis.at).abs() <= SAME;
            let outward = if axis.vertical {
                ends.0.min(ends.1) < axis.at - 1.0
            } else {
                ends.0.max(ends.1) > axis.at + 1.0
            };
            if across
                && touches
                && outward
                && along >= axis.from - SAME
                && along <= axis.to + SAME
                && !axis.ticks.iter().any(|t| (t - along).abs() < 1e-9)
            {
                axis.ticks.push(along);
            }
        }
    }
    for axis in &mut axes {
        axis.ticks.sort_by(f64::total_cmp);
        for &tick in &axis.ticks {
            let label = texts.iter().find(|t| {
                if t.rotation != Rotation::None || t.text.is_empty() {
                    return false;
                }
                let b = t.bounds;
                if axis.vertical {
                    let middle = 0.5 * (b.y0 + b.y1);
                    b.x1 <= axis.at
                        && b.x1 >= axis.at - TICK_MAX - 14.0
                        && (middle - tick).abs() <= 0.4 * t.px
                } else {
                    let middle = 0.5 * (b.x0 + b.x1);
                    b.y0 >= axis.at
                        && b.y0 <= axis.at + TICK_MAX + 14.0
                        && (middle - tick).abs() <= 3.0
                }
            });
            if let Some(t) = label {
                axis.labels.push(t.text.clone());
            }
        }
    }
    axes
}

fn axis_problems(axes: &[AxisItem], problems: &mut Vec<String>) {
    for axis in axes {
        if axis.labels.len() >= 2 {
            continue;
        }
        let shared = axis.ticks.len() >= 2
            && axes.iter().any(|other| {
                other.vertical == axis.vertical
                    && other.labels.len() >= 2
                    && (other.from - axis.from).abs() <= SAME
                    && (other.to - axis.to).abs() <= SAME
                    && other.ticks.len() == axis.ticks.len()
                    && other
                        .ticks
                        .iter()
                        .zip(&axis.ticks)
                        .all(|(a, b)| (a - b).abs() <= SAME)
            });
        if !shared {
            problems.push(format!(
                "{} has {} tick mark(s) and {} tick label(s) ({:?}); an axis needs at least 2 labels or to share its ticks with a labelled axis",
                axis.describe(),
                axis.ticks.len(),
                axis.labels.len(),
                axis.labels
            ));
        }
    }
}

fn text_problems(
    texts: &[TextItem],
    data: &[Shape],
    legends: &[Rect],
    canvas: Rect,
    problems: &mut Vec<String>,
) {
    let bounds: Vec<Rect> = data.iter().map(Shape::bounds).collect();
    let covering = |r: &Rect| {
        data.iter()
            .zip(&bounds)
            .filter(|(_, b)| b.overlaps(r))
            .any(|(s, _)| s.hits(r))
    };
    for (i, t) in texts.iter().enumerate() {
        if t.text.is_empty() {
            continue;
        }
        let b = t.bounds.inflate(-TOUCH);
        if t.px < MIN_TEXT_PX - 1e-9 {
            problems.push(format!(
                "text {:?} is {:.1} pixels high; at least {MIN_TEXT_PX} reads at scale 1",
                t.text, t.px
            ));
        }
        if !canvas.encloses(&t.bounds, TOUCH) {
            problems.push(format!(
                "text {:?} runs off the figure (estimated box x {:.0}–{:.0}, y {:.0}–{:.0} in {:.0} × {:.0})",
                t.text,
                t.bounds.x0,
                t.bounds.x1,
                t.bounds.y0,
                t.bounds.y1,
                canvas.width(),
                canvas.height()
            ));
        }
        if covering(&b) {
            problems.push(format!(
                "text {:?} (estimated box x {:.0}–{:.0}, y {:.0}–{:.0}) covers plotted data",
                t.text, t.bounds.x0, t.bounds.x1, t.bounds.y0, t.bounds.y1
            ));
        }
        for other in &texts[i + 1..] {
            if !other.text.is_empty() && b.overlaps(&other.bounds.inflate(-TOUCH)) {
                problems.push(format!("texts {:?} and {:?} overlap", t.text, other.text));
            }
        }
    }
    for l in legends {
        if covering(&l.inflate(-TOUCH)) {
            problems.push(format!(
                "a legend box (x {:.0}–{:.0}, y {:.0}–{:.0}) covers plotted data",
                l.x0, l.x1, l.y0, l.y1
            ));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::geometry::Rect as R;
    use crate::plot::style::series_stroke;
    use crate::plot::{svg_figure, Axis, Panel, Series};

    #[test]
    fn a_figure_of_the_crate_reads_back_with_its_axes() {
        let svg = svg_figure((560, 380), |c| {
            let mut p = Panel::new(
                "F_d",
                Axis::linear((0.0, 400.0), "step"),
                Axis::linear((9.9968, 10.0031), "F_d (mN)"),
            );
            p.add(
                Series::line_of(0, vec![(0.0, 10.0), (400.0, 10.001)], 1.0),
                None,
            );
            p.line(
                vec![(0.0, 10.002), (400.0, 10.002)],
                series_stroke(1, 2.0),
                Some("a line"),
            );
            p.draw(c, R::new(0.0, 0.0, 560.0, 380.0));
        });
        let check = check_svg(&svg);
        assert!(check.problems.is_empty(), "{:#?}", check.problems);
        assert_eq!(check.axes.len(), 2);
        assert!(
            check.axes.iter().all(|a| a.labels.len() >= 2),
            "{:?}",
            check.axes
        );
        assert_eq!(check.legends.len(), 1);
        assert_eq!(check.data.len(), 2);
    }

    #[test]
    fn problems_are_found() {
        // An axis without ticks, a label over a line, two texts on top of each other, a text
        // off the edge, a small font.
        let svg = r##"<svg width="300" height="200" viewBox="0 0 300 200" xmlns="http://www.w3.org/2000/svg">
<rect x="0" y="0" width="300" height="200" fill="#FFFFFF" stroke="none"/>
<polyline fill="none" opacity="1" stroke="#000000" stroke-width="1" points="50,10 50,150 "/>
<polyline fill="none" opacity="1" stroke="#000000" stroke-width="1" points="50,150 290,150 "/>
<polyline fill="none" stroke="#000000" stroke-width="1" points="100,150 100,155"/>
<polyline fill="none" stroke="#000000" stroke-width="1" points="200,150 200,155"/>
<text x="100" y="159" dy="0.76em" text-anchor="middle" font-family="sans-serif" font-size="12">1</text>
<text x="200" y="159" dy="0.76em" text-anchor="middle" font-family="sans-serif" font-size="12">2</text>
<polyline fill="none" stroke="#005AAA" stroke-width="2" points="50,80 290,80"/>
<text x="60" y="80" dy="0.5ex" text-anchor="start" font-family="sans-serif" font-size="12">over</text>
<text x="150" y="20" dy="0.5ex" text-anchor="start" font-family="sans-serif" font-size="12">one</text>
<text x="152" y="22" dy="0.5ex" text-anchor="start" font-family="sans-serif" font-size="12">two</text>
<text x="298" y="120" dy="0.5ex" text-anchor="middle" font-family="sans-serif" font-size="9.6">400</text>
</svg>"##;
        let check = check_svg(svg);
        let all = check.problems.join("\n");
        assert!(all.contains("the vertical axis at x = 50"), "{all}");
        assert!(!all.contains("the horizontal axis"), "{all}");
        assert!(all.contains("text \"over\""), "{all}");
        assert!(all.contains("texts \"one\" and \"two\" overlap"), "{all}");
        assert!(all.contains("text \"400\" runs off the figure"), "{all}");
        assert!(all.contains("text \"400\" is 9.6 pixels high"), "{all}");
        assert_eq!(check.problems.len(), 5, "{all}");
    }

    #[test]
    fn inner_axes_may_share_the_labels_of_an_outer_one() {
        // Two panels one above the other with the same x ticks; only the lower is labelled.
        let mut svg = String::from(
            r##"<svg width="300" height="300" xmlns="http://www.w3.org/2000/svg">
"##,
        );
        for (y, labels) in [(100.0, false), (250.0, true)] {
            svg.push_str(&format!(
                "<polyline stroke=\"#000000\" stroke-width=\"1\" fill=\"none\" points=\"50,{y} 250,{y}\"/>\n"
            ));
            for x in [100, 200] {
                svg.push_str(&format!(
                    "<polyline stroke=\"#000000\" stroke-width=\"1\" fill=\"none\" points=\"{x},{y} {x},{}\"/>\n",
                    y + 5.0
                ));
                if labels {
                    svg.push_str(&format!(
                        "<text x=\"{x}\" y=\"{}\" dy=\"0.76em\" text-anchor=\"middle\" font-size=\"12\">{x}</text>\n",
                        y + 9.0
                    ));
                }
            }
        }
        svg.push_str("</svg>\n");
        assert!(
            check_svg(&svg).problems.is_empty(),
            "{:?}",
            check_svg(&svg).problems
        );
        // Move one inner tick: no longer the same ticks.
        let moved = svg.replacen(
            "points=\"200,100 200,105\"",
            "points=\"190,100 190,105\"",
            1,
        );
        assert_eq!(check_svg(&moved).problems.len(), 1);
    }
}
