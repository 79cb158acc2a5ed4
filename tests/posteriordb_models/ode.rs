//! An adaptive explicit Runge–Kutta integrator, Dormand–Prince 5(4) (Hairer, Nørsett & Wanner,
//! *Solving ODEs I*, II.5 and the DOPRI5 code), for the two ODE models of posteriordb.
//!
//! Why this method: Stan integrates Lotka–Volterra with its rk45, which *is* Dormand–Prince
//! 5(4), and the one-compartment model with BDF; neither system is stiff over the posterior
//! (the one-compartment elimination rate V_m/(V·(K_m + C)) is a few per day over the bulk of
//! the posterior, while the accuracy asked for takes steps of about 0.07 day anyway: 143 steps
//! over the 10-day record), so an explicit method at tight tolerance is accurate and cheap,
//! and needs no Jacobian. The step is clamped to land on every output time, so no dense output is needed.
//! Local extrapolation (the solution advances with the 5th-order weights) and the standard
//! error norm and step-size controller of DOPRI5.

/// Why an integration failed. The densities turn it into a rejected point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OdeError {
    /// More than [`Tolerances::max_steps`] steps (accepted or rejected) were needed.
    TooManySteps,
    /// The state or the step became non-finite, or the step fell below the resolution of t.
    NotFinite,
}

/// Error control: a step is accepted when the RMS over components of
/// |error_i| / (atol + rtol·max(|y_i|, |y_new_i|)) is at most 1.
#[derive(Debug, Clone, Copy)]
pub struct Tolerances {
    /// Relative tolerance.
    pub rtol: f64,
    /// Absolute tolerance (in the units of the state).
    pub atol: f64,
    /// Most steps, accepted or rejected, over the whole integration.
    pub max_steps: usize,
}

/// Steps taken, for the tests and the report.
#[derive(Debug, Clone, Copy, Default)]
pub struct OdeStats {
    /// Accepted steps.
    pub accepted: usize,
    /// Rejected steps.
    pub rejected: usize,
}

// Dormand–Prince 5(4) tableau (DOPRI5): nodes, stages, 5th-order weights (the last stage is
// evaluated at the new point and reused as the next step's first: "first same as last"), and
// the weights of the embedded error estimate (5th minus 4th order).
const C2: f64 = 1.0 / 5.0;
const C3: f64 = 3.0 / 10.0;
const C4: f64 = 4.0 / 5.0;
const C5: f64 = 8.0 / 9.0;
const A21: f64 = 1.0 / 5.0;
const A31: f64 = 3.0 / 40.0;
const A32: f64 = 9.0 / 40.0;
const A41: f64 = 44.0 / 45.0;
const A42: f64 = -56.0 / 15.0;
const A43: f64 = 32.0 / 9.0;
const A51: f64 = 19372.0 / 6561.0;
const A52: f64 = -25360.0 / 2187.0;
const A53: f64 = 64448.0 / 6561.0;
const A54: f64 = -212.0 / 729.0;
const A61: f64 = 9017.0 / 3168.0;
const A62: f64 = -355.0 / 33.0;
const A63: f64 = 46732.0 / 5247.0;
const A64: f64 = 49.0 / 176.0;
const A65: f64 = -5103.0 / 18656.0;
const B1: f64 = 35.0 / 384.0;
const B3: f64 = 500.0 / 1113.0;
const B4: f64 = 125.0 / 192.0;
const B5: f64 = -2187.0 / 6784.0;
const B6: f64 = 11.0 / 84.0;
const E1: f64 = 71.0 / 57600.0;
const E3: f64 = -71.0 / 16695.0;
const E4: f64 = 71.0 / 1920.0;
const E5: f64 = -17253.0 / 339200.0;
const E6: f64 = 22.0 / 525.0;
const E7: f64 = -1.0 / 40.0;

/// Step-size controller (DOPRI5's defaults): safety factor and bounds of the change per step.
const SAFETY: f64 = 0.9;
const MIN_FACTOR: f64 = 0.2;
const MAX_FACTOR: f64 = 10.0;

fn axpy<const N: usize>(y: &[f64; N], h: f64, terms: &[(f64, &[f64; N])]) -> [f64; N] {
    let mut out = *y;
    for (i, o) in out.iter_mut().enumerate() {
        let s: f64 = terms.iter().map(|(a, k)| a * k[i]).sum();
        *o += h * s;
    }
    out
}

fn error_norm<const N: usize>(
    err: &[f64; N],
    y: &[f64; N],
    y_new: &[f64; N],
    tol: &Tolerances,
) -> f64 {
    let sum: f64 = (0..N)
        .map(|i| {
            let scale = tol.atol + tol.rtol * y[i].abs().max(y_new[i].abs());
            (err[i] / scale).powi(2)
        })
        .sum();
    (sum / N as f64).sqrt()
}

/// Hairer's starting step (DOPRI5's `hinit`): the step for which an Euler step's error would
/// be about the tolerance, limited by the second derivative's estimate.
fn initial_step<const N: usize>(
    rhs: &impl Fn(f64, &[f64; N]) -> [f64; N],
    t0: f64,
    y0: &[f64; N],
    f0: &[f64; N],
    span: f64,
    tol: &Tolerances,
) -> f64 {
    let scale = |y: &[f64; N], i: usize| tol.atol + tol.rtol * y[i].abs();
    let rms = |v: &[f64; N], y: &[f64; N]| {
        ((0..N).map(|i| (v[i] / scale(y, i)).powi(2)).sum::<f64>() / N as f64).sqrt()
    };
    let (d0, d1) = (rms(y0, y0), rms(f0, y0));
    let h0 = if d0 < 1e-5 || d1 < 1e-5 {
        1e-6
    } else {
        0.01 * d0 / d1
    };
    let h0 = h0.min(span);
    let y1 = axpy(y0, h0, &[(1.0, f0)]);
    let f1 = rhs(t0 + h0, &y1);
    let diff: [f64; N] = std::array::from_fn(|i| f1[i] - f0[i]);
    let d2 = rms(&diff, y0) / h0;
    let h1 = if d1.max(d2) <= 1e-15 {
        (h0 * 1e-3).max(1e-6)
    } else {
        (0.01 / d1.max(d2)).powf(1.0 / 5.0)
    };
    (100.0 * h0).min(h1).min(span)
}

/// Integrates y' = rhs(t, y) from (t0, y0) and writes y at each of `times` (increasing, all
/// above t0) into `out`.
///
/// # Errors
/// [`OdeError`] when the step budget runs out or the solution stops being finite.
pub fn integrate<const N: usize>(
    rhs: impl Fn(f64, &[f64; N]) -> [f64; N],
    t0: f64,
    y0: [f64; N],
    times: &[f64],
    tol: &Tolerances,
    out: &mut [[f64; N]],
) -> Result<OdeStats, OdeError> {
    assert_eq!(times.len(), out.len(), "one output per time");
    let mut stats = OdeStats::default();
    let Some(&t_end) = times.last() else {
        return Ok(stats);
    };
    let (mut t, mut y) = (t0, y0);
    let mut k1 = rhs(t, &y);
    let mut h = initial_step(&rhs, t, &y, &k1, t_end - t0, tol);
    let mut next = 0;
    while next < times.len() {
        if stats.accepted + stats.rejected >= tol.max_steps {
            return Err(OdeError::TooManySteps);
        }
        let target = times[next];
        // Land exactly on the next output time (and do not leave a sliver before it).
        let landing = t + 1.01 * h >= target;
        let step = if landing { target - t } else { h };
        if !(step.is_finite() && step > 0.0) || t + step <= t {
            return Err(OdeError::NotFinite);
        }
        let k2 = rhs(t + C2 * step, &axpy(&y, step, &[(A21, &k1)]));
        let k3 = rhs(t + C3 * step, &axpy(&y, step, &[(A31, &k1), (A32, &k2)]));
        let k4 = rhs(
            t + C4 * step,
            &axpy(&y, step, &[(A41, &k1), (A42, &k2), (A43, &k3)]),
        );
        let k5 = rhs(
            t + C5 * step,
            &axpy(&y, step, &[(A51, &k1), (A52, &k2), (A53, &k3), (A54, &k4)]),
        );
        let k6 = rhs(
            t + step,
            &axpy(
                &y,
                step,
                &[(A61, &k1), (A62, &k2), (A63, &k3), (A64, &k4), (A65, &k5)],
            ),
        );
        let y_new = axpy(
            &y,
            step,
            &[(B1, &k1), (B3, &k3), (B4, &k4), (B5, &k5), (B6, &k6)],
        );
        let t_new = if landing { target } else { t + step };
        let k7 = rhs(t_new, &y_new);
        let err: [f64; N] = std::array::from_fn(|i| {
            step * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] + E7 * k7[i])
        });
        let norm = error_norm(&err, &y, &y_new, tol);
        if !norm.is_finite() || y_new.iter().any(|v| !v.is_finite()) {
            // A non-finite trial is a step too large (or a solution that blows up): shrink.
            stats.rejected += 1;
            h = step * MIN_FACTOR;
            continue;
        }
        let factor = if norm < f64::MIN_POSITIVE {
            MAX_FACTOR
        } else {
            (SAFETY * norm.powf(-1.0 / 5.0)).clamp(MIN_FACTOR, MAX_FACTOR)
        };
        if norm <= 1.0 {
            stats.accepted += 1;
            t = t_new;
            y = y_new;
            k1 = k7;
            if landing {
                out[next] = y;
                next += 1;
                // A step shortened to land says nothing about the step the error allows.
                h = h.max(step * factor);
            } else {
                h = step * factor;
            }
        } else {
            stats.rejected += 1;
            // After a rejection, never grow (DOPRI5).
            h = step * factor.min(1.0);
        }
    }
    Ok(stats)
}
