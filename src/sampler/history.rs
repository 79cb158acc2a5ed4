//! A thinned in-memory copy of the chains, kept for the autocorrelation time and R̂.
//!
//! The stopping rule needs the whole chain, but keeping every step would cost memory in
//! proportion to the run length. Rows are kept every `thin` steps; when `max_rows` is
//! reached every other row is dropped and `thin` doubles, so between `max_rows/2` and
//! `max_rows` rows cover the run. With the default 2,048 rows, before convergence (run < 50 τ)
//! this thinning is finer than τ/20, so τ measured on the kept rows (times `thin`) stays
//! accurate; a large model keeps fewer rows
//! ([`SamplerConfig::history_rows_for`](super::SamplerConfig::history_rows_for)), never fewer
//! than 128, still finer than τ/2.
//!
//! Checkpoints do not store the history: the rows it keeps follow from the step count and
//! `max_rows`, and their values are in the chains ([`rebuild`]).

use serde::{Deserialize, Serialize};

use super::error::SamplerError;

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

/// The column form is built only for checkpoints; these methods are the reference the
/// row-major [`RowHistory`] is tested against.
#[cfg(test)]
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
}

/// The history as the sampler keeps it while running: per ensemble one row-major buffer
/// (`rows × walkers × ndim`, preallocated for `max_rows` rows), so that keeping a row is one
/// contiguous copy instead of `walkers × ndim` pushes into separate columns. Converted to
/// the column layout of [`History`] only when a state is taken.
#[derive(Debug, Clone)]
pub(crate) struct RowHistory {
    pub thin: u64,
    pub rows: usize,
    pub max_rows: usize,
    /// Values per row: `walkers × ndim`.
    pub width: usize,
    /// Per ensemble, `rows × width` values.
    pub data: Vec<Vec<f64>>,
}

impl RowHistory {
    pub(crate) fn new(ensembles: usize, width: usize, max_rows: usize) -> Self {
        Self {
            thin: 1,
            rows: 0,
            max_rows,
            width,
            data: (0..ensembles)
                .map(|_| Vec::with_capacity(max_rows * width))
                .collect(),
        }
    }

    /// The running form of a stored history (whose columns all have `rows` values).
    pub(crate) fn from_history(h: &History, width: usize) -> Self {
        let mut out = Self::new(h.series.len(), width, h.max_rows.max(h.rows + 1));
        out.thin = h.thin;
        out.rows = h.rows;
        for (buf, cols) in out.data.iter_mut().zip(&h.series) {
            buf.resize(h.rows * width, 0.0);
            for (c, col) in cols.iter().enumerate() {
                for (r, &v) in col.iter().enumerate() {
                    buf[r * width + c] = v;
                }
            }
        }
        out
    }

    /// The stored (column) form.
    pub(crate) fn to_history(&self) -> History {
        History {
            thin: self.thin,
            rows: self.rows,
            max_rows: self.max_rows,
            series: self
                .data
                .iter()
                .map(|buf| (0..self.width).map(|c| self.column(buf, c)).collect())
                .collect(),
        }
    }

    /// Column `c` (walker `c / ndim`, parameter `c % ndim`) of one ensemble's buffer.
    pub(crate) fn column(&self, buf: &[f64], c: usize) -> Vec<f64> {
        buf.iter().skip(c).step_by(self.width).copied().collect()
    }

    /// Whether the row of `step` (0-based) is kept.
    pub(crate) fn wants(&self, step: u64) -> bool {
        step % self.thin == 0
    }

    /// Appends the positions (`walkers × ndim`) of ensemble `e`; call for every ensemble of a
    /// wanted step, then [`finish_row`](Self::finish_row).
    pub(crate) fn push(&mut self, e: usize, positions: &[f64]) {
        self.data[e].extend_from_slice(positions);
    }

    /// Counts the row; at `max_rows` drops every other row (keeping rows 0, 2, 4, …) and
    /// doubles `thin`, exactly as [`History`] does.
    pub(crate) fn finish_row(&mut self) {
        self.rows += 1;
        if self.rows >= self.max_rows {
            let kept = self.rows.div_ceil(2);
            let w = self.width;
            for buf in &mut self.data {
                for r in 1..kept {
                    buf.copy_within(2 * r * w..(2 * r + 1) * w, r * w);
                }
                buf.truncate(kept * w);
            }
            self.rows = kept;
            self.thin *= 2;
        }
    }

    /// Step number of kept row `r`.
    pub(crate) fn step_of(&self, r: usize) -> u64 {
        r as u64 * self.thin
    }
}

/// The [`History`] an uninterrupted run of `steps` steps holds with `max_rows` rows, restored
/// from the recorded chains: `column(p, rows)` gives parameter `p` at the recorded `rows`
/// (indices in the chains' order: step, then ensemble, then walker; increasing), which are
/// those of the kept steps. Which steps are kept follows from running the thinning rule of
/// [`RowHistory`] itself over the step count: kept row `r` is step `r · thin`.
///
/// # Errors
/// What `column` returns, or [`SamplerError::Shape`] when a column has the wrong length.
pub(crate) fn rebuild<E: From<SamplerError>>(
    steps: u64,
    max_rows: usize,
    (ensembles, walkers, ndim): (usize, usize, usize),
    mut column: impl FnMut(usize, &[usize]) -> Result<Vec<f64>, E>,
) -> Result<History, E> {
    let mut rule = RowHistory::new(1, 0, max_rows);
    for step in 0..steps {
        if rule.wants(step) {
            rule.finish_row();
        }
    }
    let mut series = vec![vec![Vec::with_capacity(rule.rows); walkers * ndim]; ensembles];
    let block = ensembles * walkers;
    let wanted: Vec<usize> = (0..rule.rows)
        .flat_map(|r| {
            let first = rule.step_of(r) as usize * block;
            first..first + block
        })
        .collect();
    for p in 0..ndim {
        let values = column(p, &wanted)?;
        if values.len() != wanted.len() {
            return Err(SamplerError::Shape {
                what: format!("kept rows of parameter {p} for the history"),
                expected: wanted.len(),
                got: values.len(),
            }
            .into());
        }
        for (e, columns) in series.iter_mut().enumerate() {
            for w in 0..walkers {
                columns[w * ndim + p]
                    .extend((0..rule.rows).map(|r| values[(r * ensembles + e) * walkers + w]));
            }
        }
    }
    Ok(History {
        thin: rule.thin,
        rows: rule.rows,
        max_rows,
        series,
    })
}

/// Serialises exactly like [`RowHistory::to_history`] (checkpoints without a copy).
impl Serialize for RowHistory {
    fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeStruct;
        struct Columns<'h>(&'h [f64], usize);
        impl Serialize for Columns<'_> {
            fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
                let Self(buf, width) = *self;
                ser.collect_seq((0..width).map(|c| Column(buf, c, width)))
            }
        }
        struct Column<'h>(&'h [f64], usize, usize);
        impl Serialize for Column<'_> {
            fn serialize<S: serde::Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
                let Self(buf, c, width) = *self;
                ser.collect_seq(buf.iter().skip(c).step_by(width))
            }
        }
        let series: Vec<Columns<'_>> = self.data.iter().map(|b| Columns(b, self.width)).collect();
        let mut st = ser.serialize_struct("History", 4)?;
        st.serialize_field("thin", &self.thin)?;
        st.serialize_field("rows", &self.rows)?;
        st.serialize_field("max_rows", &self.max_rows)?;
        st.serialize_field("series", &series)?;
        st.end()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The row-major history thins exactly like the column one and converts both ways.
    #[test]
    fn row_history_matches_column_history() {
        let (ens, width, max_rows) = (2, 6, 64);
        let mut col = History::new(ens, width, 1, max_rows);
        let mut row = RowHistory::new(ens, width, max_rows);
        let mut x = vec![0.0; width];
        for step in 0..1000u64 {
            for (i, v) in x.iter_mut().enumerate() {
                *v = (step * 31 + i as u64 * 7) as f64 * 0.5;
            }
            assert_eq!(col.wants(step), row.wants(step));
            if col.wants(step) {
                for e in 0..ens {
                    col.push(e, &x);
                    row.push(e, &x);
                }
                col.finish_row();
                row.finish_row();
            }
        }
        assert!(col.thin > 8);
        assert_eq!(row.to_history(), col);
        assert_eq!(
            serde_json::to_string(&row).unwrap(),
            serde_json::to_string(&col).unwrap()
        );
        let back = RowHistory::from_history(&col, width);
        assert_eq!(back.data, row.data);
        assert_eq!((back.thin, back.rows), (row.thin, row.rows));
    }
}
