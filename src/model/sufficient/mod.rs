//! Long records, exactly: the Gaussian likelihood of a run from per-bin sufficient statistics
//! (docs/model.md §5, "Long records").
//!
//! Within a bin of consecutive observations the model is replaced by its interpolant of degree
//! q at the bin's q + 1 Chebyshev points. The sum of squared residuals of all the bin's points
//! against that polynomial is a quadratic form in the model's values at those points, whose
//! coefficients are moments of the data computed once ([`BinMoments`]). A likelihood
//! evaluation then solves the model at q + 1 points per bin instead of at every point.
//!
//! - [`plan_bins`] chooses the bins: as wide as keeps the interpolation error of the model at
//!   reference parameters within a bound derived from the tolerance on the log-likelihood
//!   ([`max_error_for`]), never across a kink (a first slide's start t0, the end of its
//!   elastic loading, a repeat slide's plateau) and never over the last observation.
//! - [`Reduction`] holds the bins with their moments and the observations left exact, and
//!   evaluates the sum of squared residuals from the model's values at its
//!   [`Layout::times`]; a bin that a kink enters at the parameters being evaluated is opened
//!   and its points evaluated one by one.
//! - [`log_likelihood_bound`] states the error of the log-likelihood that the bins' errors
//!   allow.
//!
//! This module knows nothing of the friction law: the model is whatever the caller evaluates.

mod moments;
mod plan;

use std::borrow::Cow;

use rayon::prelude::*;

pub use moments::{interpolation_error_estimate, BinMoments, ChebyshevBasis, MAX_NODES};
pub use plan::{plan_bins, PlanSettings, PlannedBin, ReferenceModel};

/// The largest interpolation error (N) a binned point may have so that the log-likelihood of
/// `points` observations errs by at most `tolerance` wherever the residuals' RMS (σ
/// integrated out) or σ (sampled) is at least `noise_n`; `inflation` ≥ 1 accounts for the
/// truncation of an integrated σ's prior ([`log_likelihood_bound`]). The inverse of
/// [`log_likelihood_bound`] at D = points × error².
pub fn max_error_for(tolerance: f64, points: usize, noise_n: f64, inflation: f64) -> f64 {
    let n = points as f64;
    let g = 2.0 * tolerance / (n * inflation);
    // ρ² + 2ρ = g / (1 + g), solved without cancellation.
    let r = g / (1.0 + g);
    let rho = r / (1.0 + (1.0 + r).sqrt());
    noise_n * rho
}

/// A bound on |ℓ̂ − ℓ|, the error of the log-likelihood of `points` observations when the sum
/// of squared interpolation errors of the binned points is at most `sum_sq_error_n2` (D),
/// wherever the residuals' RMS s (σ integrated out) or σ (sampled) is at least `noise_n`:
///
/// ```text
/// |Ŝ − S| ≤ 2√(S·D) + D                      (Cauchy–Schwarz on Σ eᵢδᵢ)
/// |ℓ̂ − ℓ| ≤ (n/2)(2ρ + ρ²)/(1 − 2ρ − ρ²) · h,  ρ = √(D / (n s²))
/// ```
///
/// For σ integrated out under a log-uniform prior on [L, H], dℓ/dS = −E[1/(2σ²) | S], at most
/// (n/S + 1/H²)/2 and largest at the smaller of S and Ŝ: `inflation` h = 1 + s²/H² takes the
/// 1/H² in. For a sampled σ, |ℓ̂ − ℓ| = |Ŝ − S|/(2σ²) ≤ (n/2)(2ρ + ρ²) at S = nσ², which the
/// same bound covers with h = 1. Infinite when ρ is too large for the bound to hold.
pub fn log_likelihood_bound(
    points: usize,
    sum_sq_error_n2: f64,
    noise_n: f64,
    inflation: f64,
) -> f64 {
    let n = points as f64;
    let rho = (sum_sq_error_n2 / (n * noise_n * noise_n)).sqrt();
    let grow = 2.0 * rho + rho * rho;
    if grow >= 1.0 {
        return f64::INFINITY;
    }
    0.5 * n * grow / (1.0 - grow) * inflation
}

/// A stretch of the evaluation: observations solved one by one, or one bin's nodes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Segment {
    /// `count` observations from observation `first` on, one model time each.
    Points {
        /// First observation.
        first: usize,
        /// Number of observations.
        count: usize,
    },
    /// The q + 1 Chebyshev points of a bin.
    Bin(usize),
}

/// A bin with its moments.
#[derive(Debug, Clone)]
struct Bin {
    first: usize,
    end: usize,
    t_lo: f64,
    t_hi: f64,
    error_n: f64,
    moments: BinMoments,
}

/// A run's observations as bins of sufficient statistics and points left exact.
#[derive(Debug, Clone)]
pub struct Reduction {
    degree: usize,
    /// Model times when no bin is opened: exact observations and bin nodes in increasing
    /// order, then the run's model times after its observations (a first slide's F_end).
    times: Vec<f64>,
    segments: Vec<Segment>,
    bins: Vec<Bin>,
    /// Model times after the observations.
    tail: usize,
}

/// The model times of one evaluation and what each stretch of them stands for.
#[derive(Debug, Clone)]
pub struct Layout<'r> {
    times: Cow<'r, [f64]>,
    segments: Cow<'r, [Segment]>,
}

impl Layout<'_> {
    /// The times where the model is to be evaluated, increasing.
    pub fn times(&self) -> &[f64] {
        &self.times
    }
}

impl Reduction {
    /// The bins `planned` of the observations (`times`, `forces`) with their moments for a
    /// polynomial of degree `degree`; `tail_times` are model times after the observations
    /// (evaluated, not observed). A bin whose moments cannot be formed (its points do not
    /// span the degree) is left exact.
    ///
    /// # Panics
    /// When `times` and `forces` differ in length, or a bin lies outside them.
    pub fn new(
        times: &[f64],
        forces: &[f64],
        tail_times: &[f64],
        degree: usize,
        planned: &[PlannedBin],
    ) -> Self {
        assert_eq!(times.len(), forces.len());
        let basis = ChebyshevBasis::new(degree);
        let moments: Vec<Option<BinMoments>> = planned
            .par_iter()
            .map(|b| {
                let (lo, hi) = (times[b.first], times[b.end - 1]);
                let (mid, half) = (0.5 * (lo + hi), 0.5 * (hi - lo));
                let u: Vec<f64> = times[b.first..b.end]
                    .iter()
                    .map(|t| ((t - mid) / half).clamp(-1.0, 1.0))
                    .collect();
                BinMoments::new(&basis, &u, &forces[b.first..b.end])
            })
            .collect();
        let mut bins = Vec::new();
        let mut segments = Vec::new();
        let mut model_times = Vec::new();
        let mut next = 0;
        let exact =
            |from: usize, to: usize, segments: &mut Vec<Segment>, model_times: &mut Vec<f64>| {
                if to > from {
                    segments.push(Segment::Points {
                        first: from,
                        count: to - from,
                    });
                    model_times.extend_from_slice(&times[from..to]);
                }
            };
        for (b, m) in planned.iter().zip(moments) {
            let Some(moments) = m else { continue };
            exact(next, b.first, &mut segments, &mut model_times);
            let (t_lo, t_hi) = (times[b.first], times[b.end - 1]);
            let (mid, half) = (0.5 * (t_lo + t_hi), 0.5 * (t_hi - t_lo));
            model_times.extend(basis.points().iter().map(|u| mid + half * u));
            segments.push(Segment::Bin(bins.len()));
            bins.push(Bin {
                first: b.first,
                end: b.end,
                t_lo,
                t_hi,
                error_n: b.error_n,
                moments,
            });
            next = b.end;
        }
        exact(next, times.len(), &mut segments, &mut model_times);
        model_times.extend_from_slice(tail_times);
        Self {
            degree,
            times: model_times,
            segments,
            bins,
            tail: tail_times.len(),
        }
    }

    /// Degree of the polynomial within a bin.
    pub fn degree(&self) -> usize {
        self.degree
    }

    /// Number of bins.
    pub fn bins(&self) -> usize {
        self.bins.len()
    }

    /// Observations in bins.
    pub fn binned_points(&self) -> usize {
        self.bins.iter().map(|b| b.end - b.first).sum()
    }

    /// Model evaluations of one likelihood evaluation (no bin opened).
    pub fn evaluations(&self) -> usize {
        self.times.len()
    }

    /// D = Σ over binned points of the squared estimated interpolation error of their bin
    /// (N²): what [`log_likelihood_bound`] turns into a bound on the log-likelihood.
    pub fn sum_sq_error(&self) -> f64 {
        self.bins
            .iter()
            .map(|b| (b.end - b.first) as f64 * b.error_n * b.error_n)
            .sum()
    }

    /// Each bin's observations (first, end) and time span.
    pub fn bin_spans(&self) -> Vec<(usize, usize, f64, f64)> {
        self.bins
            .iter()
            .map(|b| (b.first, b.end, b.t_lo, b.t_hi))
            .collect()
    }

    /// The model times of an evaluation where the model has kinks at `kinks` (NaN: none):
    /// every bin that holds a kink is opened, its observations (at `obs_times`) evaluated one
    /// by one, since a polynomial cannot follow a kink.
    pub fn layout(&self, obs_times: &[f64], kinks: &[f64]) -> Layout<'_> {
        let mut open = [usize::MAX; 4];
        let mut opened = 0;
        for &k in kinks {
            let b = self.bins.partition_point(|b| b.t_hi < k);
            if b < self.bins.len() && self.bins[b].t_lo <= k && !open.contains(&b) && opened < 4 {
                open[opened] = b;
                opened += 1;
            }
        }
        if opened == 0 {
            return Layout {
                times: Cow::Borrowed(&self.times),
                segments: Cow::Borrowed(&self.segments),
            };
        }
        let open = &open[..opened];
        let nodes = self.degree + 1;
        let mut times = Vec::with_capacity(self.times.len());
        let mut segments = Vec::with_capacity(self.segments.len());
        let mut cursor = 0;
        for &s in &self.segments {
            match s {
                Segment::Points { count, .. } => {
                    times.extend_from_slice(&self.times[cursor..cursor + count]);
                    segments.push(s);
                    cursor += count;
                }
                Segment::Bin(b) if open.contains(&b) => {
                    let bin = &self.bins[b];
                    times.extend_from_slice(&obs_times[bin.first..bin.end]);
                    segments.push(Segment::Points {
                        first: bin.first,
                        count: bin.end - bin.first,
                    });
                    cursor += nodes;
                }
                Segment::Bin(_) => {
                    times.extend_from_slice(&self.times[cursor..cursor + nodes]);
                    segments.push(s);
                    cursor += nodes;
                }
            }
        }
        times.extend_from_slice(&self.times[self.times.len() - self.tail..]);
        Layout {
            times: Cow::Owned(times),
            segments: Cow::Owned(segments),
        }
    }

    /// An accumulator of the sum of squared residuals of `forces` (the observations) over
    /// `layout`, to be given the model's value at each of its times in order.
    pub fn accumulator<'a>(&'a self, layout: &'a Layout, forces: &'a [f64]) -> Accumulator<'a> {
        Accumulator {
            reduction: self,
            segments: &layout.segments,
            forces,
            segment: 0,
            position: 0,
            nodes: [0.0; MAX_NODES],
            ssr: 0.0,
            last: f64::NAN,
        }
    }
}

/// Sums the squared residuals of a [`Layout`] from the model's values at its times.
#[derive(Debug)]
pub struct Accumulator<'a> {
    reduction: &'a Reduction,
    segments: &'a [Segment],
    forces: &'a [f64],
    segment: usize,
    position: usize,
    nodes: [f64; MAX_NODES],
    ssr: f64,
    last: f64,
}

impl Accumulator<'_> {
    /// The model's value at the next time of the layout.
    #[inline]
    pub fn visit(&mut self, model: f64) {
        self.last = model;
        let Some(&segment) = self.segments.get(self.segment) else {
            return;
        };
        match segment {
            Segment::Points { first, count } => {
                let e = self.forces[first + self.position] - model;
                self.ssr += e * e;
                self.position += 1;
                if self.position == count {
                    self.segment += 1;
                    self.position = 0;
                }
            }
            Segment::Bin(b) => {
                self.nodes[self.position] = model;
                self.position += 1;
                if self.position == self.reduction.degree + 1 {
                    self.ssr += self.reduction.bins[b]
                        .moments
                        .ssr(&self.nodes[..self.position]);
                    self.segment += 1;
                    self.position = 0;
                }
            }
        }
    }

    /// (sum of squared residuals, the model's value at the last time).
    pub fn finish(self) -> (f64, f64) {
        (self.ssr, self.last)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bound_and_the_error_it_allows_are_inverse() {
        for (tol, n, sigma, h) in [
            (0.01, 1_000_000, 1e-4, 1.0),
            (0.5, 10_000, 3e-3, 1.3),
            (1e-6, 100_000_000, 1e-8, 1.0),
        ] {
            let beta = max_error_for(tol, n, sigma, h);
            let bound = log_likelihood_bound(n, n as f64 * beta * beta, sigma, h);
            assert!((bound - tol).abs() <= 1e-9 * tol, "{bound} against {tol}");
        }
        // About σ·tol/n when the tolerance is small.
        let beta = max_error_for(0.01, 1_000_000, 1e-4, 1.0);
        assert!((beta / 1e-12 - 1.0).abs() < 1e-3, "{beta}");
    }

    /// The layout's times and segments, then the accumulated SSR, against direct summation;
    /// a kink inside a bin opens it.
    #[test]
    fn a_reduction_sums_what_direct_summation_sums() {
        let n = 5_000;
        let times: Vec<f64> = (0..n).map(|i| 1.0 + i as f64 * 0.01).collect();
        let model = |t: f64| 1e-2 * t.ln() + 1e-3 * (0.1 * t).sin();
        let forces: Vec<f64> = times
            .iter()
            .enumerate()
            .map(|(i, &t)| model(t) + 1e-4 * ((i * 7919 % 1000) as f64 / 500.0 - 1.0))
            .collect();
        let evaluate = |t: &[f64], out: &mut [f64]| {
            for (o, &t) in out.iter_mut().zip(t) {
                *o = model(t);
            }
            true
        };
        let settings = PlanSettings {
            degree: 7,
            max_error_n: 1e-13,
            min_points: 32,
            max_points: 1 << 14,
        };
        let planned = plan_bins(&times, &[], &settings, &[&evaluate]);
        let reduction = Reduction::new(&times, &forces, &[60.0], 7, &planned);
        assert!(reduction.bins() >= 2);
        let direct: f64 = times
            .iter()
            .zip(&forces)
            .map(|(&t, &y)| (y - model(t)).powi(2))
            .sum();
        let run = |layout: &Layout| {
            let mut acc = reduction.accumulator(layout, &forces);
            for &t in layout.times() {
                acc.visit(model(t));
            }
            acc.finish()
        };
        let layout = reduction.layout(&times, &[f64::NAN]);
        assert!(layout.times().windows(2).all(|w| w[0] < w[1]));
        assert_eq!(layout.times().len(), reduction.evaluations());
        let (ssr, last) = run(&layout);
        // The interpolation errors (≤ 1e-13 N) against residuals of 1e-4 N: 2Σeδ ≤ 1e-13 N²
        // in the worst case, 6e-9 of the SSR.
        assert!(
            (ssr - direct).abs() <= 1e-7 * direct,
            "{ssr} against {direct}"
        );
        assert!((last - model(60.0)).abs() < 1e-15);
        // A kink in the middle of the second bin opens it: its points are then exact.
        let (first, end, lo, hi) = reduction.bin_spans()[1];
        let opened = reduction.layout(&times, &[0.5 * (lo + hi)]);
        assert_eq!(
            opened.times().len(),
            reduction.evaluations() - 8 + (end - first)
        );
        assert!(opened.times().windows(2).all(|w| w[0] < w[1]));
        let (ssr_opened, _) = run(&opened);
        assert!((ssr_opened - direct).abs() <= 1e-7 * direct);
    }
}
