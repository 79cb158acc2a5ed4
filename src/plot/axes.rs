//! Axes around a plot area: which ticks fit, how much room their labels take, and drawing the
//! grid, axis lines, tick marks, labels, the scale/offset note and the descriptions.

use super::geometry::{Point, Rect};
use super::style::{axis_stroke, grid, TEXT_PX};
use super::svg::{Canvas, Font};
use super::text::{line_height, text_height, text_width, wrap, Anchor, HPos, Rotation, VPos};
use super::ticks::{Scale, Ticks};

/// Length of a tick mark (pixels).
pub const TICK_PX: f64 = 5.0;
/// Room between a tick mark and its label, and between rows of axis text (pixels).
pub const GAP_PX: f64 = 4.0;
/// Neighbouring x tick labels keep this much space between them (pixels).
const X_LABEL_SPACE: f64 = 14.0;
/// Ticks are at least this far apart on an x axis (pixels).
const X_TICK_MIN: f64 = 50.0;
/// Ticks are at least this far apart on a y axis (pixels).
const Y_TICK_MIN: f64 = 38.0;

/// What an axis shows.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Show {
    /// Axis line, tick marks, tick labels, note and description.
    Labels,
    /// Axis line and tick marks only: the axis shares its ticks with a labelled one of the
    /// same scale and length elsewhere in the figure (a corner plot's inner panels).
    Ticks,
    /// Nothing: no axis line (a density's height, a forest plot's rows).
    Off,
}

/// An axis: its scale, its description (with unit) and what it shows.
#[derive(Debug, Clone, PartialEq)]
pub struct Axis {
    /// How values map onto it.
    pub scale: Scale,
    /// Description, e.g. `friction force F (mN)`; may be empty.
    pub desc: String,
    /// What it shows.
    pub show: Show,
}

impl Axis {
    /// A labelled linear axis over `range`.
    pub fn linear(range: (f64, f64), desc: &str) -> Self {
        Self {
            scale: Scale::linear(range),
            desc: desc.to_owned(),
            show: Show::Labels,
        }
    }

    /// A labelled logarithmic axis over `range`.
    pub fn log(range: (f64, f64), desc: &str) -> Self {
        Self {
            scale: Scale::log(range),
            desc: desc.to_owned(),
            show: Show::Labels,
        }
    }

    /// The same axis showing `show`.
    pub fn showing(self, show: Show) -> Self {
        Self { show, ..self }
    }
}

/// A plot area: where data are drawn, in pixels, and the scales that map values into it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plot {
    /// The plot area.
    pub rect: Rect,
    /// Horizontal scale.
    pub x: Scale,
    /// Vertical scale (values grow upwards).
    pub y: Scale,
}

impl Plot {
    /// Pixel x of value `v`, if it can be shown.
    pub(crate) fn x_px(&self, v: f64) -> Option<f64> {
        self.x
            .fraction(v)
            .map(|f| self.rect.x0 + f * self.rect.width())
    }

    /// Pixel y of value `v`, if it can be shown.
    pub(crate) fn y_px(&self, v: f64) -> Option<f64> {
        self.y
            .fraction(v)
            .map(|f| self.rect.y1 - f * self.rect.height())
    }

    /// The pixel of the point `(x, y)`, if it can be shown (it may lie outside the area).
    pub fn px(&self, (x, y): (f64, f64)) -> Option<Point> {
        Some((self.x_px(x)?, self.y_px(y)?))
    }
}

/// The ticks an axis of `length` pixels gets: the densest set whose labels keep apart, or the
/// sparsest there is.
pub fn choose_ticks(scale: &Scale, length: f64, horizontal: bool) -> Ticks {
    // How far the tightest pair of neighbouring labels is from fitting (negative: apart).
    let shortfall = |t: &Ticks| {
        let pos: Vec<f64> = t
            .values
            .iter()
            .map(|&v| scale.fraction(v).unwrap_or(0.0) * length)
            .collect();
        pos.windows(2)
            .enumerate()
            .map(|(i, w)| {
                let apart = (w[1] - w[0]).abs();
                let need = if horizontal {
                    let labels = 0.5
                        * (text_width(&t.labels[i], TEXT_PX)
                            + text_width(&t.labels[i + 1], TEXT_PX))
                        + X_LABEL_SPACE;
                    labels.max(X_TICK_MIN)
                } else {
                    Y_TICK_MIN.max(1.6 * text_height(TEXT_PX))
                };
                need - apart
            })
            .fold(f64::NEG_INFINITY, f64::max)
    };
    // Plain labels where they fit, else offset and scaled ones, else the set that comes
    // closest.
    let mut all = scale.candidates();
    if let Some(i) = all.iter().position(|t| shortfall(t) <= 0.0) {
        return all.swap_remove(i);
    }
    let mut compact = scale.compact_candidates();
    if let Some(i) = compact.iter().position(|t| shortfall(t) <= 0.0) {
        return compact.swap_remove(i);
    }
    all.extend(compact);
    all.into_iter()
        .min_by(|a, b| shortfall(a).total_cmp(&shortfall(b)))
        .expect("a scale has at least one tick set")
}

/// Room around a plot area for its axes (pixels).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Margins {
    /// Left of the plot area.
    pub left: f64,
    /// Right.
    pub right: f64,
    /// Above.
    pub top: f64,
    /// Below.
    pub bottom: f64,
}

/// Width of the widest tick label.
fn widest(t: &Ticks) -> f64 {
    t.labels
        .iter()
        .map(|l| text_width(l, TEXT_PX))
        .fold(0.0, f64::max)
}

/// Lines of an x-axis description under a plot `width` pixels wide.
fn x_desc_lines(axis: &Axis, width: f64) -> Vec<String> {
    if axis.desc.is_empty() || axis.show != Show::Labels {
        Vec::new()
    } else {
        wrap(&axis.desc, TEXT_PX, width)
    }
}

/// The room the axes `x` and `y` with ticks `xt` and `yt` take around a plot area
/// `plot_width` pixels wide.
pub fn axis_margins(x: (&Axis, &Ticks), y: (&Axis, &Ticks), plot_width: f64) -> Margins {
    let (x, xt) = x;
    let (y, yt) = y;
    let line = line_height(TEXT_PX);
    let mut m = Margins::default();
    match y.show {
        Show::Labels => {
            m.left = TICK_PX + GAP_PX + widest(yt);
            if !y.desc.is_empty() {
                m.left += GAP_PX + line;
            }
            if !yt.note.is_empty() {
                m.top = line + GAP_PX;
            }
            // The top label is centred on its tick.
            m.top = m.top.max(0.5 * text_height(TEXT_PX) + 1.0);
        }
        Show::Ticks => m.left = TICK_PX,
        Show::Off => {}
    }
    match x.show {
        Show::Labels => {
            m.bottom = TICK_PX + GAP_PX + text_height(TEXT_PX);
            if !xt.note.is_empty() {
                m.bottom += GAP_PX + text_height(TEXT_PX);
            }
            let desc = x_desc_lines(x, plot_width).len() as f64;
            if desc > 0.0 {
                m.bottom += GAP_PX + desc * line;
            }
            // The last label is centred on its tick, which may be the axis's end.
            let last = xt.labels.last().map_or(0.0, |l| text_width(l, TEXT_PX));
            m.right = 0.5 * last + 1.0;
        }
        Show::Ticks => m.bottom = TICK_PX,
        Show::Off => {}
    }
    m
}

/// Draws the grid of `plot`: light lines at the minor ticks and bold ones at the ticks.
pub fn draw_grid(canvas: &mut Canvas, plot: &Plot, xt: &Ticks, yt: &Ticks) {
    let r = plot.rect;
    let (light, bold) = grid();
    for (values, stroke) in [(&xt.minor, light), (&xt.values, bold)] {
        for &v in values {
            if let Some(x) = plot.x_px(v).filter(|x| *x >= r.x0 && *x <= r.x1) {
                canvas.grid_line((x, r.y0), (x, r.y1), stroke);
            }
        }
    }
    for (values, stroke) in [(&yt.minor, light), (&yt.values, bold)] {
        for &v in values {
            if let Some(y) = plot.y_px(v).filter(|y| *y >= r.y0 && *y <= r.y1) {
                canvas.grid_line((r.x0, y), (r.x1, y), stroke);
            }
        }
    }
}

/// Draws the axes of `plot`: axis lines and tick marks, and for labelled axes the tick
/// labels, the note and the description, in the margins [`axis_margins`] reserves.
pub fn draw_axes(canvas: &mut Canvas, plot: &Plot, x: (&Axis, &Ticks), y: (&Axis, &Ticks)) {
    let (x, xt) = x;
    let (y, yt) = y;
    let r = plot.rect;
    let font = |h, v| Font::new(TEXT_PX, Anchor::new(h, v));
    let line = line_height(TEXT_PX);
    if y.show != Show::Off {
        canvas.polyline(&[(r.x0, r.y0), (r.x0, r.y1)], axis_stroke());
        for (&v, label) in yt.values.iter().zip(&yt.labels) {
            let Some(py) = plot.y_px(v) else { continue };
            canvas.polyline(&[(r.x0 - TICK_PX, py), (r.x0, py)], axis_stroke());
            if y.show == Show::Labels {
                canvas.text(
                    label,
                    (r.x0 - TICK_PX - GAP_PX, py),
                    font(HPos::Right, VPos::Center),
                );
            }
        }
        if y.show == Show::Labels {
            if !yt.note.is_empty() {
                canvas.text(
                    &yt.note,
                    (r.x0, r.y0 - GAP_PX),
                    font(HPos::Left, VPos::Bottom),
                );
            }
            if !y.desc.is_empty() {
                let right = r.x0 - TICK_PX - 2.0 * GAP_PX - widest(yt);
                let at = (right - 0.5 * line, 0.5 * (r.y0 + r.y1));
                canvas.text(
                    &y.desc,
                    at,
                    font(HPos::Center, VPos::Center).rotated(Rotation::ThreeQuarters),
                );
            }
        }
    }
    if x.show != Show::Off {
        canvas.polyline(&[(r.x0, r.y1), (r.x1, r.y1)], axis_stroke());
        for (&v, label) in xt.values.iter().zip(&xt.labels) {
            let Some(px) = plot.x_px(v) else { continue };
            canvas.polyline(&[(px, r.y1), (px, r.y1 + TICK_PX)], axis_stroke());
            if x.show == Show::Labels {
                canvas.text(
                    label,
                    (px, r.y1 + TICK_PX + GAP_PX),
                    font(HPos::Center, VPos::Top),
                );
            }
        }
        if x.show == Show::Labels {
            let mut below = r.y1 + TICK_PX + GAP_PX + text_height(TEXT_PX);
            if !xt.note.is_empty() {
                canvas.text(
                    &xt.note,
                    (r.x1, below + GAP_PX),
                    font(HPos::Right, VPos::Top),
                );
                below += GAP_PX + text_height(TEXT_PX);
            }
            for (i, l) in x_desc_lines(x, r.width()).iter().enumerate() {
                canvas.text(
                    l,
                    (0.5 * (r.x0 + r.x1), below + GAP_PX + i as f64 * line),
                    font(HPos::Center, VPos::Top),
                );
            }
        }
    }
}

/// The plot area inside `area` (pixels) for axes `x` and `y`, with `keep.top`, `keep.right`
/// and `keep.bottom` pixels kept free above, to the right and below (caption, legend), and
/// the ticks that fit it.
pub fn fit_axes(area: Rect, x: &Axis, y: &Axis, keep: Margins) -> (Plot, Ticks, Ticks) {
    let (top, right, bottom) = (keep.top, keep.right, keep.bottom);
    const PAD: f64 = 6.0;
    let mut rect = Rect::new(
        area.x0 + PAD + 70.0,
        area.y0 + PAD + top,
        area.x1 - PAD - right - 10.0,
        area.y1 - PAD - bottom - 50.0,
    );
    let mut ticks = (
        choose_ticks(&x.scale, rect.width(), true),
        choose_ticks(&y.scale, rect.height(), false),
    );
    // The margins depend on the labels, the labels on the room left: settle in a few rounds.
    for _ in 0..4 {
        let m = axis_margins((x, &ticks.0), (y, &ticks.1), rect.width());
        let next = Rect::new(
            area.x0 + PAD + m.left,
            area.y0 + PAD + top + m.top,
            area.x1 - PAD - right - m.right.max(PAD),
            area.y1 - PAD - bottom - m.bottom,
        );
        let next = Rect::new(
            next.x0,
            next.y0,
            next.x1.max(next.x0 + 10.0),
            next.y1.max(next.y0 + 10.0),
        );
        let settled = (next.width() - rect.width()).abs() < 0.5
            && (next.height() - rect.height()).abs() < 0.5;
        rect = next;
        if settled {
            break;
        }
        ticks = (
            choose_ticks(&x.scale, rect.width(), true),
            choose_ticks(&y.scale, rect.height(), false),
        );
    }
    (
        Plot {
            rect,
            x: x.scale,
            y: y.scale,
        },
        ticks.0,
        ticks.1,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_fit_their_axis() {
        let scale = Scale::linear((0.0, 30_000.0));
        let wide = choose_ticks(&scale, 480.0, true);
        let narrow = choose_ticks(&scale, 120.0, true);
        assert!(wide.values.len() > narrow.values.len());
        assert!(narrow.values.len() >= 2);
        let tall = choose_ticks(&scale, 300.0, false);
        assert!(tall.values.len() >= 4, "{tall:?}");
    }

    #[test]
    fn the_plot_area_leaves_room_for_every_label() {
        let area = Rect::new(0.0, 0.0, 560.0, 380.0);
        let x = Axis::linear((0.0, 30_000.0), "instrument time t (s)");
        let y = Axis::linear((9.9968, 10.0031), "F_d (mN)");
        let keep = Margins {
            top: 20.0,
            ..Margins::default()
        };
        let (plot, xt, yt) = fit_axes(area, &x, &y, keep);
        let m = axis_margins((&x, &xt), (&y, &yt), plot.rect.width());
        assert!(plot.rect.x0 - area.x0 >= m.left);
        assert!(area.y1 - plot.rect.y1 >= m.bottom);
        assert!(area.x1 - plot.rect.x1 >= m.right);
        assert!(yt.labels.len() >= 3, "{yt:?}");
        let mut canvas = Canvas::new((560, 380));
        draw_axes(&mut canvas, &plot, (&x, &xt), (&y, &yt));
        let svg = canvas.finish();
        assert!(svg.contains(">10.000</text>"), "{svg}");
        assert!(svg.contains(">instrument time t (s)</text>"));
    }
}
