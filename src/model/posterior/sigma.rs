//! The noise level σ when its prior is log-uniform: integrated out of the likelihood in
//! closed form (one dimension less per σ), and reported through exact draws from its
//! conditional posterior given the other parameters.

use super::layout::SigmaGroup;
use super::likelihood::LN_SQRT_2PI;
use crate::special::ln_gamma_p_diff;

/// ln ∫ N(residuals | 0, σ²) p(σ) dσ for a log-uniform p(σ) on [low, high], given the sum of
/// squared residuals and their number:
/// −n ln√(2π) + ln Γ(n/2) − ln 2 − (n/2) ln(SSR/2) − ln ln(high/low) + ln[P(n/2, SSR/(2low²))
/// − P(n/2, SSR/(2high²))], P the regularised lower incomplete gamma function (the truncation
/// to the prior's bounds). `None` only for SSR ≤ 0 or NaN: far from the data the truncation
/// mass is tiny but is kept in log space, so an optimiser started there can still climb.
pub(super) fn marginal_sigma_log_likelihood(
    ssr: f64,
    n: usize,
    low: f64,
    high: f64,
) -> Option<f64> {
    use statrs::function::gamma::ln_gamma;
    if n == 0 {
        return Some(0.0);
    }
    if ssr.is_nan() || ssr <= 0.0 {
        return None;
    }
    let half_n = 0.5 * n as f64;
    let half_ssr = 0.5 * ssr;
    let ln_mass = ln_gamma_p_diff(half_n, half_ssr / (high * high), half_ssr / (low * low));
    if !ln_mass.is_finite() {
        return None;
    }
    Some(
        -(n as f64) * LN_SQRT_2PI + ln_gamma(half_n)
            - std::f64::consts::LN_2
            - half_n * half_ssr.ln()
            - (high / low).ln().ln()
            + ln_mass,
    )
}

/// A draw of σ from its conditional posterior when nearly all of it lies outside the prior's
/// bounds [low, high] (far from the data, e.g. at a walker's start), where plain rejection
/// fails. With u = SSR/(2σ²), u ~ Gamma(n/2, 1) truncated to [SSR/(2high²), SSR/(2low²)].
/// Above the bounds (the lower truncation point u_h beyond the mode): exact rejection from the
/// shifted exponential u = u_h + E/λ, λ = 1 − (n/2 − 1)/u_h, whose acceptance
/// exp((n/2 − 1)[ln(u/u_h) − (u − u_h)/u_h]) ≤ 1. Below the bounds, or if that fails, the
/// bound where the mass piles up: an approximation only ever needed before burn-in.
fn truncated_sigma_tail_draw<R: rand::Rng>(
    ssr: f64,
    n: usize,
    low: f64,
    high: f64,
    rng: &mut R,
) -> f64 {
    use rand_distr::{Distribution, Exp1};
    let s = 0.5 * n as f64;
    let u_h = 0.5 * ssr / (high * high);
    let u_l = 0.5 * ssr / (low * low);
    if u_h <= s + 1.0 || u_h.is_nan() {
        return low;
    }
    let lambda = 1.0 - (s - 1.0) / u_h;
    for _ in 0..1000 {
        let e: f64 = Exp1.sample(rng);
        let u = u_h + e / lambda;
        let accept = ((s - 1.0) * ((u / u_h).ln() - (u - u_h) / u_h)).exp();
        if u <= u_l && rng.random::<f64>() < accept {
            return (0.5 * ssr / u).sqrt();
        }
    }
    high
}

impl SigmaGroup {
    /// σ drawn from its conditional posterior given the other parameters, from the residuals
    /// of the group's runs (`ssr` over `n` observations): σ² = SSR / χ²_n, truncated to the
    /// prior's bounds. Together with the sampled parameters this is an exact draw from the
    /// joint posterior. `seed` makes the draw a deterministic function of the point.
    pub(super) fn conditional_draw(&self, seed: u64, ssr: f64, n: usize) -> f64 {
        use rand::SeedableRng;
        use rand_distr::{ChiSquared, Distribution};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
        let Ok(chi2) = ChiSquared::new(n as f64) else {
            return f64::NAN;
        };
        for _ in 0..1000 {
            let sigma = (ssr / chi2.sample(&mut rng)).sqrt();
            if sigma >= self.low && sigma <= self.high {
                return sigma;
            }
        }
        truncated_sigma_tail_draw(ssr, n, self.low, self.high, &mut rng)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The closed form against brute-force integration over ln σ.
    #[test]
    fn marginal_sigma_matches_quadrature() {
        for &(ssr, n, low, high) in &[
            (3.0e-5_f64, 3000usize, 1e-8_f64, 1.0_f64),
            (2.0, 10, 0.1, 10.0),
            // Posterior of σ pressed against the upper bound: the truncation term matters.
            (50.0, 8, 0.01, 1.5),
        ] {
            let ln_range = (high / low).ln();
            let m = 400_000;
            let (a, b) = (low.ln(), high.ln());
            let h = (b - a) / m as f64;
            let log_terms: Vec<f64> = (0..m)
                .map(|i| {
                    let u = a + (i as f64 + 0.5) * h;
                    let sigma = u.exp();
                    -(n as f64) * (sigma.ln() + LN_SQRT_2PI)
                        - 0.5 * ssr / (sigma * sigma)
                        - ln_range.ln()
                })
                .collect();
            let max = log_terms.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            let quad = max + (log_terms.iter().map(|t| (t - max).exp()).sum::<f64>() * h).ln();
            let closed = marginal_sigma_log_likelihood(ssr, n, low, high).unwrap();
            assert!(
                (quad - closed).abs() < 1e-6,
                "ssr {ssr} n {n}: quadrature {quad} closed {closed}"
            );
        }
        assert!(marginal_sigma_log_likelihood(0.0, 100, 1e-8, 1.0).is_none());
    }

    /// Far above the prior's bounds the conditional σ piles up just below `high`: the tail
    /// draw matches the exact truncated law there, E[u] ≈ u_h + 1/λ.
    #[test]
    fn sigma_tail_draws_follow_the_truncated_conditional() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
        let (ssr, n, low, high) = (1.0, 201usize, 3e-5, 3e-4);
        let (s, u_h) = (100.5, 0.5 / (high * high));
        let m = 20_000;
        let draws: Vec<f64> = (0..m)
            .map(|_| truncated_sigma_tail_draw(ssr, n, low, high, &mut rng))
            .collect();
        assert!(draws.iter().all(|&d| d > low && d <= high));
        let mean_u = draws.iter().map(|d| 0.5 * ssr / (d * d)).sum::<f64>() / m as f64;
        // Truncated Gamma(s) above u_h ≫ s: u − u_h is nearly Exp(λ), λ = 1 − (s − 1)/u_h;
        // the Monte-Carlo error of the mean is about 1/(λ√m).
        let lambda = 1.0 - (s - 1.0) / u_h;
        assert!(
            (mean_u - u_h - 1.0 / lambda).abs() < 5.0 / (lambda * (m as f64).sqrt()),
            "{mean_u} vs {}",
            u_h + 1.0 / lambda
        );
        // Below the bounds: the lower bound.
        assert!((truncated_sigma_tail_draw(1e-12, n, low, high, &mut rng) - low).abs() < 1e-20);
    }

    /// Binned observations: ∫ Πⱼ N(rⱼ | 0, σ²/wⱼ) p(σ) dσ by quadrature equals the closed form
    /// at the weighted sum of squares plus ½ Σ ln wⱼ, as `log_density` adds them.
    #[test]
    fn weighted_marginal_sigma_matches_quadrature() {
        let residuals = [0.3, -1.1, 0.4, 2.0, -0.7, 0.05, 1.3];
        let weights = [10.0, 11.0, 10.0, 3.0, 1.0, 25.0, 7.0];
        let (low, high) = (0.05_f64, 20.0_f64);
        let n = residuals.len();
        let wssr: f64 = residuals.iter().zip(&weights).map(|(r, w)| w * r * r).sum();
        let half_log_w: f64 = 0.5 * weights.iter().map(|w: &f64| w.ln()).sum::<f64>();
        let closed = marginal_sigma_log_likelihood(wssr, n, low, high).unwrap() + half_log_w;
        let m = 400_000;
        let (a, b) = (low.ln(), high.ln());
        let h = (b - a) / m as f64;
        let ln_range = (high / low).ln();
        let terms: Vec<f64> = (0..m)
            .map(|i| {
                let sigma = (a + (i as f64 + 0.5) * h).exp();
                // The density of each bin mean written out, not through the sum of squares.
                residuals
                    .iter()
                    .zip(&weights)
                    .map(|(r, w)| {
                        let sd = sigma / w.sqrt();
                        -sd.ln() - LN_SQRT_2PI - 0.5 * (r / sd).powi(2)
                    })
                    .sum::<f64>()
                    - ln_range.ln()
            })
            .collect();
        let max = terms.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
        let quad = max + (terms.iter().map(|t| (t - max).exp()).sum::<f64>() * h).ln();
        assert!(
            (quad - closed).abs() < 1e-6,
            "quadrature {quad}, closed {closed}"
        );
    }
}
