//! Rational minimax fits for Ei(x), x > 0, in double precision.
//!
//! The coefficients are the published double-precision fits of Boost.Math (`expint.hpp`,
//! J. Maddock; the same construction as Cody and Thacher, Math. Comp. 22 (1968) 641 and
//! 23 (1969) 289): on (0, 6] a fit that carries the root of Ei explicitly,
//! Ei(x) = ln(x/r) + (x − r) R(x/3 − 1); beyond 6, fits of g(x) = e^(−x) (Ei(x) − x) on
//! (6, 10], (10, 20], (20, 40] and x > 40 (in 1/x). Each fit's own error is below 1e−16
//! relative; what is left is rounding in the evaluation.

// The coefficients keep the digits as published (21 significant), so they can be checked
// against the source; the compiler rounds them to the nearest double.
#![allow(clippy::excessive_precision)]

/// The positive root of Ei, split so that `x − ROOT_HI − ROOT_LO` is exact to ~1e−33:
/// `ROOT_HI` = 1677624236387711 / 2^52 is the double nearest the root.
const ROOT_HI: f64 = 1677624236387711.0 / 4503599627370496.0;
const ROOT_LO: f64 = 1.314_018_341_438_602_8e-17;
/// The root rounded to double (equal to `ROOT_HI`; named for the division in ln(x/r)).
pub(crate) const ROOT: f64 = 0.372_507_410_781_366_634_461_991_866_580_119_133_535_689_5;
/// ln(ROOT), for inputs so small that x/ROOT would lose bits in the subnormal range.
const LN_ROOT: f64 = -0.987_498_346_645_341_9;
/// Below this, ln(x/r) is formed as ln x − ln r (no cancellation: ln x < −690).
const TINY: f64 = 1e-300;

/// e^700 as an unevaluated sum, so that Ei(x) = e^(x−700) · (g(x) e^700) + x extends to the
/// true overflow point of Ei (≈ 716.35) rather than that of e^x (≈ 709.78).
const E700_HI: f64 = 1.014_232_054_735_004_5e304;
const E700_LO: f64 = 1.666_657_192_073_467_3e287;

// (0, 6]: Ei(x) = ln(x/r) + (x − r) P(t)/Q(t), t = x/3 − 1.
const P6: [f64; 10] = [
    2.986_772_243_435_985_930_13,
    0.356_343_618_769_377_415_068,
    0.780_836_076_283_730_801_839,
    0.114_670_926_327_032_002_811,
    0.049_943_477_357_651_526_053_4,
    0.007_262_245_933_412_281_595_61,
    0.001_154_782_372_278_043_068_27,
    0.000_116_419_523_609_765_200_999,
    0.798_296_365_679_269_702_435e-5,
    0.277_705_625_440_200_872_1e-6,
];
const Q6: [f64; 8] = [
    1.0,
    -1.170_904_123_654_139_119_47,
    0.622_151_098_460_167_462_76,
    -0.195_114_782_069_495_403_315,
    0.039_152_343_139_296_723_816_6,
    -0.005_048_001_586_637_057_473_45,
    0.000_389_034_007_436_065_401_822,
    -0.138_972_589_601_781_706_598e-4,
];

// (6, 10]: g(x) = (Y + P(t)/Q(t)) / x, t = x/2 − 4.
const Y10: f64 = 1.158_985_137_939_453_125;
const P10: [f64; 8] = [
    0.001_393_240_861_994_028_041_73,
    -0.034_992_122_182_388_874_496_6,
    -0.026_409_552_075_413_484_853_8,
    -0.007_612_240_030_054_764_384_12,
    -0.002_474_962_095_921_436_279_77,
    -0.000_374_885_917_942_100_256_775,
    -0.554_086_272_024_881_826_253e-4,
    -0.396_487_648_924_804_510_056e-5,
];
const Q10: [f64; 8] = [
    1.0,
    0.744_625_566_823_272_107_711,
    0.329_061_095_011_767_059_236,
    0.100_128_624_977_313_872_323,
    0.022_385_109_912_850_634_727_8,
    0.003_653_341_907_423_166_501_06,
    0.000_402_453_408_512_476_836_472,
    0.263_649_630_720_255_691_787e-4,
];

// (10, 20]: t = x/5 − 3.
const Y20: f64 = 1.086_973_190_307_617_187_5;
const P20: [f64; 9] = [
    -0.008_938_910_943_569_456_674_51,
    -0.048_460_773_012_713_404_580_6,
    -0.065_281_044_422_223_689_577_2,
    -0.047_844_757_264_730_967_145_5,
    -0.022_605_921_892_377_709_459_6,
    -0.007_206_036_369_174_820_659_07,
    -0.001_559_419_470_359_720_313_34,
    -0.000_209_750_022_660_200_888_349,
    -0.138_652_200_349_182_596_186e-4,
];
const Q20: [f64; 9] = [
    1.0,
    1.970_172_140_390_611_949_71,
    1.862_324_650_430_731_575_08,
    1.096_014_370_903_375_199_77,
    0.438_873_285_773_088_870_812,
    0.122_537_731_979_686_102_756,
    0.023_345_847_827_576_928_815_9,
    0.002_781_707_691_633_036_690_21,
    0.000_159_150_281_166_108_755_531,
];

// (20, 40]: t = x/10 − 3.
const Y40: f64 = 1.039_375_305_175_781_25;
const P40: [f64; 9] = [
    -0.003_561_651_489_144_475_979_95,
    -0.022_993_032_035_798_233_340_6,
    -0.044_981_435_048_227_791_771_6,
    -0.045_375_938_304_819_340_233_6,
    -0.027_205_083_720_938_071_706_9,
    -0.009_944_030_598_833_508_132_95,
    -0.002_075_922_678_122_917_269_61,
    -0.000_192_178_045_857_733_706_044,
    -0.113_161_784_705_911_400_295e-9,
];
const Q40: [f64; 8] = [
    1.0,
    2.843_544_088_401_485_611_31,
    3.659_961_009_007_239_301_2,
    2.750_884_643_442_930_835_95,
    1.298_524_407_399_839_864_3,
    0.383_213_198_510_794_507_409,
    0.065_116_545_549_628_133_783_1,
    0.004_880_710_775_192_278_535_85,
];

// x > 40: t = 1/x.
const YINF: f64 = 1.013_065_338_134_765_625;
const PINF: [f64; 6] = [
    -0.013_065_338_134_765_624_384_9,
    0.190_297_105_594_865_766_82,
    94.736_509_453_719_723_601_1,
    -2_516.353_236_798_442_562_03,
    18_932.085_001_492_599_302_5,
    -38_703.143_136_205_671_413_4,
];
const QINF: [f64; 7] = [
    1.0,
    61.973_359_284_943_988_414_5,
    -2_354.562_113_234_201_942_83,
    22_329.145_948_989_307_904_1,
    -70_126.245_140_396_567_133,
    54_738.283_314_777_553_710_6,
    8_297.162_963_565_184_093_47,
];

/// Past this x, x e^(−x) is below 1e−22 of g(x) ≈ 1/x and is dropped from S.
pub(crate) const X_DROP_EXP: f64 = 60.0;
/// Up to this x, e^x is formed directly; beyond, through e^(x−700) · e^700.
const X_SPLIT_EXP: f64 = 700.0;

/// Horner evaluation of c[0] + c[1] t + c[2] t² + …
#[inline(always)]
fn poly<const N: usize>(c: &[f64; N], t: f64) -> f64 {
    let mut acc = c[N - 1];
    let mut i = N - 1;
    while i > 0 {
        i -= 1;
        acc = acc * t + c[i];
    }
    acc
}

/// Ei(x) for 0 < x ≤ 6, relative accuracy kept through the root: both terms vanish with
/// x − r, and x − r is formed almost exactly.
#[inline]
pub(crate) fn ei_small(x: f64) -> f64 {
    let t = x / 3.0 - 1.0;
    let r = poly(&P6, t) / poly(&Q6, t);
    let d = (x - ROOT_HI) - ROOT_LO;
    let lg = if d.abs() < 0.1 {
        (d / ROOT).ln_1p()
    } else if x < TINY {
        x.ln() - LN_ROOT
    } else {
        (x / ROOT).ln()
    };
    r * d + lg
}

/// g(x) = e^(−x) (Ei(x) − x) for x > 6; g(∞) = 0.
#[inline]
pub(crate) fn g_large(x: f64) -> f64 {
    if x <= 10.0 {
        g_upto_10(x)
    } else if x <= 20.0 {
        g_upto_20(x)
    } else if x <= 40.0 {
        g_upto_40(x)
    } else {
        g_beyond_40(x)
    }
}

// The four pieces of g, each without a branch, so that a batch of arguments in one range
// is evaluated lane by lane in vector registers (`super::lanes`).

/// g(x) on (6, 10].
#[inline(always)]
pub(crate) fn g_upto_10(x: f64) -> f64 {
    let t = x / 2.0 - 4.0;
    (Y10 + poly(&P10, t) / poly(&Q10, t)) / x
}

/// g(x) on (10, 20].
#[inline(always)]
pub(crate) fn g_upto_20(x: f64) -> f64 {
    let t = x / 5.0 - 3.0;
    (Y20 + poly(&P20, t) / poly(&Q20, t)) / x
}

/// g(x) on (20, 40].
#[inline(always)]
pub(crate) fn g_upto_40(x: f64) -> f64 {
    let t = x / 10.0 - 3.0;
    (Y40 + poly(&P40, t) / poly(&Q40, t)) / x
}

/// g(x) for x > 40.
#[inline(always)]
pub(crate) fn g_beyond_40(x: f64) -> f64 {
    let t = 1.0 / x;
    (YINF + poly(&PINF, t) / poly(&QINF, t)) / x
}

/// x·g(x) on the pieces of (6, ∞) as a fraction (numerator, denominator), for lanes that
/// share one division between g = numerator/(denominator·x), 1/x and the law's a/τ
/// (`super::lanes::d_subtracted`): Y + P/Q = (Y·Q + P)/Q. The reduced argument t is formed
/// with a multiplication (x·0.2 rather than x/5, within an ulp of it), which moves t by at
/// most a few 1e−16 and the fit's value by less.
#[inline(always)]
pub(crate) fn xg_fraction_upto_10(x: f64) -> (f64, f64) {
    fraction(Y10, &P10, &Q10, x * 0.5 - 4.0)
}

/// As [`xg_fraction_upto_10`] on (10, 20].
#[inline(always)]
pub(crate) fn xg_fraction_upto_20(x: f64) -> (f64, f64) {
    fraction(Y20, &P20, &Q20, x * 0.2 - 3.0)
}

/// As [`xg_fraction_upto_10`] on (20, 40].
#[inline(always)]
pub(crate) fn xg_fraction_upto_40(x: f64) -> (f64, f64) {
    fraction(Y40, &P40, &Q40, x * 0.1 - 3.0)
}

/// As [`xg_fraction_upto_10`] for x > 40 (the fit is in 1/x, one more division, a piece few
/// slides reach).
#[inline(always)]
pub(crate) fn xg_fraction_beyond_40(x: f64) -> (f64, f64) {
    fraction(YINF, &PINF, &QINF, 1.0 / x)
}

#[inline(always)]
fn fraction<const NP: usize, const NQ: usize>(
    y: f64,
    p: &[f64; NP],
    q: &[f64; NQ],
    t: f64,
) -> (f64, f64) {
    let q = poly(q, t);
    (y * q + poly(p, t), q)
}

/// Ei(x) for 1 ≤ x ≤ 6 given ln x, without a branch (the root of Ei is below 1, so ln(x/r)
/// = ln x − ln r adds two positive terms): the same fit as [`ei_small`].
#[inline(always)]
pub(crate) fn ei_mid_given_ln(x: f64, ln_x: f64) -> f64 {
    let t = x / 3.0 - 1.0;
    let r = poly(&P6, t) / poly(&Q6, t);
    let d = (x - ROOT_HI) - ROOT_LO;
    r * d + (ln_x - LN_ROOT)
}

/// Ei(x) for x > 6 from g: e^x g(x) + x, overflowing only where Ei itself does.
#[inline]
pub(crate) fn ei_large(x: f64) -> f64 {
    if x.is_infinite() {
        return f64::INFINITY;
    }
    let g = g_large(x);
    if x <= X_SPLIT_EXP {
        x.exp() * g + x
    } else {
        // x − 700 is exact here (Sterbenz for x ≤ 1400; beyond, e^(x−700) is +inf anyway).
        (x - X_SPLIT_EXP).exp() * (g * E700_HI + g * E700_LO) + x
    }
}
