//! D(x, x0) = e^(−x) [Ei(x) − Ei(x0)] for 0 < x0 ≤ x, without cancellation.
//!
//! Three regimes of h = x − x0:
//! - h < 1, x ≤ 2: the series D = e^(−x) [ln(x/x0) + Σ_{k≥1} (x^k − x0^k)/(k k!)]. For
//!   x ≥ 2 x0 the two power sums are fixed-degree polynomials (Estrin) and subtract with at
//!   most one bit lost; for x < 2 x0, x^k − x0^k is built by d_k = x d_{k−1} + h x0^(k−1),
//!   every term positive.
//! - otherwise, if h < 2 and x0 ≥ h (this includes every h < 1, x > 2):
//!   D = ∫_0^h e^(−u)/(x − u) du by Gauss–Legendre with 4, 8 or 12 nodes; the pole at u = x
//!   is at least x0 ≥ h away, and the node count is chosen from x0/h and h so that the
//!   rule's error stays below 2e−19 relative (measured with mpmath).
//! - otherwise (h ≥ 2, or 1 ≤ h < 2 with x0 < h): D = S(x) − e^(−h) S(x0), which loses at
//!   most a factor ≈ 2 to cancellation there (none when S(x0) < 0). The rounding of h is
//!   corrected to first order. Taking the quadrature up to h = 2 for x0 ≥ h halved the
//!   worst measured error against the first design (subtraction for all h ≥ 1).

use super::ei_scaled;

// Gauss–Legendre rules on [−1, 1] (positive nodes and their weights; the rules are symmetric),
// printed by `tests/reference/make_ei_reference.py --tables` from a 40-digit Newton solve.
const GL4_X: [f64; 2] = [0.8611363115940526, 0.33998104358485626];
const GL4_W: [f64; 2] = [0.34785484513745385, 0.6521451548625461];
const GL8_X: [f64; 4] = [
    0.9602898564975363,
    0.7966664774136267,
    0.525532409916329,
    0.1834346424956498,
];
const GL8_W: [f64; 4] = [
    0.10122853629037626,
    0.22238103445337448,
    0.31370664587788727,
    0.362683783378362,
];
const GL12_X: [f64; 6] = [
    0.9815606342467192,
    0.9041172563704749,
    0.7699026741943047,
    0.5873179542866175,
    0.3678314989981802,
    0.1252334085114689,
];
const GL12_W: [f64; 6] = [
    0.04717533638651183,
    0.10693932599531843,
    0.16007832854334622,
    0.20316742672306592,
    0.2334925365383548,
    0.24914704581340277,
];

/// 1/(k k!) for k = 1..=32 (same provenance as the rules above).
pub(super) const INV_K_KFACT: [f64; 32] = [
    1.0,
    0.25,
    0.05555555555555555,
    0.010416666666666666,
    0.0016666666666666668,
    0.0002314814814814815,
    2.834467120181406e-05,
    3.1001984126984127e-06,
    3.0619243582206544e-07,
    2.755731922398589e-08,
    2.27746439867652e-09,
    1.7397297489890083e-10,
    1.2353110643708935e-11,
    8.193389712664089e-13,
    5.0981091545465446e-14,
    2.9871733327421158e-15,
    1.6537983849091297e-16,
    8.677337204770125e-18,
    4.326650129802279e-19,
    2.0551588116560825e-20,
    9.32044812542441e-22,
    4.0439960874775335e-23,
    1.6818131176655147e-24,
    6.715573212900493e-26,
    2.5787801137537893e-27,
    9.53690870471076e-29,
    3.401366616220572e-30,
    1.1713890132392279e-31,
    3.8999872022233505e-33,
    1.2566625429386353e-34,
    3.922984005011348e-36,
    1.1876221108921073e-37,
];

/// Below this h = x − x0 and at or below `X_SERIES_MAX` in x, D is formed by the series.
const H_SERIES_MAX: f64 = 1.0;
const X_SERIES_MAX: f64 = 2.0;
/// Below this h, and with x0 ≥ h (pole of the integrand at least h away), by quadrature.
const H_QUADRATURE_MAX: f64 = 2.0;
/// Past this h, e^(−h) rounds to zero in double precision.
const H_EXP_ZERO: f64 = 745.2;
/// The 8-node rule is used up to this h (its error at h = 2 grows to ~1e−18).
const H_GL8_MAX: f64 = 1.5;
/// The series stops once a pair of terms is below this fraction of the running total (the
/// remaining terms then sum to less than that pair, for x ≤ 2 and k ≥ 3).
const SERIES_STOP: f64 = 1.0 / (1u64 << 56) as f64;

/// e^(−x) [Ei(x) − Ei(x0)] for 0 < x0 ≤ x, accurate to a few ε relative for every such pair
/// (both tiny, both huge, a few ulps apart, far apart).
///
/// Edge cases: 0 when x = x0 and when x = +∞; +∞ when x0 = 0 < x; NaN when either input is NaN,
/// x0 < 0 or x < x0 (the law is zero before t0; the caller decides that, not this function).
#[inline]
pub fn ei_scaled_diff(x: f64, x0: f64) -> f64 {
    diff(x, x0, || ei_scaled(x0))
}

/// [`ei_scaled_diff`] for a fixed x0, with S(x0) computed once. [`ScaledEiDiff::eval`] gives
/// results bit-for-bit identical to `ei_scaled_diff(x, x0)`.
#[derive(Debug, Clone, Copy)]
pub struct ScaledEiDiff {
    x0: f64,
    s0: f64,
}

impl ScaledEiDiff {
    /// Prepares D(·, x0). Any x0 is accepted; out-of-domain x0 makes `eval` return NaN
    /// (x0 < 0 or NaN) or +∞ (x0 = 0), as `ei_scaled_diff` does.
    #[inline]
    pub fn new(x0: f64) -> Self {
        Self {
            x0,
            s0: ei_scaled(x0),
        }
    }

    /// The lower point x0.
    #[inline]
    pub fn x0(&self) -> f64 {
        self.x0
    }

    /// D(x, x0) = e^(−x) [Ei(x) − Ei(x0)].
    #[inline]
    pub fn eval(&self, x: f64) -> f64 {
        diff(x, self.x0, || self.s0)
    }
}

/// Shared body of `ei_scaled_diff` and `ScaledEiDiff::eval`; `s0` yields S(x0) (called only
/// on the subtraction path, and deterministic, so both callers agree to the bit).
#[inline]
fn diff(x: f64, x0: f64, s0: impl FnOnce() -> f64) -> f64 {
    if x.is_nan() || x0.is_nan() || x0 < 0.0 || x < x0 {
        return f64::NAN;
    }
    if x <= x0 || x.is_infinite() {
        // x = x0 (including both +∞), or S(∞) − 0 · S(x0).
        return 0.0;
    }
    if x0 <= 0.0 {
        return f64::INFINITY;
    }
    let h = x - x0;
    if h < H_SERIES_MAX && x <= X_SERIES_MAX {
        series(x, x0, h)
    } else if h < H_QUADRATURE_MAX && x0 >= h {
        quadrature(x, x0, h)
    } else {
        // Fast2Sum (|x| ≥ |x0|): x − x0 = h + err exactly; e^(−(h+err)) ≈ e^(−h) (1 − err).
        let err = -x0 - (h - x);
        // e^(−h) rounds to 0 past h ≈ 745.13; skip exp's slow underflow path there.
        let e = if h < H_EXP_ZERO { (-h).exp() } else { 0.0 };
        let w = e - e * err;
        ei_scaled(x) - w * s0()
    }
}

/// Whether D(x, x0) is formed by subtraction (neither the series nor the quadrature regime:
/// then h = x − x0 ≥ 1 and x > 1), the regime whose branch-free form `lanes::d_subtracted`
/// evaluates; false for NaN.
#[inline(always)]
pub(crate) fn in_subtraction(x: f64, x0: f64) -> bool {
    let h = x - x0;
    // `&` rather than `&&`: no branches, so that a batch of lanes is tested in vector registers.
    (x0 > 0.0)
        & (h >= 0.0)
        & !((h < H_SERIES_MAX) & (x <= X_SERIES_MAX))
        & !((h < H_QUADRATURE_MAX) & (x0 >= h))
}

/// Whether D(x, x0) is formed by the series with x ≥ 2 x0, whose branch-free form
/// `lanes::d_series` evaluates (two fixed-degree power sums, no loop).
#[inline(always)]
pub(crate) fn in_series_apart(x: f64, x0: f64) -> bool {
    let h = x - x0;
    (x0 > 0.0) & (h < H_SERIES_MAX) & (x <= X_SERIES_MAX) & (x >= 2.0 * x0)
}

/// Whether D(x, x0) is formed by the series with x < 2 x0, whose branch-free form
/// `lanes::d_series_close` evaluates.
#[inline(always)]
// `&` on comparisons, not `Range::contains` (`&&`): no branches in a loop over lanes.
#[allow(clippy::manual_range_contains)]
pub(crate) fn in_series_close(x: f64, x0: f64) -> bool {
    let h = x - x0;
    (x0 > 0.0) & (h >= 0.0) & (h < H_SERIES_MAX) & (x <= X_SERIES_MAX) & (x < 2.0 * x0)
}

/// h < 1, x ≤ 2: e^(−x) [ln(x/x0) + Σ_{k≥1} (x^k − x0^k)/(k k!)].
#[inline]
fn series(x: f64, x0: f64, h: f64) -> f64 {
    if x < 2.0 * x0 {
        // x0 ≤ x < 2 x0: h is exact (Sterbenz) and h/x0 < 1.
        return (-x).exp() * ((h / x0).ln_1p() + series_close(x, x0, h));
    }
    let q = x / x0;
    let lg = if q.is_finite() {
        q.ln()
    } else {
        // Subnormal x0: ln x − ln x0 > 709, no cancellation.
        x.ln() - x0.ln()
    };
    // x ≥ 2 x0: Ein(x) − Ein(x0) with Ein(t) = Σ t^k/(k k!) loses at most one bit
    // (Ein(x0) ≤ Ein(x)/2), so both are summed as fixed-degree polynomials. The degree is
    // chosen from x so that the dropped tail is below 2^−56 Ein(x).
    let sum = if x <= 1.0 / 32.0 {
        ein_diff::<8>(x, x0)
    } else if x <= 0.25 {
        ein_diff::<12>(x, x0)
    } else if x <= 1.0 {
        ein_diff::<17>(x, x0)
    } else {
        ein_diff::<22>(x, x0)
    };
    (-x).exp() * (lg + sum)
}

/// Σ_{k=1}^{N} (x^k − x0^k)/(k k!) as x E(x) − x0 E(x0), E(t) = Σ t^(k−1)/(k k!), for
/// x0 ≤ x/2 (every coefficient positive, at most one bit lost in the difference).
#[inline(always)]
pub(super) fn ein_diff<const N: usize>(x: f64, x0: f64) -> f64 {
    let mut c = [0.0; N];
    c.copy_from_slice(&INV_K_KFACT[..N]);
    x * estrin(c, x) - x0 * estrin(c, x0)
}

/// c[0] + c[1] t + … + c[N−1] t^(N−1) by Estrin's scheme: pairs combined with t, t², t⁴, …,
/// so the dependency chain is log2 N deep instead of N (Horner's).
#[inline(always)]
fn estrin<const N: usize>(mut c: [f64; N], t: f64) -> f64 {
    let mut len = N;
    let mut p = t;
    while len > 1 {
        let half = len / 2;
        for i in 0..half {
            c[i] = c[2 * i] + c[2 * i + 1] * p;
        }
        if len % 2 == 1 {
            c[half] = c[len - 1];
        }
        len = half + len % 2;
        p *= p;
    }
    c[0]
}

/// Σ (x^k − x0^k)/(k k!) for x0 ≤ x < 2 x0, where the two sums would cancel: d_k = x^k − x0^k
/// and q_k = x0^k advanced two steps at a time (odd and even chains in parallel),
/// d_(k+2) = x² d_k + h (x + x0) q_k, every term positive.
#[inline]
fn series_close(x: f64, x0: f64, h: f64) -> f64 {
    let (x2, x02, hs) = (x * x, x0 * x0, h * (x + x0));
    let (mut d_odd, mut q_odd) = (h, x0);
    let (mut d_even, mut q_even) = (hs, x02);
    let mut sum = d_odd * INV_K_KFACT[0] + d_even * INV_K_KFACT[1];
    for c in INV_K_KFACT[2..].chunks_exact(2) {
        d_odd = x2 * d_odd + hs * q_odd;
        q_odd *= x02;
        d_even = x2 * d_even + hs * q_even;
        q_even *= x02;
        let term = d_odd * c[0] + d_even * c[1];
        sum += term;
        // Relative to the sum alone (the log term only adds): the tail is below the last pair.
        if term <= sum * SERIES_STOP {
            break;
        }
    }
    sum
}

/// h < 2, x0 ≥ h: ∫_0^h e^(−u)/(x − u) du by Gauss–Legendre.
#[inline]
fn quadrature(x: f64, x0: f64, h: f64) -> f64 {
    // Relative errors of the rules (mpmath, worst case over the stated ranges):
    // 4 nodes, h ≤ 1/64, x0 ≥ 64 h: 3e−20; 8 nodes, h ≤ 1.5, x0 ≥ 3 h: 2e−20;
    // 12 nodes, h < 2, x0 ≥ h: 1.2e−19.
    if h <= 1.0 / 64.0 && x0 >= 64.0 * h {
        gauss(x, h, &GL4_X, &GL4_W)
    } else if h <= H_GL8_MAX && x0 >= 3.0 * h {
        gauss(x, h, &GL8_X, &GL8_W)
    } else {
        gauss(x, h, &GL12_X, &GL12_W)
    }
}

/// c Σ w_i [f(c − c s_i) + f(c + c s_i)], c = h/2, f(u) = e^(−u)/(x − u); the exponentials
/// of a symmetric node pair share one exp: e^(−c ∓ c s) = e^(−c) e^(± c s).
#[inline(always)]
fn gauss<const N: usize>(x: f64, h: f64, nodes: &[f64; N], weights: &[f64; N]) -> f64 {
    let c = 0.5 * h;
    let ec = (-c).exp();
    let mut acc = 0.0;
    for (&s, &w) in nodes.iter().zip(weights) {
        let cs = c * s;
        let ep = (-cs).exp(); // e^(−c s)
        let lo = c - cs; // node c(1 − s)
        let hi = c + cs; // node c(1 + s)
        acc += w * (1.0 / (ep * (x - lo)) + ep / (x - hi));
    }
    c * ec * acc
}
