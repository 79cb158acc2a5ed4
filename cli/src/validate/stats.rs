//! Statistics of simulation-based calibration: ranks, their uniformity, interval coverage.
//!
//! If the posterior is calibrated, the rank of the true value among L independent posterior
//! draws is uniform on {0, …, L} (Talts et al. 2018), and the truth falls inside the central
//! p-interval of the posterior with probability p.

use serde::{Deserialize, Serialize};
use slipbayes::special::gamma_q;
use statrs::function::gamma::ln_gamma;

/// Smallest expected count per bin of the χ² test (the usual rule of thumb).
const MIN_EXPECTED_PER_BIN: usize = 5;
/// Bin counts tried for the χ² test, most first.
const BIN_CHOICES: [usize; 6] = [20, 10, 5, 4, 2, 1];
/// Two-sided probability outside the band drawn behind each rank histogram.
pub const BAND_TAIL: f64 = 0.01;

/// Rank of `truth` among `draws`: how many draws are below it (NaN draws count as not below).
pub fn rank(truth: f64, draws: &[f64]) -> usize {
    draws.iter().filter(|&&d| d < truth).count()
}

/// Coverage of the central `nominal` interval over the replications.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Coverage {
    /// Nominal probability of the interval (0.5, 0.95).
    pub nominal: f64,
    /// Replications whose truth lies inside.
    pub covered: usize,
    /// Replications.
    pub n: usize,
    /// covered / n.
    pub rate: f64,
    /// 95 % Wilson score interval of the true coverage, [low, high].
    pub wilson95: [f64; 2],
}

impl Coverage {
    /// Coverage from each replication's posterior quantile of the truth (fraction of draws
    /// below it): the truth is inside the central interval when that quantile is.
    pub fn from_quantiles(nominal: f64, quantiles: &[f64]) -> Self {
        let (lo, hi) = (0.5 * (1.0 - nominal), 0.5 * (1.0 + nominal));
        let covered = quantiles.iter().filter(|&&q| q >= lo && q <= hi).count();
        let n = quantiles.len();
        let rate = if n == 0 {
            f64::NAN
        } else {
            covered as f64 / n as f64
        };
        Self {
            nominal,
            covered,
            n,
            rate,
            wilson95: wilson(covered, n, 1.959_963_984_540_054),
        }
    }
}

/// Wilson score interval for a binomial proportion with `k` successes in `n`, at `z` sds.
pub fn wilson(k: usize, n: usize, z: f64) -> [f64; 2] {
    if n == 0 {
        return [0.0, 1.0];
    }
    let n = n as f64;
    let p = k as f64 / n;
    let z2 = z * z;
    let centre = (p + z2 / (2.0 * n)) / (1.0 + z2 / n);
    let half = z / (1.0 + z2 / n) * (p * (1.0 - p) / n + z2 / (4.0 * n * n)).sqrt();
    [(centre - half).max(0.0), (centre + half).min(1.0)]
}

/// χ² test that ranks on {0, …, max_rank} are uniform, with equal-width bins.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Uniformity {
    /// Ranks binned: count per bin.
    pub counts: Vec<usize>,
    /// Ranks per bin.
    pub ranks_per_bin: usize,
    /// Pearson's χ² statistic.
    pub chi2: f64,
    /// Degrees of freedom (bins − 1).
    pub dof: usize,
    /// P(χ²_dof ≥ chi2) under uniformity.
    pub p_value: f64,
}

impl Uniformity {
    /// Bins the ranks (each in 0..=max_rank) into as many equal bins as keep at least five
    /// expected per bin, and tests them. The number of bins divides max_rank + 1, so every
    /// bin holds the same number of rank values (choose max_rank + 1 = 100 or 200).
    pub fn test(ranks: &[usize], max_rank: usize) -> Self {
        let values = max_rank + 1;
        let n = ranks.len();
        let bins = BIN_CHOICES
            .into_iter()
            .find(|&b| values % b == 0 && n >= MIN_EXPECTED_PER_BIN * b)
            .unwrap_or(1);
        let per_bin = values / bins;
        let mut counts = vec![0usize; bins];
        for &r in ranks {
            counts[(r / per_bin).min(bins - 1)] += 1;
        }
        let expected = n as f64 / bins as f64;
        let chi2 = if n == 0 {
            0.0
        } else {
            counts
                .iter()
                .map(|&c| (c as f64 - expected).powi(2) / expected)
                .sum()
        };
        let dof = bins - 1;
        let p_value = if dof == 0 {
            1.0
        } else {
            gamma_q(0.5 * dof as f64, 0.5 * chi2)
        };
        Self {
            counts,
            ranks_per_bin: per_bin,
            chi2,
            dof,
            p_value,
        }
    }
}

/// Central interval [low, high] holding at least 1 − `tail` of Binomial(n, p): the range of
/// a histogram bar's count expected under uniformity.
pub fn binomial_band(n: usize, p: f64, tail: f64) -> [usize; 2] {
    let ln_pmf = |k: usize| {
        ln_gamma(n as f64 + 1.0) - ln_gamma(k as f64 + 1.0) - ln_gamma((n - k) as f64 + 1.0)
            + k as f64 * p.ln()
            + (n - k) as f64 * (1.0 - p).ln()
    };
    let pmf: Vec<f64> = (0..=n).map(|k| ln_pmf(k).exp()).collect();
    let (mut low, mut cum) = (0, 0.0);
    while low < n && cum + pmf[low] <= 0.5 * tail {
        cum += pmf[low];
        low += 1;
    }
    let (mut high, mut cum) = (n, 0.0);
    while high > 0 && cum + pmf[high] <= 0.5 * tail {
        cum += pmf[high];
        high -= 1;
    }
    [low, high]
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn ranks_count_draws_below() {
        assert_eq!(rank(2.0, &[1.0, 3.0, 2.5, 0.0, f64::NAN]), 2);
        assert_eq!(rank(-1.0, &[1.0, 3.0]), 0);
    }

    #[test]
    fn uniform_ranks_pass_and_skewed_ranks_fail() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        let uniform: Vec<usize> = (0..200).map(|_| rng.random_range(0..100)).collect();
        let u = Uniformity::test(&uniform, 99);
        assert_eq!(u.counts.len(), 20);
        assert_eq!(u.counts.iter().sum::<usize>(), 200);
        assert!(u.p_value > 0.01, "{u:?}");
        // An overconfident posterior: the truth is often outside all draws.
        let skewed: Vec<usize> = (0..200)
            .map(|i| {
                if i % 3 == 0 {
                    0
                } else {
                    rng.random_range(0..100)
                }
            })
            .collect();
        let s = Uniformity::test(&skewed, 99);
        assert!(s.p_value < 1e-6, "{s:?}");
        // Thirty replications: five bins of twenty ranks.
        assert_eq!(Uniformity::test(&uniform[..30], 99).counts.len(), 5);
    }

    #[test]
    fn chi2_p_value_matches_a_table() {
        // χ²(4) = 9.4877 has upper tail 0.05.
        let ranks: Vec<usize> = [
            vec![0; 10],
            vec![1; 10],
            vec![2; 10],
            vec![3; 10],
            vec![4; 10],
        ]
        .concat();
        let u = Uniformity::test(&ranks, 4);
        assert!(u.chi2.abs() < 1e-12 && (u.p_value - 1.0).abs() < 1e-12);
        assert!((gamma_q(2.0, 0.5 * 9.4877) - 0.05).abs() < 1e-5);
    }

    #[test]
    fn coverage_and_wilson() {
        let q = [0.5, 0.01, 0.99, 0.3, 0.8, 0.026];
        let c95 = Coverage::from_quantiles(0.95, &q);
        assert_eq!((c95.covered, c95.n), (4, 6));
        let c50 = Coverage::from_quantiles(0.5, &q);
        assert_eq!(c50.covered, 2);
        // Wilson interval of 0 of 10 at z = 1.96 is [0, 0.2775].
        let w = wilson(0, 10, 1.959_963_984_540_054);
        assert!(w[0].abs() < 1e-12 && (w[1] - 0.2775).abs() < 1e-4, "{w:?}");
        let w = wilson(190, 200, 1.959_963_984_540_054);
        assert!(w[0] < 0.95 && w[1] > 0.95);
    }

    #[test]
    fn binomial_band_holds_its_mass() {
        let [lo, hi] = binomial_band(200, 0.05, 0.01);
        // Binomial(200, 0.05): mean 10, sd 3.08; the 99 % band is about [3, 19].
        assert!(
            (2..=4).contains(&lo) && (18..=20).contains(&hi),
            "{lo} {hi}"
        );
    }
}
