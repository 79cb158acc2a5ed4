//! The elastic correction (paper Eq. 1): what the instrument records.
//!
//! The rheometer advances at a constant rate v; part of that motion is stored in the spring of
//! stiffness k instead of sliding the interface. Instrument time t and interface time τ obey
//! `t = τ + F(τ)/(kv)`, and the recorded force at t is F(τ(t)). t(τ) increases as long as
//! dF/dτ > −kv; where friction weakens faster than that, there is no quasi-static path
//! (stick-slip) and [`LawError::StickSlip`] is returned instead of a number.
//!
//! Before t0 the interface does not evolve and the force is zero. The published law jumps to
//! F(t0) = F_d(1 − e^(−x0)) at t0; the instrument sees that jump as elastic loading,
//! F = kv(t − t0), while τ waits at t0 — which keeps the recorded force continuous.

use super::kernel::{self, KernelCounts};
use super::root::increasing_root;
use super::{positive, InterfaceLaw, Law, LawError, LogAging, Simd};

/// What the elastic solve needs of a law in interface time.
pub(super) trait InterfaceForce {
    /// t0 (s): the force is zero before it.
    fn cut_off(&self) -> f64;
    /// F(τ) and dF/dτ.
    fn force_rate(&self, tau: f64) -> (f64, f64);
    /// The most negative dF/dτ on [t0, τ_end], and where.
    fn steepest_weakening(&self, tau_end: f64) -> (f64, f64);
}

impl InterfaceForce for Law {
    #[inline(always)]
    fn cut_off(&self) -> f64 {
        self.t0()
    }
    #[inline(always)]
    fn force_rate(&self, tau: f64) -> (f64, f64) {
        self.force_and_rate(tau)
    }
    fn steepest_weakening(&self, tau_end: f64) -> (f64, f64) {
        self.min_rate_up_to(tau_end)
    }
}

impl InterfaceForce for LogAging {
    #[inline(always)]
    fn cut_off(&self) -> f64 {
        self.t0()
    }
    #[inline(always)]
    fn force_rate(&self, tau: f64) -> (f64, f64) {
        self.force_and_rate(tau)
    }
    /// dF/dτ = a/τ falls for ever but stays positive: its minimum is at the end.
    fn steepest_weakening(&self, tau_end: f64) -> (f64, f64) {
        (tau_end, self.force_and_rate(tau_end).1)
    }
}

/// How the machine's elasticity enters a slide.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Elastic {
    /// k → ∞, or a fast slide declared stiff: τ = t.
    Stiff,
    /// A spring of stiffness k driven at velocity v; holds the product kv (N/s).
    Spring {
        /// k·v in N/s.
        kv: f64,
    },
}

impl Elastic {
    /// A spring of stiffness `k_n_per_m` driven at `velocity_m_per_s`.
    ///
    /// # Errors
    /// [`LawError::InvalidParameter`] naming `k` or `v` when either is not finite and positive.
    pub fn spring(k_n_per_m: f64, velocity_m_per_s: f64) -> Result<Self, LawError> {
        let k = positive("k", k_n_per_m)?;
        let v = positive("v", velocity_m_per_s)?;
        Ok(Self::Spring {
            kv: positive("k*v", k * v)?,
        })
    }
}

/// A first (or fast) slide as the instrument records it.
#[derive(Debug, Clone)]
pub struct ObservedSlide {
    law: InterfaceLaw,
    elastic: Elastic,
}

impl ObservedSlide {
    /// The slide of `law` (a [`Law`], a [`LogAging`] or an [`InterfaceLaw`]) seen through
    /// `elastic`.
    pub fn new(law: impl Into<InterfaceLaw>, elastic: Elastic) -> Self {
        Self {
            law: law.into(),
            elastic,
        }
    }

    /// The law in interface time.
    pub fn law(&self) -> &InterfaceLaw {
        &self.law
    }

    /// The machine's elasticity.
    pub fn elastic(&self) -> Elastic {
        self.elastic
    }

    /// Recorded force at each instrument time of `times` (strictly increasing), written into
    /// `forces`; the interface times are written into `taus` when given.
    ///
    /// # Errors
    /// As [`ObservedSlide::for_each_force`], and [`LawError::LengthMismatch`] for outputs of
    /// the wrong length.
    pub fn forces(
        &self,
        times: &[f64],
        forces: &mut [f64],
        mut taus: Option<&mut [f64]>,
    ) -> Result<(), LawError> {
        check_len(times.len(), forces.len())?;
        if let Some(taus) = taus.as_deref() {
            check_len(times.len(), taus.len())?;
        }
        self.for_each_force(times, |i, tau, force| {
            forces[i] = force;
            if let Some(taus) = taus.as_deref_mut() {
                taus[i] = tau;
            }
        })
    }

    /// Calls `visit(i, τ_i, F_i)` with the interface time and recorded force at each instrument
    /// time of `times` (strictly increasing), in order, without allocating: the hot path of a
    /// likelihood.
    ///
    /// The points of the aging–rejuvenation law are solved in batches in vector registers
    /// (`kernel`): every
    /// 33rd, 65th, 129th, 257th or 513th point by Newton steps from an extrapolated or Taylor
    /// guess, one after the other, the points between by one Newton step each from a septic
    /// Hermite guess between those anchors, completed by a step of third order from the same
    /// evaluation of the law where a lane's predicted error is above round-off, and repeated
    /// where it still is. The result agrees
    /// with [`for_each_force_serial`](Self::for_each_force_serial) to rounding, on whatever
    /// vector instructions the machine has ([`Simd::active`](super::Simd::active)), and is
    /// the same bit for bit on every one of them. Pure logarithmic aging is cheap and never
    /// folds: it is solved point after point.
    ///
    /// # Errors
    /// [`LawError::UnsortedTimes`] when times do not increase (checked before any visit), and
    /// [`LawError::StickSlip`] when dF/dτ ≤ −kv anywhere on the path up to the last point
    /// (checked after the visits, whose values are then meaningless).
    pub fn for_each_force(
        &self,
        times: &[f64],
        visit: impl FnMut(usize, f64, f64),
    ) -> Result<(), LawError> {
        self.for_each_force_with(Simd::active(), times, visit)
    }

    /// [`for_each_force`](Self::for_each_force) on the instruction set `simd` (for benchmarks
    /// and for checking that every set gives the same bits).
    ///
    /// # Errors
    /// As [`for_each_force`](Self::for_each_force); [`LawError::InvalidParameter`] naming
    /// `simd` when this machine cannot run it.
    pub fn for_each_force_with(
        &self,
        simd: Simd,
        times: &[f64],
        mut visit: impl FnMut(usize, f64, f64),
    ) -> Result<(), LawError> {
        self.run_kernel(simd, times, &mut visit, &mut ())
    }

    /// How often each path of the kernel ran on `times` (every point is solved as by
    /// [`for_each_force_with`](Self::for_each_force_with)): for tests that the fast paths
    /// are the ones taken, and for benchmarks.
    ///
    /// # Errors
    /// As [`for_each_force_with`](Self::for_each_force_with).
    pub fn kernel_counts(&self, simd: Simd, times: &[f64]) -> Result<KernelCounts, LawError> {
        let mut counts = KernelCounts::default();
        self.run_kernel(simd, times, &mut |_, _, _| {}, &mut counts)?;
        Ok(counts)
    }

    fn run_kernel(
        &self,
        simd: Simd,
        times: &[f64],
        visit: &mut impl FnMut(usize, f64, f64),
        tally: &mut impl kernel::Tally,
    ) -> Result<(), LawError> {
        if !simd.is_available() {
            return Err(LawError::InvalidParameter {
                name: "simd",
                value: f64::NAN,
                expected: "an instruction set this machine has (Simd::available)",
            });
        }
        check_sorted(simd, times)?;
        let law = match &self.law {
            InterfaceLaw::AgingRejuvenation(law) => law,
            InterfaceLaw::LogAging(law) => {
                tally.count(|c| c.serial_slides += 1);
                return serial_forces(law, self.elastic, times, visit);
            }
        };
        match self.elastic {
            Elastic::Stiff => {
                kernel::stiff(simd, law, times, visit, tally);
                Ok(())
            }
            Elastic::Spring { kv } => {
                // Where t(τ) folds before the last time, a time can have several τ: only the
                // serial solve, point after point from t0, follows the quasi-static branch
                // (and says whether the data reach the fold).
                let t_last = times.last().copied().unwrap_or(f64::NEG_INFINITY);
                if t_last > law.t0() && law.min_rate_up_to(t_last).1 <= -kv {
                    tally.count(|c| c.serial_slides += 1);
                    return serial_forces(law, self.elastic, times, visit);
                }
                kernel::spring(simd, law, kv, times, visit, tally)
            }
        }
    }

    /// [`for_each_force`](Self::for_each_force) solved point after point, each by the
    /// safeguarded Newton iteration warm-started from the previous point: the reference that
    /// the batched kernel is tested and measured against.
    ///
    /// Each point is solved by a safeguarded Newton iteration on the bracket
    /// [τ of the previous point, t], warm-started by extrapolating along the previous point's
    /// slope dτ/dt = 1/(1 + F'/(kv)) and its change since the point before; it always
    /// converges.
    ///
    /// # Errors
    /// [`LawError::UnsortedTimes`] when times do not increase (checked before any visit), and
    /// [`LawError::StickSlip`] when dF/dτ ≤ −kv anywhere on the path up to the last point
    /// (checked after the visits, whose values are then meaningless).
    pub fn for_each_force_serial(
        &self,
        times: &[f64],
        visit: impl FnMut(usize, f64, f64),
    ) -> Result<(), LawError> {
        match &self.law {
            InterfaceLaw::AgingRejuvenation(law) => serial_forces(law, self.elastic, times, visit),
            InterfaceLaw::LogAging(law) => serial_forces(law, self.elastic, times, visit),
        }
    }

    /// Recorded force at one instrument time, solved without a warm start.
    ///
    /// # Errors
    /// As [`ObservedSlide::forces`].
    pub(crate) fn force_at(&self, time: f64) -> Result<f64, LawError> {
        let mut out = [0.0];
        self.forces(&[time], &mut out, None)?;
        Ok(out[0])
    }
}

/// [`ObservedSlide::for_each_force_serial`] for any law in interface time.
fn serial_forces(
    law: &impl InterfaceForce,
    elastic: Elastic,
    times: &[f64],
    mut visit: impl FnMut(usize, f64, f64),
) -> Result<(), LawError> {
    check_sorted(Simd::active(), times)?;
    let kv = match elastic {
        Elastic::Stiff => {
            for (i, &t) in times.iter().enumerate() {
                visit(i, t, law.force_rate(t).0);
            }
            return Ok(());
        }
        Elastic::Spring { kv } => kv,
    };

    let t0 = law.cut_off();
    let (force_t0, rate_t0) = law.force_rate(t0);
    let loading_ends = t0 + force_t0 / kv;
    // The last two solved points as (t, τ, dτ/dt): the warm start of the next, by
    // quadratic extrapolation along τ(t) once two are known.
    let slope = |rate: f64| 1.0 / (1.0 + rate / kv);
    let mut previous = (loading_ends, t0, slope(rate_t0));
    let mut before: Option<(f64, f64, f64)> = None;
    for (i, &t) in times.iter().enumerate() {
        let (tau, force) = if t <= t0 {
            (t, 0.0)
        } else if t <= loading_ends {
            (t0, kv * (t - t0))
        } else {
            let (t_prev, tau_prev, slope_prev) = previous;
            let dt = t - t_prev;
            let curvature = match before {
                Some((t_b, _, slope_b)) => (slope_prev - slope_b) / (t_prev - t_b),
                None => 0.0,
            };
            let guess = tau_prev + dt * (slope_prev + 0.5 * curvature * dt);
            let (root, force, r_eval) = solve_point(law, kv, tau_prev, t, guess)?;
            before = Some(previous);
            previous = (t, root, slope(r_eval));
            (root, force)
        };
        visit(i, tau, force);
    }
    if let Some(&t_last) = times.last() {
        if t_last > loading_ends {
            let (tau_min, rate_min) = law.steepest_weakening(previous.1);
            if rate_min <= -kv {
                return Err(LawError::StickSlip {
                    tau: tau_min,
                    rate: rate_min,
                    limit: -kv,
                });
            }
        }
    }
    Ok(())
}

/// Times must strictly increase (NaN fails the comparison too); the pairs are compared in
/// `simd`'s registers (`kernel::strictly_increasing`), the offending index looked for only on
/// failure.
fn check_sorted(simd: Simd, times: &[f64]) -> Result<(), LawError> {
    let increasing = kernel::strictly_increasing(simd, times);
    if increasing {
        return Ok(());
    }
    let mut previous_time = f64::NEG_INFINITY;
    for (index, &time) in times.iter().enumerate() {
        if time.partial_cmp(&previous_time) != Some(std::cmp::Ordering::Greater) {
            return Err(LawError::UnsortedTimes { index, time });
        }
        previous_time = time;
    }
    Ok(())
}

fn check_len(expected: usize, got: usize) -> Result<(), LawError> {
    if expected == got {
        Ok(())
    } else {
        Err(LawError::LengthMismatch { expected, got })
    }
}

/// τ, F and dF/dτ at time `t` by the safeguarded Newton iteration on [max(lo, t0), t], from
/// `guess`: the serial solve of every point and the kernel's anchors and fallbacks. The root is
/// one tiny Newton step from the last evaluation, so F is carried along its tangent rather than
/// paying for one more evaluation.
#[inline(always)]
pub(super) fn solve_point(
    law: &impl InterfaceForce,
    kv: f64,
    lo: f64,
    t: f64,
    guess: f64,
) -> Result<(f64, f64, f64), LawError> {
    let mut last = (f64::NAN, 0.0, 0.0);
    let root = increasing_root(
        |tau| {
            let (f, r) = law.force_rate(tau);
            last = (tau, f, r);
            (tau + f / kv - t, 1.0 + r / kv)
        },
        lo.max(law.cut_off()),
        t,
        guess,
    )
    .ok_or(LawError::NotFinite { tau: last.0 })?;
    let (tau_eval, f_eval, r_eval) = last;
    Ok((root, f_eval + r_eval * (root - tau_eval), r_eval))
}
