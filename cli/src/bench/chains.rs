//! Chains of sampled coordinates in memory and the statistics the bench takes from them, by
//! one estimator for both samplers (ours and the peer's), so that their ESS and medians are
//! comparable.

use serde::Serialize;

use slipbayes::diagnostics::{ess_bulk, mcse_quantile, quantile};
use slipbayes::sampler::MemoryChain;

/// Coordinates of a run: per ensemble, step-major `[step][walker][dim]`.
#[derive(Debug, Clone)]
pub struct Draws {
    /// One buffer per ensemble.
    pub ensembles: Vec<Vec<f64>>,
    /// Walkers per ensemble.
    pub walkers: usize,
    /// Steps per walker.
    pub steps: usize,
    /// Coordinates per draw.
    pub ndim: usize,
}

/// Statistics of one coordinate after the burn-in.
#[derive(Debug, Clone, Serialize)]
pub struct CoordStats {
    /// Coordinate name.
    pub name: String,
    /// Median.
    pub median: f64,
    /// Standard deviation.
    pub sd: f64,
    /// Monte-Carlo standard error of the median.
    pub mcse_median: f64,
    /// Bulk ESS (every walker of every ensemble as a chain).
    pub ess_bulk: f64,
}

impl Draws {
    /// From the in-memory chains of the sampler.
    pub fn from_memory(chains: &[MemoryChain]) -> Self {
        let first = chains.first();
        Self {
            ensembles: chains.iter().map(|c| c.positions.clone()).collect(),
            walkers: first.map_or(0, |c| c.walkers),
            steps: first.map_or(0, |c| c.steps.len()),
            ndim: first.map_or(0, |c| c.ndim),
        }
    }

    /// The series of coordinate `d` of walker `w` of ensemble `e` from step `from` on.
    pub fn series(&self, e: usize, w: usize, d: usize, from: usize) -> Vec<f64> {
        let stride = self.walkers * self.ndim;
        (from..self.steps)
            .map(|s| self.ensembles[e][s * stride + w * self.ndim + d])
            .collect()
    }

    /// The draw of walker `w` of ensemble `e` at step `s`.
    pub fn draw(&self, e: usize, s: usize, w: usize) -> &[f64] {
        let at = (s * self.walkers + w) * self.ndim;
        &self.ensembles[e][at..at + self.ndim]
    }

    /// Median, sd, MCSE of the median and bulk ESS of every coordinate, after dropping the
    /// first `burn_in` steps.
    ///
    /// # Errors
    /// A message when the chains are too short for the diagnostics.
    pub fn stats(&self, names: &[String], burn_in: usize) -> Result<Vec<CoordStats>, String> {
        (0..self.ndim)
            .map(|d| {
                let series: Vec<Vec<f64>> = (0..self.ensembles.len())
                    .flat_map(|e| (0..self.walkers).map(move |w| (e, w)))
                    .map(|(e, w)| self.series(e, w, d, burn_in))
                    .collect();
                let refs: Vec<&[f64]> = series.iter().map(Vec::as_slice).collect();
                let mut all: Vec<f64> = series.concat();
                all.sort_by(f64::total_cmp);
                let n = all.len() as f64;
                let mean = all.iter().sum::<f64>() / n;
                let sd = (all.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
                let name = names.get(d).cloned().unwrap_or_else(|| format!("x{d}"));
                let fail = |e: slipbayes::diagnostics::DiagnosticsError| format!("{name}: {e}");
                Ok(CoordStats {
                    median: quantile(&all, 0.5).map_err(fail)?,
                    sd,
                    mcse_median: mcse_quantile(&refs, 0.5).map_err(fail)?,
                    ess_bulk: ess_bulk(&refs).map_err(fail)?,
                    name,
                })
            })
            .collect()
    }
}

/// The smallest bulk ESS over coordinates.
pub fn min_ess(stats: &[CoordStats]) -> f64 {
    stats
        .iter()
        .map(|s| s.ess_bulk)
        .fold(f64::INFINITY, f64::min)
}

/// Largest |median − reference median| / reference sd over coordinates.
pub fn median_error(stats: &[CoordStats], reference: &[CoordStats]) -> f64 {
    stats
        .iter()
        .zip(reference)
        .map(|(s, r)| (s.median - r.median).abs() / r.sd)
        .fold(0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn series_and_draw_follow_the_sampler_layout() {
        // 1 ensemble, 2 walkers, 3 steps, 2 dims: value = 100 s + 10 w + d.
        let mut buf = Vec::new();
        for s in 0..3 {
            for w in 0..2 {
                for d in 0..2 {
                    buf.push((100 * s + 10 * w + d) as f64);
                }
            }
        }
        let draws = Draws {
            ensembles: vec![buf],
            walkers: 2,
            steps: 3,
            ndim: 2,
        };
        assert_eq!(draws.series(0, 1, 1, 1), vec![111.0, 211.0]);
        assert_eq!(draws.draw(0, 2, 0), &[200.0, 201.0]);
    }

    #[test]
    fn median_error_is_in_reference_sds() {
        let s = |median: f64, sd: f64| CoordStats {
            name: "x".into(),
            median,
            sd,
            mcse_median: 0.0,
            ess_bulk: 1.0,
        };
        let err = median_error(&[s(1.0, 1.0), s(5.0, 1.0)], &[s(0.5, 2.0), s(4.0, 4.0)]);
        assert!((err - 0.25).abs() < 1e-12, "{err}");
    }
}
