//! Pixel geometry: rectangles, clipping to a plot area, and whether a shape touches a box.
//!
//! Pixels run right (x) and down (y) from the figure's top left corner, as in SVG. The same
//! tests place legends where no data are drawn and, in [`check`](super::check), find text that
//! covers data.

/// A point in pixels.
pub type Point = (f64, f64);

/// An axis-aligned rectangle in pixels, `x0 ≤ x1`, `y0 ≤ y1`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rect {
    /// Left edge.
    pub x0: f64,
    /// Top edge.
    pub y0: f64,
    /// Right edge.
    pub x1: f64,
    /// Bottom edge.
    pub y1: f64,
}

impl Rect {
    /// The rectangle spanned by two corners, in any order.
    pub fn new(xa: f64, ya: f64, xb: f64, yb: f64) -> Self {
        Self {
            x0: xa.min(xb),
            y0: ya.min(yb),
            x1: xa.max(xb),
            y1: ya.max(yb),
        }
    }

    /// The rectangle of `size` at the origin.
    pub(crate) fn of_size((width, height): (f64, f64)) -> Self {
        Self::new(0.0, 0.0, width, height)
    }

    /// Width.
    pub fn width(&self) -> f64 {
        self.x1 - self.x0
    }

    /// Height.
    pub(crate) fn height(&self) -> f64 {
        self.y1 - self.y0
    }

    /// The rectangle grown by `d` on every side (shrunk for negative `d`, never inside out).
    pub(crate) fn inflate(&self, d: f64) -> Self {
        let (cx, cy) = ((self.x0 + self.x1) / 2.0, (self.y0 + self.y1) / 2.0);
        Self {
            x0: (self.x0 - d).min(cx),
            y0: (self.y0 - d).min(cy),
            x1: (self.x1 + d).max(cx),
            y1: (self.y1 + d).max(cy),
        }
    }

    /// Whether the two rectangles share an area (touching edges do not count).
    pub(crate) fn overlaps(&self, other: &Rect) -> bool {
        self.x0 < other.x1 && other.x0 < self.x1 && self.y0 < other.y1 && other.y0 < self.y1
    }

    /// Whether `p` lies inside or on the edge.
    pub fn contains(&self, (x, y): Point) -> bool {
        x >= self.x0 && x <= self.x1 && y >= self.y0 && y <= self.y1
    }

    /// Whether `other` lies wholly inside (edges included), with `slack` pixels to spare.
    pub(crate) fn encloses(&self, other: &Rect, slack: f64) -> bool {
        other.x0 >= self.x0 - slack
            && other.x1 <= self.x1 + slack
            && other.y0 >= self.y0 - slack
            && other.y1 <= self.y1 + slack
    }

    /// The rectangle of the given size with its top left corner at `(x, y)`.
    pub fn at((x, y): Point, (width, height): (f64, f64)) -> Self {
        Self::new(x, y, x + width, y + height)
    }

    /// `rows` × `columns` equal cells, row by row from the top left.
    pub fn grid(&self, rows: usize, columns: usize) -> Vec<Rect> {
        let (rows, columns) = (rows.max(1), columns.max(1));
        let (w, h) = (self.width() / columns as f64, self.height() / rows as f64);
        (0..rows)
            .flat_map(|r| {
                (0..columns).map(move |c| {
                    Rect::at((self.x0 + c as f64 * w, self.y0 + r as f64 * h), (w, h))
                })
            })
            .collect()
    }

    /// The top `height` pixels and the rest.
    pub fn split_top(&self, height: f64) -> (Rect, Rect) {
        let y = (self.y0 + height).min(self.y1);
        (
            Rect::new(self.x0, self.y0, self.x1, y),
            Rect::new(self.x0, y, self.x1, self.y1),
        )
    }

    /// The left `width` pixels and the rest.
    pub fn split_left(&self, width: f64) -> (Rect, Rect) {
        let x = (self.x0 + width).min(self.x1);
        (
            Rect::new(self.x0, self.y0, x, self.y1),
            Rect::new(x, self.y0, self.x1, self.y1),
        )
    }
}

/// Whether the segment `a`–`b` passes through `r` (Liang–Barsky).
pub(crate) fn segment_hits(a: Point, b: Point, r: &Rect) -> bool {
    clip_segment(a, b, r).is_some()
}

/// The part of the segment `a`–`b` inside `r`, if any (Liang–Barsky).
pub(crate) fn clip_segment(a: Point, b: Point, r: &Rect) -> Option<(Point, Point)> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0_f64, 1.0_f64);
    for (p, q) in [
        (-dx, a.0 - r.x0),
        (dx, r.x1 - a.0),
        (-dy, a.1 - r.y0),
        (dy, r.y1 - a.1),
    ] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
            if t0 > t1 {
                return None;
            }
        }
    }
    Some((
        (a.0 + t0 * dx, a.1 + t0 * dy),
        (a.0 + t1 * dx, a.1 + t1 * dy),
    ))
}

/// The pieces of the polyline through `points` inside `r`: a line leaving the plot area and
/// coming back is drawn as two pieces, never across the frame. Non-finite points break the
/// line.
pub(crate) fn clip_polyline(points: &[Point], r: &Rect) -> Vec<Vec<Point>> {
    let mut pieces: Vec<Vec<Point>> = Vec::new();
    let mut current: Vec<Point> = Vec::new();
    let finite = |p: &Point| p.0.is_finite() && p.1.is_finite();
    if points.len() == 1 && finite(&points[0]) && r.contains(points[0]) {
        return vec![points.to_vec()];
    }
    for w in points.windows(2) {
        let (a, b) = (w[0], w[1]);
        if !(finite(&a) && finite(&b)) {
            if current.len() > 1 {
                pieces.push(std::mem::take(&mut current));
            }
            current.clear();
            continue;
        }
        match clip_segment(a, b, r) {
            Some((p, q)) => {
                let joined = current.last().is_some_and(|l| near(*l, p));
                if !joined {
                    if current.len() > 1 {
                        pieces.push(std::mem::take(&mut current));
                    }
                    current.clear();
                    current.push(p);
                }
                current.push(q);
                if !near(q, b) {
                    pieces.push(std::mem::take(&mut current));
                }
            }
            None => {
                if current.len() > 1 {
                    pieces.push(std::mem::take(&mut current));
                }
                current.clear();
            }
        }
    }
    if current.len() > 1 {
        pieces.push(current);
    }
    pieces
}

fn near(a: Point, b: Point) -> bool {
    (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9
}

/// The polygon `points` cut to `r` (Sutherland–Hodgman); empty when nothing is left.
pub(crate) fn clip_polygon(points: &[Point], r: &Rect) -> Vec<Point> {
    type Inside = fn(Point, &Rect) -> bool;
    type Cross = fn(Point, Point, &Rect) -> Point;
    let edges: [(Inside, Cross); 4] = [
        (|p, r| p.0 >= r.x0, |a, b, r| at_x(a, b, r.x0)),
        (|p, r| p.0 <= r.x1, |a, b, r| at_x(a, b, r.x1)),
        (|p, r| p.1 >= r.y0, |a, b, r| at_y(a, b, r.y0)),
        (|p, r| p.1 <= r.y1, |a, b, r| at_y(a, b, r.y1)),
    ];
    let mut out: Vec<Point> = points
        .iter()
        .copied()
        .filter(|p| p.0.is_finite() && p.1.is_finite())
        .collect();
    for (inside, cross) in edges {
        if out.is_empty() {
            break;
        }
        let input = std::mem::take(&mut out);
        let mut prev = *input.last().expect("not empty");
        for &p in &input {
            match (inside(p, r), inside(prev, r)) {
                (true, true) => out.push(p),
                (true, false) => {
                    out.push(cross(prev, p, r));
                    out.push(p);
                }
                (false, true) => out.push(cross(prev, p, r)),
                (false, false) => {}
            }
            prev = p;
        }
    }
    if out.len() < 3 {
        out.clear();
    }
    out
}

fn at_x(a: Point, b: Point, x: f64) -> Point {
    let t = (x - a.0) / (b.0 - a.0);
    (x, a.1 + t * (b.1 - a.1))
}

fn at_y(a: Point, b: Point, y: f64) -> Point {
    let t = (y - a.1) / (b.1 - a.1);
    (a.0 + t * (b.0 - a.0), y)
}

/// Whether `p` lies inside the polygon `poly` (even-odd rule).
pub fn point_in_polygon(p: Point, poly: &[Point]) -> bool {
    let mut inside = false;
    let n = poly.len();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + n - 1) % n]);
        if (a.1 > p.1) != (b.1 > p.1) && p.0 < (b.0 - a.0) * (p.1 - a.1) / (b.1 - a.1) + a.0 {
            inside = !inside;
        }
    }
    inside
}

/// A drawn shape, as far as covering something goes.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// A stroked line `half_width` pixels to each side of `points`.
    Line {
        /// The points.
        points: Vec<Point>,
        /// Half the stroke width.
        half_width: f64,
    },
    /// A filled polygon.
    Area(Vec<Point>),
    /// A disc.
    Disc {
        /// Centre.
        center: Point,
        /// Radius, stroke included.
        radius: f64,
    },
    /// A filled rectangle.
    Block(Rect),
}

impl Shape {
    /// Whether the shape covers any part of `r`.
    pub fn hits(&self, r: &Rect) -> bool {
        match self {
            Shape::Line { points, half_width } => {
                let grown = r.inflate(*half_width);
                if points.len() == 1 {
                    return grown.contains(points[0]);
                }
                points.windows(2).any(|w| segment_hits(w[0], w[1], &grown))
            }
            Shape::Area(poly) => {
                if poly.len() < 3 {
                    return false;
                }
                let corners = [(r.x0, r.y0), (r.x1, r.y0), (r.x1, r.y1), (r.x0, r.y1)];
                poly.iter().any(|&p| r.contains(p))
                    || corners.iter().any(|&c| point_in_polygon(c, poly))
                    || (0..poly.len()).any(|i| segment_hits(poly[i], poly[(i + 1) % poly.len()], r))
            }
            Shape::Disc { center, radius } => {
                let nx = center.0.clamp(r.x0, r.x1);
                let ny = center.1.clamp(r.y0, r.y1);
                (nx - center.0).powi(2) + (ny - center.1).powi(2) < radius * radius
            }
            Shape::Block(b) => b.overlaps(r),
        }
    }

    /// The bounding rectangle.
    pub fn bounds(&self) -> Rect {
        let of = |points: &[Point], pad: f64| {
            points
                .iter()
                .fold(
                    Rect {
                        x0: f64::INFINITY,
                        y0: f64::INFINITY,
                        x1: f64::NEG_INFINITY,
                        y1: f64::NEG_INFINITY,
                    },
                    |b, &(x, y)| Rect {
                        x0: b.x0.min(x),
                        y0: b.y0.min(y),
                        x1: b.x1.max(x),
                        y1: b.y1.max(y),
                    },
                )
                .inflate(pad)
        };
        match self {
            Shape::Line { points, half_width } => of(points, *half_width),
            Shape::Area(poly) => of(poly, 0.0),
            Shape::Disc { center, radius } => Rect::new(
                center.0 - radius,
                center.1 - radius,
                center.0 + radius,
                center.1 + radius,
            ),
            Shape::Block(b) => *b,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const BOX: Rect = Rect {
        x0: 0.0,
        y0: 0.0,
        x1: 10.0,
        y1: 10.0,
    };

    #[test]
    fn segments_are_cut_at_the_frame() {
        let (a, b) = clip_segment((-5.0, 5.0), (15.0, 5.0), &BOX).unwrap();
        assert_eq!((a, b), ((0.0, 5.0), (10.0, 5.0)));
        assert!(clip_segment((-5.0, -1.0), (15.0, -1.0), &BOX).is_none());
        assert!(segment_hits((5.0, 5.0), (6.0, 6.0), &BOX));
    }

    #[test]
    fn a_line_leaving_the_frame_becomes_two_pieces() {
        let pieces = clip_polyline(&[(1.0, 5.0), (5.0, 20.0), (9.0, 5.0)], &BOX);
        assert_eq!(pieces.len(), 2);
        assert!(pieces.iter().flatten().all(|&p| BOX.contains(p)));
        let whole = clip_polyline(&[(1.0, 1.0), (2.0, 2.0), (3.0, 1.0)], &BOX);
        assert_eq!(whole, vec![vec![(1.0, 1.0), (2.0, 2.0), (3.0, 1.0)]]);
        let broken = clip_polyline(&[(1.0, 1.0), (f64::NAN, 2.0), (3.0, 1.0), (4.0, 1.0)], &BOX);
        assert_eq!(broken, vec![vec![(3.0, 1.0), (4.0, 1.0)]]);
    }

    #[test]
    fn polygons_are_cut_to_the_frame() {
        let cut = clip_polygon(&[(-5.0, -5.0), (5.0, -5.0), (5.0, 5.0), (-5.0, 5.0)], &BOX);
        assert!(cut.iter().all(|&p| BOX.contains(p)));
        assert!(point_in_polygon((2.0, 2.0), &cut));
        assert!(clip_polygon(&[(20.0, 20.0), (30.0, 20.0), (30.0, 30.0)], &BOX).is_empty());
    }

    #[test]
    fn shapes_know_what_they_cover() {
        let probe = Rect::new(4.0, 4.0, 6.0, 6.0);
        let around = Shape::Area(vec![(0.0, 0.0), (10.0, 0.0), (10.0, 10.0), (0.0, 10.0)]);
        assert!(around.hits(&probe));
        let line = Shape::Line {
            points: vec![(0.0, 3.0), (10.0, 3.0)],
            half_width: 1.5,
        };
        assert!(line.hits(&probe));
        let thin = Shape::Line {
            points: vec![(0.0, 3.0), (10.0, 3.0)],
            half_width: 0.5,
        };
        assert!(!thin.hits(&probe));
        let disc = Shape::Disc {
            center: (8.0, 8.0),
            radius: 2.0,
        };
        assert!(!disc.hits(&probe));
        assert!(Shape::Block(Rect::new(5.0, 5.0, 7.0, 7.0)).hits(&probe));
    }
}
