//! A first slide through a spring in batches: anchors solved one after the other, the points
//! between two anchors together from the anchors' Hermite interpolant.

use super::lanes::LawLanes;
use super::newton::{newton_step, third_order_step, Start};
use super::{batch_of, Tally, CLEAN_CHUNKS_TO_GROW, LANES, MAX_BATCHES_PER_CHUNK, MAX_ROUNDS};
use crate::law::observed::solve_point;
use crate::law::{Law, LawError};

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

#[inline(always)]
pub(super) fn spring_lanes<V: FnMut(usize, f64, f64), T: Tally>(
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
