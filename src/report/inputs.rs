//! What a report reads back from a finished run directory: `summary.json` (with the optional
//! per-run data provenance), `settings.json`, `predictive.csv` and the chains.

use std::path::{Path, PathBuf};

use serde::Deserialize;

use super::ReportError;
use crate::fit::{FitSummary, SUMMARY_JSON};
use crate::storage::{read_chains, Chains};

/// File name of the run record written by `fit` and `demo`.
pub const SETTINGS_JSON: &str = "settings.json";
/// File name of the posterior predictive bands written by `fit` and `demo`.
pub const PREDICTIVE_CSV: &str = "predictive.csv";
/// File name of the exact model fitted, inside the run directory.
pub const MODEL_TOML: &str = "model.toml";

/// How a run's data were read (the optional `"data"` list of `summary.json`).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct DataRecord {
    /// Run name.
    pub run: String,
    /// Data file as given in the model.
    pub file: String,
    /// File format (e.g. `csv`, `rheocompass`).
    pub format: String,
    /// Points in the file.
    pub points_read: u64,
    /// Points the likelihood used.
    pub points_used: u64,
    /// Points dropped as invalid.
    pub dropped_invalid: u64,
    /// Time window kept, in s.
    pub window_s: Option<[f64; 2]>,
    /// Binning applied, if any.
    pub binning: Option<Binning>,
    /// Unit conversions and other changes made on reading, in words.
    #[serde(default)]
    pub conversions: Vec<String>,
}

/// Binning of a run's data.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct Binning {
    /// Number of bins.
    pub bins: u64,
    /// Mean points per bin.
    pub points_per_bin: f64,
}

/// The run record (`settings.json`): what produced the run.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct RunRecord {
    /// Version of slipbayes that wrote the run.
    pub slipbayes_version: String,
    /// The command line.
    pub command: Vec<String>,
    /// The model file given.
    pub model_file: String,
    /// Directory the model's data paths are relative to, relative to the run directory
    /// (absent in runs written before reports existed).
    #[serde(default)]
    pub data_dir: Option<String>,
    /// Sampled dimension.
    pub dimension: usize,
    /// Fit settings, as written.
    pub settings: serde_json::Value,
}

/// Posterior and posterior predictive bands of one run at its data times, as
/// `predictive.csv` holds them.
pub type PredictiveRun = crate::model::Band;

/// Fraction of a run's observations inside its 95 % predictive band.
pub fn coverage_95(run: &PredictiveRun) -> f64 {
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
pub struct RunInputs {
    /// The run directory.
    pub dir: PathBuf,
    /// `summary.json`.
    pub summary: FitSummary,
    /// The `"data"` list of `summary.json`, when the run recorded it.
    pub data: Option<Vec<DataRecord>>,
    /// `settings.json`.
    pub record: RunRecord,
    /// `predictive.csv`, per run in file order.
    pub predictive: Vec<PredictiveRun>,
    /// The chains.
    pub chains: Chains,
}

fn read_text(path: &Path) -> Result<String, ReportError> {
    std::fs::read_to_string(path).map_err(|source| ReportError::Read {
        path: path.to_path_buf(),
        source,
    })
}

fn parse_json<T: serde::de::DeserializeOwned>(path: &Path, text: &str) -> Result<T, ReportError> {
    serde_json::from_str(text).map_err(|e| ReportError::Parse {
        path: path.to_path_buf(),
        message: format!("line {}, column {}: {e}", e.line(), e.column()),
    })
}

/// The `"data"` key of a `summary.json` text: `None` when absent or null.
///
/// # Errors
/// [`ReportError::Parse`] when the key is present but not a list of data records.
pub fn data_records(
    path: &Path,
    summary_text: &str,
) -> Result<Option<Vec<DataRecord>>, ReportError> {
    let value: serde_json::Value = parse_json(path, summary_text)?;
    match value.get("data") {
        None | Some(serde_json::Value::Null) => Ok(None),
        Some(list) => serde_json::from_value(list.clone())
            .map(Some)
            .map_err(|e| ReportError::Parse {
                path: path.to_path_buf(),
                message: format!(
                    "key \"data\": {e}; expected a list of {{run, file, format, points_read, points_used, dropped_invalid, window_s, binning, conversions}}"
                ),
            }),
    }
}

/// Parses `predictive.csv` (header `run,time_s,observed_N,model_q025_N,model_median_N,
/// model_q975_N,pred_q025_N,pred_q25_N,pred_q75_N,pred_q975_N`), grouping rows by run in
/// order of first appearance.
///
/// # Errors
/// [`ReportError::Parse`] naming the line and column of a malformed field.
pub fn parse_predictive(path: &Path, text: &str) -> Result<Vec<PredictiveRun>, ReportError> {
    const COLUMNS: usize = 10;
    let mut runs: Vec<PredictiveRun> = Vec::new();
    let bad = |line: usize, message: String| ReportError::Parse {
        path: path.to_path_buf(),
        message: format!("line {line}: {message}"),
    };
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, header)) if header.split(',').count() == COLUMNS && header.starts_with("run,") => {
        }
        _ => {
            return Err(bad(
                1,
                format!("expected a header of {COLUMNS} columns starting with `run,`"),
            ))
        }
    }
    for (index, line) in lines {
        let number = index + 1;
        if line.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = line.split(',').collect();
        if fields.len() != COLUMNS {
            return Err(bad(
                number,
                format!("{} fields, expected {COLUMNS}", fields.len()),
            ));
        }
        let mut values = [0.0; COLUMNS - 1];
        for (k, field) in fields[1..].iter().enumerate() {
            values[k] = field.parse().map_err(|_| {
                bad(
                    number,
                    format!("column {}: {field:?} is not a number", k + 2),
                )
            })?;
        }
        let name = fields[0];
        if runs.last().is_none_or(|r| r.run != name) {
            runs.push(PredictiveRun {
                run: name.to_owned(),
                time_s: Vec::new(),
                observed_n: Vec::new(),
                model_n: Default::default(),
                predictive_n: Default::default(),
            });
        }
        let run = runs.last_mut().expect("pushed above");
        run.time_s.push(values[0]);
        run.observed_n.push(values[1]);
        for q in 0..3 {
            run.model_n[q].push(values[2 + q]);
        }
        for q in 0..4 {
            run.predictive_n[q].push(values[5 + q]);
        }
    }
    Ok(runs)
}

/// Reads a finished run directory.
///
/// # Errors
/// [`ReportError`] naming the file that is missing or malformed.
pub fn read_run(dir: &Path) -> Result<RunInputs, ReportError> {
    let summary_path = dir.join(SUMMARY_JSON);
    let summary_text = read_text(&summary_path)?;
    let summary: FitSummary = parse_json(&summary_path, &summary_text)?;
    let data = data_records(&summary_path, &summary_text)?;
    let settings_path = dir.join(SETTINGS_JSON);
    let record: RunRecord = parse_json(&settings_path, &read_text(&settings_path)?)?;
    let predictive_path = dir.join(PREDICTIVE_CSV);
    let predictive = parse_predictive(&predictive_path, &read_text(&predictive_path)?)?;
    let chains = read_chains(dir).map_err(|source| ReportError::Chains {
        dir: dir.to_path_buf(),
        source,
    })?;
    Ok(RunInputs {
        dir: dir.to_path_buf(),
        summary,
        data,
        record,
        predictive,
        chains,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_provenance_is_optional_and_checked() {
        let path = Path::new("summary.json");
        assert_eq!(data_records(path, r#"{"parameters": []}"#).unwrap(), None);
        let text = r#"{"data": [{"run": "ptfe-c1-first", "file": "data/a.txt",
            "format": "rheocompass", "points_read": 1200, "points_used": 1190,
            "dropped_invalid": 10, "window_s": [0.0, 3000.0],
            "binning": {"bins": 300, "points_per_bin": 3.97},
            "conversions": ["torque mN·m / 7 mm arm -> N"]}]}"#;
        let records = data_records(path, text).unwrap().unwrap();
        assert_eq!(records.len(), 1);
        assert_eq!(records[0].points_used, 1190);
        assert_eq!(records[0].binning.as_ref().unwrap().bins, 300);
        let err = data_records(path, r#"{"data": [{"run": 3}]}"#).unwrap_err();
        assert!(err.to_string().contains("\"data\""), "{err}");
    }

    #[test]
    fn predictive_csv_groups_runs_and_names_bad_lines() {
        let path = Path::new("predictive.csv");
        let header = "run,time_s,observed_N,model_q025_N,model_median_N,model_q975_N,pred_q025_N,pred_q25_N,pred_q75_N,pred_q975_N";
        let text = format!(
            "{header}\na,0,1,1,1,1,0,0.5,1.5,2\na,1,5,1,1,1,0,0.5,1.5,2\nb,0,1,1,1,1,0,1,1,2\n"
        );
        let runs = parse_predictive(path, &text).unwrap();
        assert_eq!(runs.len(), 2);
        assert_eq!(runs[0].time_s.len(), 2);
        assert!((coverage_95(&runs[0]) - 0.5).abs() < 1e-12);
        assert!((runs[1].predictive_n[3][0] - 2.0).abs() < 1e-12);
        let err = parse_predictive(path, &format!("{header}\na,0,x,1,1,1,0,0,1,2\n")).unwrap_err();
        assert!(err.to_string().contains("line 2"), "{err}");
        assert!(err.to_string().contains("column 3"), "{err}");
    }
}
