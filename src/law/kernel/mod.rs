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
//!
//! # Where the parts are
//! This file holds the entry points and their compilations per instruction set, and the stiff
//! slide; `spring` the anchors and the batches between them, `newton` the steps and their
//! predicted errors, `lanes` the law evaluated in lanes.

use std::sync::OnceLock;

use super::{Law, LawError};

mod lanes;
mod newton;
mod spring;
#[cfg(test)]
mod tests;

use lanes::LawLanes;
use spring::spring_lanes;

/// Points per batch: four AVX-512 registers of f64 (eight AVX2 registers), so that several
/// independent dependency chains fill the pipelines, which one register's worth leaves idle.
pub const LANES: usize = 32;
/// Batches between two anchors where the Hermite guesses have been good: a chunk of
/// `MAX_BATCHES_PER_CHUNK * LANES + 1` points. An anchor is a serial chain of scalar law
/// evaluations, as slow whatever the vector width, so longer chunks pay for fewer of them; the
/// septic guesses (error ∝ spacing⁸) and the third-order step that completes the Newton steps
/// that miss keep the batches of a 513-point chunk as cheap as those of a shorter one, and a
/// longer chunk saves few anchors more while a sparse record's guesses degrade.
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
/// the pairs on `simd`'s registers: the check runs on every evaluation, and a branch per point
/// would cost a visible share of a stiff slide.
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
