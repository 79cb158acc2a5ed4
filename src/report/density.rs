//! Posterior densities of the report's figures, from the kept draws. Pure numbers; no
//! drawing.

use crate::diagnostics::quantile;

/// Gaussian kernel density of `values` on `points` grid points spanning the values ± 3
/// bandwidths (Silverman's rule): (grid, density). Empty for fewer than two finite values.
pub(crate) fn kernel_density(values: &[f64], points: usize) -> (Vec<f64>, Vec<f64>) {
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
}
