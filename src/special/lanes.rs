//! Branch-free building blocks for evaluating D(x, x0) = e^(−x) [Ei(x) − Ei(x0)] at many x at
//! once: e^(−x), ln x and the pieces of Ei written with plain IEEE operations and bit
//! manipulation only, so that a loop over a fixed-size batch of lanes compiles to vector
//! instructions (the law's kernel, `crate::law::kernel`).
//!
//! Why not `f64::exp` and `f64::ln`: they are calls into the C library, one lane at a time,
//! and a call cannot be vectorised. The versions here cost a polynomial each and stay within
//! about one ulp (tested against 50-digit references). They use no fused multiply-add, which
//! Rust never forms on its own, so every lane rounds exactly as the scalar code does and a
//! batch gives the same bits at any vector width.
//!
//! The caller selects the regime: [`d_subtracted`] is the form of D used where
//! `super::ei_scaled_diff` subtracts (h = x − x0 ≥ 1 outside its series and quadrature
//! regimes, see `diff.rs`), for x up to [`X_LANES_MAX`].

use super::diff::{ein_diff, INV_K_KFACT};
use super::fits;

/// Accuracy of [`exp_neg`], [`ln`] and [`one_minus_exp_neg`] against 40-digit references, in
/// ulps of the exact value (ln: in ε absolute where |ln x| < 1); measured 1.0 for each.
#[cfg(test)]
const LANE_ULPS: f64 = 2.0;
/// The same for [`ln_1p`], whose argument u/(2 + u) is rounded twice: measured 3.0.
#[cfg(test)]
const LN_1P_ULPS: f64 = 4.0;

/// Largest x the lane functions accept: e^(−x) stays a normal number (e^(−708) ≈ 3e−308).
pub(crate) const X_LANES_MAX: f64 = 700.0;

const LOG2_E: f64 = std::f64::consts::LOG2_E;
/// ln 2 split so that k · LN2_HI is exact for |k| < 2^21 (fdlibm's constants).
const LN2_HI: f64 = 0.693_147_180_369_123_8;
const LN2_LO: f64 = 1.908_214_929_270_587_7e-10;
/// 1.5 · 2^52: adding it rounds a number of magnitude below 2^51 to an integer, which then
/// sits in the low bits of the sum.
const ROUND_SHIFT: f64 = 6_755_399_441_055_744.0;
/// 2^52 + 1023: an exponent field read as the low bits of 2^52 carries the bias.
const EXPONENT_SHIFT: f64 = 4_503_599_627_371_519.0;
const EXPONENT_BITS_OF_2_52: u64 = 0x4330_0000_0000_0000;
const MANTISSA_MASK: u64 = 0x000f_ffff_ffff_ffff;
const ONE_BITS: u64 = 0x3ff0_0000_0000_0000;

/// 1/n! for n = 0..=13: the Taylor polynomial of e^r on |r| ≤ ln2/2 (the dropped term is
/// below 4e−18 relative).
const EXP_TAYLOR: [f64; 14] = [
    1.0,
    1.0,
    0.5,
    1.666_666_666_666_666_7e-1,
    4.166_666_666_666_666_4e-2,
    8.333_333_333_333_333e-3,
    1.388_888_888_888_889e-3,
    1.984_126_984_126_984e-4,
    2.480_158_730_158_73e-5,
    2.755_731_922_398_589e-6,
    2.755_731_922_398_589_3e-7,
    2.505_210_838_544_172e-8,
    2.087_675_698_786_81e-9,
    1.605_904_383_682_161_3e-10,
];

/// 2/(2j + 3) for j = 0..=10: ln m = 2s + s·s² Σ_j c_j s^(2j) with s = (m − 1)/(m + 1),
/// |s| ≤ 0.1716 (the dropped term is below 1e−18 relative).
const LN_ATANH: [f64; 11] = [
    2.0 / 3.0,
    2.0 / 5.0,
    2.0 / 7.0,
    2.0 / 9.0,
    2.0 / 11.0,
    2.0 / 13.0,
    2.0 / 15.0,
    2.0 / 17.0,
    2.0 / 19.0,
    2.0 / 21.0,
    2.0 / 23.0,
];

#[inline(always)]
fn horner<const N: usize>(c: &[f64; N], t: f64) -> f64 {
    let mut acc = c[N - 1];
    let mut i = N - 1;
    while i > 0 {
        i -= 1;
        acc = acc * t + c[i];
    }
    acc
}

/// e^(−x) for 0 ≤ x ≤ [`X_LANES_MAX`] (outside, the result is meaningless: the caller
/// checks), within about one ulp.
///
/// # Formula
/// −x = k ln 2 + r with k = round(−x log2 e) and |r| ≤ ln2/2 (Cody–Waite, exact for these k),
/// e^r by its Taylor polynomial of degree 13 ([`exp_taylor`]), 2^k written into the exponent
/// field.
#[inline(always)]
pub(crate) fn exp_neg(x: f64) -> f64 {
    let y = -x;
    let shifted = y * LOG2_E + ROUND_SHIFT;
    let k = shifted - ROUND_SHIFT;
    let r = (y - k * LN2_HI) - k * LN2_LO;
    // The low 12 bits of `shifted` hold k modulo 4096; adding the bias and moving them into
    // the exponent field gives 2^k for −1022 < k ≤ 0.
    let two_k = f64::from_bits(shifted.to_bits().wrapping_add(1023) << 52);
    exp_taylor(r) * two_k
}

/// e^r by its Taylor polynomial of degree 13 in Estrin's form, 1 + (r + r² T(r)), whose
/// dependency chain is 11 operations long instead of Horner's 26 (a batch of lanes waits on
/// it), while the last two additions, of the largest terms, round as Horner's do.
#[inline(always)]
fn exp_taylor(r: f64) -> f64 {
    let c = &EXP_TAYLOR;
    let (r2, pair) = (r * r, |i: usize| c[i] + c[i + 1] * r);
    let r4 = r2 * r2;
    let high = (pair(8) + pair(10) * r2) + pair(12) * r4;
    let tail = pair(2) + r2 * ((pair(4) + pair(6) * r2) + r4 * high);
    1.0 + (r + r2 * tail)
}

/// ln x for a positive normal x, within about two ulps.
///
/// # Formula
/// x = 2^e m with m in [√½, √2), ln x = e ln 2 + 2 atanh((m − 1)/(m + 1)).
#[inline(always)]
pub(crate) fn ln(x: f64) -> f64 {
    let bits = x.to_bits();
    let m = f64::from_bits((bits & MANTISSA_MASK) | ONE_BITS);
    let e = f64::from_bits((bits >> 52) | EXPONENT_BITS_OF_2_52) - EXPONENT_SHIFT;
    let high = m > std::f64::consts::SQRT_2;
    let m = if high { 0.5 * m } else { m };
    let e = if high { e + 1.0 } else { e };
    let s = (m - 1.0) / (m + 1.0);
    let z = s * s;
    let ln_m = 2.0 * s + s * z * horner(&LN_ATANH, z);
    e * LN2_HI + (e * LN2_LO + ln_m)
}

/// Which pieces of Ei a batch of x needs; computing a piece for every lane and selecting per
/// lane keeps the loop free of branches, so a batch costs one pass per piece it touches (one,
/// or two at a boundary between pieces).
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Pieces {
    /// Every lane lies in the one piece the batch needs (the bulk of a slide): no lane keeps
    /// another piece's value, so the per-lane select is left out (the same values).
    whole: bool,
    mid: bool,
    upto_10: bool,
    upto_20: bool,
    upto_40: bool,
    beyond_40: bool,
}

impl Pieces {
    /// The pieces that x in [lo, hi] needs.
    #[inline(always)]
    pub(crate) fn spanning(lo: f64, hi: f64) -> Self {
        let (mid, upto_10, upto_20, upto_40, beyond_40) = (
            lo <= 6.0,
            lo <= 10.0 && hi > 6.0,
            lo <= 20.0 && hi > 10.0,
            lo <= 40.0 && hi > 20.0,
            hi > 40.0,
        );
        let needed = [mid, upto_10, upto_20, upto_40, beyond_40];
        Self {
            whole: needed.iter().filter(|&&p| p).count() == 1,
            mid,
            upto_10,
            upto_20,
            upto_40,
            beyond_40,
        }
    }
}

/// D(x, x0) = e^(−x) [Ei(x) − Ei(x0)] in the subtraction regime, given `e = e^(−x)` and
/// `ei0 = Ei(x0)`, for the lanes of `x` whose pieces `pieces` covers; written into `d`, and
/// 1/x into `inv_x` (a by-product of the one division per lane, which the law's a/τ needs).
///
/// # Formula
/// x ≤ 6: e^(−x) [Ei(x) − Ei(x0)]; x > 6: g(x) + e^(−x) [x − Ei(x0)], from Ei(x) =
/// e^x g(x) + x. Both have the cancellation of `ei_scaled_diff`'s subtraction (at most a
/// factor ≈ 2 where Ei(x0) > 0), and one e^(−x) serves D and the law. Beyond 6 each piece
/// divides once, g(x) = n/(q x) with 1/x = q · 1/(q x); on (1, 6] the fit, ln x and 1/x keep
/// their own divisions (sharing one there moved the law by up to 2 ε from the scalar law's
/// value, against 1 ε otherwise).
#[inline(always)]
pub(crate) fn d_subtracted<const L: usize>(
    x: &[f64; L],
    e: &[f64; L],
    ei0: f64,
    pieces: Pieces,
    d: &mut [f64; L],
    inv_x: &mut [f64; L],
) {
    if pieces.whole {
        d_pieces::<L, true>(x, e, ei0, pieces, d, inv_x);
    } else {
        d_pieces::<L, false>(x, e, ei0, pieces, d, inv_x);
    }
}

/// [`d_subtracted`], each piece's lanes selected unless the batch lies in one piece (`WHOLE`).
#[inline(always)]
fn d_pieces<const L: usize, const WHOLE: bool>(
    x: &[f64; L],
    e: &[f64; L],
    ei0: f64,
    pieces: Pieces,
    d: &mut [f64; L],
    inv_x: &mut [f64; L],
) {
    if pieces.mid {
        for l in 0..L {
            let xl = x[l].clamp(1.0, 6.0);
            let mid = e[l] * (fits::ei_mid_given_ln(xl, ln(xl)) - ei0);
            let inside = WHOLE || x[l] <= 6.0;
            d[l] = if inside { mid } else { d[l] };
            inv_x[l] = if inside { 1.0 / xl } else { inv_x[l] };
        }
    }
    if pieces.upto_10 {
        g_piece::<L, WHOLE>(x, e, ei0, (6.0, 10.0), fits::xg_fraction_upto_10, d, inv_x);
    }
    if pieces.upto_20 {
        g_piece::<L, WHOLE>(x, e, ei0, (10.0, 20.0), fits::xg_fraction_upto_20, d, inv_x);
    }
    if pieces.upto_40 {
        g_piece::<L, WHOLE>(x, e, ei0, (20.0, 40.0), fits::xg_fraction_upto_40, d, inv_x);
    }
    if pieces.beyond_40 {
        let beyond = (40.0, f64::INFINITY);
        g_piece::<L, WHOLE>(x, e, ei0, beyond, fits::xg_fraction_beyond_40, d, inv_x);
    }
}

/// The lanes of `x` in (lo, hi] get g(x) + e^(−x) [x − Ei(x0)] and 1/x, from x g(x) as the
/// fraction n/q that `fraction` gives; the others keep their values. Every lane is evaluated
/// (clamped into the piece's range, so nothing overflows) and the result selected, which
/// vectorises; where every lane is in the piece (`WHOLE`), without the select.
#[inline(always)]
fn g_piece<const L: usize, const WHOLE: bool>(
    x: &[f64; L],
    e: &[f64; L],
    ei0: f64,
    (lo, hi): (f64, f64),
    fraction: impl Fn(f64) -> (f64, f64),
    d: &mut [f64; L],
    inv_x: &mut [f64; L],
) {
    for l in 0..L {
        let xl = x[l].clamp(lo, hi);
        let (n, q) = fraction(xl);
        let r = 1.0 / (q * xl);
        let v = n * r + e[l] * (x[l] - ei0);
        let inside = WHOLE || ((x[l] > lo) & (x[l] <= hi));
        d[l] = if inside { v } else { d[l] };
        inv_x[l] = if inside { q * r } else { inv_x[l] };
    }
}

/// D(x, x0) = e^(−x) [ln(x/x0) + Σ_k (x^k − x0^k)/(k k!)] where the series applies with
/// x ≥ 2 x0 (`in_series_apart`), given `e = e^(−x)` and the batch's largest x; the degree of the
/// power sums is chosen once for the batch from `x_max`, as the scalar series chooses it per
/// point (a higher degree than a lane needs only adds terms below its rounding).
#[inline(always)]
pub(crate) fn d_series<const L: usize>(
    x: &[f64; L],
    e: &[f64; L],
    x0: f64,
    x_max: f64,
    d: &mut [f64; L],
) {
    if x_max <= 1.0 / 32.0 {
        d_series_degree::<L, 8>(x, e, x0, d)
    } else if x_max <= 0.25 {
        d_series_degree::<L, 12>(x, e, x0, d)
    } else if x_max <= 1.0 {
        d_series_degree::<L, 17>(x, e, x0, d)
    } else {
        d_series_degree::<L, 22>(x, e, x0, d)
    }
}

#[inline(always)]
fn d_series_degree<const L: usize, const N: usize>(
    x: &[f64; L],
    e: &[f64; L],
    x0: f64,
    d: &mut [f64; L],
) {
    for l in 0..L {
        d[l] = e[l] * (ln(x[l] / x0) + ein_diff::<N>(x[l], x0));
    }
}

/// D(x, x0) = e^(−x) [ln(1 + h/x0) + Σ_k (x^k − x0^k)/(k k!)], h = x − x0, where the series
/// applies with x < 2 x0 (`in_series_close`): x^k − x0^k built as d_(k+1) = x d_k + h x0^k, every
/// term positive, as the scalar series does. The number of terms is chosen once for the batch
/// from its largest x: terms fall as x^(k−1)/k! relative to the sum, below 2^−56 after 9, 13,
/// 19 and 24 terms for x up to 1/32, 1/4, 1 and 2.
#[inline(always)]
pub(crate) fn d_series_close<const L: usize>(
    x: &[f64; L],
    e: &[f64; L],
    x0: f64,
    x_max: f64,
    d: &mut [f64; L],
) {
    if x_max <= 1.0 / 32.0 {
        d_close_terms::<L, 9>(x, e, x0, d)
    } else if x_max <= 0.25 {
        d_close_terms::<L, 13>(x, e, x0, d)
    } else if x_max <= 1.0 {
        d_close_terms::<L, 19>(x, e, x0, d)
    } else {
        d_close_terms::<L, 24>(x, e, x0, d)
    }
}

#[inline(always)]
fn d_close_terms<const L: usize, const N: usize>(
    x: &[f64; L],
    e: &[f64; L],
    x0: f64,
    d: &mut [f64; L],
) {
    for l in 0..L {
        // x0 ≤ x < 2 x0: h is exact (Sterbenz).
        let h = x[l] - x0;
        let (mut d_k, mut q_k) = (h, x0);
        let mut sum = d_k * INV_K_KFACT[0];
        for c in &INV_K_KFACT[1..N] {
            d_k = x[l] * d_k + h * q_k;
            q_k *= x0;
            sum += d_k * c;
        }
        d[l] = e[l] * (ln_1p(h / x0) + sum);
    }
}

/// 2/(2j + 1) for j = 0..=17: ln(1 + u) = Σ_j c_j s^(2j+1) with s = u/(2 + u) ≤ 1/3 for
/// 0 ≤ u ≤ 1 (the dropped term is below 1e−18 relative).
const LN_1P_ATANH: [f64; 18] = [
    2.0,
    2.0 / 3.0,
    2.0 / 5.0,
    2.0 / 7.0,
    2.0 / 9.0,
    2.0 / 11.0,
    2.0 / 13.0,
    2.0 / 15.0,
    2.0 / 17.0,
    2.0 / 19.0,
    2.0 / 21.0,
    2.0 / 23.0,
    2.0 / 25.0,
    2.0 / 27.0,
    2.0 / 29.0,
    2.0 / 31.0,
    2.0 / 33.0,
    2.0 / 35.0,
];

/// ln(1 + u) for 0 ≤ u ≤ 1, to about three ulps: 2 atanh(u/(2 + u)) by its series, which keeps
/// the relative accuracy of small u that ln(1 + u) would lose.
#[inline(always)]
pub(crate) fn ln_1p(u: f64) -> f64 {
    let s = u / (2.0 + u);
    s * horner(&LN_1P_ATANH, s * s)
}

/// 1/(k+1)! for k = 0..=17: 1 − e^(−x) = x Σ_k (−x)^k/(k+1)! for 0 ≤ x ≤ 1/2, where 1 − e^(−x)
/// would cancel (the dropped term is below 1e−21 relative).
const ONE_MINUS_EXP_NEG: [f64; 18] = [
    1.0,
    -0.5,
    1.666_666_666_666_666_7e-1,
    -4.166_666_666_666_666_4e-2,
    8.333_333_333_333_333e-3,
    -1.388_888_888_888_889e-3,
    1.984_126_984_126_984e-4,
    -2.480_158_730_158_73e-5,
    2.755_731_922_398_589e-6,
    -2.755_731_922_398_589_3e-7,
    2.505_210_838_544_172e-8,
    -2.087_675_698_786_81e-9,
    1.605_904_383_682_161_3e-10,
    -1.147_074_559_772_972_5e-11,
    7.647_163_731_819_816e-13,
    -4.779_477_332_387_385e-14,
    2.811_457_254_345_520_6e-15,
    -1.561_920_696_858_622_6e-16,
];

/// 1 − e^(−x) for 0 ≤ x ≤ [`X_LANES_MAX`] given `e = e^(−x)`: by its series below 1/2, where
/// the subtraction would lose digits, as `-expm1(-x)` does for the scalar law.
#[inline(always)]
pub(crate) fn one_minus_exp_neg(x: f64, e: f64) -> f64 {
    let series = x * horner(&ONE_MINUS_EXP_NEG, x);
    if x < 0.5 {
        series
    } else {
        1.0 - e
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Error of `got` in units of the last place of `want` (the reference rounded to double).
    fn ulps(got: f64, want: f64) -> f64 {
        let ulp = f64::from_bits(want.abs().to_bits() + 1) - want.abs();
        (got - want).abs() / ulp
    }

    /// A batch inside one piece of D is evaluated without the per-lane select, to the same
    /// bits as with it; a batch across a boundary between pieces keeps the select.
    #[test]
    fn a_batch_in_one_piece_skips_the_select_with_the_same_bits() {
        let ei0 = crate::special::ei(0.0136);
        for (lo, hi) in [
            (1.5, 5.5),
            (6.5, 9.5),
            (10.5, 19.5),
            (20.5, 39.5),
            (41.0, 90.0),
        ] {
            let pieces = Pieces::spanning(lo, hi);
            assert!(pieces.whole, "[{lo}, {hi}]");
            let x: [f64; 16] = std::array::from_fn(|l| lo + (hi - lo) * l as f64 / 15.0);
            let e = x.map(exp_neg);
            let (mut d_whole, mut inv_whole) = ([0.0; 16], [0.0; 16]);
            let (mut d_each, mut inv_each) = ([0.0; 16], [0.0; 16]);
            d_pieces::<16, true>(&x, &e, ei0, pieces, &mut d_whole, &mut inv_whole);
            d_pieces::<16, false>(&x, &e, ei0, pieces, &mut d_each, &mut inv_each);
            for l in 0..16 {
                assert_eq!(d_whole[l].to_bits(), d_each[l].to_bits(), "x = {}", x[l]);
                assert_eq!(
                    inv_whole[l].to_bits(),
                    inv_each[l].to_bits(),
                    "x = {}",
                    x[l]
                );
            }
        }
        for (lo, hi) in [(5.5, 6.5), (9.0, 11.0), (19.0, 41.0)] {
            assert!(!Pieces::spanning(lo, hi).whole, "[{lo}, {hi}]");
        }
    }

    /// The lane functions against 40-digit mpmath values
    /// (`tests/reference/make_lanes_reference.py`): the worst error of each, in ulps.
    #[test]
    fn lane_functions_match_mpmath() {
        let path = concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/tests/reference/lanes_mpmath.csv"
        );
        let text = std::fs::read_to_string(path).expect("reference table");
        let mut worst = [(0.0_f64, 0.0_f64); 4];
        for line in text.lines().skip(1) {
            let mut cols = line.split(',');
            let (name, x, want) = (
                cols.next().unwrap(),
                cols.next().unwrap(),
                cols.next().unwrap(),
            );
            let x: f64 = x.parse().unwrap();
            let want: f64 = want.parse().unwrap();
            let (slot, got) = match name {
                "exp_neg" => (0, exp_neg(x)),
                "ln" => (1, ln(x)),
                "one_minus_exp_neg" => (2, one_minus_exp_neg(x, exp_neg(x))),
                "ln_1p" => (3, ln_1p(x)),
                other => panic!("unknown function {other}"),
            };
            // ln is judged absolutely near its root, where relative error has no meaning.
            let err = if name == "ln" && want.abs() < 1.0 {
                (got - want).abs() / f64::EPSILON
            } else {
                ulps(got, want)
            };
            if err > worst[slot].0 {
                worst[slot] = (err, x);
            }
        }
        eprintln!(
            "worst errors (ulps, at x): exp_neg {:?}, ln {:?}, one_minus_exp_neg {:?}, ln_1p {:?}",
            worst[0], worst[1], worst[2], worst[3]
        );
        for ((err, x), (name, bar)) in worst.iter().zip([
            ("exp_neg", LANE_ULPS),
            ("ln", LANE_ULPS),
            ("one_minus_exp_neg", LANE_ULPS),
            ("ln_1p", LN_1P_ULPS),
        ]) {
            assert!(
                *err <= bar,
                "{name}({x:e}) is {err:.2} ulps off the reference (bar {bar})"
            );
        }
    }
}
