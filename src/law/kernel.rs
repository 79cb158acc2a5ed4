//! The observed-time model over a whole slide, evaluated in batches of [`LANES`] points in
//! vector registers: the hot path of every likelihood evaluation.
//!
//! # Why batches, and why anchors
//! Solving t = τ + F(τ)/(kv) point after point (the reference,
//! [`ObservedSlide::for_each_force_serial`](super::ObservedSlide::for_each_force_serial)) is
//! one serial chain: each point's Newton iteration starts from the previous point's root.
//! Here only every 513th point (an *anchor*; every 33rd where a Newton step from the guesses
//! below was not final, every 65th, 129th or 257th while they grow back, see `spring_lanes`)
//! is solved one
//! after the other, by Newton steps from the previous chunk's septic Hermite interpolant
//! extrapolated to it, or from a cubic Taylor guess along τ(t) (dτ/dt, d²τ/dt², d³τ/dt³ from
//! the law) where there is none or it leaves the bracket. The points between two anchors get a
//! septic Hermite guess of τ(t) from the anchors' τ, dτ/dt, d²τ/dt² and d³τ/dt³, which makes
//! them independent of one another, and are solved together: one evaluation of the law per
//! lane and one Newton step, batch after batch (or, where that step is not final, a step of
//! third order from the same evaluation).
//!
//! # Exactness
//! A Newton step from a guess off by s leaves an error of ½ |G''/G'| s² in τ, G(τ) = τ +
//! F(τ)/(kv) − t, and carrying F along its tangent leaves ½ |F''| s². Both are computed per
//! lane from the law's own curvature (|d²F/dτ²| = |a/τ² + αv dF/dτ| = αv |αv a/x² + dF/dτ|,
//! x = αvτ, with 1/x from the law's own division) and must be below
//! a quarter of an ulp of τ and of F. A lane that fails takes, from the same guess and the
//! same evaluation of the law, a step of third order (Chebyshev's method, `third_order_step`:
//! F'' and F⁽³⁾ follow from dF/dτ and 1/x), whose error, of order s³, is bounded the same
//! way; a batch where some lane fails that too takes another Newton round, and a lane that
//! still fails after four rounds (or leaves its bracket) is solved by the safeguarded serial
//! iteration. So every point is as exact as the serial solve's: the
//! difference is rounding (tested against it and against 50-digit references).
//!
//! # The law in lanes
//! Where every lane of a batch lies in the regime where e^(−x)[Ei(x) − Ei(x0)] is formed by
//! subtraction (x ≥ x0 + 1 outside the series and quadrature regimes of
//! [`crate::special::ei_scaled_diff`]: the bulk of any slide), the law is assembled from one
//! branch-free e^(−x), one ln x (for x ≤ 6) and one rational fit per lane
//! ([`crate::special`]'s lane functions); beyond x = 6 one division per lane gives the fit,
//! 1/x and the law's a/τ = αv a/x together. A batch that straddles the regimes (the series
//! of e^(−x)[Ei(x) − Ei(x0)] near x0, apart from or close to it) evaluates each form it needs
//! in lanes and keeps per lane the one the scalar law would use; only batches outside every
//! vector form (quadrature, τ before t0, x past the lanes' range) evaluate the scalar law
//! lane by lane.
//!
//! # Where the path folds
//! Where dF/dτ ≤ −kv before the slide's last time, t(τ) is not monotonic and only the serial
//! solve follows the quasi-static branch up to the fold (a batched Newton step can find a
//! root beyond it), so such a slide is evaluated by the serial reference, which then reports
//! the stick-slip as before.
//!
//! # Vector width
//! The same code is compiled for the baseline x86-64 (SSE2), AVX2 and AVX-512 and chosen at
//! run time ([`Simd`]). It uses only IEEE additions, multiplications, divisions and bit
//! operations, no fused multiply-add, so every width gives the same bits: the chains do not
//! depend on the machine's vector unit.

use std::sync::OnceLock;

use super::observed::solve_point;
use super::{Law, LawError};
use crate::special::lanes::{
    d_series, d_series_close, d_subtracted, exp_neg, one_minus_exp_neg, Pieces, X_LANES_MAX,
};
use crate::special::{in_series_apart, in_series_close, in_subtraction};

/// Points per batch: four AVX-512 registers of f64 (eight AVX2 registers), so that several
/// independent dependency chains fill the pipelines (one register's worth, 8, was 1.3–1.5×
/// slower per point on this project's machine, 16 about 5 % slower than 32).
pub const LANES: usize = 32;
/// Batches between two anchors where the Hermite guesses have been good: a chunk of
/// `MAX_BATCHES_PER_CHUNK * LANES + 1` points. An anchor is a serial chain of scalar law
/// evaluations (about 34 ns each on this project's machine, whatever the vector width), so
/// longer chunks pay for fewer of them; 4 (129 points) was 4 % faster per point than 2 on the
/// bench's slide on AVX2 and AVX-512 (more anchors take a second Newton step, 35 of 56 against
/// 32 of 87, and the batches take no more rounds). With the quintic guesses 8 took more rounds
/// and was slower; with the septic ones (error ∝ spacing⁸) 8 (257 points) takes one batch round
/// more than 4 on the bench's slide but 33 anchors instead of 48: callgrind 88.04 → 86.73
/// instructions per point on AVX2. With the step of third order completing the Newton steps
/// that miss, 16 (513 points) takes 26 anchors instead of 33 and no more batch work (81.41 →
/// 80.67); 32 took 24 (80.55), and is left for sparser records' sake.
const MAX_BATCHES_PER_CHUNK: usize = 16;
/// Chunks in a row whose every batch's Newton steps were final before a short chunk (one
/// batch between anchors) grows back.
const CLEAN_CHUNKS_TO_GROW: usize = 2;
/// Newton steps a batch may take before its failing lanes are solved serially.
const MAX_ROUNDS: usize = 4;
/// Largest predicted error of a lane, relative to τ and to F: a quarter of an ulp.
const ROUND_OFF: f64 = f64::EPSILON / 4.0;

type Lanes = [f64; LANES];

/// What the kernel did on one slide: how often each of its paths ran (for tests and
/// benchmarks, through [`ObservedSlide::kernel_counts`](super::ObservedSlide::kernel_counts)).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct KernelCounts {
    /// Batches evaluated: the points between anchors of a slide through a spring, every point
    /// of a stiff slide.
    pub batches: u64,
    /// Newton rounds (evaluations of the law) over the batches between anchors: one per batch
    /// whose guesses were close enough for a single Newton step or, failing that, for the
    /// step of third order from the same evaluation.
    pub rounds: u64,
    /// Batch evaluations of the law outside the lanes' regimes, done lane by lane by the
    /// scalar law.
    pub scalar_law_batches: u64,
    /// Batches some of whose lanes were final only after the step of third order from the
    /// guess (which needs no second evaluation of the law), not after the Newton step.
    pub third_order_batches: u64,
    /// Anchors solved serially.
    pub anchors: u64,
    /// Evaluations of the scalar law for the anchors.
    pub anchor_evaluations: u64,
    /// Points left to the serial iteration after the last Newton round.
    pub serial_points: u64,
    /// Slides solved point after point by the serial reference, because t(τ) folds
    /// (dF/dτ ≤ −kv) somewhere before the last time, where a time may have several τ and only
    /// the serial path follows the quasi-static branch.
    pub serial_slides: u64,
}

/// Counting the kernel's paths, or not: `()` counts nothing and compiles to nothing.
pub(super) trait Tally {
    /// Records what happened, when counting.
    fn count(&mut self, what: impl FnOnce(&mut KernelCounts));
}

impl Tally for KernelCounts {
    #[inline(always)]
    fn count(&mut self, what: impl FnOnce(&mut KernelCounts)) {
        what(self)
    }
}

impl Tally for () {
    #[inline(always)]
    fn count(&mut self, _: impl FnOnce(&mut KernelCounts)) {}
}

/// The vector instructions the kernel is compiled for; every choice gives the same bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Simd {
    /// The baseline of the target (SSE2 on x86-64, whatever the compiler targets elsewhere).
    Baseline,
    /// AVX2 (x86-64): four lanes per register.
    Avx2,
    /// AVX-512 F/DQ/VL (x86-64): eight lanes per register.
    Avx512,
}

/// Environment variable that overrides the detected instruction set (`baseline`, `avx2`,
/// `avx512`): for measuring one against another, and for checking that they agree.
pub const SIMD_ENV: &str = "SLIPBAYES_SIMD";

impl Simd {
    /// `"baseline"`, `"avx2"` or `"avx512"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Baseline => "baseline",
            Self::Avx2 => "avx2",
            Self::Avx512 => "avx512",
        }
    }

    /// Whether this machine can run it.
    pub fn is_available(self) -> bool {
        match self {
            Self::Baseline => true,
            #[cfg(target_arch = "x86_64")]
            Self::Avx2 => std::arch::is_x86_feature_detected!("avx2"),
            #[cfg(target_arch = "x86_64")]
            Self::Avx512 => {
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512dq")
                    && std::arch::is_x86_feature_detected!("avx512vl")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// Every instruction set this machine can run, widest last.
    pub fn available() -> Vec<Self> {
        [Self::Baseline, Self::Avx2, Self::Avx512]
            .into_iter()
            .filter(|s| s.is_available())
            .collect()
    }

    /// The one in use: [`SIMD_ENV`] when it names an available set, else the widest
    /// available. Decided once per process.
    pub fn active() -> Self {
        static ACTIVE: OnceLock<Simd> = OnceLock::new();
        *ACTIVE.get_or_init(|| {
            let widest = *Self::available().last().unwrap_or(&Self::Baseline);
            match std::env::var(SIMD_ENV).ok().as_deref() {
                Some("baseline") => Self::Baseline,
                Some("avx2") if Self::Avx2.is_available() => Self::Avx2,
                Some("avx512") if Self::Avx512.is_available() => Self::Avx512,
                _ => widest,
            }
        })
    }
}

/// One point solved: interface time, force, and dτ/dt, d²τ/dt², d³τ/dt³ there.
#[derive(Debug, Clone, Copy)]
struct Anchor {
    t: f64,
    tau: f64,
    force: f64,
    slope: f64,
    curvature: f64,
    jerk: f64,
}

impl Anchor {
    /// The anchor at (t, τ) with F and dF/dτ there. From dτ/dt = 1/G' = kv/(kv + F'):
    /// d²τ/dt² = −c (dτ/dt)³ with c = F''/kv, and d³τ/dt³ = −(F⁽³⁾/kv) (dτ/dt)⁴ −
    /// 3 c (dτ/dt)² d²τ/dt², where F⁽³⁾ = 2a/τ³ − αv F'' (from Eq. 2).
    fn new(law: &Law, kv: f64, t: f64, tau: f64, force: f64, rate: f64) -> Self {
        let slope = 1.0 / (1.0 + rate / kv);
        let f2 = law.curvature(tau, rate);
        let f3 = 2.0 * law.a / (tau * tau * tau) - law.alpha_v * f2;
        let s2 = slope * slope;
        let curvature = -f2 / kv * s2 * slope;
        let jerk = -f3 / kv * s2 * s2 - 3.0 * f2 / kv * s2 * curvature;
        Self {
            t,
            tau,
            force,
            slope,
            curvature,
            jerk,
        }
    }
}

/// One Newton step on G(τ) = τ + F(τ)/(kv) − t from a τ where the law gives F and dF/dτ:
/// the next τ, F carried along its tangent, whether both are final (the predicted error of
/// each below a quarter ulp, see the module's doc) and whether the step stayed in (lo, t].
#[derive(Debug, Clone, Copy)]
struct Step {
    tau: f64,
    force: f64,
    converged: bool,
    inside: bool,
}

/// Where a step starts: the point's time `t`, a τ, the law's F and dF/dτ there and 1/x
/// (x = αvτ).
#[derive(Debug, Clone, Copy)]
struct Start {
    t: f64,
    tau: f64,
    force: f64,
    rate: f64,
    inv_x: f64,
}

/// The Newton [`Step`] from `at` (the law's curvature from its 1/x); branch-free, so that it
/// vectorises across lanes.
#[inline(always)]
fn newton_step(law: &Law, inv_kv: f64, lo: f64, at: Start) -> Step {
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
fn third_order_step(law: &Law, inv_kv: f64, lo: f64, at: Start) -> Step {
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

/// The law's constants for batches.
struct LawLanes<'l> {
    law: &'l Law,
    /// Ei(x0), for D = e^(−x)[Ei(x) − Ei(x0)].
    ei0: f64,
}

impl<'l> LawLanes<'l> {
    fn new(law: &'l Law) -> Self {
        Self {
            law,
            ei0: crate::special::ei(law.diff.x0()),
        }
    }

    /// F, dF/dτ and 1/x (x = αvτ) at every lane of `tau`.
    #[inline(always)]
    fn force_and_rate(
        &self,
        tau: &Lanes,
        force: &mut Lanes,
        rate: &mut Lanes,
        inv_x: &mut Lanes,
        tally: &mut impl Tally,
    ) {
        let law = self.law;
        let (alpha_v, x0) = (law.alpha_v, law.diff.x0());
        let mut x = [0.0; LANES];
        for l in 0..LANES {
            x[l] = alpha_v * tau[l];
        }
        // Which forms of D the batch needs, decided from its smallest and largest x where
        // the batch lies in one regime (the bulk of a slide): subtraction holds from some x on
        // for a fixed x0 (h ≥ 2 always subtracts, 1 ≤ h < 2 does once h > x0, h < 1 never
        // does), so at the smallest x; either series holds on an interval of x, so at both
        // ends. A batch across a boundary is classified lane by lane and evaluated in each
        // form it needs; a lane in no vector form (the quadrature regime, τ before t0, x past
        // the lanes' range, NaN) sends the batch to the scalar law. The reductions are
        // pairwise, so that they cost a few vector operations rather than a chain of 16.
        let lo = reduce(&x, |a, b| if b < a { b } else { a });
        let hi = reduce(&x, |a, b| if b > a { b } else { a });
        // Every lane in [0, X_LANES_MAX], and none NaN: the smallest and largest are exact
        // where no lane is NaN, and a NaN lane makes the sum NaN (a sum of lanes in range
        // stays finite). A few vector operations, where a per-lane test gathered into one
        // flag cost a comparison and a pack per lane.
        let in_range = (lo >= 0.0) & (hi <= X_LANES_MAX) & !reduce(&x, |a, b| a + b).is_nan();
        let finite = in_range && self.ei0.is_finite();
        let mut forms = [[false; LANES]; 3];
        let (subtract, apart, close) = if !finite {
            (false, false, false)
        } else if in_subtraction(lo, x0) {
            (true, false, false)
        } else if in_series_apart(lo, x0) && in_series_apart(hi, x0) {
            (false, true, false)
        } else if in_series_close(lo, x0) && in_series_close(hi, x0) {
            (false, false, true)
        } else {
            let mut every = true;
            for l in 0..LANES {
                forms[0][l] = in_subtraction(x[l], x0);
                forms[1][l] = in_series_apart(x[l], x0);
                forms[2][l] = in_series_close(x[l], x0);
                every &= forms[0][l] | forms[1][l] | forms[2][l];
            }
            let any = |f: &[bool; LANES]| every && f.iter().any(|&b| b);
            (any(&forms[0]), any(&forms[1]), any(&forms[2]))
        };
        let forms_needed = u8::from(subtract) + u8::from(apart) + u8::from(close);
        if forms_needed == 0 {
            tally.count(|c| c.scalar_law_batches += 1);
            for l in 0..LANES {
                (force[l], rate[l]) = law.force_and_rate(tau[l]);
                inv_x[l] = 1.0 / x[l];
            }
            return;
        }
        let mut e = [0.0; LANES];
        for l in 0..LANES {
            e[l] = exp_neg(x[l]);
        }
        let mut d = [0.0; LANES];
        if forms_needed == 1 && subtract {
            d_subtracted(&x, &e, self.ei0, Pieces::spanning(lo, hi), &mut d, inv_x);
            // x ≥ 1 where D subtracts, so 1 − e^(−x) keeps its digits.
            self.assemble(&e, &d, inv_x, |l| 1.0 - e[l], force, rate);
            return;
        }
        // Near x0 (the first batches of a slide): each form into `part`, then its lanes
        // into `d`; 1/x by its own division.
        let mut part = [0.0; LANES];
        let take = |form: &[bool; LANES], part: &Lanes, d: &mut Lanes| {
            for l in 0..LANES {
                d[l] = if form[l] { part[l] } else { d[l] };
            }
        };
        if forms_needed == 1 {
            if apart {
                d_series(&x, &e, x0, hi, &mut d);
            } else {
                d_series_close(&x, &e, x0, hi, &mut d);
            }
        } else {
            if subtract {
                d_subtracted(&x, &e, self.ei0, Pieces::spanning(lo, hi), &mut part, inv_x);
                take(&forms[0], &part, &mut d);
            }
            if apart {
                d_series(&x, &e, x0, hi, &mut part);
                take(&forms[1], &part, &mut d);
            }
            if close {
                d_series_close(&x, &e, x0, hi, &mut part);
                take(&forms[2], &part, &mut d);
            }
        }
        for l in 0..LANES {
            inv_x[l] = 1.0 / x[l];
        }
        // x may be below 1/2 here, where 1 − e^(−x) is taken by its series, as the scalar law
        // takes −expm1(−x).
        self.assemble(
            &e,
            &d,
            inv_x,
            |l| one_minus_exp_neg(x[l], e[l]),
            force,
            rate,
        );
    }

    /// F and dF/dτ from e^(−x), D, 1/x and 1 − e^(−x), as in `Law::force_and_rate` (with
    /// a/τ = αv · a/x).
    #[inline(always)]
    fn assemble(
        &self,
        e: &Lanes,
        d: &Lanes,
        inv_x: &Lanes,
        one_minus_e: impl Fn(usize) -> f64,
        force: &mut Lanes,
        rate: &mut Lanes,
    ) {
        let law = self.law;
        for l in 0..LANES {
            let aging = law.a * d[l];
            force[l] = aging + law.f_d * one_minus_e(l);
            rate[l] = law.alpha_v * (law.a * inv_x[l] - (aging - law.f_d * e[l]));
        }
    }
}

/// `op` over the lanes, pairwise (`op` is min or max, as a comparison and select so that it
/// vectorises, which only NaN would tell from `f64::min`: a batch with NaN goes to the scalar
/// law whatever its smallest and largest x).
#[inline(always)]
fn reduce(v: &Lanes, op: impl Fn(f64, f64) -> f64) -> f64 {
    let mut w = *v;
    let mut half = LANES / 2;
    while half > 0 {
        for l in 0..half {
            w[l] = op(w[l], w[l + half]);
        }
        half /= 2;
    }
    w[0]
}

/// A slide declared stiff (τ = t): the law at every time, in batches.
pub(super) fn stiff<V: FnMut(usize, f64, f64), T: Tally>(
    simd: Simd,
    law: &Law,
    times: &[f64],
    visit: &mut V,
    tally: &mut T,
) {
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: callers name only instruction sets that `Simd::is_available` confirmed on
        // this machine (`Simd::active`, `ObservedSlide::for_each_force_with`).
        Simd::Avx512 => unsafe { stiff_avx512(law, times, visit, tally) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above.
        Simd::Avx2 => unsafe { stiff_avx2(law, times, visit, tally) },
        _ => stiff_lanes(law, times, visit, tally),
    }
}

/// Whether `times` strictly increase (a NaN fails the comparison), compared branch-free over
/// the pairs on `simd`'s registers: on the baseline's two lanes per comparison, this check cost
/// about 2.5 % of the observed-time model in lanes on AVX2 (callgrind), a branch per point
/// about 5 % of a stiff slide.
pub(super) fn strictly_increasing(simd: Simd, times: &[f64]) -> bool {
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as in `stiff`.
        Simd::Avx512 => unsafe { strictly_increasing_avx512(times) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as in `stiff`.
        Simd::Avx2 => unsafe { strictly_increasing_avx2(times) },
        _ => strictly_increasing_lanes(times),
    }
}

#[inline(always)]
fn strictly_increasing_lanes(times: &[f64]) -> bool {
    times.first().is_none_or(|&t| t > f64::NEG_INFINITY)
        && times
            .get(1..)
            .unwrap_or_default()
            .iter()
            .zip(times)
            .fold(true, |ok, (&next, &previous)| ok & (next > previous))
}

/// A first slide through a spring (kv in N/s): the elastic solve at every time, in batches.
/// Times are sorted, and t(τ) = τ + F(τ)/(kv) increases for every τ up to the last time
/// (dF/dτ > −kv there, checked by the caller): each time then has exactly one τ, so the root
/// that a Newton step finds from any guess in its bracket is the quasi-static path's.
///
/// # Errors
/// [`LawError::NotFinite`] when the law is not finite on the path.
pub(super) fn spring<V: FnMut(usize, f64, f64), T: Tally>(
    simd: Simd,
    law: &Law,
    kv: f64,
    times: &[f64],
    visit: &mut V,
    tally: &mut T,
) -> Result<(), LawError> {
    match simd {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as in `stiff`.
        Simd::Avx512 => unsafe { spring_avx512(law, kv, times, visit, tally) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as in `stiff`.
        Simd::Avx2 => unsafe { spring_avx2(law, kv, times, visit, tally) },
        _ => spring_lanes(law, kv, times, visit, tally),
    }
}

// The same bodies compiled for wider registers: `#[inline(always)]` on every function they
// call puts the whole kernel inside the `target_feature` function, where the compiler may use
// the wider instructions.

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2")]
unsafe fn stiff_avx512<V: FnMut(usize, f64, f64), T: Tally>(
    law: &Law,
    times: &[f64],
    visit: &mut V,
    tally: &mut T,
) {
    stiff_lanes(law, times, visit, tally)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn stiff_avx2<V: FnMut(usize, f64, f64), T: Tally>(
    law: &Law,
    times: &[f64],
    visit: &mut V,
    tally: &mut T,
) {
    stiff_lanes(law, times, visit, tally)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2")]
unsafe fn spring_avx512<V: FnMut(usize, f64, f64), T: Tally>(
    law: &Law,
    kv: f64,
    times: &[f64],
    visit: &mut V,
    tally: &mut T,
) -> Result<(), LawError> {
    spring_lanes(law, kv, times, visit, tally)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn spring_avx2<V: FnMut(usize, f64, f64), T: Tally>(
    law: &Law,
    kv: f64,
    times: &[f64],
    visit: &mut V,
    tally: &mut T,
) -> Result<(), LawError> {
    spring_lanes(law, kv, times, visit, tally)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl,avx2")]
unsafe fn strictly_increasing_avx512(times: &[f64]) -> bool {
    strictly_increasing_lanes(times)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn strictly_increasing_avx2(times: &[f64]) -> bool {
    strictly_increasing_lanes(times)
}

/// Copies up to [`LANES`] values into a batch, repeating the last to fill it (the repeated
/// lanes are computed and dropped).
#[inline(always)]
fn batch_of(values: &[f64]) -> Lanes {
    if let Ok(full) = Lanes::try_from(values) {
        return full;
    }
    let mut out = [values[values.len() - 1]; LANES];
    out[..values.len()].copy_from_slice(values);
    out
}

#[inline(always)]
fn stiff_lanes<V: FnMut(usize, f64, f64), T: Tally>(
    law: &Law,
    times: &[f64],
    visit: &mut V,
    tally: &mut T,
) {
    let lanes = LawLanes::new(law);
    let (mut force, mut rate, mut inv_x) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
    for (b, chunk) in times.chunks(LANES).enumerate() {
        tally.count(|c| c.batches += 1);
        let t = batch_of(chunk);
        lanes.force_and_rate(&t, &mut force, &mut rate, &mut inv_x, tally);
        for (l, &t) in chunk.iter().enumerate() {
            visit(b * LANES + l, t, force[l]);
        }
    }
}

#[inline(always)]
fn spring_lanes<V: FnMut(usize, f64, f64), T: Tally>(
    law: &Law,
    kv: f64,
    times: &[f64],
    visit: &mut V,
    tally: &mut T,
) -> Result<(), LawError> {
    let t0 = law.t0();
    let (force_t0, rate_t0) = law.force_and_rate(t0);
    let loading_ends = t0 + force_t0 / kv;
    let n = times.len();
    let mut i = 0;
    // Before t0 the interface does not evolve; until the spring has taken up the law's jump
    // at t0 it loads elastically (docs/model.md §3).
    while i < n && times[i] <= t0 {
        visit(i, times[i], 0.0);
        i += 1;
    }
    while i < n && times[i] <= loading_ends {
        visit(i, t0, kv * (times[i] - t0));
        i += 1;
    }
    if i == n {
        return Ok(());
    }
    let lanes = LawLanes::new(law);
    let mut left = Anchor::new(law, kv, loading_ends, t0, force_t0, rate_t0);
    // The chunk's length adapts to how good the guesses are: where a batch's Newton steps were
    // not all final (the steep rise at the start of a slow slide; the step of third order from
    // the same guesses, or a second round, then finished it), the next chunks are one batch
    // long, whose guesses are far closer (their error falls as the eighth power of the
    // spacing); after `CLEAN_CHUNKS_TO_GROW` clean chunks they double, up to
    // `MAX_BATCHES_PER_CHUNK`. Rounds are the same on every instruction set, so are the
    // anchors.
    let (mut batches, mut clean) = (1, 0);
    let mut guess = None;
    while i < n {
        let end = (i + batches * LANES + 1).min(n) - 1;
        tally.count(|c| c.anchors += 1);
        let right = solve_anchor(law, kv, &left, guess.as_ref(), times[end], tally)?;
        let between = &times[i..end];
        let chunk_guess = Hermite::new(&left, &right);
        if solve_between(&lanes, kv, &chunk_guess, (i, between), tally, visit)? {
            clean += 1;
            if clean >= CLEAN_CHUNKS_TO_GROW && batches < MAX_BATCHES_PER_CHUNK {
                (batches, clean) = (batches * 2, 0);
            }
        } else {
            (batches, clean) = (1, 0);
        }
        visit(end, right.tau, right.force);
        left = right;
        guess = Some(chunk_guess);
        i = end + 1;
    }
    Ok(())
}

/// The point at time `t` after `left`: Newton steps until the predicted error of one, or of
/// the step of third order from the same evaluation, is round-off, else the safeguarded
/// iteration on [τ_left, t]. They start from the previous chunk's Hermite
/// interpolant extrapolated to `t` (`previous`; its error grows as the eighth power of the
/// spacing, against the fourth for a Taylor guess, so that one step usually suffices) where
/// that lies in (τ_left, t], else from the cubic Taylor guess along τ(t).
#[inline(always)]
fn solve_anchor(
    law: &Law,
    kv: f64,
    left: &Anchor,
    previous: Option<&Hermite>,
    t: f64,
    tally: &mut impl Tally,
) -> Result<Anchor, LawError> {
    let dt = t - left.t;
    let extrapolated = previous.map_or(f64::NAN, |p| p.at(t));
    let mut tau = if extrapolated > left.tau && extrapolated <= t {
        extrapolated
    } else {
        left.tau + dt * (left.slope + dt * (0.5 * left.curvature + dt * left.jerk / 6.0))
    };
    for _ in 0..MAX_ROUNDS {
        if !(tau > left.tau && tau <= t) {
            break;
        }
        tally.count(|c| c.anchor_evaluations += 1);
        let (force, rate) = law.force_and_rate(tau);
        let inv_x = 1.0 / (law.alpha_v * tau);
        let at = Start {
            t,
            tau,
            force,
            rate,
            inv_x,
        };
        let step = newton_step(law, 1.0 / kv, left.tau, at);
        if step.converged {
            return Ok(Anchor::new(law, kv, t, step.tau, step.force, rate));
        }
        let third = third_order_step(law, 1.0 / kv, left.tau, at);
        if third.converged {
            // dF/dτ at the root along its tangent, for the anchor's derivatives.
            let rate = rate + law.curvature(tau, rate) * (third.tau - tau);
            return Ok(Anchor::new(law, kv, t, third.tau, third.force, rate));
        }
        tau = if third.inside { third.tau } else { step.tau };
    }
    tally.count(|c| c.serial_points += 1);
    let (root, force, rate) = solve_point(law, kv, left.tau, t, tau)?;
    Ok(Anchor::new(law, kv, t, root, force, rate))
}

/// The points strictly between two anchors, `times`, the first of which is point `first` of
/// the slide, batch by batch: guesses from the anchors' Hermite interpolant `guess`, a Newton
/// step, the step of third order from the guess for the lanes whose Newton step is not final,
/// more Newton rounds until every lane's predicted error is round-off, the serial solve for
/// what remains. Returns whether every batch's Newton steps were final.
#[inline(always)]
fn solve_between<V: FnMut(usize, f64, f64), T: Tally>(
    lanes: &LawLanes,
    kv: f64,
    guess: &Hermite,
    (first, times): (usize, &[f64]),
    tally: &mut T,
    visit: &mut V,
) -> Result<bool, LawError> {
    let law = lanes.law;
    let left_tau = guess.tau_left();
    let mut newton_sufficed = true;
    let inv_kv = 1.0 / kv;
    // Each round's τ, and its steps' τ and F. Every lane of each is written before it is read,
    // so they are set up once here rather than zeroed for every batch.
    let (mut tau, mut next, mut out_force) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
    let (mut force, mut rate, mut inv_x) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
    // 1 where the lane's last step is not final: a word per lane rather than a bool, so that
    // a vector comparison stores without being packed to bytes.
    let mut missed = [0_u64; LANES];
    for (b, chunk) in times.chunks(LANES).enumerate() {
        tally.count(|c| c.batches += 1);
        let t = batch_of(chunk);
        for l in 0..LANES {
            tau[l] = guess.at(t[l]);
        }
        let mut failed = 0_u64;
        for round in 0..MAX_ROUNDS {
            newton_sufficed &= round == 0;
            tally.count(|c| c.rounds += 1);
            lanes.force_and_rate(&tau, &mut force, &mut rate, &mut inv_x, tally);
            let start = |l: usize| Start {
                t: t[l],
                tau: tau[l],
                force: force[l],
                rate: rate[l],
                inv_x: inv_x[l],
            };
            // Branch-free (`&`, `|`, selects), so that the lanes stay in vector registers.
            failed = 0;
            for l in 0..LANES {
                let step = newton_step(law, inv_kv, left_tau, start(l));
                missed[l] = u64::from(!step.converged);
                failed |= missed[l];
                next[l] = step.tau;
                out_force[l] = step.force;
            }
            if failed == 0 {
                break;
            }
            if round == 0 {
                // The lanes whose Newton step from the guess is not final take the step of
                // third order from it instead, which needs no new evaluation of the law.
                tally.count(|c| c.third_order_batches += 1);
                newton_sufficed = false;
                failed = 0;
                for l in 0..LANES {
                    let step = third_order_step(law, inv_kv, left_tau, start(l));
                    let retake = missed[l] != 0;
                    missed[l] = u64::from(retake & !step.converged);
                    failed |= missed[l];
                    next[l] = if retake { step.tau } else { next[l] };
                    out_force[l] = if retake { step.force } else { out_force[l] };
                }
                if failed == 0 {
                    break;
                }
            }
            // The next round starts from these steps; a lane that left its bracket restarts
            // from the bracket's middle.
            for l in 0..LANES {
                let inside = (next[l] > left_tau) & (next[l] <= t[l]);
                let middle = left_tau + 0.5 * (t[l] - left_tau);
                tau[l] = if inside { next[l] } else { middle };
            }
        }
        if failed != 0 {
            for (l, &t) in chunk.iter().enumerate() {
                if missed[l] != 0 {
                    tally.count(|c| c.serial_points += 1);
                    (next[l], out_force[l], _) = solve_point(law, kv, left_tau, t, tau[l])?;
                }
            }
        }
        // A loop of visits alone, with no call that could see the caller's state, so that
        // the caller's accumulators stay in registers.
        for l in 0..chunk.len() {
            visit(first + b * LANES + l, next[l], out_force[l]);
        }
    }
    Ok(newton_sufficed)
}

/// The septic Hermite interpolant of τ(t) between two anchors, from their τ, dτ/dt, d²τ/dt²
/// and d³τ/dt³ (its error falls as the eighth power of the anchors' spacing, so that one
/// Newton step usually leaves only round-off, also on the steep rise at the start of a slow
/// slide, where the quintic interpolant of τ, dτ/dt and d²τ/dt² left most batches a second
/// round), as a polynomial in u = (t − t_left)/span whose coefficients are formed once per
/// chunk: a guess then costs a multiplication and seven Horner steps.
struct Hermite {
    t_left: f64,
    inv_span: f64,
    /// Coefficients of u⁰ … u⁷.
    c: [f64; 8],
}

impl Hermite {
    fn new(left: &Anchor, right: &Anchor) -> Self {
        let span = right.t - left.t;
        // The interpolant's values and derivatives in u at both ends.
        let rise = right.tau - left.tau;
        let (d0, d1) = (span * left.slope, span * right.slope);
        let (c0, c1) = (span * span * left.curvature, span * span * right.curvature);
        let cube = span * span * span;
        let (j0, j1) = (cube * left.jerk, cube * right.jerk);
        Self {
            t_left: left.t,
            inv_span: 1.0 / span,
            c: [
                left.tau,
                d0,
                0.5 * c0,
                j0 / 6.0,
                35.0 * rise - 20.0 * d0 - 15.0 * d1 - 5.0 * c0 + 2.5 * c1
                    - j0 * (2.0 / 3.0)
                    - j1 / 6.0,
                -84.0 * rise + 45.0 * d0 + 39.0 * d1 + 10.0 * c0 - 7.0 * c1 + j0 + 0.5 * j1,
                70.0 * rise - 36.0 * d0 - 34.0 * d1 - 7.5 * c0 + 6.5 * c1
                    - j0 * (2.0 / 3.0)
                    - 0.5 * j1,
                -20.0 * rise + 10.0 * (d0 + d1) + 2.0 * (c0 - c1) + (j0 + j1) / 6.0,
            ],
        }
    }

    /// τ at the left anchor, the lower end of every bracket in the chunk.
    fn tau_left(&self) -> f64 {
        self.c[0]
    }

    /// The guess of τ at `t`.
    #[inline(always)]
    fn at(&self, t: f64) -> f64 {
        let u = (t - self.t_left) * self.inv_span;
        let c = &self.c;
        c[0] + u
            * (c[1] + u * (c[2] + u * (c[3] + u * (c[4] + u * (c[5] + u * (c[6] + u * c[7]))))))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::law::LawParams;

    /// The times' check gives the same verdict on every instruction set wherever the pair out
    /// of order lies (in the vector body or the scalar tail of 37 times): equal, NaN, or a
    /// first time of −∞.
    #[test]
    fn times_out_of_order_are_found_on_every_instruction_set() {
        let sorted: Vec<f64> = (0..37).map(|i| 0.5 * i as f64).collect();
        for simd in Simd::available() {
            assert!(strictly_increasing(simd, &sorted), "{simd:?}");
            assert!(strictly_increasing(simd, &[]), "{simd:?}");
            assert!(
                !strictly_increasing(simd, &[f64::NEG_INFINITY, 0.0]),
                "{simd:?}"
            );
            for i in 1..sorted.len() {
                for odd in [sorted[i - 1], f64::NAN] {
                    let mut times = sorted.clone();
                    times[i] = odd;
                    assert!(!strictly_increasing(simd, &times), "{simd:?}: {odd} at {i}");
                }
            }
        }
    }

    /// The step of third order from a guess whose Newton step is far from final lands on the
    /// root to a few ulps, in τ and in F, and says so; on the steep rise of a slow slide (x = 2)
    /// and beyond it. Its predicted error must also be honest: a guess so far off that the step
    /// cannot be final is not declared final.
    #[test]
    fn the_third_order_step_is_final_where_the_newton_step_is_not() {
        let law = Law::new(&LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8).unwrap(), 1e-9).unwrap();
        let kv = 1.2e4 * 1e-9;
        for x in [0.8, 2.0, 7.0, 30.0] {
            let tau = x / law.alpha_v;
            let t = tau + law.force_and_rate(tau).0 / kv;
            let lo = law.t0();
            let (root, root_force, _) = solve_point(&law, kv, lo, t, tau).unwrap();
            // (How far the guess is off, relatively; whether the step is final from it; whether
            // Newton's is off by more than 1e-13 there, which holds on the steep rise.)
            for (offset, final_expected, newton_far) in [
                (1e-7, true, false),
                (1e-6, true, false),
                (3e-6, true, x <= 7.0),
                (1e-2, false, true),
            ] {
                let guess = root * (1.0 + offset);
                let (force, rate) = law.force_and_rate(guess);
                let inv_x = 1.0 / (law.alpha_v * guess);
                let at = Start {
                    t,
                    tau: guess,
                    force,
                    rate,
                    inv_x,
                };
                let newton = newton_step(&law, 1.0 / kv, lo, at);
                let third = third_order_step(&law, 1.0 / kv, lo, at);
                let what = format!("x {x}, guess off by {offset:e}: {newton:?} {third:?}");
                assert!(!newton.converged, "{what}");
                assert_eq!(third.converged, final_expected, "{what}");
                if final_expected {
                    assert!(
                        (third.tau - root).abs() <= 2.0 * f64::EPSILON * root,
                        "{what}"
                    );
                    assert!(
                        (third.force - root_force).abs() <= 8.0 * f64::EPSILON * root_force.abs(),
                        "{what}: F {root_force:e}"
                    );
                }
                if newton_far {
                    assert!((newton.tau - root).abs() > 1e-13 * root, "{what}");
                }
            }
        }
    }

    /// A batch in the lanes' regimes stays in lanes; one lane that is NaN, past the lanes'
    /// range or negative sends the whole batch to the scalar law, whose values it then has
    /// bit for bit (the range check is a reduction over the batch, and a NaN lane must not
    /// slip through its smallest and largest x).
    #[test]
    fn a_lane_out_of_range_sends_the_batch_to_the_scalar_law() {
        let law = Law::new(&LawParams::new(0.92e6, 6.2e-3, 10e-3, 14.8).unwrap(), 1e-9).unwrap();
        let lanes = LawLanes::new(&law);
        // x = αvτ from 2 to about 30: the subtraction regime.
        let clean: Lanes = std::array::from_fn(|l| (2.0 + l as f64) / law.alpha_v);
        let beyond = 2.0 * X_LANES_MAX / law.alpha_v;
        for (name, odd) in [
            ("none", None),
            ("NaN", Some(f64::NAN)),
            ("beyond", Some(beyond)),
            ("negative", Some(-1.0)),
        ] {
            for lane in [0, 13, LANES - 1] {
                let mut tau = clean;
                if let Some(v) = odd {
                    tau[lane] = v;
                }
                let (mut force, mut rate, mut inv_x) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
                let mut counts = KernelCounts::default();
                lanes.force_and_rate(&tau, &mut force, &mut rate, &mut inv_x, &mut counts);
                let expected_scalar = u64::from(odd.is_some());
                assert_eq!(
                    counts.scalar_law_batches, expected_scalar,
                    "{name} at lane {lane}"
                );
                if odd.is_some() {
                    for l in 0..LANES {
                        let (f, r) = law.force_and_rate(tau[l]);
                        assert_eq!(
                            (force[l].to_bits(), rate[l].to_bits()),
                            (f.to_bits(), r.to_bits()),
                            "{name} at lane {lane}: lane {l}"
                        );
                    }
                }
            }
        }
    }
}
