//! One bin's sufficient statistics: the moments of its data against the Lagrange basis of the
//! Chebyshev points, from which the sum of squared residuals against any polynomial of the
//! bin's degree is a quadratic form in the polynomial's values at those points.

/// Most interpolation points a bin may have (degree + 1).
pub const MAX_NODES: usize = 16;

/// The `n` Chebyshev points of the first kind on [−1, 1], in increasing order:
/// u_j = −cos((2j + 1)π / 2n).
pub(crate) fn chebyshev_points(n: usize) -> Vec<f64> {
    (0..n).map(|j| -angle(j, n).cos()).collect()
}

/// (2j + 1)π / 2n: the angle of the j-th Chebyshev point of the first kind.
fn angle(j: usize, n: usize) -> f64 {
    (2 * j + 1) as f64 * std::f64::consts::PI / (2 * n) as f64
}

/// The barycentric weights of [`chebyshev_points`]`(n)`: (−1)^j sin((2j + 1)π / 2n), up to a
/// common factor that cancels (Berrut & Trefethen 2004).
fn barycentric_weights(n: usize) -> Vec<f64> {
    (0..n)
        .map(|j| {
            let w = angle(j, n).sin();
            if j % 2 == 0 {
                w
            } else {
                -w
            }
        })
        .collect()
}

/// The Lagrange basis of the Chebyshev points of the first kind, evaluated by the
/// barycentric formula (stable at every u, exact at the points themselves).
#[derive(Debug, Clone)]
pub struct ChebyshevBasis {
    points: Vec<f64>,
    weights: Vec<f64>,
}

impl ChebyshevBasis {
    /// The basis of degree `degree` (degree + 1 points, at most [`MAX_NODES`]).
    ///
    /// # Panics
    /// When `degree + 1` exceeds [`MAX_NODES`].
    pub fn new(degree: usize) -> Self {
        let n = degree + 1;
        assert!(n <= MAX_NODES, "degree {degree} above {}", MAX_NODES - 1);
        Self {
            points: chebyshev_points(n),
            weights: barycentric_weights(n),
        }
    }

    /// Number of points (degree + 1).
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Always false: a basis has at least one point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The points on [−1, 1], increasing.
    pub fn points(&self) -> &[f64] {
        &self.points
    }

    /// ℓ_j(u) for every j into `out` (of length [`len`](Self::len)).
    pub fn eval(&self, u: f64, out: &mut [f64]) {
        let mut sum = 0.0;
        for (j, (&p, &w)) in self.points.iter().zip(&self.weights).enumerate() {
            let d = u - p;
            if d == 0.0 {
                out.iter_mut().for_each(|v| *v = 0.0);
                out[j] = 1.0;
                return;
            }
            out[j] = w / d;
            sum += out[j];
        }
        for v in out.iter_mut() {
            *v /= sum;
        }
    }
}

/// The sufficient statistics of one bin of points (u_i, y_i), u_i ∈ [−1, 1], for a
/// polynomial p of the basis' degree given by its values p_j at the Chebyshev points:
///
/// ```text
/// Σ_i (y_i − p(u_i))² = Y − 2 Σ_j b_j d_j + Σ_jk G_jk d_j d_k,   d_j = p_j − r_j
/// ```
///
/// with G_jk = Σ_i ℓ_j(u_i) ℓ_k(u_i), and Y = Σ_i y′_i², b_j = Σ_i y′_i ℓ_j(u_i) the moments of
/// the data centred on r, the bin's own least-squares polynomial (y′_i = y_i − r(u_i)).
/// Centring keeps every term the size of a residual: the moments of raw forces (≈ 1e-2 N,
/// residuals ≈ 1e-4 N, 10⁵ points) would cancel to a few digits.
#[derive(Debug, Clone, PartialEq)]
pub struct BinMoments {
    /// r_j: the bin's least-squares polynomial at the Chebyshev points.
    reference: Vec<f64>,
    /// b_j = Σ y′_i ℓ_j(u_i) (zero up to rounding: y′ is orthogonal to the basis).
    cross: Vec<f64>,
    /// G, row-major.
    gram: Vec<f64>,
    /// Y = Σ y′_i².
    centred_sq: f64,
    points: usize,
}

impl BinMoments {
    /// The moments of the points (u_i, y_i) against `basis`; `None` when the Gram matrix is
    /// not positive definite (fewer distinct points than the basis has).
    ///
    /// # Panics
    /// When `u` and `y` differ in length.
    pub fn new(basis: &ChebyshevBasis, u: &[f64], y: &[f64]) -> Option<Self> {
        assert_eq!(u.len(), y.len());
        let n = basis.len();
        let mut ell = vec![0.0; u.len() * n];
        let mut gram = vec![0.0; n * n];
        let mut raw_cross = vec![0.0; n];
        for (i, (&ui, &yi)) in u.iter().zip(y).enumerate() {
            let l = &mut ell[i * n..(i + 1) * n];
            basis.eval(ui, l);
            for j in 0..n {
                raw_cross[j] += yi * l[j];
                for k in j..n {
                    gram[j * n + k] += l[j] * l[k];
                }
            }
        }
        for j in 0..n {
            for k in 0..j {
                gram[j * n + k] = gram[k * n + j];
            }
        }
        let reference = solve_positive_definite(&gram, &raw_cross, n)?;
        let mut cross = vec![0.0; n];
        let mut centred_sq = 0.0;
        for (i, &yi) in y.iter().enumerate() {
            let l = &ell[i * n..(i + 1) * n];
            let fitted: f64 = l.iter().zip(&reference).map(|(a, b)| a * b).sum();
            let centred = yi - fitted;
            centred_sq += centred * centred;
            for j in 0..n {
                cross[j] += centred * l[j];
            }
        }
        Some(Self {
            reference,
            cross,
            gram,
            centred_sq,
            points: u.len(),
        })
    }

    /// Σ_i (y_i − p(u_i))² for the polynomial p with values `at_nodes` at the Chebyshev
    /// points (clamped at zero: rounding may take a perfect fit a hair below).
    pub fn ssr(&self, at_nodes: &[f64]) -> f64 {
        let n = self.reference.len();
        let mut d = [0.0; MAX_NODES];
        for j in 0..n {
            d[j] = at_nodes[j] - self.reference[j];
        }
        let mut linear = 0.0;
        let mut quadratic = 0.0;
        for j in 0..n {
            linear += self.cross[j] * d[j];
            let row = &self.gram[j * n..(j + 1) * n];
            let mut g = 0.0;
            for k in 0..n {
                g += row[k] * d[k];
            }
            quadratic += d[j] * g;
        }
        (self.centred_sq - 2.0 * linear + quadratic).max(0.0)
    }
}

/// Solves G x = b for a symmetric positive definite `n × n` G (row-major) by Cholesky;
/// `None` when G is not numerically positive definite.
fn solve_positive_definite(g: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; n * n];
    let scale = (0..n).map(|j| g[j * n + j]).fold(0.0, f64::max);
    for j in 0..n {
        for k in 0..=j {
            let mut s = g[j * n + k];
            for m in 0..k {
                s -= l[j * n + m] * l[k * n + m];
            }
            if j == k {
                // A pivot lost to rounding relative to the largest diagonal (or NaN): not
                // definite.
                if s.is_nan() || s <= 1e-13 * scale {
                    return None;
                }
                l[j * n + j] = s.sqrt();
            } else {
                l[j * n + k] = s / l[k * n + k];
            }
        }
    }
    let mut x = b.to_vec();
    for j in 0..n {
        for m in 0..j {
            x[j] -= l[j * n + m] * x[m];
        }
        x[j] /= l[j * n + j];
    }
    for j in (0..n).rev() {
        for m in j + 1..n {
            x[j] -= l[m * n + j] * x[m];
        }
        x[j] /= l[j * n + j];
    }
    Some(x)
}

/// Chebyshev coefficients c_0 … c_(n−1) of the polynomial of degree n − 1 through `values`
/// at [`chebyshev_points`]`(n)` (a discrete cosine transform, O(n²)).
pub(crate) fn chebyshev_coefficients(values: &[f64]) -> Vec<f64> {
    let n = values.len();
    (0..n)
        .map(|k| {
            // Point j of the increasing order is cos(θ) with θ = π − angle(j); T_k(cos θ) =
            // cos(kθ).
            let sum: f64 = values
                .iter()
                .enumerate()
                .map(|(j, v)| v * (k as f64 * (std::f64::consts::PI - angle(j, n))).cos())
                .sum();
            let c = 2.0 * sum / n as f64;
            if k == 0 {
                0.5 * c
            } else {
                c
            }
        })
        .collect()
}

/// How many times the two highest coefficients stand in for the unresolved tail of the
/// Chebyshev series beyond them: Σ_(k>n)|a_k| ≤ |a_n| / (ρ − 1) for coefficients decaying as
/// ρ^(−k), so 8 covers every decay faster than ρ = 1.125 per degree.
const TAIL_FACTOR: f64 = 8.0;

/// An estimate of max |f − p| over the bin, p the interpolant of degree `degree` at its own
/// Chebyshev points, from f's `values` at the `values.len()` (> degree + 2) Chebyshev points
/// of the same bin: the interpolant of a function f = Σ a_k T_k at the Chebyshev points of
/// the first kind errs by at most 2 Σ_(k>degree) |a_k| (each T_k with k > degree aliases to
/// ±T_r, r ≤ degree, or to zero). The a_k are read from the finer interpolant's
/// coefficients, and the tail beyond them is taken as 8 times its last two (`TAIL_FACTOR`).
pub fn interpolation_error_estimate(values: &[f64], degree: usize) -> f64 {
    let c = chebyshev_coefficients(values);
    let n = c.len();
    debug_assert!(n > degree + 2);
    let resolved: f64 = c[degree + 1..].iter().map(|v| v.abs()).sum();
    let tail = TAIL_FACTOR * (c[n - 2].abs() + c[n - 1].abs());
    2.0 * (resolved + tail)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Σ (y − p(u))² summed point by point, p given by its values at the Chebyshev points.
    fn direct_ssr(basis: &ChebyshevBasis, u: &[f64], y: &[f64], at_nodes: &[f64]) -> f64 {
        let mut l = vec![0.0; basis.len()];
        u.iter()
            .zip(y)
            .map(|(&ui, &yi)| {
                basis.eval(ui, &mut l);
                let p: f64 = l.iter().zip(at_nodes).map(|(a, b)| a * b).sum();
                (yi - p).powi(2)
            })
            .sum()
    }

    #[test]
    fn the_basis_interpolates_polynomials_of_its_degree() {
        let basis = ChebyshevBasis::new(5);
        let p = |u: f64| 0.3 - 1.2 * u + 0.7 * u.powi(3) + 0.25 * u.powi(5);
        let at: Vec<f64> = basis.points().iter().map(|&u| p(u)).collect();
        let mut l = vec![0.0; 6];
        for i in 0..=40 {
            let u = -1.0 + i as f64 / 20.0;
            basis.eval(u, &mut l);
            let q: f64 = l.iter().zip(&at).map(|(a, b)| a * b).sum();
            assert!((q - p(u)).abs() < 1e-14, "u {u}: {q} against {}", p(u));
        }
    }

    #[test]
    fn chebyshev_coefficients_of_a_known_sum() {
        // f = 0.5 T_0 − 0.25 T_2 + 0.125 T_5 on 8 points.
        let f = |u: f64| {
            let t = u.acos();
            0.5 - 0.25 * (2.0 * t).cos() + 0.125 * (5.0 * t).cos()
        };
        let values: Vec<f64> = chebyshev_points(8).iter().map(|&u| f(u)).collect();
        let c = chebyshev_coefficients(&values);
        let expected = [0.5, 0.0, -0.25, 0.0, 0.0, 0.125, 0.0, 0.0];
        for (a, b) in c.iter().zip(expected) {
            assert!((a - b).abs() < 1e-15, "{c:?}");
        }
    }

    #[test]
    fn the_error_estimate_bounds_the_error_of_an_analytic_function() {
        // e^(3u) + 1/(2 − u): analytic, coefficients decaying geometrically.
        let f = |u: f64| (3.0 * u).exp() + 1.0 / (2.0 - u);
        for degree in [3, 5, 7] {
            let fine: Vec<f64> = chebyshev_points(2 * degree + 2)
                .iter()
                .map(|&u| f(u))
                .collect();
            let estimate = interpolation_error_estimate(&fine, degree);
            let basis = ChebyshevBasis::new(degree);
            let at: Vec<f64> = basis.points().iter().map(|&u| f(u)).collect();
            let mut l = vec![0.0; degree + 1];
            let worst = (0..=2000)
                .map(|i| {
                    let u = -1.0 + i as f64 / 1000.0;
                    basis.eval(u, &mut l);
                    let p: f64 = l.iter().zip(&at).map(|(a, b)| a * b).sum();
                    (p - f(u)).abs()
                })
                .fold(0.0, f64::max);
            assert!(
                worst <= estimate && estimate <= 50.0 * worst,
                "degree {degree}: error {worst:e}, estimate {estimate:e}"
            );
        }
    }

    /// The cancellation the centring avoids: forces of 1e-2 N with residuals of 1e-9 N over
    /// 10⁵ points. The moments of the raw forces (Σy² − 2Σ y p + Σ p², all ≈ 10 N²) would
    /// leave SSR ≈ 1e-13 N² to rounding of about 1e-15 N², a relative error of 1e-2 (and
    /// 10³ in the log-likelihood at this noise); the centred moments keep it to 1e-9.
    #[test]
    fn centred_moments_keep_tiny_residuals_against_large_forces() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let basis = ChebyshevBasis::new(7);
        let n = 100_000;
        let u: Vec<f64> = (0..n)
            .map(|i| -1.0 + 2.0 * i as f64 / (n - 1) as f64)
            .collect();
        let model = |u: f64| 1e-2 * (1.0 + 0.3 * u - 0.1 * u * u);
        let y: Vec<f64> = u
            .iter()
            .map(|&ui| model(ui) + 1e-9 * (rng.random::<f64>() - 0.5) * 12f64.sqrt())
            .collect();
        let moments = BinMoments::new(&basis, &u, &y).unwrap();
        let at: Vec<f64> = basis.points().iter().map(|&p| model(p)).collect();
        let direct = direct_ssr(&basis, &u, &y, &at);
        let reduced = moments.ssr(&at);
        assert!(
            (reduced - direct).abs() <= 1e-9 * direct,
            "reduced {reduced:e}, direct {direct:e}"
        );
        // The raw moments lose most of the digits.
        let (mut syy, mut syp, mut spp) = (0.0, 0.0, 0.0);
        let mut l = vec![0.0; 8];
        for (&ui, &yi) in u.iter().zip(&y) {
            basis.eval(ui, &mut l);
            let p: f64 = l.iter().zip(&at).map(|(a, b)| a * b).sum();
            syy += yi * yi;
            syp += yi * p;
            spp += p * p;
        }
        let raw = syy - 2.0 * syp + spp;
        assert!(
            (raw - direct).abs() > 1e-4 * direct,
            "raw moments kept {raw:e} against {direct:e}"
        );
    }

    proptest! {
        /// The quadratic form of the moments equals the sum of squared residuals summed point
        /// by point, for any bin, data and polynomial.
        #[test]
        fn moments_give_the_directly_summed_ssr(
            degree in 1usize..10,
            extra in 0usize..200,
            level in -1e-1f64..1e-1,
            noise in 1e-8f64..1e-3,
            seed in 0u64..1000,
            offset in prop::collection::vec(-1e-3f64..1e-3, 10),
        ) {
            use rand::{Rng, SeedableRng};
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let basis = ChebyshevBasis::new(degree);
            // Irregular increasing points spanning [−1, 1], at least four per basis function
            // (as a planned bin has).
            let n = 4 * (degree + 1) + extra;
            let mut u: Vec<f64> = (0..n).map(|_| rng.random::<f64>()).collect();
            u.sort_by(f64::total_cmp);
            let (lo, hi) = (u[0], u[n - 1]);
            let u: Vec<f64> = u.iter().map(|v| -1.0 + 2.0 * (v - lo) / (hi - lo)).collect();
            let y: Vec<f64> = u
                .iter()
                .map(|&x| level * (1.0 + 0.5 * x) + noise * (rng.random::<f64>() - 0.5))
                .collect();
            let moments = BinMoments::new(&basis, &u, &y).unwrap();
            let at: Vec<f64> = basis
                .points()
                .iter()
                .zip(&offset)
                .map(|(&p, &o)| level * (1.0 + 0.5 * p) + o)
                .collect();
            let direct = direct_ssr(&basis, &u, &y, &at);
            let reduced = moments.ssr(&at);
            // Rounding of both sums: a few ε of the largest term, times the points.
            let scale = direct + n as f64 * noise * noise;
            prop_assert!(
                (reduced - direct).abs() <= 1e-10 * scale,
                "reduced {reduced:e}, direct {direct:e}"
            );
        }
    }
}
