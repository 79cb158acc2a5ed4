//! Curves a report redraws from posterior draws, where the data do not sample them: the law
//! in interface time (elastic part removed), the peak against t0 (the paper's Fig. 4), and
//! posterior densities. Pure numbers; no drawing.

use super::ReportError;
use crate::diagnostics::quantile;
use crate::fit::SamplerSummary;
use crate::law::{Elastic, InterfaceLaw};
use crate::model::Posterior;
use crate::storage::ChainReader;

/// Decades of interface time a redrawn law spans below its end.
pub const CURVE_DECADES: f64 = 6.0;

/// Quantiles drawn as a median with a 95 % band.
pub const BAND_PROBS: [f64; 3] = [0.025, 0.5, 0.975];

/// The sampler coordinates of up to `max_draws` kept draws (after the burn-in),
/// spread evenly over the chains, with their row numbers.
///
/// # Errors
/// [`ReportError::Chains`] when a coordinate column is missing.
pub fn coordinate_draws(
    chains: &ChainReader,
    sampler: &SamplerSummary,
    max_draws: usize,
) -> Result<Vec<(usize, Vec<f64>)>, ReportError> {
    let rows = crate::fit::kept_rows(chains, sampler, max_draws);
    let mut draws: Vec<(usize, Vec<f64>)> = rows
        .iter()
        .map(|&i| (i, Vec::with_capacity(chains.param_names().len())))
        .collect();
    // The rows asked for, one column at a time, read one row group at a time.
    for name in chains.param_names() {
        let column = chains
            .rows_of(name, &rows)
            .map_err(|source| ReportError::Chains {
                dir: chains.dir().to_path_buf(),
                source,
            })?;
        for ((_, draw), v) in draws.iter_mut().zip(column) {
            draw.push(v);
        }
    }
    Ok(draws)
}

/// Per grid point, the `probs` quantiles over the rows of `values[draw][point]`:
/// `out[q][point]`. Rows holding a NaN at a point are skipped there.
pub fn pointwise_quantiles(values: &[Vec<f64>], points: usize, probs: &[f64]) -> Vec<Vec<f64>> {
    let mut out = vec![vec![f64::NAN; points]; probs.len()];
    let mut column = Vec::with_capacity(values.len());
    for j in 0..points {
        column.clear();
        column.extend(values.iter().map(|row| row[j]).filter(|v| v.is_finite()));
        column.sort_by(f64::total_cmp);
        for (q, &p) in probs.iter().enumerate() {
            out[q][j] = quantile(&column, p).unwrap_or(f64::NAN);
        }
    }
    out
}

/// A first or fast slide redrawn in interface time τ.
#[derive(Debug, Clone, PartialEq)]
pub struct InterfaceCurve {
    /// Grid of interface times (s).
    pub tau_s: Vec<f64>,
    /// F(τ) quantiles over the draws, [`BAND_PROBS`] (N).
    pub force_n: [Vec<f64>; 3],
    /// Posterior median of k·v (N/s); `None` for a stiff slide (τ = t).
    pub kv_n_per_s: Option<f64>,
}

impl InterfaceCurve {
    /// Interface time of an observation (t, F): τ = t − F/(kv), the paper's Eq. 1 with the
    /// posterior median k.
    pub fn interface_time(&self, time_s: f64, force_n: f64) -> f64 {
        match self.kv_n_per_s {
            Some(kv) => time_s - force_n / kv,
            None => time_s,
        }
    }
}

/// The law of run `run` on `points` interface times from 0 to `tau_end_s`, over `draws`:
/// 0, then log-spaced from [`CURVE_DECADES`] decades below the end, so that the curve has
/// its rise on a logarithmic distance axis and is smooth on a linear one. `None` for a
/// repeat slide.
///
/// # Errors
/// [`ReportError::Law`] when a posterior draw gives an invalid law (it cannot: the sampler
/// rejects those).
pub fn interface_curve(
    posterior: &Posterior,
    run: usize,
    draws: &[(usize, Vec<f64>)],
    tau_end_s: f64,
    points: usize,
) -> Result<Option<InterfaceCurve>, ReportError> {
    let tau_s: Vec<f64> = std::iter::once(0.0)
        .chain((0..points.saturating_sub(1)).map(|j| {
            let f = j as f64 / points.saturating_sub(2).max(1) as f64;
            tau_end_s * 10f64.powf(CURVE_DECADES * (f - 1.0))
        }))
        .collect();
    let mut forces = Vec::with_capacity(draws.len());
    let mut kvs = Vec::with_capacity(draws.len());
    for (_, x) in draws {
        let Some(slide) = posterior.run_slide(x, run).map_err(ReportError::Law)? else {
            return Ok(None);
        };
        if let Elastic::Spring { kv } = slide.elastic() {
            kvs.push(kv);
        }
        let law = slide.law();
        forces.push(tau_s.iter().map(|&t| law.force(t)).collect::<Vec<f64>>());
    }
    let q = pointwise_quantiles(&forces, tau_s.len(), &BAND_PROBS);
    let [low, median, high]: [Vec<f64>; 3] = q.try_into().expect("three quantiles");
    Ok(Some(InterfaceCurve {
        tau_s,
        force_n: [low, median, high],
        kv_n_per_s: quantile(&kvs, 0.5).ok(),
    }))
}

/// The peak against t0 for one run, other parameters from the posterior (the paper's Fig. 4).
#[derive(Debug, Clone, PartialEq)]
pub struct PeakVsT0 {
    /// Grid of t0 (s), log-spaced.
    pub t0_s: Vec<f64>,
    /// F_peak quantiles over the draws at each t0, [`BAND_PROBS`] (N).
    pub peak_n: [Vec<f64>; 3],
    /// The posterior draws themselves: (t0, F_peak).
    pub draws: Vec<(f64, f64)>,
}

/// F_peak of run `run` on `points` log-spaced values of t0 in `t0_range_s`, keeping each
/// draw's αv, a and F_d; and each draw's own (t0, F_peak). `None` for a repeat slide.
///
/// # Errors
/// [`ReportError::Law`] when a draw gives an invalid law.
pub fn peak_vs_t0(
    posterior: &Posterior,
    run: usize,
    draws: &[(usize, Vec<f64>)],
    t0_range_s: (f64, f64),
    points: usize,
) -> Result<Option<PeakVsT0>, ReportError> {
    let (lo, hi) = (t0_range_s.0.ln(), t0_range_s.1.ln());
    let t0_s: Vec<f64> = (0..points)
        .map(|j| (lo + (hi - lo) * j as f64 / (points - 1).max(1) as f64).exp())
        .collect();
    let peak = |law: &InterfaceLaw| law.peak().interior().map_or(f64::NAN, |p| p.force_n);
    let mut curves = Vec::with_capacity(draws.len());
    let mut own = Vec::with_capacity(draws.len());
    for (_, x) in draws {
        let Some(slide) = posterior.run_slide(x, run).map_err(ReportError::Law)? else {
            return Ok(None);
        };
        let law = slide.law();
        own.push((law.t0(), peak(law)));
        let curve = t0_s
            .iter()
            .map(|&t0| law.with_t0(t0).map_or(f64::NAN, |l| peak(&l)))
            .collect::<Vec<f64>>();
        curves.push(curve);
    }
    let q = pointwise_quantiles(&curves, t0_s.len(), &BAND_PROBS);
    let [low, median, high]: [Vec<f64>; 3] = q.try_into().expect("three quantiles");
    Ok(Some(PeakVsT0 {
        t0_s,
        peak_n: [low, median, high],
        draws: own,
    }))
}

/// Gaussian kernel density of `values` on `points` grid points spanning the values ± 3
/// bandwidths (Silverman's rule): (grid, density). Empty for fewer than two finite values.
pub fn kernel_density(values: &[f64], points: usize) -> (Vec<f64>, Vec<f64>) {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.len() < 2 {
        return (Vec::new(), Vec::new());
    }
    v.sort_by(f64::total_cmp);
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let sd = (v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let iqr = quantile(&v, 0.75).unwrap_or(0.0) - quantile(&v, 0.25).unwrap_or(0.0);
    let spread = if iqr > 0.0 { sd.min(iqr / 1.34) } else { sd };
    let h = (0.9 * spread * n.powf(-0.2)).max(f64::MIN_POSITIVE);
    let (lo, hi) = (v[0] - 3.0 * h, v[v.len() - 1] + 3.0 * h);
    let grid: Vec<f64> = (0..points)
        .map(|j| lo + (hi - lo) * j as f64 / (points - 1).max(1) as f64)
        .collect();
    let norm = 1.0 / (n * h * (2.0 * std::f64::consts::PI).sqrt());
    let density = grid
        .iter()
        .map(|&g| {
            norm * v
                .iter()
                .map(|&x| (-0.5 * ((g - x) / h).powi(2)).exp())
                .sum::<f64>()
        })
        .collect();
    (grid, density)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_density_integrates_to_one() {
        let values: Vec<f64> = (0..500).map(|i| ((i * 37) % 101) as f64 / 10.0).collect();
        let (grid, density) = kernel_density(&values, 400);
        let dx = grid[1] - grid[0];
        let area: f64 = density.iter().sum::<f64>() * dx;
        assert!((area - 1.0).abs() < 0.01, "area {area}");
        assert!(kernel_density(&[1.0], 10).0.is_empty());
    }

    #[test]
    fn pointwise_quantiles_skip_nan() {
        let rows = vec![vec![1.0, f64::NAN], vec![2.0, 5.0], vec![3.0, 7.0]];
        let q = pointwise_quantiles(&rows, 2, &[0.5]);
        assert!((q[0][0] - 2.0).abs() < 1e-12);
        assert!((q[0][1] - 6.0).abs() < 1e-12);
    }
}
