//! `kfold.csv` and the `kfold` section of `summary.json`: K-fold cross-validation by time
//! blocks ([`crate::fit::kfold`]), the fallback where PSIS-LOO is unreliable, kept per
//! observation so that `slipbayes compare` can rank models by it.

use std::fmt::Write;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::loo::parse_rows;
use super::RunDirError;

/// The header of `kfold.csv`.
pub const KFOLD_HEADER: &str = "run,point,observed_N,fold,elpd_kfold";

/// K-fold cross-validation of a fit, as `summary.json` reports it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct KFoldSummary {
    /// Number of folds (blocks of time per run).
    pub folds: usize,
    /// Sum over every observation of its log predictive density under the fold that left it
    /// out.
    pub elpd_kfold: f64,
    /// Its standard error, √(n · var(elpd_i)).
    pub se: f64,
    /// Effective number of parameters: the full fit's log predictive density of its own data
    /// minus elpd_kfold (`None` when the fit has no PSIS-LOO to take the former from).
    pub p_kfold: Option<f64>,
    /// Draws of each fold's posterior used.
    pub draws: usize,
    /// Folds whose fit did not meet the convergence standard (their scores are less certain).
    pub unconverged_folds: Vec<usize>,
    /// Per run, in file order.
    pub runs: Vec<RunKFold>,
}

/// One run's share of [`KFoldSummary`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunKFold {
    /// The run.
    pub run: String,
    /// Its observations.
    pub points: usize,
    /// Their elpd_kfold.
    pub elpd_kfold: f64,
    /// Its standard error.
    pub se: f64,
}

/// One observation's row of `kfold.csv`.
#[derive(Debug, Clone, PartialEq)]
pub struct KFoldPoint {
    /// The run.
    pub run: String,
    /// The observation's index in the run.
    pub point: usize,
    /// The observed force (N): what `compare` checks to know two fits saw the same data.
    pub observed_n: f64,
    /// The fold that left it out.
    pub fold: usize,
    /// Its log predictive density under that fold's posterior.
    pub elpd_kfold: f64,
}

/// The text of `kfold.csv`: one row per observation, numbers in their shortest exact form.
pub(super) fn to_csv(points: &[KFoldPoint]) -> String {
    let mut csv = format!("{KFOLD_HEADER}\n");
    for p in points {
        let _ = writeln!(
            csv,
            "{},{},{:?},{},{:?}",
            p.run, p.point, p.observed_n, p.fold, p.elpd_kfold
        );
    }
    csv
}

/// Parses `kfold.csv`.
pub(super) fn parse(path: &Path, text: &str) -> Result<Vec<KFoldPoint>, RunDirError> {
    parse_rows(path, text, KFOLD_HEADER, |row| {
        Ok(KFoldPoint {
            run: row.text(0).to_owned(),
            point: row.index(1)?,
            observed_n: row.number(2)?,
            fold: row.index(3)?,
            elpd_kfold: row.number(4)?,
        })
    })
}
