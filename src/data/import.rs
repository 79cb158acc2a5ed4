//! Import of instrument files: a table of named columns (from CSV, Parquet, or an Anton Paar
//! RheoCompass, TA Instruments TRIOS or Malvern rSpace export) is mapped to time and friction
//! force by name and unit, converted to SI and checked before anything is fitted. The format is
//! recognised from the file's content, whatever its name; a file that is none of the exports
//! is read as a plain table, and if that fails too, the error says what was tried and why each
//! did not fit. Nothing is dropped silently: a point with text, an empty cell, a non-finite
//! number or an absurdly large one (beyond [`MAX_MAGNITUDE_SI`]) in a mapped column is an error
//! naming file, line and column, unless the caller asks to drop such points, and then they are
//! counted.

use std::borrow::Cow;
use std::fmt;
use std::path::Path;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::rheocompass::IntervalChoice;
pub use super::table::{Cell, Table};
use super::text::{decode, decode_owned, Encoding};
use super::{rheocompass, rspace, trios, DataError, Series};

mod mapping;

use mapping::map_table;

/// Default moment arm of a rheometer friction cell (m): the radius at which the sphere slides.
pub const DEFAULT_MOMENT_ARM_M: f64 = 7e-3;

/// File formats slipbayes reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Format {
    /// Comma-, semicolon- or tab-separated text with one header line.
    Csv,
    /// Apache Parquet.
    Parquet,
    /// Anton Paar RheoCompass text export, in any language (docs/model.md §9).
    Rheocompass,
    /// TA Instruments TRIOS export, text or CSV, with `[step]` blocks.
    Trios,
    /// Malvern (Netzsch) Kinexus rSpace CSV export.
    Rspace,
}

/// What format detection found, and why the formats tried before it did not fit.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Detection {
    /// The format to read the file in.
    pub format: Format,
    /// Formats tried first, each with the reason it does not fit.
    pub tried: Vec<(Format, String)>,
}

impl Detection {
    /// The tried formats and their reasons in one sentence, if any were tried.
    pub fn explain(&self) -> Option<String> {
        (!self.tried.is_empty()).then(|| {
            self.tried
                .iter()
                .map(|(f, reason)| format!("not {}: {reason}", f.described()))
                .collect::<Vec<_>>()
                .join("; ")
        })
    }
}

impl Format {
    /// The name used in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Csv => "csv",
            Self::Parquet => "parquet",
            Self::Rheocompass => "rheocompass",
            Self::Trios => "trios",
            Self::Rspace => "rspace",
        }
    }

    /// The format in words, with an article.
    fn described(self) -> &'static str {
        match self {
            Self::Csv => "a plain CSV table",
            Self::Parquet => "a Parquet file",
            Self::Rheocompass => "an Anton Paar RheoCompass export",
            Self::Trios => "a TA Instruments TRIOS export",
            Self::Rspace => "a Malvern rSpace export",
        }
    }

    /// The format of a file from its content (its name plays no part): Parquet by its magic
    /// bytes, the instrument exports by their structure, anything else as a plain table.
    pub fn detect(bytes: &[u8]) -> Detection {
        if bytes.starts_with(b"PAR1") {
            return Detection {
                format: Self::Parquet,
                tried: Vec::new(),
            };
        }
        Self::detect_text(&decode(bytes).0)
    }

    fn detect_text(text: &str) -> Detection {
        let mut tried = Vec::new();
        for format in [Self::Rheocompass, Self::Trios, Self::Rspace] {
            let recognised = match format {
                Self::Rheocompass => rheocompass::recognise(text),
                Self::Trios => trios::recognise(text),
                _ => rspace::recognise(text),
            };
            match recognised {
                Ok(_) => return Detection { format, tried },
                Err(reason) => tried.push((format, reason)),
            }
        }
        Detection {
            format: Self::Csv,
            tried,
        }
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Format {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        [
            Self::Csv,
            Self::Parquet,
            Self::Rheocompass,
            Self::Trios,
            Self::Rspace,
        ]
        .into_iter()
        .find(|f| f.name().eq_ignore_ascii_case(text.trim()))
        .ok_or_else(|| {
            format!(
                "`{text}`: give csv, parquet, rheocompass, trios or rspace (or leave it out to \
                 detect it)"
            )
        })
    }
}

/// Which time an export's points are placed on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Clock {
    /// The instrument's continuous time (RheoCompass `Time`, TRIOS `Time`, rSpace
    /// `Time (sequence)`).
    #[default]
    Global,
    /// The time of each interval, step or action, restarting in each (RheoCompass
    /// `Interval Time`, TRIOS `Step time`, rSpace `Time (action)`).
    Step,
}

impl Clock {
    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Global => "global",
            Self::Step => "step",
        }
    }
}

impl fmt::Display for Clock {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Clock {
    type Err = String;

    fn from_str(text: &str) -> Result<Self, String> {
        match text.trim() {
            "global" => Ok(Self::Global),
            "step" => Ok(Self::Step),
            _ => Err(format!(
                "`{text}`: give global (the continuous time) or step (each interval's, step's \
                 or action's own time)"
            )),
        }
    }
}

/// One mapped column: its name in the file and, when the file does not say, its unit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnRef {
    /// Column name as in the file's header.
    pub name: String,
    /// Unit (`s`, `min`, `h`, `N`, `mN`, `µN`, `N·m`, `mN·m`, `µN·m`); when absent, the
    /// file's units row, else a suffix of the name (`time_s`, `force_N`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub unit: Option<String>,
}

impl ColumnRef {
    /// A column by name, unit from the file.
    pub fn named(name: &str) -> Self {
        Self {
            name: name.to_owned(),
            unit: None,
        }
    }
}

/// Which columns hold time, friction (force or torque) and, optionally, the normal force.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ColumnMap {
    /// Time column (continuous instrument time).
    pub time: ColumnRef,
    /// Friction force, or torque (converted through the moment arm).
    pub force: ColumnRef,
    /// Normal force, optional.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normal_force: Option<ColumnRef>,
}

/// How to read one file.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportOptions {
    /// Format; detected from the file when `None`.
    pub format: Option<Format>,
    /// Column mapping; when `None`, the usual names (`time_s`/`Time`, `force_N`/`Force`/
    /// `Torque`, `normal_force_N`/`Normal Force`).
    pub columns: Option<ColumnMap>,
    /// Moment arm (m) converting torque to force.
    pub moment_arm_m: f64,
    /// Intervals (RheoCompass), steps (TRIOS) or actions (rSpace) of an export to keep.
    pub intervals: IntervalChoice,
    /// The time an export's points are placed on, when `columns` does not name it.
    pub clock: Clock,
    /// Drop points whose mapped cells are not finite numbers (and count them) instead of
    /// stopping at the first.
    pub drop_invalid: bool,
}

impl Default for ImportOptions {
    fn default() -> Self {
        Self {
            format: None,
            columns: None,
            moment_arm_m: DEFAULT_MOMENT_ARM_M,
            intervals: IntervalChoice::All,
            clock: Clock::Global,
            drop_invalid: false,
        }
    }
}

/// A file imported: the series in SI units and what was done to get it.
#[derive(Debug, Clone, PartialEq)]
pub struct Imported {
    /// The data, SI units, times strictly increasing.
    pub series: Series,
    /// 1-based line (or Parquet row) of each kept point, for later messages.
    pub lines: Vec<usize>,
    /// Format read.
    pub format: Format,
    /// Data rows read.
    pub points_read: usize,
    /// Rows dropped because a mapped cell was not a finite number (only with `drop_invalid`).
    pub dropped_invalid: usize,
    /// Unit conversions applied, in words.
    pub conversions: Vec<String>,
    /// What the reader found (intervals, columns, units), in words.
    pub found: Vec<String>,
}

/// Reads `path` with `options`: parse, map columns, convert to SI, validate.
///
/// # Errors
/// [`DataError`] naming the file and, where there is one, the line and column: unreadable
/// file, no data rows, a missing column, an unknown or contradictory unit, a cell that is not a
/// finite number (unless `drop_invalid`), times that do not strictly increase.
pub fn import(path: &Path, options: &ImportOptions) -> Result<Imported, DataError> {
    let bytes = std::fs::read(path).map_err(crate::IoError::at("read", path))?;
    import_text(Cow::Owned(bytes), path, options)
}

/// As [`import`] for the content of a file already in memory; `path` names it in messages
/// and, with its extension, helps to detect the format.
///
/// # Errors
/// As [`import`].
pub fn import_bytes(
    bytes: &[u8],
    path: &Path,
    options: &ImportOptions,
) -> Result<Imported, DataError> {
    import_text(Cow::Borrowed(bytes), path, options)
}

/// As [`import_bytes`]; a file read into memory is decoded without a copy when it is UTF-8.
fn import_text(
    bytes: Cow<'_, [u8]>,
    path: &Path,
    options: &ImportOptions,
) -> Result<Imported, DataError> {
    if options.format == Some(Format::Parquet)
        || (options.format.is_none() && bytes.starts_with(b"PAR1"))
    {
        let table = read_parquet_table(&bytes, path)?;
        refuse_intervals(&table, path, Format::Parquet, options)?;
        return map_table(&table, path, Format::Parquet, options);
    }
    let (text, encoding) = decode_owned(bytes);
    let detection = match options.format {
        Some(format) => Detection {
            format,
            tried: Vec::new(),
        },
        None => Format::detect_text(&text),
    };
    let choice = &options.intervals;
    let table = match detection.format {
        Format::Rheocompass => rheocompass::parse(text, encoding, path, choice)?,
        Format::Trios => trios::parse(text, encoding, path, choice)?,
        Format::Rspace => rspace::parse(text, encoding, path, choice)?,
        // Parquet, recognised by its magic bytes or named, was read above.
        Format::Csv | Format::Parquet => {
            let explained = detection.explain();
            let mut table = read_csv_table(&text, encoding, path)
                .map_err(|e| with_note(e, explained.as_deref()))?;
            table.tried = explained;
            table
        }
    };
    refuse_intervals(&table, path, detection.format, options)?;
    map_table(&table, path, detection.format, options)
}

/// Only exports have intervals (steps, actions): one asked of a plain table would otherwise be
/// ignored and the whole table fitted.
fn refuse_intervals(
    table: &Table,
    path: &Path,
    format: Format,
    options: &ImportOptions,
) -> Result<(), DataError> {
    match (format, &options.intervals) {
        (Format::Csv | Format::Parquet, IntervalChoice::Numbers(numbers)) => {
            Err(DataError::NoSuchInterval {
                path: path.to_owned(),
                kind: "interval",
                asked: numbers[0],
                intervals: Vec::new(),
                table: Some((format, table.rows())),
            })
        }
        _ => Ok(()),
    }
}

/// Why a file was read as a plain table, for messages.
fn read_as_csv(tried: &str) -> String {
    format!("read as a plain CSV table because it is {tried}")
}

/// Adds to an error why the file was read as a plain table.
fn with_note(error: DataError, tried: Option<&str>) -> DataError {
    let Some(tried) = tried else {
        return error;
    };
    let note = |message: String| format!("{message} — {}", read_as_csv(tried));
    match error {
        DataError::Malformed {
            path,
            line,
            column,
            message,
        } => DataError::Malformed {
            path,
            line,
            column,
            message: note(message),
        },
        DataError::Unsupported { path, message } => DataError::Unsupported {
            path,
            message: note(message),
        },
        other => other,
    }
}

/// Largest magnitude of a time (s) or force (N) read from a file: no measurement comes near
/// it, and below it the sum of squared residuals over any record stays finite (a single
/// value of 1e155 already squares to infinity).
pub const MAX_MAGNITUDE_SI: f64 = 1e100;

#[cfg(feature = "tabular")]
fn read_csv_table(text: &str, encoding: Encoding, path: &Path) -> Result<Table, DataError> {
    super::tabular::read_csv(text, encoding, path)
}

/// Without polars, CSV import reads slipbayes' own format only.
#[cfg(not(feature = "tabular"))]
fn read_csv_table(text: &str, encoding: Encoding, path: &Path) -> Result<Table, DataError> {
    let series = Series::parse_csv(text.trim_start_matches('\u{feff}'), path)?;
    let mut names = vec![
        super::TIME_COLUMN.to_owned(),
        super::FORCE_COLUMN.to_owned(),
    ];
    let mut cells = vec![
        series.time_s.iter().map(|&v| Cell::Number(v)).collect(),
        series.force_n.iter().map(|&v| Cell::Number(v)).collect(),
    ];
    if let Some(normal) = &series.normal_force_n {
        names.push(super::NORMAL_FORCE_COLUMN.to_owned());
        cells.push(normal.iter().map(|&v| Cell::Number(v)).collect());
    }
    // Blank lines are skipped by the simple parser; line numbers then shift, which only
    // this build without polars accepts.
    let lines = (2..series.len() + 2).collect();
    let units = vec![None; names.len()];
    let mut table = Table::of_cells(names, units, lines, cells, 1);
    table.found = vec![format!(
        "CSV in slipbayes' own format, {encoding} (built without polars)"
    )];
    Ok(table)
}

#[cfg(feature = "tabular")]
fn read_parquet_table(bytes: &[u8], path: &Path) -> Result<Table, DataError> {
    super::tabular::read_parquet(bytes, path)
}

#[cfg(not(feature = "tabular"))]
fn read_parquet_table(_bytes: &[u8], path: &Path) -> Result<Table, DataError> {
    Err(DataError::Unsupported {
        path: path.to_owned(),
        message: "Parquet import needs slipbayes built with the `tabular` feature (the default)"
            .into(),
    })
}

/// Where a run's data came from and what was done to them: the `data` entries of
/// `summary.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Run name.
    pub run: String,
    /// Data file as given.
    pub file: String,
    /// Format read (`csv`, `parquet`, `rheocompass`).
    pub format: String,
    /// Data rows read from the file.
    pub points_read: usize,
    /// Observations entering the likelihood (after the window).
    pub points_used: usize,
    /// Rows dropped because they held no finite number (explicit `drop_invalid`).
    pub dropped_invalid: usize,
    /// Time window kept (s), if any.
    pub window_s: Option<[f64; 2]>,
    /// The bins of sufficient statistics a long run's likelihood is evaluated on, if any.
    pub binning: Option<Binning>,
    /// Unit conversions applied.
    pub conversions: Vec<String>,
}

/// A long run's likelihood evaluated on sufficient statistics of bins of consecutive points
/// (docs/model.md §5, "Long records"): every point still enters it, the model within a bin
/// is its interpolant of degree `degree`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Binning {
    /// Number of bins.
    pub bins: usize,
    /// Mean number of points per bin.
    pub points_per_bin: f64,
    /// Observations outside every bin, evaluated one by one (around kinks, where the model
    /// curves too fast, the last one).
    pub exact_points: usize,
    /// Model evaluations per likelihood evaluation (q + 1 per bin, one per exact point).
    pub evaluations: usize,
    /// Degree q of the polynomial within a bin.
    pub degree: usize,
    /// Largest error of the log-likelihood asked for.
    pub tolerance: f64,
    /// The bound on the error of the log-likelihood that the bins' estimated interpolation
    /// errors give, wherever the residuals' RMS (σ integrated out) or σ (sampled) is at
    /// least `noise_n`.
    pub bound: f64,
    /// The noise level the bound is stated at: half the record's noise estimate from second
    /// differences (N).
    pub noise_n: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimal_commas_and_text() {
        assert_eq!(Cell::parse(" 1,5 "), Cell::Number(1.5));
        assert_eq!(Cell::parse("-2.5e-3"), Cell::Number(-2.5e-3));
        assert_eq!(Cell::parse("1,000.5"), Cell::Text("1,000.5".into()));
        assert_eq!(Cell::parse("Invalid"), Cell::Text("Invalid".into()));
        assert_eq!(Cell::parse(""), Cell::Text(String::new()));
    }
}
