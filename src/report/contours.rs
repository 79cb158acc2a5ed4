//! Two-dimensional densities for corner plots, as corner.py draws them: a histogram of the
//! draws of two quantities, smoothed, and the contours that enclose 0.5, 1, 1.5 and 2 σ of a
//! two-dimensional Gaussian (11.8, 39.3, 67.5 and 86.5 % of the draws). Pure numbers; no
//! drawing.

/// Contour levels as σ of a 2-D Gaussian: each encloses 1 − exp(−σ²/2) of the mass.
pub(crate) const SIGMAS: [f64; 4] = [0.5, 1.0, 1.5, 2.0];
/// Bins of a corner plot's histograms along each axis.
pub(crate) const BINS: usize = 30;
/// Smoothing of a 2-D histogram: a Gaussian of this many bins' standard deviation.
const SMOOTH_BINS: f64 = 1.0;

/// Closed contour lines in data coordinates, each a polygon.
pub(crate) type Loops = Vec<Vec<(f64, f64)>>;

/// A histogram of pairs over a `bins` × `bins` grid spanning `x` and `y`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Histogram2d {
    /// Range of the first quantity.
    pub x: (f64, f64),
    /// Range of the second.
    pub y: (f64, f64),
    /// Bins along each axis.
    pub bins: usize,
    /// Counts, `counts[i * bins + j]` for x bin `i` and y bin `j`.
    pub counts: Vec<f64>,
}

impl Histogram2d {
    /// An empty histogram.
    pub fn new(x: (f64, f64), y: (f64, f64), bins: usize) -> Self {
        Self {
            x,
            y,
            bins,
            counts: vec![0.0; bins * bins],
        }
    }

    /// Counts the pair `(x, y)`; pairs outside the ranges are left out.
    pub fn add(&mut self, x: f64, y: f64) {
        let (Some(i), Some(j)) = (bin(x, self.x, self.bins), bin(y, self.y, self.bins)) else {
            return;
        };
        self.counts[i * self.bins + j] += 1.0;
    }

    /// The closed contours of the smoothed histogram at each of [`SIGMAS`], outermost (2 σ)
    /// first: `(σ, loops)`, each loop a polygon in data coordinates.
    ///
    /// The smoothed histogram is interpolated onto a grid four times finer before the
    /// levels are found: on the histogram's own bins a level is reached a whole bin at a time,
    /// and the innermost contour comes out a fifth too small.
    pub fn contours(&self) -> Vec<(f64, Loops)> {
        let n = self.bins;
        let smooth = smoothed(&self.counts, n, SMOOTH_BINS);
        let fine = refined(&smooth, n, REFINE);
        let m = n * REFINE;
        let levels = mass_levels(&fine);
        // A ring of zeros around the grid closes every contour.
        let padded = m + 2;
        let value = |i: usize, j: usize| {
            if i == 0 || j == 0 || i > m || j > m {
                0.0
            } else {
                fine[(i - 1) * m + (j - 1)]
            }
        };
        let grid: Vec<f64> = (0..padded * padded)
            .map(|k| value(k / padded, k % padded))
            .collect();
        // Fine cell k (of the padded grid) is centred at (k − 1 + 0.5) / REFINE bins.
        let at = |range: (f64, f64), k: f64| {
            range.0 + (k - 0.5) / REFINE as f64 * (range.1 - range.0) / n as f64
        };
        SIGMAS
            .iter()
            .zip(levels)
            .rev()
            .filter(|(_, level)| *level > 0.0)
            .map(|(&sigma, level)| {
                let loops = march(&grid, padded, level)
                    .into_iter()
                    .map(|l| {
                        l.into_iter()
                            .map(|(gi, gj)| (at(self.x, gi), at(self.y, gj)))
                            .collect()
                    })
                    .collect();
                (sigma, loops)
            })
            .collect()
    }
}

/// Fine cells per histogram bin along each axis when contours are found.
const REFINE: usize = 4;

/// The `n` × `n` grid of bin values interpolated bilinearly between bin centres onto a grid
/// `k` times finer (zero beyond the outer bins' centres, half a bin out).
fn refined(values: &[f64], n: usize, k: usize) -> Vec<f64> {
    let m = n * k;
    let at = |i: isize, j: isize| {
        if i < 0 || j < 0 || i >= n as isize || j >= n as isize {
            0.0
        } else {
            values[i as usize * n + j as usize]
        }
    };
    let mut out = vec![0.0; m * m];
    for a in 0..m {
        // Position in bin-centre coordinates.
        let u = (a as f64 + 0.5) / k as f64 - 0.5;
        let (i, fu) = (u.floor() as isize, u - u.floor());
        for b in 0..m {
            let v = (b as f64 + 0.5) / k as f64 - 0.5;
            let (j, fv) = (v.floor() as isize, v - v.floor());
            out[a * m + b] = (1.0 - fu) * (1.0 - fv) * at(i, j)
                + fu * (1.0 - fv) * at(i + 1, j)
                + (1.0 - fu) * fv * at(i, j + 1)
                + fu * fv * at(i + 1, j + 1);
        }
    }
    out
}

/// The bin of `v` in `range` split into `bins`, if it falls inside.
pub fn bin(v: f64, range: (f64, f64), bins: usize) -> Option<usize> {
    let f = (v - range.0) / (range.1 - range.0);
    if !(0.0..=1.0).contains(&f) {
        return None;
    }
    Some(((f * bins as f64) as usize).min(bins - 1))
}

/// `counts` on an `n` × `n` grid convolved with a Gaussian of `sigma` bins (zero outside).
fn smoothed(counts: &[f64], n: usize, sigma: f64) -> Vec<f64> {
    let reach = (3.0 * sigma).ceil() as isize;
    let kernel: Vec<f64> = (-reach..=reach)
        .map(|d| (-0.5 * (d as f64 / sigma).powi(2)).exp())
        .collect();
    let pass = |src: &[f64], along_i: bool| {
        let mut out = vec![0.0; n * n];
        for i in 0..n {
            for j in 0..n {
                let mut s = 0.0;
                for (k, w) in kernel.iter().enumerate() {
                    let d = k as isize - reach;
                    let (ii, jj) = if along_i {
                        (i as isize + d, j as isize)
                    } else {
                        (i as isize, j as isize + d)
                    };
                    if ii >= 0 && jj >= 0 && (ii as usize) < n && (jj as usize) < n {
                        s += w * src[ii as usize * n + jj as usize];
                    }
                }
                out[i * n + j] = s;
            }
        }
        out
    };
    pass(&pass(counts, true), false)
}

/// For each of [`SIGMAS`], the density above which that share of the mass lies.
fn mass_levels(density: &[f64]) -> Vec<f64> {
    let mut sorted: Vec<f64> = density.to_vec();
    sorted.sort_by(|a, b| b.total_cmp(a));
    let total: f64 = sorted.iter().sum();
    SIGMAS
        .iter()
        .map(|s| {
            let mass = 1.0 - (-0.5 * s * s).exp();
            let mut cum = 0.0;
            for &v in &sorted {
                cum += v;
                if cum >= mass * total {
                    return v;
                }
            }
            0.0
        })
        .collect()
}

/// Marching squares: the closed loops where the `n` × `n` grid crosses `level`, in grid
/// coordinates (first index, second index). The grid's border must lie below the level.
fn march(grid: &[f64], n: usize, level: f64) -> Vec<Vec<(f64, f64)>> {
    use std::collections::HashMap;
    // An edge of the grid: its lower node, and whether it runs along the second index.
    type Edge = (usize, usize, bool);
    let at = |i: usize, j: usize| grid[i * n + j];
    let point = |(i, j, along_j): Edge| {
        let (a, b) = if along_j {
            (at(i, j), at(i, j + 1))
        } else {
            (at(i, j), at(i + 1, j))
        };
        let t = ((level - a) / (b - a)).clamp(0.0, 1.0);
        if along_j {
            (i as f64, j as f64 + t)
        } else {
            (i as f64 + t, j as f64)
        }
    };
    let mut links: HashMap<Edge, Vec<Edge>> = HashMap::new();
    let mut link = |a: Edge, b: Edge| {
        links.entry(a).or_default().push(b);
        links.entry(b).or_default().push(a);
    };
    for i in 0..n - 1 {
        for j in 0..n - 1 {
            let corners = [at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)];
            let above = corners.map(|c| c >= level);
            // The cell's edges in order around it: bottom, right, top, left.
            let edges: [Edge; 4] = [
                (i, j, false),
                (i + 1, j, true),
                (i, j + 1, false),
                (i, j, true),
            ];
            let crossed: Vec<usize> = (0..4).filter(|&k| above[k] != above[(k + 1) % 4]).collect();
            match crossed.len() {
                2 => link(edges[crossed[0]], edges[crossed[1]]),
                4 => {
                    // A saddle: the cell's mean decides which corners join.
                    let mean = corners.iter().sum::<f64>() / 4.0;
                    if (mean >= level) == above[0] {
                        link(edges[0], edges[1]);
                        link(edges[2], edges[3]);
                    } else {
                        link(edges[3], edges[0]);
                        link(edges[1], edges[2]);
                    }
                }
                _ => {}
            }
        }
    }
    let mut loops = Vec::new();
    let mut keys: Vec<Edge> = links.keys().copied().collect();
    keys.sort_unstable();
    let mut used: std::collections::HashSet<Edge> = std::collections::HashSet::new();
    for start in keys {
        if used.contains(&start) {
            continue;
        }
        let mut chain = vec![start];
        used.insert(start);
        let mut current = start;
        loop {
            let next = links[&current].iter().copied().find(|e| !used.contains(e));
            match next {
                Some(e) => {
                    used.insert(e);
                    chain.push(e);
                    current = e;
                }
                None => break,
            }
        }
        if chain.len() >= 3 {
            loops.push(chain.into_iter().map(point).collect());
        }
    }
    loops
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plot::point_in_polygon;

    /// A histogram of a standard 2-D Gaussian on a fine lattice of weighted points.
    fn gaussian() -> Histogram2d {
        let mut h = Histogram2d::new((-4.0, 4.0), (-4.0, 4.0), BINS);
        let steps = 300;
        for a in 0..steps {
            for b in 0..steps {
                let x = -4.0 + 8.0 * (a as f64 + 0.5) / steps as f64;
                let y = -4.0 + 8.0 * (b as f64 + 0.5) / steps as f64;
                let (Some(i), Some(j)) = (bin(x, h.x, BINS), bin(y, h.y, BINS)) else {
                    continue;
                };
                h.counts[i * BINS + j] += (-0.5 * (x * x + y * y)).exp();
            }
        }
        h
    }

    #[test]
    fn contours_of_a_gaussian_are_circles_of_radius_sigma() {
        let contours = gaussian().contours();
        assert_eq!(contours.len(), 4);
        assert!((contours[0].0 - 2.0).abs() < 1e-12, "outermost first");
        for (sigma, loops) in &contours {
            assert_eq!(loops.len(), 1, "one loop at {sigma} σ");
            let radii: Vec<f64> = loops[0].iter().map(|(x, y)| x.hypot(*y)).collect();
            let mean = radii.iter().sum::<f64>() / radii.len() as f64;
            // Smoothing by one bin (0.27) widens the Gaussian to sd 1.036.
            let expected = sigma * (1.0_f64 + (8.0 / BINS as f64).powi(2)).sqrt();
            assert!(
                (mean - expected).abs() < 0.08,
                "{sigma} σ: radius {mean}, expected {expected}"
            );
            assert!(point_in_polygon((0.0, 0.0), &loops[0]));
        }
    }

    #[test]
    fn two_separate_peaks_give_two_loops() {
        let mut h = Histogram2d::new((0.0, 10.0), (0.0, 10.0), BINS);
        for k in 0..2000 {
            let t = k as f64 * 0.618_033_988_7 % 1.0;
            let s = k as f64 * 0.754_877_666_2 % 1.0;
            h.add(2.0 + t, 2.0 + s);
            h.add(7.0 + t, 7.0 + s);
        }
        let contours = h.contours();
        let inner = &contours.last().unwrap().1;
        assert_eq!(inner.len(), 2);
        assert!(bin(11.0, (0.0, 10.0), 5).is_none());
        assert_eq!(bin(10.0, (0.0, 10.0), 5), Some(4));
    }
}
