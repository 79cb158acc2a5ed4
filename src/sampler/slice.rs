//! Univariate slice sampling (Neal 2003, "Slice sampling", Ann. Statist. 31: stepping out
//! and shrinkage), the exact update of a block whose conditional density is cheap (see
//! [`ExactConditional`](crate::density::ExactConditional)).
//!
//! One update of coordinate `i` leaves the conditional density of `x_i` given the other
//! coordinates invariant, for any initial width `w` that does not depend on `x_i` itself:
//! draw a level `y = ln f(x) − E` (E ~ Exp(1)) below the density, place an interval of width `w`
//! at random around `x_i`, step it out by `w` until both ends lie below the level (at most
//! [`MAX_STEPS_OUT`] steps in all), then draw uniformly from the interval, shrinking it towards
//! `x_i` after each point below the level. Stepping out with a random split of the budget and
//! shrinking towards the current point make the move reversible (Neal 2003, §4.3).

use rand::Rng;

/// Most widths the interval is stepped out by, shared at random between its two ends.
pub(crate) const MAX_STEPS_OUT: usize = 32;

/// Most points drawn while shrinking; the interval halves on average with each, so reaching
/// this means the level is not below the density at the current point (a broken density).
const MAX_SHRINKS: usize = 200;

/// Why a slice update could not be made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) enum SliceError {
    /// The conditional density at the current point is not finite.
    NotFinite(f64),
    /// The interval shrank onto the current point without finding a point on the slice.
    Shrunk,
}

/// One slice update of `x[i]` under the log-density `ln_f`, whose value at `x` is `ln_fx`,
/// with initial width `width`. Returns the log-density at the new point.
///
/// # Errors
/// [`SliceError`] when `ln_fx` is not finite or the interval collapses.
pub(crate) fn update_coordinate<R: Rng>(
    x: &mut [f64],
    i: usize,
    width: f64,
    ln_fx: f64,
    ln_f: &mut impl FnMut(&[f64]) -> f64,
    rng: &mut R,
) -> Result<f64, SliceError> {
    if !ln_fx.is_finite() {
        return Err(SliceError::NotFinite(ln_fx));
    }
    let x0 = x[i];
    let level = ln_fx - exponential(rng);
    let mut at = |x: &mut [f64], v: f64| {
        x[i] = v;
        ln_f(x)
    };
    let mut left = x0 - width * rng.random::<f64>();
    let mut right = left + width;
    let mut steps_left = (MAX_STEPS_OUT as f64 * rng.random::<f64>()) as usize;
    let mut steps_right = MAX_STEPS_OUT - 1 - steps_left;
    while steps_left > 0 && at(x, left) > level {
        left -= width;
        steps_left -= 1;
    }
    while steps_right > 0 && at(x, right) > level {
        right += width;
        steps_right -= 1;
    }
    for _ in 0..MAX_SHRINKS {
        let v = left + (right - left) * rng.random::<f64>();
        let f = at(x, v);
        if f > level {
            return Ok(f);
        }
        if v < x0 {
            left = v;
        } else {
            right = v;
        }
    }
    x[i] = x0;
    Err(SliceError::Shrunk)
}

/// What one slice update along a line did (see [`update_along_line`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct LineUpdate {
    /// The new position on the line.
    pub t: f64,
    /// Its log-density (the last value `ln_f` returned).
    pub ln_f: f64,
    /// Widths the interval was stepped out by.
    pub expansions: u64,
    /// Points drawn below the level, each shrinking the interval.
    pub contractions: u64,
    /// Calls of `ln_f`.
    pub evaluations: u64,
}

/// Why a slice update along a line could not be made.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum LineError<E> {
    /// `ln_f` failed (a fatal fault of the density).
    Eval(E),
    /// The interval shrank onto the start without finding a point on the slice.
    Shrunk,
}

/// One slice update (stepping out, then shrinkage) of the one-dimensional density
/// `t ↦ exp(ln_f(t))` along a line, from `t = 0` where the log-density is `ln_f0`, with
/// initial width 1 (the caller scales the line) and at most `max_steps_out` widths of
/// stepping out, shared at random between the two ends. `ln_f` returns −∞ where the density
/// refuses a point, an error only for a fatal fault; its last call is at the returned `t`.
///
/// Leaves the density on the line invariant for any scale of the line that does not depend on
/// the start (Neal 2003, §4: stepping out with a random split of the budget and shrinking
/// towards the start make the update reversible).
///
/// # Errors
/// [`LineError::Eval`] as `ln_f` fails; [`LineError::Shrunk`] when [`MAX_SHRINKS`] points
/// all lie below the level (a density that is not finite near the start).
pub(crate) fn update_along_line<R: Rng, E>(
    ln_f0: f64,
    max_steps_out: usize,
    ln_f: &mut impl FnMut(f64) -> Result<f64, E>,
    rng: &mut R,
) -> Result<LineUpdate, LineError<E>> {
    let level = ln_f0 - exponential(rng);
    let mut out = LineUpdate {
        t: 0.0,
        ln_f: ln_f0,
        expansions: 0,
        contractions: 0,
        evaluations: 0,
    };
    let mut at = |t: f64, out: &mut LineUpdate| {
        out.evaluations += 1;
        ln_f(t).map_err(LineError::Eval)
    };
    let mut left = -rng.random::<f64>();
    let mut right = left + 1.0;
    let mut steps_left = (max_steps_out as f64 * rng.random::<f64>()) as usize;
    let mut steps_right = max_steps_out.saturating_sub(1 + steps_left);
    while steps_left > 0 && at(left, &mut out)? > level {
        left -= 1.0;
        steps_left -= 1;
        out.expansions += 1;
    }
    while steps_right > 0 && at(right, &mut out)? > level {
        right += 1.0;
        steps_right -= 1;
        out.expansions += 1;
    }
    for _ in 0..MAX_SHRINKS {
        let t = left + (right - left) * rng.random::<f64>();
        let f = at(t, &mut out)?;
        if f > level {
            out.t = t;
            out.ln_f = f;
            return Ok(out);
        }
        // Shrink towards the start, which is always on the slice.
        if t < 0.0 {
            left = t;
        } else {
            right = t;
        }
        out.contractions += 1;
    }
    Err(LineError::Shrunk)
}

/// A standard exponential variate, −ln U with U in (0, 1].
fn exponential<R: Rng>(rng: &mut R) -> f64 {
    -(1.0 - rng.random::<f64>()).ln()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;

    /// Repeated updates of one coordinate sample its density: a standard normal, and a
    /// half-normal whose support ends at 0 (the stepping out must stop at the boundary).
    #[test]
    fn repeated_updates_sample_the_density() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for (name, support_low, mean, var) in [
            ("normal", f64::NEG_INFINITY, 0.0, 1.0),
            (
                "half-normal",
                0.0,
                (2.0 / std::f64::consts::PI).sqrt(),
                1.0 - 2.0 / std::f64::consts::PI,
            ),
        ] {
            let mut ln_f = |x: &[f64]| {
                if x[1] < support_low {
                    f64::NEG_INFINITY
                } else {
                    -0.5 * x[1] * x[1]
                }
            };
            // Coordinate 0 is a bystander that must not move.
            let mut x = [3.0, 0.5];
            let mut f = ln_f(&x);
            let n = 200_000;
            let (mut s1, mut s2) = (0.0, 0.0);
            for _ in 0..n {
                f = update_coordinate(&mut x, 1, 0.7, f, &mut ln_f, &mut rng).unwrap();
                assert_eq!(x[0].to_bits(), 3.0f64.to_bits());
                s1 += x[1];
                s2 += x[1] * x[1];
            }
            let m = s1 / n as f64;
            let v = s2 / n as f64 - m * m;
            // Successive slice draws of a normal are nearly independent: 5 standard errors.
            let se = (var / n as f64).sqrt();
            assert!((m - mean).abs() < 5.0 * se, "{name}: mean {m} vs {mean}");
            assert!((v - var).abs() < 0.02, "{name}: variance {v} vs {var}");
        }
    }

    /// Repeated updates along a line sample the density on it: a normal of sd 2 on a line of
    /// unit scale (so that stepping out is needed), and a half-normal whose support ends at
    /// 0, where the refused points count as evaluations outside the slice.
    #[test]
    fn repeated_updates_along_a_line_sample_the_density() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let sd = 2.0;
        let normal = |t: f64| -0.5 * (t / sd) * (t / sd);
        for (name, low, mean, var) in [
            ("normal", f64::NEG_INFINITY, 0.0, sd * sd),
            (
                "half-normal",
                0.0,
                sd * (2.0 / std::f64::consts::PI).sqrt(),
                sd * sd * (1.0 - 2.0 / std::f64::consts::PI),
            ),
        ] {
            // The line starts at the current point: t is measured from it.
            let mut x = 0.5;
            let mut f = normal(x);
            let n = 100_000;
            let (mut s1, mut s2, mut evals) = (0.0, 0.0, 0);
            for _ in 0..n {
                let mut ln_f = |t: f64| -> Result<f64, ()> {
                    let y = x + t;
                    Ok(if y < low {
                        f64::NEG_INFINITY
                    } else {
                        normal(y)
                    })
                };
                let u = update_along_line(f, MAX_STEPS_OUT, &mut ln_f, &mut rng).unwrap();
                assert_eq!(u.ln_f.to_bits(), normal(x + u.t).to_bits());
                x += u.t;
                f = u.ln_f;
                evals += u.evaluations;
                // Each end is evaluated once more than it expands (unless its budget runs
                // out), then every point drawn once.
                let drawn = u.contractions + 1;
                assert!((u.expansions + drawn..=u.expansions + drawn + 2).contains(&u.evaluations));
                s1 += x;
                s2 += x * x;
            }
            let m = s1 / n as f64;
            let v = s2 / n as f64 - m * m;
            // Successive draws are nearly independent: 5 standard errors of the mean, and the
            // variance to 2 % (its standard error is about 0.5 %).
            let se = (var / n as f64).sqrt();
            assert!((m - mean).abs() < 5.0 * se, "{name}: mean {m} vs {mean}");
            assert!(
                (v - var).abs() < 0.02 * var,
                "{name}: variance {v} vs {var}"
            );
            assert!(evals > 3 * n, "{name}: {evals} evaluations");
        }
    }

    #[test]
    fn a_fault_of_the_density_is_returned() {
        let mut rng = ChaCha8Rng::seed_from_u64(2);
        let mut ln_f = |_: f64| Err("diverged");
        let r = update_along_line(0.0, MAX_STEPS_OUT, &mut ln_f, &mut rng);
        assert_eq!(r, Err(LineError::Eval("diverged")));
    }

    #[test]
    fn a_non_finite_start_is_an_error() {
        let mut rng = ChaCha8Rng::seed_from_u64(1);
        let mut x = [0.0];
        let mut ln_f = |_: &[f64]| 0.0;
        let r = update_coordinate(&mut x, 0, 1.0, f64::NEG_INFINITY, &mut ln_f, &mut rng);
        assert_eq!(r, Err(SliceError::NotFinite(f64::NEG_INFINITY)));
    }
}
