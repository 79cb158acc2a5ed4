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
