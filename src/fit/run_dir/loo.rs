//! `loo.csv` and the `loo` section of `summary.json`: a fit's leave-one-out predictive accuracy
//! (PSIS-LOO over its kept draws), kept per observation so that `slipbayes compare` can rank
//! models fitted to the same data without refitting them.

use std::fmt::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::RunDirError;
use crate::diagnostics::Loo;

/// The header of `loo.csv`.
pub const LOO_HEADER: &str = "run,point,observed_N,elpd_loo,pareto_k";

/// PSIS-LOO of a fit, as `summary.json` reports it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LooSummary {
    /// Sum over every observation of its leave-one-out log predictive density.
    pub elpd_loo: f64,
    /// Its standard error.
    pub se: f64,
    /// Effective number of parameters.
    pub p_loo: f64,
    /// Posterior draws used (spread evenly over the kept draws).
    pub draws: usize,
    /// Their relative efficiency (mean bulk ESS of the parameters / draws, at most 1).
    pub r_eff: f64,
    /// The Pareto k̂ above which a point's estimate is unreliable.
    pub good_k: f64,
    /// The largest k̂ of any point.
    pub max_pareto_k: f64,
    /// Points whose k̂ exceeds `good_k`.
    pub unreliable_points: usize,
    /// Per run, in file order.
    pub runs: Vec<RunLoo>,
}

/// One run's share of [`LooSummary`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunLoo {
    /// The run.
    pub run: String,
    /// Its observations.
    pub points: usize,
    /// Their elpd_loo.
    pub elpd_loo: f64,
    /// Its standard error.
    pub se: f64,
    /// Effective number of parameters.
    pub p_loo: f64,
    /// Points whose k̂ exceeds `good_k`.
    pub unreliable_points: usize,
}

impl LooSummary {
    /// The summary of `total` and its `runs`, from `draws` draws of relative efficiency `r_eff`.
    pub fn new(total: &Loo, runs: &[(String, Loo)], r_eff: f64) -> Self {
        Self {
            elpd_loo: total.elpd,
            se: total.se,
            p_loo: total.p_loo,
            draws: total.draws,
            r_eff,
            good_k: total.good_k,
            max_pareto_k: total
                .pareto_k
                .iter()
                .copied()
                .fold(f64::NEG_INFINITY, f64::max),
            unreliable_points: total.unreliable_points().len(),
            runs: runs
                .iter()
                .map(|(run, loo)| RunLoo {
                    run: run.clone(),
                    points: loo.pointwise.len(),
                    elpd_loo: loo.elpd,
                    se: loo.se,
                    p_loo: loo.p_loo,
                    unreliable_points: loo.unreliable_points().len(),
                })
                .collect(),
        }
    }
}

/// One observation's row of `loo.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct LooPoint {
    /// The run.
    pub run: String,
    /// The observation's index in the run.
    pub point: usize,
    /// The observed force (N): what `compare` checks to know two fits saw the same data.
    pub observed_n: f64,
    /// Its elpd_loo.
    pub elpd_loo: f64,
    /// Its Pareto k̂.
    pub pareto_k: f64,
}

/// The text of `loo.csv`: one row per observation, numbers in their shortest exact form.
pub(super) fn to_csv(points: &[LooPoint]) -> String {
    let mut csv = format!("{LOO_HEADER}\n");
    for p in points {
        let _ = writeln!(
            csv,
            "{},{},{:?},{:?},{:?}",
            p.run, p.point, p.observed_n, p.elpd_loo, p.pareto_k
        );
    }
    csv
}

/// Parses `loo.csv`.
pub(super) fn parse(path: &Path, text: &str) -> Result<Vec<LooPoint>, RunDirError> {
    parse_rows(path, text, LOO_HEADER, |row| {
        Ok(LooPoint {
            run: row.text(0).to_owned(),
            point: row.index(1)?,
            observed_n: row.number(2)?,
            elpd_loo: row.number(3)?,
            pareto_k: row.number(4)?,
        })
    })
}

/// One data row of a per-observation CSV file, with errors naming its line and column.
pub(super) struct Row<'a> {
    path: &'a Path,
    line: usize,
    fields: Vec<&'a str>,
}

impl Row<'_> {
    fn error(&self, message: String) -> RunDirError {
        RunDirError::Parse {
            path: self.path.to_path_buf(),
            message: format!("line {}: {message}", self.line),
        }
    }

    /// Field `i` (0-based) as text.
    pub(super) fn text(&self, i: usize) -> &str {
        self.fields[i]
    }

    /// Field `i` as a non-negative integer.
    pub(super) fn index(&self, i: usize) -> Result<usize, RunDirError> {
        let field = self.fields[i];
        field.parse().map_err(|_| {
            self.error(format!(
                "column {}: {field:?} is not a non-negative integer",
                i + 1
            ))
        })
    }

    /// Field `i` as a number.
    pub(super) fn number(&self, i: usize) -> Result<f64, RunDirError> {
        let field = self.fields[i];
        field
            .parse()
            .map_err(|_| self.error(format!("column {}: {field:?} is not a number", i + 1)))
    }
}

/// The rows of a per-observation CSV file whose first line is `header`, each turned into a
/// `T` by `read` (blank lines skipped; every row must have the header's number of fields).
pub(super) fn parse_rows<T>(
    path: &Path,
    text: &str,
    header: &str,
    read: impl Fn(&Row) -> Result<T, RunDirError>,
) -> Result<Vec<T>, RunDirError> {
    let bad = |line: usize, message: String| RunDirError::Parse {
        path: path.to_path_buf(),
        message: format!("line {line}: {message}"),
    };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, first)) if first == header => {}
        _ => return Err(bad(1, format!("expected the header `{header}`"))),
    }
    let columns = header.split(',').count();
    let mut rows = Vec::new();
    for (index, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != columns {
            return Err(bad(
                index + 1,
                format!("{} fields, expected {columns}", fields.len()),
            ));
        }
        rows.push(read(&Row {
            path,
            line: index + 1,
            fields,
        })?);
    }
    Ok(rows)
}
