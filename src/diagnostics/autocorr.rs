//! emcee's integrated autocorrelation time (Sokal's adaptive window), reproduced exactly.
//!
//! This follows `emcee.autocorr.integrated_time` (emcee 3.1): for each walker the
//! autocorrelation function is computed by FFT of the mean-subtracted series zero-padded to
//! twice the next power of two at or above its length, normalised so that `rho(0) = 1`; the
//! functions are averaged over walkers (walkers of one ensemble share the same stationary law,
//! so averaging their ACFs reduces noise without assuming they are independent chains);
//! `tau(M) = 2 sum_{t <= M} rho(t) - 1`; the window is the first `M` with `M >= c tau(M)`, or
//! the last lag if there is none. The estimate is trusted only when the run is longer than
//! [`super::TAU_FACTOR`] times tau (emcee's `tol = 50`).
//!
//! The sampler and the fit's summary use [`pooled_integrated_time`] instead: the same window
//! over the autocovariance of every walker about the mean of *all* walkers of its ensemble,
//! summed over every walker of every ensemble and normalised by its lag-0 sum (the
//! multi-chain form of Geyer's and Stan's estimators). emcee's form subtracts each walker's own mean, which on a chain of n steps
//! removes about τ/n of the correlation at every lag: on the one-contact posterior its τ is
//! 0.51 of the long-run value on chains of 10 τ and still 0.83 on chains of 50 τ, while the
//! pooled form gives 0.92 and 0.98 (`benches/tau_windows.py`, `reports/fit-defaults.md`). Its noise falls with the number
//! of walkers, so it is trusted on chains of [`tau_trusted_length`], not 50 τ whatever the
//! ensemble.

use rustfft::{num_complex::Complex, FftPlanner};

use super::error::{validate_chains, DiagnosticsError};
use super::verdict::TAU_FACTOR;

/// emcee's default window factor `c`.
pub const DEFAULT_WINDOW_FACTOR: f64 = 5.0;

/// Fewest steps for which an autocorrelation function is defined (a mean-subtracted series of
/// one step is identically zero).
pub const MIN_STEPS_AUTOCORR: usize = 2;

/// An integrated autocorrelation time with the window that produced it.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct AutocorrTime {
    /// Integrated autocorrelation time, in steps.
    pub tau: f64,
    /// The window `M` chosen by Sokal's rule (the last lag summed).
    pub window: usize,
    /// Whether the run is long enough to trust `tau`: `n_steps >= TAU_FACTOR * tau`
    /// (emcee raises `AutocorrError` exactly when this is false).
    pub reliable: bool,
}

/// Smallest power of two at or above `n` (emcee's `next_pow_two`).
fn next_pow_two(n: usize) -> usize {
    n.max(1).next_power_of_two()
}

/// Normalised autocorrelation function of one series, `rho(0) = 1`, same length as `x`
/// (emcee's `function_1d`). `fft`/`ifft` are planned for length `2 * next_pow_two(x.len())`.
fn acf_into(
    x: &[f64],
    buf: &mut [Complex<f64>],
    fft: &dyn rustfft::Fft<f64>,
    ifft: &dyn rustfft::Fft<f64>,
    out: &mut [f64],
) -> Option<()> {
    let n = x.len();
    let mean = x.iter().sum::<f64>() / n as f64;
    for (b, &v) in buf.iter_mut().zip(x) {
        *b = Complex::new(v - mean, 0.0);
    }
    for b in buf.iter_mut().skip(n) {
        *b = Complex::new(0.0, 0.0);
    }
    fft.process(buf);
    for b in buf.iter_mut() {
        *b = Complex::new(b.norm_sqr(), 0.0);
    }
    ifft.process(buf);
    let acf0 = buf[0].re;
    // Zero (or, by rounding, negative) lag-0 power means the series is constant.
    if acf0 <= 0.0 {
        return None;
    }
    for (o, b) in out.iter_mut().zip(buf.iter()) {
        *o = b.re / acf0;
    }
    Some(())
}

/// Normalised autocorrelation function averaged over walkers, `rho(0) = 1`, one value per lag
/// `0..n_steps`.
///
/// # Errors
/// Empty input, ragged walkers, fewer than [`MIN_STEPS_AUTOCORR`] steps, non-finite values, or
/// a constant walker (whose autocorrelation is undefined).
pub fn mean_acf(walkers: &[&[f64]]) -> Result<Vec<f64>, DiagnosticsError> {
    let n = validate_chains(walkers, MIN_STEPS_AUTOCORR, "an autocorrelation function")?;
    let mut sum = AcfSum::new(n);
    for (w, x) in walkers.iter().enumerate() {
        sum.push(x).ok_or(DiagnosticsError::ConstantChain {
            chain: w,
            value: x[0],
        })?;
    }
    Ok(sum.finish())
}

/// [`mean_acf`] fed one walker's series at a time, in walker order: its memory is one
/// series' length, whatever the number of walkers.
pub(crate) struct AcfSum {
    n: usize,
    fft: std::sync::Arc<dyn rustfft::Fft<f64>>,
    ifft: std::sync::Arc<dyn rustfft::Fft<f64>>,
    buf: Vec<Complex<f64>>,
    one: Vec<f64>,
    sum: Vec<f64>,
    walkers: usize,
}

impl AcfSum {
    /// For series of `n` steps.
    pub(crate) fn new(n: usize) -> Self {
        let len = 2 * next_pow_two(n);
        let mut planner = FftPlanner::<f64>::new();
        Self {
            n,
            fft: planner.plan_fft_forward(len),
            ifft: planner.plan_fft_inverse(len),
            buf: vec![Complex::new(0.0, 0.0); len],
            one: vec![0.0; n],
            sum: vec![0.0; n],
            walkers: 0,
        }
    }

    /// Adds the next walker's series (`n` finite values); `None` when it is constant.
    pub(crate) fn push(&mut self, x: &[f64]) -> Option<()> {
        debug_assert_eq!(x.len(), self.n);
        acf_into(
            x,
            &mut self.buf,
            self.fft.as_ref(),
            self.ifft.as_ref(),
            &mut self.one,
        )?;
        for (s, o) in self.sum.iter_mut().zip(&self.one) {
            *s += o;
        }
        self.walkers += 1;
        Some(())
    }

    /// The mean of the functions added.
    pub(crate) fn finish(mut self) -> Vec<f64> {
        let k = self.walkers as f64;
        for s in self.sum.iter_mut() {
            *s /= k;
        }
        self.sum
    }
}

/// The autocovariance of walkers about the mean of their ensemble, summed over every walker of
/// every ensemble, fed one walker's series at a time, ensemble after ensemble (memory of a few
/// series, whatever the number of walkers).
///
/// Each walker's autocovariance about its own mean `m_w` is corrected to its ensemble's mean
/// `g` once `g` is known: with `d = x − m_w` and `P(j) = Σ_{t<j} d_t`,
/// `Σ_t (x_t − g)(x_{t+k} − g) = Σ_t d_t d_{t+k} + (m_w − g)(P(n−k) + P(n) − P(k)) + (n−k)(m_w − g)²`
/// (`P(n)` is zero but for rounding), so the sums over an ensemble's walkers of `d_t d_{t+k}`,
/// of `P` and of `m_w P`, and of `m_w` and `m_w²`, are all it keeps. Ensembles are centred
/// each on its own mean: whether they agree with each other is R̂'s question, not τ's.
pub(crate) struct PooledAcf {
    n: usize,
    walkers_per_ensemble: usize,
    fft: std::sync::Arc<dyn rustfft::Fft<f64>>,
    ifft: std::sync::Arc<dyn rustfft::Fft<f64>>,
    buf: Vec<Complex<f64>>,
    /// Over the current ensemble: Σ_w Σ_t d_t d_{t+k}.
    own: Vec<f64>,
    /// Over the current ensemble: Σ_w P_w(j), j = 0..=n.
    prefix: Vec<f64>,
    /// Over the current ensemble: Σ_w m_w P_w(j).
    weighted_prefix: Vec<f64>,
    mean_sum: f64,
    mean_square_sum: f64,
    in_ensemble: usize,
    /// The autocovariance about each ensemble's mean, summed over the ensembles closed.
    total: Vec<f64>,
}

impl PooledAcf {
    /// For series of `n` steps, in ensembles of `walkers_per_ensemble` walkers.
    pub(crate) fn new(n: usize, walkers_per_ensemble: usize) -> Self {
        let len = 2 * next_pow_two(n);
        let mut planner = FftPlanner::<f64>::new();
        Self {
            n,
            walkers_per_ensemble: walkers_per_ensemble.max(1),
            fft: planner.plan_fft_forward(len),
            ifft: planner.plan_fft_inverse(len),
            buf: vec![Complex::new(0.0, 0.0); len],
            own: vec![0.0; n],
            prefix: vec![0.0; n + 1],
            weighted_prefix: vec![0.0; n + 1],
            mean_sum: 0.0,
            mean_square_sum: 0.0,
            in_ensemble: 0,
            total: vec![0.0; n],
        }
    }

    /// Adds the next walker's series (`n` finite values).
    pub(crate) fn push(&mut self, x: &[f64]) {
        debug_assert_eq!(x.len(), self.n);
        let n = self.n;
        let mean = x.iter().sum::<f64>() / n as f64;
        for (b, &v) in self.buf.iter_mut().zip(x) {
            *b = Complex::new(v - mean, 0.0);
        }
        for b in self.buf.iter_mut().skip(n) {
            *b = Complex::new(0.0, 0.0);
        }
        self.fft.process(&mut self.buf);
        for b in self.buf.iter_mut() {
            *b = Complex::new(b.norm_sqr(), 0.0);
        }
        self.ifft.process(&mut self.buf);
        // rustfft does not normalise: the inverse carries a factor of the transform length.
        let scale = 1.0 / self.buf.len() as f64;
        for (o, b) in self.own.iter_mut().zip(&self.buf) {
            *o += b.re * scale;
        }
        let mut p = 0.0;
        for (j, &v) in x.iter().enumerate() {
            self.prefix[j] += p;
            self.weighted_prefix[j] += mean * p;
            p += v - mean;
        }
        self.prefix[n] += p;
        self.weighted_prefix[n] += mean * p;
        self.mean_sum += mean;
        self.mean_square_sum += mean * mean;
        self.in_ensemble += 1;
        if self.in_ensemble == self.walkers_per_ensemble {
            self.close_ensemble();
        }
    }

    /// Adds the current ensemble's autocovariance about its mean to the total, and starts the
    /// next ensemble.
    fn close_ensemble(&mut self) {
        let n = self.n;
        let g = self.mean_sum / self.in_ensemble as f64;
        // Σ_w (m_w − g)² and Σ_w (m_w − g) P_w(j).
        let spread = (self.mean_square_sum - g * self.mean_sum).max(0.0);
        let (prefix, weighted) = (&self.prefix, &self.weighted_prefix);
        let cross = |j: usize| weighted[j] - g * prefix[j];
        for (k, t) in self.total.iter_mut().enumerate() {
            *t += self.own[k] + cross(n - k) + cross(n) - cross(k) + (n - k) as f64 * spread;
        }
        self.own.fill(0.0);
        self.prefix.fill(0.0);
        self.weighted_prefix.fill(0.0);
        self.mean_sum = 0.0;
        self.mean_square_sum = 0.0;
        self.in_ensemble = 0;
    }

    /// The autocorrelation function, `rho(0) = 1`; `None` when every walker of every ensemble
    /// sits at its ensemble's mean.
    pub(crate) fn finish(mut self) -> Option<Vec<f64>> {
        if self.in_ensemble > 0 {
            self.close_ensemble();
        }
        let acov0 = self.total[0];
        (acov0 > 0.0).then(|| self.total.iter().map(|a| a / acov0).collect())
    }
}

/// The pooled integrated autocorrelation time of a scalar quantity over the walkers of one or
/// more ensembles (`walkers` ensemble after ensemble, `walkers_per_ensemble` each): Sokal's
/// window (factor `c`) over the autocorrelation about each ensemble's mean, summed over every
/// walker (see the module documentation). `reliable` follows [`tau_trusted_length`] for all
/// the walkers.
///
/// # Errors
/// Empty input, ragged walkers, fewer than [`MIN_STEPS_AUTOCORR`] steps, non-finite values, a
/// window factor that is not finite and positive, or every walker constant at its ensemble's
/// mean.
pub fn pooled_integrated_time(
    walkers: &[&[f64]],
    walkers_per_ensemble: usize,
    c: f64,
) -> Result<AutocorrTime, DiagnosticsError> {
    if !(c.is_finite() && c > 0.0) {
        return Err(DiagnosticsError::InvalidArgument {
            name: "c",
            value: c,
            reason: "the window factor must be finite and positive (emcee uses 5)",
        });
    }
    let n = validate_chains(walkers, MIN_STEPS_AUTOCORR, "an autocorrelation function")?;
    let mut sum = PooledAcf::new(n, walkers_per_ensemble);
    for x in walkers {
        sum.push(x);
    }
    let rho = sum.finish().ok_or(DiagnosticsError::ConstantChain {
        chain: 0,
        value: walkers[0][0],
    })?;
    Ok(pooled_time_of_acf(&rho, c, walkers.len()))
}

/// Sokal's window over the pooled ACF `rho` of `walkers` walkers, trusted by
/// [`tau_trusted_length`].
pub(crate) fn pooled_time_of_acf(rho: &[f64], c: f64, walkers: usize) -> AutocorrTime {
    let t = time_of_acf(rho, c);
    AutocorrTime {
        reliable: tau_trusted_length(walkers, TAU_FACTOR) * t.tau < rho.len() as f64,
        ..t
    }
}

/// The chain length, in units of τ, on which a pooled τ over `walkers` walkers is trusted,
/// for a precision asked as emcee's `tau_factor` ([`TAU_FACTOR`], 50) on
/// [`TAU_REFERENCE_WALKERS`] walkers: the pooled estimate's variance falls as one over the
/// walker-steps it is computed from, so `tau_factor · 32 / walkers` τ give the same
/// precision; never fewer than [`TAU_MIN_FACTOR`] τ (or `tau_factor`, when that is smaller),
/// so that Sokal's window of 5 τ spans at most half the chains.
pub fn tau_trusted_length(walkers: usize, tau_factor: f64) -> f64 {
    let floor = TAU_MIN_FACTOR.min(tau_factor);
    (tau_factor * TAU_REFERENCE_WALKERS / walkers.max(1) as f64).max(floor)
}

/// The walkers of the ensemble on which emcee's rule of 50 τ is the reference precision.
pub const TAU_REFERENCE_WALKERS: f64 = 32.0;
/// The shortest chains, in τ, on which a pooled τ is trusted however many walkers there are.
pub const TAU_MIN_FACTOR: f64 = 10.0;

/// emcee's integrated autocorrelation time of a scalar quantity over an ensemble.
///
/// `walkers[w]` is one walker's series (all the same length, in steps). Use `c` =
/// [`DEFAULT_WINDOW_FACTOR`] (5) as emcee does.
///
/// # Formula
/// `rho` = walker-averaged normalised ACF; `tau(M) = 2 sum_{t=0}^{M} rho(t) - 1`;
/// `window = min { M : M >= c tau(M) }` (or `n - 1`); `tau = tau(window)`.
///
/// As in emcee, `tau` is not clamped: an anti-correlated series can give `tau < 1`, even
/// `tau <= 0`. Callers that derive a thinning interval or a burn-in from it should use at
/// least one step.
///
/// # Errors
/// As [`mean_acf`], and [`DiagnosticsError::InvalidArgument`] if `c` is not finite and
/// positive.
pub fn integrated_time(walkers: &[&[f64]], c: f64) -> Result<AutocorrTime, DiagnosticsError> {
    if !(c.is_finite() && c > 0.0) {
        return Err(DiagnosticsError::InvalidArgument {
            name: "c",
            value: c,
            reason: "the window factor must be finite and positive (emcee uses 5)",
        });
    }
    let rho = mean_acf(walkers)?;
    Ok(time_of_acf(&rho, c))
}

/// Sokal's window over the walker-averaged ACF `rho`, window factor `c` (valid, as
/// [`integrated_time`] checks).
pub(crate) fn time_of_acf(rho: &[f64], c: f64) -> AutocorrTime {
    let n = rho.len();
    let mut cum = 0.0;
    let mut taus = Vec::with_capacity(n);
    for r in rho {
        cum += r;
        taus.push(2.0 * cum - 1.0);
    }
    let window = taus
        .iter()
        .enumerate()
        .position(|(m, &t)| (m as f64) >= c * t)
        .unwrap_or(n - 1);
    let tau = taus[window];
    AutocorrTime {
        tau,
        window,
        reliable: TAU_FACTOR * tau <= n as f64,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_pow_two_matches_emcee() {
        assert_eq!(next_pow_two(1), 1);
        assert_eq!(next_pow_two(2), 2);
        assert_eq!(next_pow_two(3), 4);
        assert_eq!(next_pow_two(1024), 1024);
        assert_eq!(next_pow_two(1025), 2048);
    }

    /// The pooled ACF equals the direct sum over walkers of the products of deviations from
    /// the mean of all of them, normalised at lag 0: the correction from each walker's own
    /// mean to the grand mean is exact.
    #[test]
    fn pooled_acf_equals_the_direct_sum_about_the_grand_mean() {
        let walkers: Vec<Vec<f64>> = (0..5)
            .map(|w| {
                (0..23)
                    .map(|i| ((i * i + 3 * w) % 7) as f64 + 0.7 * w as f64 - 0.05 * i as f64)
                    .collect()
            })
            .collect();
        let n = 23;
        let all: Vec<f64> = walkers.iter().flatten().copied().collect();
        let g = all.iter().sum::<f64>() / all.len() as f64;
        let direct: Vec<f64> = (0..n)
            .map(|k| {
                walkers
                    .iter()
                    .map(|x| (0..n - k).map(|t| (x[t] - g) * (x[t + k] - g)).sum::<f64>())
                    .sum()
            })
            .collect();
        let mut pooled = PooledAcf::new(n, walkers.len());
        for x in &walkers {
            pooled.push(x);
        }
        let rho = pooled.finish().expect("not constant");
        for k in 0..n {
            assert!((rho[k] - direct[k] / direct[0]).abs() < 1e-13, "lag {k}");
        }
    }

    /// On walkers that sit at different levels (not yet mixed), the pooled τ sees the spread
    /// between them as correlation that never decays; emcee's per-walker form cannot.
    #[test]
    fn pooled_tau_counts_walkers_apart_as_unmixed() {
        let walkers: Vec<Vec<f64>> = (0..8)
            .map(|w| {
                (0..200)
                    .map(|i| 10.0 * w as f64 + ((i * 7919 + w * 104_729) % 13) as f64 / 13.0)
                    .collect()
            })
            .collect();
        let refs: Vec<&[f64]> = walkers.iter().map(Vec::as_slice).collect();
        let emcee = integrated_time(&refs, DEFAULT_WINDOW_FACTOR).expect("tau");
        let pooled = pooled_integrated_time(&refs, 8, DEFAULT_WINDOW_FACTOR).expect("tau");
        assert!(emcee.tau < 3.0, "emcee τ {}", emcee.tau);
        assert!(
            pooled.tau > 30.0 && !pooled.reliable,
            "pooled τ {}",
            pooled.tau
        );
        // Two ensembles of one walker each are each centred on their own mean: emcee's τ.
        let apart = pooled_integrated_time(&refs[..2], 1, DEFAULT_WINDOW_FACTOR).expect("tau");
        let each = integrated_time(&refs[..2], DEFAULT_WINDOW_FACTOR).expect("tau");
        assert!(
            (apart.tau - each.tau).abs() < 0.5,
            "{} vs {}",
            apart.tau,
            each.tau
        );
    }

    /// The trusted length: emcee's 50 τ on 32 walkers, shorter in proportion with more walkers,
    /// never below 10 τ (or the factor asked, when smaller).
    #[test]
    fn the_trusted_length_falls_with_the_walkers_to_its_floor() {
        for (walkers, factor, length) in [(32, 50.0, 50.0), (128, 50.0, 12.5), (1024, 50.0, 10.0)]
            .into_iter()
            .chain([(128, 1.0, 1.0)])
        {
            let got = tau_trusted_length(walkers, factor);
            assert!((got - length).abs() < 1e-12, "{walkers} walkers: {got}");
        }
    }

    /// The FFT ACF equals the direct O(n^2) sum (the padding makes the circular correlation
    /// linear).
    #[test]
    fn fft_acf_equals_direct_sum() {
        let x: Vec<f64> = (0..37)
            .map(|i| ((i * i) % 11) as f64 + 0.1 * i as f64)
            .collect();
        let n = x.len();
        let mean = x.iter().sum::<f64>() / n as f64;
        let direct: Vec<f64> = (0..n)
            .map(|t| {
                (0..n - t)
                    .map(|i| (x[i] - mean) * (x[i + t] - mean))
                    .sum::<f64>()
            })
            .collect();
        let acf = mean_acf(&[&x]).expect("valid series");
        for t in 0..n {
            assert!((acf[t] - direct[t] / direct[0]).abs() < 1e-13, "lag {t}");
        }
    }

    #[test]
    fn errors_name_the_fault() {
        let a = [1.0, 2.0, 3.0];
        let b = [1.0, 2.0];
        assert!(matches!(
            integrated_time(&[&a, &b], 5.0),
            Err(DiagnosticsError::RaggedChains {
                chain: 1,
                len: 2,
                expected: 3
            })
        ));
        let c = [1.0, f64::NAN, 3.0];
        assert!(matches!(
            integrated_time(&[&a, &c], 5.0),
            Err(DiagnosticsError::NonFinite {
                chain: 1,
                index: 1,
                ..
            })
        ));
        let k = [2.0, 2.0, 2.0];
        assert!(matches!(
            integrated_time(&[&a, &k], 5.0),
            Err(DiagnosticsError::ConstantChain { chain: 1, .. })
        ));
        assert!(matches!(
            integrated_time(&[], 5.0),
            Err(DiagnosticsError::NoChains { .. })
        ));
        assert!(matches!(
            integrated_time(&[&a[..1]], 5.0),
            Err(DiagnosticsError::TooFewDraws {
                have: 1,
                needed: 2,
                ..
            })
        ));
        assert!(integrated_time(&[&a], 0.0).is_err());
    }
}
