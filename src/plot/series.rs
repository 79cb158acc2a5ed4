//! Series on a plot: lines, markers, filled bands and areas, bars. Each is cut to the plot
//! area (nothing is drawn over the axes) and becomes marks in pixels, which are drawn and
//! which legends keep clear of.
//!
//! Points that are not finite, or not positive on a log scale, are left out rather than
//! failing the figure.

use super::axes::Plot;
use super::geometry::{clip_polygon, clip_polyline, Point, Rect, Shape};
use super::style::Rgb;
use super::svg::{Canvas, Fill, Stroke};

/// A marker shape.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Marker {
    /// Open circle.
    Circle,
    /// Filled circle.
    Disc,
    /// White circle with an outline: visible on a dark bar.
    Dot,
    /// Open triangle.
    Triangle,
    /// Diagonal cross.
    Cross,
    /// Open square.
    Square,
}

impl Marker {
    /// The marker of series `k`: open circle, triangle, cross, square (then again).
    pub fn of(k: usize) -> Self {
        [Self::Circle, Self::Triangle, Self::Cross, Self::Square][k % 4]
    }

    /// The marks of this marker of `radius` pixels in `color` at `c`.
    fn marks(self, c: Point, radius: f64, color: Rgb) -> Vec<Mark> {
        let stroke = Stroke::solid(color, 1.0);
        let r = radius;
        match self {
            Self::Circle => vec![Mark::Circle(c, r, None, Some(stroke))],
            Self::Disc => vec![Mark::Circle(c, r, Some(Fill::solid(color)), None)],
            Self::Dot => vec![Mark::Circle(
                c,
                r,
                Some(Fill::solid(Rgb::WHITE)),
                Some(stroke),
            )],
            Self::Triangle => vec![Mark::Polygon(
                vec![
                    (c.0, c.1 - r),
                    (c.0 + 0.87 * r, c.1 + 0.5 * r),
                    (c.0 - 0.87 * r, c.1 + 0.5 * r),
                ],
                None,
                Some(stroke),
            )],
            Self::Cross => {
                let d = 0.8 * r;
                vec![
                    Mark::Polyline(vec![(c.0 - d, c.1 - d), (c.0 + d, c.1 + d)], stroke),
                    Mark::Polyline(vec![(c.0 - d, c.1 + d), (c.0 + d, c.1 - d)], stroke),
                ]
            }
            Self::Square => {
                let d = 0.8 * r;
                vec![Mark::Rect(
                    Rect::new(c.0 - d, c.1 - d, c.0 + d, c.1 + d),
                    None,
                    Some(stroke),
                )]
            }
        }
    }
}

/// One series, in data coordinates.
#[derive(Debug, Clone, PartialEq)]
pub enum Series {
    /// A line through the points.
    Line {
        /// The points.
        points: Vec<(f64, f64)>,
        /// How it is stroked.
        stroke: Stroke,
    },
    /// A marker at each point.
    Markers {
        /// The points.
        points: Vec<(f64, f64)>,
        /// Shape.
        marker: Marker,
        /// Colour.
        color: Rgb,
        /// Radius in pixels.
        radius: f64,
    },
    /// The area between `low` and `high` over `xs`.
    Band {
        /// Abscissae.
        xs: Vec<f64>,
        /// Lower edge.
        low: Vec<f64>,
        /// Upper edge.
        high: Vec<f64>,
        /// Fill.
        fill: Fill,
    },
    /// A closed polygon.
    Area {
        /// Corners.
        points: Vec<(f64, f64)>,
        /// Fill.
        fill: Option<Fill>,
        /// Outline.
        stroke: Option<Stroke>,
    },
    /// Bars from `base`: each `((left, right), height)`, one pixel narrower on each side so
    /// that neighbours stay apart.
    Bars {
        /// The bars.
        bars: Vec<((f64, f64), f64)>,
        /// Where they start.
        base: f64,
        /// Fill.
        fill: Fill,
    },
}

impl Series {
    /// A line of series `k` (its ink and dash), `width` pixels wide.
    #[cfg(test)]
    pub(crate) fn line_of(k: usize, points: Vec<(f64, f64)>, width: f64) -> Self {
        Self::Line {
            points,
            stroke: super::style::series_stroke(k, width),
        }
    }

    /// Markers of series `k` (its shape and ink).
    #[cfg(test)]
    pub(crate) fn markers_of(k: usize, points: Vec<(f64, f64)>) -> Self {
        Self::Markers {
            points,
            marker: Marker::of(k),
            color: super::style::ink(k),
            radius: 3.5,
        }
    }

    /// The marks this series leaves on `plot`, cut to its area.
    pub(crate) fn marks(&self, plot: &Plot) -> Vec<Mark> {
        let area = plot.rect;
        let to_px = |pts: &mut dyn Iterator<Item = (f64, f64)>| -> Vec<Point> {
            pts.map(|p| plot.px(p).unwrap_or((f64::NAN, f64::NAN)))
                .collect()
        };
        match self {
            Series::Line { points, stroke } => {
                let px = to_px(&mut points.iter().copied());
                clip_polyline(&px, &area)
                    .into_iter()
                    .map(|piece| Mark::Polyline(piece, *stroke))
                    .collect()
            }
            Series::Markers {
                points,
                marker,
                color,
                radius,
            } => points
                .iter()
                .filter_map(|&p| plot.px(p))
                .filter(|&c| area.contains(c))
                .flat_map(|c| marker.marks(c, *radius, *color))
                .collect(),
            Series::Band {
                xs,
                low,
                high,
                fill,
            } => {
                // A band is cut where an edge is missing: each run of finite points a polygon.
                let mut marks = Vec::new();
                let mut run: Vec<(Point, Point)> = Vec::new();
                let flush = |run: &mut Vec<(Point, Point)>, marks: &mut Vec<Mark>| {
                    if run.len() >= 2 {
                        let outline: Vec<Point> = run
                            .iter()
                            .map(|(l, _)| *l)
                            .chain(run.iter().rev().map(|(_, h)| *h))
                            .collect();
                        let cut = clip_polygon(&outline, &area);
                        if !cut.is_empty() {
                            marks.push(Mark::Polygon(cut, Some(*fill), None));
                        }
                    }
                    run.clear();
                };
                for j in 0..xs.len().min(low.len()).min(high.len()) {
                    match (plot.px((xs[j], low[j])), plot.px((xs[j], high[j]))) {
                        (Some(l), Some(h)) => run.push((l, h)),
                        _ => flush(&mut run, &mut marks),
                    }
                }
                flush(&mut run, &mut marks);
                marks
            }
            Series::Area {
                points,
                fill,
                stroke,
            } => {
                let px: Vec<Point> = points.iter().filter_map(|&p| plot.px(p)).collect();
                let cut = clip_polygon(&px, &area);
                if cut.is_empty() {
                    Vec::new()
                } else {
                    vec![Mark::Polygon(cut, *fill, *stroke)]
                }
            }
            Series::Bars { bars, base, fill } => bars
                .iter()
                .filter_map(|&((l, r), h)| {
                    let (a, b) = (plot.px((l, *base))?, plot.px((r, h))?);
                    let bar = Rect::new(a.0 + 1.0, a.1, b.0 - 1.0, b.1);
                    let cut = Rect::new(
                        bar.x0.max(area.x0),
                        bar.y0.max(area.y0),
                        bar.x1.min(area.x1),
                        bar.y1.min(area.y1),
                    );
                    (cut.width() > 0.0 && cut.height() > 0.0 && bar.overlaps(&area))
                        .then_some(Mark::Rect(cut, Some(*fill), None))
                })
                .collect(),
        }
    }
}

/// One element drawn on the canvas, in pixels.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Mark {
    /// An open polyline.
    Polyline(Vec<Point>, Stroke),
    /// A polygon.
    Polygon(Vec<Point>, Option<Fill>, Option<Stroke>),
    /// A circle: centre, radius.
    Circle(Point, f64, Option<Fill>, Option<Stroke>),
    /// A rectangle.
    Rect(Rect, Option<Fill>, Option<Stroke>),
}

impl Mark {
    /// What the mark covers.
    pub fn shape(&self) -> Shape {
        let half = |s: &Option<Stroke>| s.map_or(0.0, |s| s.width / 2.0);
        match self {
            Mark::Polyline(points, stroke) => Shape::Line {
                points: points.clone(),
                half_width: stroke.width / 2.0,
            },
            Mark::Polygon(points, Some(_), _) => Shape::Area(points.clone()),
            Mark::Polygon(points, None, stroke) => {
                let mut closed = points.clone();
                closed.extend(points.first().copied());
                Shape::Line {
                    points: closed,
                    half_width: half(stroke),
                }
            }
            Mark::Circle(c, r, _, stroke) => Shape::Disc {
                center: *c,
                radius: r + half(stroke),
            },
            Mark::Rect(r, _, stroke) => Shape::Block(r.inflate(half(stroke))),
        }
    }

    /// Draws the mark.
    pub fn draw(&self, canvas: &mut Canvas) {
        match self {
            Mark::Polyline(points, stroke) => canvas.polyline(points, *stroke),
            Mark::Polygon(points, fill, stroke) => canvas.polygon(points, *fill, *stroke),
            Mark::Circle(c, r, fill, stroke) => canvas.circle(*c, *r, *fill, *stroke),
            Mark::Rect(r, fill, stroke) => canvas.rect(r, *fill, *stroke),
        }
    }
}

/// Draws `series` on `plot`, in order.
pub fn draw_series(canvas: &mut Canvas, plot: &Plot, series: &[Series]) {
    for s in series {
        for mark in s.marks(plot) {
            mark.draw(canvas);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::style::ink;
    use crate::plot::ticks::Scale;

    fn plot() -> Plot {
        Plot {
            rect: Rect::new(10.0, 10.0, 110.0, 110.0),
            x: Scale::linear((0.0, 1.0)),
            y: Scale::log((1.0, 100.0)),
        }
    }

    #[test]
    fn series_stay_inside_the_plot_area() {
        let p = plot();
        let line = Series::line_of(0, vec![(0.0, 1.0), (0.5, 1000.0), (1.0, 10.0)], 2.0);
        for m in line.marks(&p) {
            assert!(p
                .rect
                .inflate(1e-9)
                .encloses(&m.shape().bounds().inflate(-1.0), 0.0));
        }
        let markers = Series::markers_of(1, vec![(0.5, 10.0), (2.0, 10.0), (0.5, -1.0)]);
        assert_eq!(markers.marks(&p).len(), 1);
        let bars = Series::Bars {
            bars: vec![((0.0, 0.5), 10.0), ((0.5, 1.0), 1e4)],
            base: 1.0,
            fill: Fill::solid(ink(1)),
        };
        let marks = bars.marks(&p);
        assert_eq!(marks.len(), 2);
        assert!(marks
            .iter()
            .all(|m| p.rect.encloses(&m.shape().bounds(), 0.0)));
    }

    #[test]
    fn a_band_breaks_where_an_edge_is_missing() {
        let band = Series::Band {
            xs: vec![0.0, 0.2, 0.4, 0.6, 0.8],
            low: vec![2.0, 2.0, f64::NAN, 2.0, 2.0],
            high: vec![5.0, 5.0, 5.0, 5.0, 5.0],
            fill: Fill::solid(Rgb::BLACK),
        };
        assert_eq!(band.marks(&plot()).len(), 2);
    }
}
