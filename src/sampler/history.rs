//! A thinned in-memory copy of the chains, kept for the autocorrelation time and R̂.
//!
//! The stopping rule needs the whole chain, but keeping every step would cost memory in
//! proportion to the run length. Rows are kept every `thin` steps; when `max_rows` is
//! reached every other row is dropped and `thin` doubles, so between `max_rows/2` and
//! `max_rows` rows cover the run. Before convergence (run < 50 τ) this thinning is finer
//! than τ/12, so τ measured on the kept rows (times `thin`) stays accurate.

use serde::{Deserialize, Serialize};

/// Thinned history of all ensembles.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct History {
    /// Steps between kept rows.
    pub thin: u64,
    /// Rows kept so far.
    pub rows: usize,
    /// Rows at which the history is halved.
    pub max_rows: usize,
    /// Per ensemble, per (walker, parameter) column `walker * ndim + p`, the kept values.
    pub series: Vec<Vec<Vec<f64>>>,
}

impl History {
    pub(crate) fn new(ensembles: usize, walkers: usize, ndim: usize, max_rows: usize) -> Self {
        Self {
            thin: 1,
            rows: 0,
            max_rows,
            series: vec![vec![Vec::new(); walkers * ndim]; ensembles],
        }
    }

    /// Whether the row of `step` (0-based) is kept.
    pub(crate) fn wants(&self, step: u64) -> bool {
        step % self.thin == 0
    }

    /// Appends the positions (`walkers × ndim`) of ensemble `e`; call for every ensemble of a
    /// wanted step, then [`finish_row`](Self::finish_row).
    pub(crate) fn push(&mut self, e: usize, positions: &[f64]) {
        for (col, &v) in self.series[e].iter_mut().zip(positions) {
            col.push(v);
        }
    }

    pub(crate) fn finish_row(&mut self) {
        self.rows += 1;
        if self.rows >= self.max_rows {
            for cols in &mut self.series {
                for col in cols.iter_mut() {
                    let mut k = 0;
                    col.retain(|_| {
                        k += 1;
                        (k - 1) % 2 == 0
                    });
                }
            }
            self.rows = self.rows.div_ceil(2);
            self.thin *= 2;
        }
    }

    /// Step number of kept row `r`.
    pub(crate) fn step_of(&self, r: usize) -> u64 {
        r as u64 * self.thin
    }
}
