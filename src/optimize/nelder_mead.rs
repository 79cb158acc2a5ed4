//! The Nelder–Mead simplex method: no gradients, robust to points a function refuses (+∞ or
//! NaN), which is what polishing a mode near the edge of a posterior's support needs.

/// Options of [`nelder_mead`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NelderMeadOptions {
    /// Initial simplex edge relative to `max(|x_i|, 1)`.
    pub initial_step: f64,
    /// Stop when the spread of function values in the simplex is below this (absolute).
    pub f_tol: f64,
    /// Stop when every simplex edge is below `x_tol · max(|x_i|, 1)`.
    pub x_tol: f64,
    /// Largest number of function evaluations.
    pub max_evals: usize,
    /// Restarts from the best point (a collapsed simplex can stall away from the minimum).
    pub restarts: usize,
}

impl Default for NelderMeadOptions {
    fn default() -> Self {
        Self {
            initial_step: 0.1,
            f_tol: 1e-10,
            x_tol: 1e-8,
            max_evals: 20_000,
            restarts: 3,
        }
    }
}

/// Minimises `f` from `start` with the Nelder–Mead simplex method using the
/// dimension-adaptive coefficients of Gao & Han (2012). `f` may return +∞ (or NaN) for
/// points it refuses. Returns the best point, its value and the number of evaluations.
pub fn nelder_mead<F: FnMut(&[f64]) -> f64>(
    mut f: F,
    start: &[f64],
    options: &NelderMeadOptions,
) -> (Vec<f64>, f64, usize) {
    let n = start.len();
    let nf = n as f64;
    let (alpha, beta, gamma, delta) = (1.0, 1.0 + 2.0 / nf, 0.75 - 0.5 / nf, 1.0 - 1.0 / nf);
    let mut evals = 0usize;
    let mut eval = |x: &[f64], evals: &mut usize| {
        *evals += 1;
        let v = f(x);
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    };
    let mut best = start.to_vec();
    let mut fbest = eval(&best, &mut evals);
    for _restart in 0..=options.restarts {
        let mut simplex: Vec<Vec<f64>> = vec![best.clone()];
        for i in 0..n {
            let mut v = best.clone();
            v[i] += options.initial_step * best[i].abs().max(1.0);
            simplex.push(v);
        }
        let mut fv: Vec<f64> = Vec::with_capacity(n + 1);
        fv.push(fbest);
        for v in simplex.iter().skip(1) {
            fv.push(eval(v, &mut evals));
        }
        let mut centroid = vec![0.0; n];
        let mut trial = vec![0.0; n];
        let mut trial2 = vec![0.0; n];
        while evals < options.max_evals {
            // Order: best first, worst last.
            let mut order: Vec<usize> = (0..=n).collect();
            order.sort_by(|&a, &b| fv[a].total_cmp(&fv[b]));
            simplex = order.iter().map(|&i| simplex[i].clone()).collect();
            fv = order.iter().map(|&i| fv[i]).collect();
            let size = simplex.iter().skip(1).fold(0.0f64, |m, v| {
                v.iter()
                    .zip(&simplex[0])
                    .map(|(a, b)| (a - b).abs() / b.abs().max(1.0))
                    .fold(m, f64::max)
            });
            if (fv[n] - fv[0]).abs() <= options.f_tol && size <= options.x_tol {
                break;
            }
            centroid.iter_mut().for_each(|c| *c = 0.0);
            for v in &simplex[..n] {
                for (c, &x) in centroid.iter_mut().zip(v) {
                    *c += x / nf;
                }
            }
            let point = |t: f64, out: &mut [f64], worst: &[f64]| {
                for ((o, &c), &w) in out.iter_mut().zip(&centroid).zip(worst) {
                    *o = c + t * (c - w);
                }
            };
            point(alpha, &mut trial, &simplex[n]);
            let fr = eval(&trial, &mut evals);
            if fr < fv[0] {
                point(alpha * beta, &mut trial2, &simplex[n]);
                let fe = eval(&trial2, &mut evals);
                if fe < fr {
                    simplex[n].copy_from_slice(&trial2);
                    fv[n] = fe;
                } else {
                    simplex[n].copy_from_slice(&trial);
                    fv[n] = fr;
                }
            } else if fr < fv[n - 1] {
                simplex[n].copy_from_slice(&trial);
                fv[n] = fr;
            } else {
                // Outside or inside contraction.
                let outside = fr < fv[n];
                let t = if outside { alpha * gamma } else { -gamma };
                point(t, &mut trial2, &simplex[n]);
                let fc = eval(&trial2, &mut evals);
                if fc < fr.min(fv[n]) {
                    simplex[n].copy_from_slice(&trial2);
                    fv[n] = fc;
                } else {
                    // Shrink towards the best vertex.
                    let (head, rest) = simplex.split_at_mut(1);
                    for (v, f) in rest.iter_mut().zip(fv.iter_mut().skip(1)) {
                        for (vj, &bj) in v.iter_mut().zip(&head[0]) {
                            *vj = bj + delta * (*vj - bj);
                        }
                        *f = eval(v, &mut evals);
                    }
                }
            }
        }
        let (ib, &fb) = fv
            .iter()
            .enumerate()
            .min_by(|a, b| a.1.total_cmp(b.1))
            .unwrap_or((0, &fbest));
        let improved = fb < fbest - options.f_tol;
        if fb <= fbest {
            best = simplex[ib].clone();
            fbest = fb;
        }
        if !improved || evals >= options.max_evals {
            break;
        }
    }
    (best, fbest, evals)
}
