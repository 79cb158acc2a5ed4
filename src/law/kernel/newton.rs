//! One step towards a point's root from a guess: Newton's, or of third order from the same
//! evaluation of the law, each with its predicted error (see the [parent](super)'s
//! "Exactness").

use super::ROUND_OFF;
use crate::law::Law;

/// One Newton step on G(τ) = τ + F(τ)/(kv) − t from a τ where the law gives F and dF/dτ:
/// the next τ, F carried along its tangent, whether both are final (the predicted error of
/// each below a quarter ulp, see the module's doc) and whether the step stayed in (lo, t].
#[derive(Debug, Clone, Copy)]
pub(super) struct Step {
    pub(super) tau: f64,
    pub(super) force: f64,
    pub(super) converged: bool,
    pub(super) inside: bool,
}

/// Where a step starts: the point's time `t`, a τ, the law's F and dF/dτ there and 1/x
/// (x = αvτ).
#[derive(Debug, Clone, Copy)]
pub(super) struct Start {
    pub(super) t: f64,
    pub(super) tau: f64,
    pub(super) force: f64,
    pub(super) rate: f64,
    pub(super) inv_x: f64,
}

/// The Newton [`Step`] from `at` (the law's curvature from its 1/x); branch-free, so that it
/// vectorises across lanes.
#[inline(always)]
pub(super) fn newton_step(law: &Law, inv_kv: f64, lo: f64, at: Start) -> Step {
    let (g_slope, inv_slope, step) = newton_increment(inv_kv, &at);
    let next = at.tau + step;
    let next_force = at.force + at.rate * step;
    // ½ |d²F/dτ²| s² = ½ |a/τ² + αv dF/dτ| s² = ½ αv |αv a/x² + dF/dτ| s².
    let remainder = (0.5 * law.alpha_v)
        * ((law.alpha_v * law.a) * at.inv_x * at.inv_x + at.rate).abs()
        * (step * step);
    let tau_error = remainder * inv_kv * inv_slope;
    // ½ |F''| s² + |F'| · (the error in τ).
    let force_error = remainder + at.rate.abs() * tau_error;
    checked_step(lo, at.t, g_slope, next, next_force, tau_error, force_error)
}

/// G'(τ) = 1 + (dF/dτ)/(kv) at `at`, its reciprocal and the Newton step −G/G' from it.
#[inline(always)]
fn newton_increment(inv_kv: f64, at: &Start) -> (f64, f64, f64) {
    let g_slope = 1.0 + at.rate * inv_kv;
    let inv_slope = 1.0 / g_slope;
    (
        g_slope,
        inv_slope,
        (at.t - at.tau - at.force * inv_kv) * inv_slope,
    )
}

/// The [`Step`] to `next` (force `next_force`) with these predicted errors: final where G
/// increases, the step stayed in (lo, t] and both errors are below a quarter ulp.
#[inline(always)]
fn checked_step(
    lo: f64,
    t: f64,
    g_slope: f64,
    next: f64,
    next_force: f64,
    tau_error: f64,
    force_error: f64,
) -> Step {
    let inside = (next > lo) & (next <= t);
    Step {
        tau: next,
        force: next_force,
        converged: (g_slope > 0.0)
            & inside
            & (tau_error <= ROUND_OFF * next)
            & (force_error <= ROUND_OFF * next_force.abs()),
        inside,
    }
}

/// A step of third order from the same start as [`newton_step`], for a point whose Newton step
/// was not final: it needs no new evaluation of the law, since F'' and F⁽³⁾ follow from F'
/// and 1/x (Eq. 2: F'' = −a/τ² − αv F', F⁽³⁾ = 2a/τ³ − αv F''), and its error is of order
/// s³ where Newton's is ½ |G''/G'| s² (s the Newton step), so that a guess some hundred
/// times worse is still final after it.
///
/// # Formula
/// With p = G''/G' and q = G'''/G', the root lies at τ + e with
/// e = s − (p/2) s² + (p²/2 − q/6) s³ + O(s⁴) (Chebyshev's method, from the series of the
/// inverse function). The step takes the first two terms and predicts |p²/2 − q/6| |s|³ as
/// its error in τ; F is carried along its Taylor polynomial of second order,
/// F + F' ê + ½ F'' ê² with ê = s − (p/2) s², whose error is
/// |F'| |p²/2 − q/6| |s|³ + |F⁽³⁾| |s|³ / 6 to leading order. Both must be below a quarter
/// ulp, as for the Newton step.
#[inline(always)]
pub(super) fn third_order_step(law: &Law, inv_kv: f64, lo: f64, at: Start) -> Step {
    let (g_slope, inv_slope, newton) = newton_increment(inv_kv, &at);
    let alpha_v = law.alpha_v;
    // a/τ² = αv² a/x², a/τ³ = αv a/τ² · 1/x.
    let a_over_tau2 = alpha_v * alpha_v * law.a * at.inv_x * at.inv_x;
    let f2 = -a_over_tau2 - alpha_v * at.rate;
    let f3 = 2.0 * a_over_tau2 * alpha_v * at.inv_x - alpha_v * f2;
    let p = f2 * inv_kv * inv_slope;
    let q = f3 * inv_kv * inv_slope;
    let step = newton * (1.0 - 0.5 * p * newton);
    let cube = (newton * newton * newton).abs();
    let tau_error = (0.5 * p * p - q / 6.0).abs() * cube;
    let force_error = at.rate.abs() * tau_error + f3.abs() * cube / 6.0;
    checked_step(
        lo,
        at.t,
        g_slope,
        at.tau + step,
        at.force + step * (at.rate + 0.5 * f2 * step),
        tau_error,
        force_error,
    )
}
