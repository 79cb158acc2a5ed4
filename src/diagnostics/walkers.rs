//! Whether an ensemble's walkers span the parameter space (emcee's `walkers_independent`):
//! an ensemble whose walkers lie (nearly) on a hyperplane can never leave it under
//! affine-invariant moves.

use nalgebra::DMatrix;

/// Largest condition number of the column-normalised, centred initial walker matrix
/// (emcee's `walkers_independent` limit).
pub const WALKER_CONDITION_LIMIT: f64 = 1e8;

/// Condition number of the centred walker matrix with columns scaled to unit norm
/// (`walkers × ndim`); +∞ when a column is constant.
pub(crate) fn walker_condition_number(positions: &[f64], ndim: usize) -> f64 {
    let walkers = positions.len() / ndim;
    let mut m = DMatrix::from_row_slice(walkers, ndim, positions);
    for mut col in m.column_iter_mut() {
        let mean = col.mean();
        col.add_scalar_mut(-mean);
        let norm = col.norm();
        if !(norm > 0.0 && norm.is_finite()) {
            return f64::INFINITY;
        }
        col /= norm;
    }
    let sv = m.singular_values();
    let max = sv.max();
    let min = sv.min();
    if min > 0.0 {
        max / min
    } else {
        f64::INFINITY
    }
}

/// The largest [`walker_condition_number`] of the walkers' coordinates in each block
/// (`blocks` of coordinate indices; the whole space when empty): under blocked updates the
/// walkers need to span each block's subspace, not the whole space.
pub(crate) fn blockwise_condition_number(
    positions: &[f64],
    ndim: usize,
    blocks: &[Vec<usize>],
) -> f64 {
    if blocks.is_empty() {
        return walker_condition_number(positions, ndim);
    }
    let mut worst: f64 = 0.0;
    for b in blocks {
        let sub: Vec<f64> = positions
            .chunks_exact(ndim)
            .flat_map(|x| b.iter().map(move |&i| x[i]))
            .collect();
        let c = walker_condition_number(&sub, b.len());
        if c.is_nan() {
            return c;
        }
        worst = worst.max(c);
    }
    worst
}
