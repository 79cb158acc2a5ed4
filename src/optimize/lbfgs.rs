//! Limited-memory BFGS with central finite-difference gradients: finds the mode of a smooth
//! log-density in tens of dimensions in a few thousand evaluations, where Nelder–Mead needs
//! tens of thousands.

/// Options of [`lbfgs`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LbfgsOptions {
    /// Pairs (s, y) kept for the inverse-Hessian approximation.
    pub memory: usize,
    /// Stop when the largest gradient component is below `g_tol · (1 + |f|)`.
    pub g_tol: f64,
    /// Stop when f improves by less than `f_tol · (1 + |f|)` three iterations in a row
    /// (1e−10: for a log-density, changes far below what any posterior summary can see).
    pub f_tol: f64,
    /// Largest number of iterations.
    pub max_iterations: usize,
}

impl Default for LbfgsOptions {
    fn default() -> Self {
        Self {
            memory: 10,
            g_tol: 1e-9,
            f_tol: 1e-10,
            max_iterations: 1000,
        }
    }
}

/// What [`lbfgs`] minimises: a function of a point, and its values one step along each axis
/// for the finite differences (by default one call per point; an objective that can evaluate
/// such points more cheaply, or in parallel, says so here). Any `FnMut(&[f64]) -> f64` is one.
pub trait Objective {
    /// The value at `x` (+∞ or NaN where refused).
    fn value(&mut self, x: &[f64]) -> f64;

    /// `[f(x + h_i e_i), f(x − h_i e_i)]` for every coordinate `i`.
    fn axis_values(&mut self, x: &[f64], h: &[f64]) -> Vec<[f64; 2]> {
        let mut p = x.to_vec();
        (0..x.len())
            .map(|i| {
                p[i] = x[i] + h[i];
                let fp = self.value(&p);
                p[i] = x[i] - h[i];
                let fm = self.value(&p);
                p[i] = x[i];
                [fp, fm]
            })
            .collect()
    }
}

impl<F: FnMut(&[f64]) -> f64> Objective for F {
    fn value(&mut self, x: &[f64]) -> f64 {
        self(x)
    }
}

/// Refused points (NaN) as +∞, which the line search backs off from.
struct Refusing<O>(O);

fn refused(v: f64) -> f64 {
    if v.is_nan() {
        f64::INFINITY
    } else {
        v
    }
}

impl<O: Objective> Objective for Refusing<O> {
    fn value(&mut self, x: &[f64]) -> f64 {
        refused(self.0.value(x))
    }

    fn axis_values(&mut self, x: &[f64], h: &[f64]) -> Vec<[f64; 2]> {
        let mut v = self.0.axis_values(x, h);
        for pair in &mut v {
            *pair = pair.map(refused);
        }
        v
    }
}

/// Central finite-difference gradient of `f` at `x` (one-sided where a side is refused).
/// Returns `None` when neither side gives a finite value along some axis.
fn gradient<O: Objective>(f: &mut O, x: &[f64], fx: f64, out: &mut [f64]) -> Option<()> {
    // ε^(1/3) balances truncation (h²) against rounding (ε/h) of a central difference.
    let h: Vec<f64> = x
        .iter()
        .map(|v| f64::EPSILON.cbrt() * v.abs().max(1.0))
        .collect();
    for ((o, [fp, fm]), h) in out.iter_mut().zip(f.axis_values(x, &h)).zip(h) {
        *o = match (fp.is_finite(), fm.is_finite()) {
            (true, true) => (fp - fm) / (2.0 * h),
            (true, false) => (fp - fx) / h,
            (false, true) => (fx - fm) / h,
            (false, false) => return None,
        };
    }
    Some(())
}

/// 1/|∂²f/∂x_i²| by central second differences (the magnitude: far from the optimum the
/// curvature may have either sign, but its size still sets the scale), or `None` when one is
/// zero or not finite.
fn diagonal_inverse_curvature<O: Objective>(f: &mut O, x: &[f64], fx: f64) -> Option<Vec<f64>> {
    // ε^(1/4) balances truncation (h²) against rounding (ε/h²) of a second difference.
    let h: Vec<f64> = x
        .iter()
        .map(|v| f64::EPSILON.powf(0.25) * v.abs().max(1.0))
        .collect();
    f.axis_values(x, &h)
        .into_iter()
        .zip(h)
        .map(|([fp, fm], h)| {
            let c = ((fp - 2.0 * fx + fm) / (h * h)).abs();
            (c.is_finite() && c > 0.0).then(|| 1.0 / c)
        })
        .collect()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// Minimises `f` from `start`. `f` may return +∞ or NaN for points it refuses; the line
/// search backs off from them. Returns the best point and its value.
pub fn lbfgs<O: Objective>(f: O, start: &[f64], options: &LbfgsOptions) -> (Vec<f64>, f64) {
    let n = start.len();
    let mut f = Refusing(f);
    let mut x = start.to_vec();
    let mut fx = f.value(&x);
    let mut g = vec![0.0; n];
    if !fx.is_finite() || gradient(&mut f, &x, fx, &mut g).is_none() {
        return (x, fx);
    }
    // Diagonal preconditioner: the coordinates of a posterior can differ in curvature by many
    // orders of magnitude, which a scalar initial inverse Hessian cannot absorb.
    let mut precondition = diagonal_inverse_curvature(&mut f, &x, fx);
    let mut s_hist: Vec<Vec<f64>> = Vec::new();
    let mut y_hist: Vec<Vec<f64>> = Vec::new();
    let mut d = vec![0.0; n];
    let mut x_new = vec![0.0; n];
    let mut g_new = vec![0.0; n];
    let mut stalls = 0;
    for _ in 0..options.max_iterations {
        let g_max = g.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
        if g_max <= options.g_tol * (1.0 + fx.abs()) {
            break;
        }
        two_loop_direction(&g, g_max, &s_hist, &y_hist, precondition.as_deref(), &mut d);
        let mut slope = dot(&g, &d);
        if slope >= 0.0 {
            // Not a descent direction (bad curvature pairs): restart along the gradient.
            s_hist.clear();
            y_hist.clear();
            for (di, gi) in d.iter_mut().zip(&g) {
                *di = -gi * 1e-3 / g_max;
            }
            slope = dot(&g, &d);
        }
        let (step, f_new) = backtracking_line_search(&mut f, &x, fx, &d, slope, &mut x_new);
        if !(f_new.is_finite() && f_new <= fx) {
            if s_hist.is_empty() && precondition.is_none() {
                break;
            }
            // A bad model of the curvature: start again from steepest descent.
            s_hist.clear();
            y_hist.clear();
            precondition = None;
            continue;
        }
        if gradient(&mut f, &x_new, f_new, &mut g_new).is_none() {
            break;
        }
        if step < 1e-6 {
            // The quasi-Newton model has gone stale (a kink or a change of curvature): rebuild
            // it at the new point.
            s_hist.clear();
            y_hist.clear();
            precondition = diagonal_inverse_curvature(&mut f, &x_new, f_new);
        }
        let s: Vec<f64> = x_new.iter().zip(&x).map(|(a, b)| a - b).collect();
        let y: Vec<f64> = g_new.iter().zip(&g).map(|(a, b)| a - b).collect();
        if dot(&s, &y) > 1e-12 * dot(&y, &y).sqrt() * dot(&s, &s).sqrt() {
            if s_hist.len() == options.memory {
                s_hist.remove(0);
                y_hist.remove(0);
            }
            s_hist.push(s);
            y_hist.push(y);
        }
        let improvement = fx - f_new;
        x.copy_from_slice(&x_new);
        g.copy_from_slice(&g_new);
        fx = f_new;
        if improvement <= options.f_tol * (1.0 + fx.abs()) {
            stalls += 1;
            if stalls >= 3 {
                break;
            }
        } else {
            stalls = 0;
        }
    }
    (x, fx)
}

/// The two-loop recursion: `d` = −H g, H the inverse Hessian that the curvature pairs
/// (`s_hist`, `y_hist`) model over a diagonal start: `precondition` if there is one, else the
/// scale of the last pair (a small step along the gradient before any).
fn two_loop_direction(
    g: &[f64],
    g_max: f64,
    s_hist: &[Vec<f64>],
    y_hist: &[Vec<f64>],
    precondition: Option<&[f64]>,
    d: &mut [f64],
) {
    d.copy_from_slice(g);
    let m = s_hist.len();
    let mut alpha = vec![0.0; m];
    for k in (0..m).rev() {
        let rho = 1.0 / dot(&y_hist[k], &s_hist[k]);
        alpha[k] = rho * dot(&s_hist[k], d);
        for (di, yi) in d.iter_mut().zip(&y_hist[k]) {
            *di -= alpha[k] * yi;
        }
    }
    match precondition {
        Some(p) => {
            for (di, pi) in d.iter_mut().zip(p) {
                *di *= pi;
            }
        }
        None => {
            let gamma = if m > 0 {
                dot(&s_hist[m - 1], &y_hist[m - 1]) / dot(&y_hist[m - 1], &y_hist[m - 1])
            } else {
                // First step: move a small distance along the gradient.
                1e-3 / g_max.max(f64::MIN_POSITIVE)
            };
            for di in d.iter_mut() {
                *di *= gamma;
            }
        }
    }
    for k in 0..m {
        let rho = 1.0 / dot(&y_hist[k], &s_hist[k]);
        let beta = rho * dot(&y_hist[k], d);
        for (di, si) in d.iter_mut().zip(&s_hist[k]) {
            *di += (alpha[k] - beta) * si;
        }
    }
    for di in d.iter_mut() {
        *di = -*di;
    }
}

/// Backtracking Armijo line search from `x` (value `fx`) along `d` (`slope` = g·d < 0): halves
/// the step from 1 until the value falls enough, at most 60 times. Returns the last step and
/// its value, the point left in `x_new`.
fn backtracking_line_search<O: Objective>(
    f: &mut O,
    x: &[f64],
    fx: f64,
    d: &[f64],
    slope: f64,
    x_new: &mut [f64],
) -> (f64, f64) {
    let n = x.len();
    let mut step = 1.0;
    let mut f_new = f64::INFINITY;
    for _ in 0..60 {
        for i in 0..n {
            x_new[i] = x[i] + step * d[i];
        }
        f_new = f.value(x_new);
        if f_new.is_finite() && f_new <= fx + 1e-4 * step * slope {
            break;
        }
        step *= 0.5;
    }
    (step, f_new)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_rosenbrock_minimum() {
        let rosen = |x: &[f64]| (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2);
        let (x, f) = lbfgs(rosen, &[-1.2, 1.0], &LbfgsOptions::default());
        assert!(
            (x[0] - 1.0).abs() < 1e-5 && (x[1] - 1.0).abs() < 1e-5,
            "{x:?} {f}"
        );
    }

    #[test]
    fn ill_conditioned_quadratic_in_20_dimensions() {
        let f = |x: &[f64]| -> f64 {
            x.iter()
                .enumerate()
                .map(|(i, v)| 10f64.powf(i as f64 / 4.0) * (v - 1.0).powi(2))
                .sum()
        };
        let (x, fx) = lbfgs(f, &[0.0; 20], &LbfgsOptions::default());
        // From f(0) ≈ 1.4e5 down to the floor of the stopping rule (improvements of 1e−13).
        assert!(fx < 1e-8, "{fx}");
        assert!(x.iter().all(|v| (v - 1.0).abs() < 1e-4), "{x:?}");
    }
}
