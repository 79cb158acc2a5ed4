//! The arrowhead Cholesky factor of a curvature whose blocks meet only through the shared
//! coordinates, and the repair of a block's curvature that is not positive definite.

use nalgebra::{Cholesky, DMatrix, DVector, SymmetricEigen};

/// A diagonal matrix.
pub(super) fn diagonal(values: impl ExactSizeIterator<Item = f64>) -> DMatrix<f64> {
    DMatrix::from_diagonal(&DVector::from_iterator(values.len(), values))
}

/// `m` (the curvature of `coords`) with every eigenvalue without positive curvature (at most
/// 1e-12 of the largest) replaced: the eigenvector gets the fallback curvature spread along
/// it as the coordinates' fallbacks are.
pub(super) fn positive_part(
    m: &DMatrix<f64>,
    coords: &[usize],
    fallback: impl Fn(usize) -> f64,
) -> DMatrix<f64> {
    let n = coords.len();
    let eig = SymmetricEigen::new(m.clone());
    let lmax = eig.eigenvalues.iter().copied().fold(0.0f64, f64::max);
    let values = DVector::from_iterator(
        n,
        eig.eigenvalues.iter().enumerate().map(|(k, &l)| {
            if l > lmax * 1e-12 && l > 0.0 {
                l
            } else {
                let v = eig.eigenvectors.column(k);
                let variance: f64 = (0..n).map(|a| v[a] * v[a] / fallback(coords[a])).sum();
                1.0 / variance
            }
        }),
    );
    &eig.eigenvectors * DMatrix::from_diagonal(&values) * eig.eigenvectors.transpose()
}

/// The Cholesky factor `L` (`K = L Lᵀ`) of an arrowhead curvature, the shared coordinates
/// last: each block's own factor `L_j`, its coupling `M_j = L_j⁻¹ K_jS`, and the factor of the
/// Schur complement `K_SS − Σ_j M_jᵀ M_j`. Solving with it and drawing from `N(0, K⁻¹)` cost
/// O(blocks).
#[derive(Debug, Clone, PartialEq)]
pub struct ArrowheadFactor {
    pub(super) shared: Vec<usize>,
    pub(super) blocks: Vec<FactorBlock>,
    pub(super) schur: DMatrix<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub(super) struct FactorBlock {
    pub(super) coords: Vec<usize>,
    pub(super) l: DMatrix<f64>,
    pub(super) m: DMatrix<f64>,
}

impl FactorBlock {
    /// The factor of a block's curvature `own` and its coupling `cross` to the shared
    /// coordinates; `None` when `own` is not positive definite.
    pub(super) fn new(coords: &[usize], own: DMatrix<f64>, cross: &DMatrix<f64>) -> Option<Self> {
        let l = Cholesky::new(own)?.l();
        let m = l.solve_lower_triangular(cross)?;
        Some(Self {
            coords: coords.to_vec(),
            l,
            m,
        })
    }
}

impl ArrowheadFactor {
    /// `K⁻¹ g`.
    pub(super) fn solve(&self, g: &[f64]) -> Vec<f64> {
        // L y = g, block by block, then the Schur complement's rows.
        let ys: Vec<DVector<f64>> = self
            .blocks
            .iter()
            .map(|b| {
                let gj = DVector::from_iterator(b.coords.len(), b.coords.iter().map(|&i| g[i]));
                b.l.solve_lower_triangular(&gj)
                    .expect("a Cholesky factor is invertible")
            })
            .collect();
        let mut rhs = DVector::from_iterator(self.shared.len(), self.shared.iter().map(|&i| g[i]));
        for (b, y) in self.blocks.iter().zip(&ys) {
            rhs -= b.m.transpose() * y;
        }
        let y_shared = self
            .schur
            .solve_lower_triangular(&rhs)
            .expect("a Cholesky factor is invertible");
        let mut out = vec![0.0; g.len()];
        self.back_substitute(&y_shared, |j| ys[j].clone(), &mut out);
        out
    }

    /// `L⁻ᵀ z`, a draw from `N(0, K⁻¹)` when `z` is standard normal (`z` indexed by
    /// coordinate).
    pub(crate) fn draw(&self, z: &DVector<f64>) -> DVector<f64> {
        let z_shared = DVector::from_iterator(self.shared.len(), self.shared.iter().map(|&i| z[i]));
        let mut out = vec![0.0; z.len()];
        self.back_substitute(
            &z_shared,
            |j| {
                let b = &self.blocks[j];
                DVector::from_iterator(b.coords.len(), b.coords.iter().map(|&i| z[i]))
            },
            &mut out,
        );
        DVector::from_vec(out)
    }

    /// `Lᵀ u = y` for `u`, into `out` by coordinate: the shared rows `y_S` first, then each
    /// block's rows `y_j`.
    fn back_substitute(
        &self,
        y_shared: &DVector<f64>,
        y_block: impl Fn(usize) -> DVector<f64>,
        out: &mut [f64],
    ) {
        let u_shared = self
            .schur
            .tr_solve_lower_triangular(y_shared)
            .expect("a Cholesky factor is invertible");
        for (a, &i) in self.shared.iter().enumerate() {
            out[i] = u_shared[a];
        }
        for (j, b) in self.blocks.iter().enumerate() {
            let rhs = y_block(j) - &b.m * &u_shared;
            let u =
                b.l.tr_solve_lower_triangular(&rhs)
                    .expect("a Cholesky factor is invertible");
            for (a, &i) in b.coords.iter().enumerate() {
                out[i] = u[a];
            }
        }
    }

    /// The covariance `K⁻¹`, row-major `n × n`, column by column (O(n²) memory: for tests
    /// and small densities).
    pub fn to_dense(&self, n: usize) -> Vec<f64> {
        let mut cov = vec![0.0; n * n];
        let mut e = vec![0.0; n];
        for c in 0..n {
            e[c] = 1.0;
            let column = self.solve(&e);
            e[c] = 0.0;
            for (r, v) in column.into_iter().enumerate() {
                cov[r * n + c] = v;
            }
        }
        cov
    }
}
