//! What a report reads back from a finished run directory, through the run directory's own
//! types: `model.toml`, `summary.json`, `settings.json`, `predictive.csv`, `curves.json`,
//! `truth.json` and the chains.

use super::ReportError;
use crate::fit::run_dir::{Curves, RunTruth};
use crate::fit::{FitSummary, RunDir, RunFile, RunRecord};
use crate::model::Band;
use crate::storage::ChainReader;

/// Fraction of a run's observations inside its 95 % predictive band.
pub(crate) fn coverage_95(run: &Band) -> f64 {
    let inside = (0..run.time_s.len())
        .filter(|&j| {
            let y = run.observed_n[j];
            y >= run.predictive_n[0][j] && y <= run.predictive_n[3][j]
        })
        .count();
    inside as f64 / run.time_s.len().max(1) as f64
}

/// Everything read back from a run directory.
#[derive(Debug, Clone)]
pub(crate) struct RunInputs {
    /// The run directory.
    pub dir: RunDir,
    /// `model.toml`: the runs, contacts and materials the report names (their data are not
    /// read).
    pub run: RunFile,
    /// `summary.json`.
    pub summary: FitSummary,
    /// `settings.json`.
    pub record: RunRecord,
    /// `predictive.csv`, per run in file order.
    pub predictive: Vec<Band>,
    /// `curves.json`: the curves the fit redrew from the posterior.
    pub curves: Curves,
    /// `truth.json`: the simulations behind synthetic data.
    pub truths: Vec<RunTruth>,
    /// The chains, read one row group at a time.
    pub chains: ChainReader,
}

impl RunInputs {
    /// Reads a finished run directory.
    ///
    /// # Errors
    /// [`ReportError::RunDir`] naming the file that is missing or malformed.
    pub fn read(dir: &RunDir) -> Result<Self, ReportError> {
        // settings.json first: a fit writes it once its chains are summarised, so that a
        // directory without it is no finished run, which the error says.
        let record = dir.read_record()?;
        let summary = dir.read_summary()?;
        Ok(Self {
            dir: dir.clone(),
            record,
            run: dir.read_model()?,
            predictive: dir.read_predictive()?,
            curves: dir.read_curves()?,
            truths: dir.read_truths()?,
            // Last, and checked against the summary: a run replaced while it was read is
            // refused, never reported half old and half new.
            chains: dir.finished_chain_reader(&summary)?,
            summary,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_counts_points_inside_the_outer_band() {
        let band = Band {
            run: "a".into(),
            time_s: vec![0.0, 1.0],
            observed_n: vec![1.0, 5.0],
            model_n: Default::default(),
            predictive_n: [
                vec![0.0, 0.0],
                vec![0.5, 0.5],
                vec![1.5, 1.5],
                vec![2.0, 2.0],
            ],
        };
        assert!((coverage_95(&band) - 0.5).abs() < 1e-12);
    }
}
