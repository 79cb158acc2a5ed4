//! A safeguarded Newton iteration on a bracket: Newton where it behaves, bisection where it
//! does not, so it always converges.

/// Relative step below which a Newton iterate is final: the next step would be of order its
/// square (about 1e−20 relative), far below one ulp.
pub(crate) const NEWTON_REL_STEP: f64 = 1e-10;

/// Enough halvings to shrink any finite bracket of doubles to adjacent values; reaching it
/// means the function is not continuous on the bracket.
const MAX_ITERATIONS: usize = 2200;

/// Finds the root of `f` in `[lo, hi]`, where `f(lo) <= 0 <= f(hi)` (an increasing crossing).
///
/// `f` returns the value and the derivative at a point. `guess` is used when it lies strictly
/// inside the bracket.
///
/// When the root comes from a Newton step it lies one tiny step beyond the last point where
/// `f` was evaluated, so callers may carry values along the tangent.
///
/// Returns `None` when `f` returns NaN, or if the bracket does not shrink to a root, which
/// cannot happen for a function continuous on the bracket.
pub(crate) fn increasing_root(
    mut f: impl FnMut(f64) -> (f64, f64),
    mut lo: f64,
    mut hi: f64,
    guess: f64,
) -> Option<f64> {
    let mut x = if guess > lo && guess < hi {
        guess
    } else {
        lo + 0.5 * (hi - lo)
    };
    let mut previous_step = hi - lo;
    for _ in 0..MAX_ITERATIONS {
        let (value, slope) = f(x);
        if value.is_nan() {
            return None;
        }
        if value > 0.0 {
            hi = x;
        } else if value < 0.0 {
            lo = x;
        } else {
            return Some(x);
        }
        let newton = x - value / slope;
        let step = x - newton;
        // Newton unless it leaves the bracket or does not at least halve the previous step
        // (the rtsafe safeguard); a non-positive slope fails the bracket test via NaN/inf.
        let newton_ok = newton > lo && newton < hi && step.abs() * 2.0 <= previous_step.abs();
        if newton_ok {
            if step.abs() <= NEWTON_REL_STEP * x.abs() {
                return Some(newton);
            }
            previous_step = step;
            x = newton;
        } else {
            let mid = lo + 0.5 * (hi - lo);
            if mid <= lo || mid >= hi {
                // Adjacent doubles: the bracket is as small as it gets.
                return Some(mid);
            }
            previous_step = hi - lo;
            x = mid;
        }
    }
    None
}
