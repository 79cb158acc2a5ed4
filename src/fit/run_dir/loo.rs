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
    let bad = |line: usize, message: String| RunDirError::Parse {
        path: path.to_path_buf(),
        message: format!("line {line}: {message}"),
    };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, header)) if header == LOO_HEADER => {}
        _ => return Err(bad(1, format!("expected the header `{LOO_HEADER}`"))),
    }
    let mut points = Vec::new();
    for (index, line) in lines {
        let number = index + 1;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        let [run, point, observed, elpd, k] = fields[..] else {
            return Err(bad(number, format!("{} fields, expected 5", fields.len())));
        };
        let number_in = |column: usize, field: &str| {
            field.parse::<f64>().map_err(|_| {
                bad(
                    number,
                    format!("column {column}: {field:?} is not a number"),
                )
            })
        };
        points.push(LooPoint {
            run: run.to_owned(),
            point: point
                .parse()
                .map_err(|_| bad(number, format!("column 2: {point:?} is not a point index")))?,
            observed_n: number_in(3, observed)?,
            elpd_loo: number_in(4, elpd)?,
            pareto_k: number_in(5, k)?,
        });
    }
    Ok(points)
}
