//! Import of instrument files: a table of named columns (from CSV, Parquet or a RheoCompass
//! export) is mapped to time and friction force by name and unit, converted to SI and checked
//! before anything is fitted. Nothing is dropped silently: a point with text, an empty cell, a
//! non-finite number or an absurdly large one (beyond [`MAX_MAGNITUDE_SI`]) in a mapped column
//! is an error naming file, line and column, unless the caller asks to drop such points, and
//! then they are counted.

use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::rheocompass::{self, IntervalChoice};
use super::units::{parse_unit, Quantity, Unit, KNOWN_UNITS};
use super::{DataError, Series};

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
    /// Anton Paar RheoCompass text export (docs/model.md §9).
    Rheocompass,
}

impl Format {
    /// The name used in files and reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Csv => "csv",
            Self::Parquet => "parquet",
            Self::Rheocompass => "rheocompass",
        }
    }

    /// The format of a file from its extension and, for text, its first bytes.
    pub fn detect(path: &Path, bytes: &[u8]) -> Self {
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        if ext.as_deref() == Some("parquet") || bytes.starts_with(b"PAR1") {
            return Self::Parquet;
        }
        if rheocompass::looks_like(bytes) {
            return Self::Rheocompass;
        }
        Self::Csv
    }
}

impl fmt::Display for Format {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
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
    /// Intervals of a RheoCompass export to keep.
    pub intervals: IntervalChoice,
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
            drop_invalid: false,
        }
    }
}

/// A cell as read: a number, or the text found where a number belongs.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// A number (possibly non-finite).
    Number(f64),
    /// Text, or the empty string for an empty or missing cell.
    Text(String),
}

impl Cell {
    /// Parses a text cell: a number with a decimal point or a decimal comma, else text.
    pub fn parse(text: &str) -> Self {
        let t = text.trim();
        let parsed = if t.contains(',') && !t.contains('.') && t.matches(',').count() == 1 {
            t.replacen(',', ".", 1).parse::<f64>()
        } else {
            t.parse::<f64>()
        };
        match parsed {
            Ok(v) => Self::Number(v),
            Err(_) => Self::Text(t.to_owned()),
        }
    }
}

/// A table read from a file, before mapping: named columns, the units the file declares,
/// and where each row came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// Column names.
    pub names: Vec<String>,
    /// Units declared by the file (a RheoCompass units row), per column.
    pub units: Vec<Option<String>>,
    /// 1-based line of each row in the file (the row number for Parquet).
    pub lines: Vec<usize>,
    /// Cells, column-major: `cells[column][row]`.
    pub cells: Vec<Vec<Cell>>,
    /// 1-based line of the header (where a missing column is reported).
    pub header_line: usize,
    /// What the reader found, for the user (intervals, separators, encodings).
    pub found: Vec<String>,
}

impl Table {
    fn position(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n.trim() == name)
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
    let bytes = std::fs::read(path).map_err(|source| DataError::Io {
        path: path.to_owned(),
        source,
    })?;
    import_bytes(&bytes, path, options)
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
    let format = options
        .format
        .unwrap_or_else(|| Format::detect(path, bytes));
    let table = match format {
        Format::Rheocompass => rheocompass::parse(bytes, path, &options.intervals)?,
        Format::Csv => read_csv_table(bytes, path)?,
        Format::Parquet => read_parquet_table(bytes, path)?,
    };
    // Only RheoCompass exports have intervals: an interval asked of any other file would
    // otherwise be ignored and the whole table fitted.
    if let (Format::Csv | Format::Parquet, IntervalChoice::Numbers(numbers)) =
        (format, &options.intervals)
    {
        return Err(DataError::NoSuchInterval {
            path: path.to_owned(),
            asked: numbers[0],
            intervals: Vec::new(),
            table: Some((format, table.lines.len())),
        });
    }
    map_table(&table, path, format, options)
}

/// Largest magnitude of a time (s) or force (N) read from a file: no measurement comes near
/// it, and below it the sum of squared residuals over any record stays finite (a single
/// value of 1e155 already squares to infinity).
pub const MAX_MAGNITUDE_SI: f64 = 1e100;

#[cfg(feature = "tabular")]
fn read_csv_table(bytes: &[u8], path: &Path) -> Result<Table, DataError> {
    super::tabular::read_csv(bytes, path)
}

/// Without polars, CSV import reads slipbayes' own format only.
#[cfg(not(feature = "tabular"))]
fn read_csv_table(bytes: &[u8], path: &Path) -> Result<Table, DataError> {
    let text = std::str::from_utf8(bytes).map_err(|e| DataError::Unsupported {
        path: path.to_owned(),
        message: format!("not UTF-8 text ({e})"),
    })?;
    let series = Series::parse_csv(text, path)?;
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
    Ok(Table {
        units: vec![None; names.len()],
        names,
        // Blank lines are skipped by the simple parser; line numbers then shift, which only
        // this build without polars accepts.
        lines: (2..series.len() + 2).collect(),
        cells,
        header_line: 1,
        found: vec!["CSV in slipbayes' own format (built without polars)".into()],
    })
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

/// Usual names of the time, friction and normal force columns, in order of preference.
const TIME_NAMES: [&str; 3] = ["time_s", "Time", "time"];
const FORCE_NAMES: [&str; 6] = [
    "force_N",
    "Friction Force",
    "Force",
    "force",
    "Torque",
    "torque",
];
const NORMAL_NAMES: [&str; 3] = ["normal_force_N", "Normal Force", "normal_force"];

fn default_map(table: &Table, path: &Path) -> Result<ColumnMap, DataError> {
    let find = |names: &[&str]| {
        names
            .iter()
            .find(|n| table.position(n).is_some())
            .map(|n| ColumnRef::named(n))
    };
    let missing = |what: &str, names: &[&str]| DataError::Malformed {
        path: path.to_owned(),
        line: table.header_line,
        column: 1,
        message: format!(
            "no {what} column: looked for {} among the columns {}; name the column with a \
             mapping (model file: `columns = {{ time = {{ name = \"…\", unit = \"s\" }}, … }}`; \
             command line: --time-column/--force-column)",
            quoted(names.iter().copied()),
            quoted(table.names.iter().map(String::as_str)),
        ),
    };
    Ok(ColumnMap {
        time: find(&TIME_NAMES).ok_or_else(|| missing("time", &TIME_NAMES))?,
        force: find(&FORCE_NAMES).ok_or_else(|| missing("force or torque", &FORCE_NAMES))?,
        normal_force: find(&NORMAL_NAMES),
    })
}

fn quoted<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// A mapped column: where it is, its unit, and the factor to SI.
struct Resolved {
    index: usize,
    role: &'static str,
    unit: Unit,
    to_si: f64,
}

fn resolve(
    table: &Table,
    path: &Path,
    reference: &ColumnRef,
    role: &'static str,
    moment_arm_m: f64,
    conversions: &mut Vec<String>,
) -> Result<Resolved, DataError> {
    let at_header = |column: usize, message: String| DataError::Malformed {
        path: path.to_owned(),
        line: table.header_line,
        column,
        message,
    };
    let index = table.position(&reference.name).ok_or_else(|| {
        at_header(
            1,
            format!(
                "no column `{}` (the {role} column); the file has {}",
                reference.name,
                quoted(table.names.iter().map(String::as_str))
            ),
        )
    })?;
    let declared = table.units[index]
        .as_deref()
        .filter(|u| !u.trim().is_empty());
    // `time_s`, `force_N`: a unit after the last underscore.
    let suffix = reference
        .name
        .rsplit_once('_')
        .map(|(_, s)| s)
        .filter(|s| parse_unit(s).is_some());
    let written = reference.unit.as_deref().or(declared).or(suffix);
    let Some(written) = written else {
        return Err(at_header(
            index + 1,
            format!(
                "column `{}` has no unit; give one in the mapping (units: {KNOWN_UNITS})",
                reference.name
            ),
        ));
    };
    let unit = parse_unit(written).ok_or_else(|| {
        at_header(
            index + 1,
            format!(
                "unknown unit `{written}` for column `{}`; slipbayes knows {KNOWN_UNITS}",
                reference.name
            ),
        )
    })?;
    if let (Some(given), Some(file)) = (reference.unit.as_deref(), declared) {
        let file_unit = parse_unit(file);
        if file_unit.as_ref().map(|u| u.quantity) != Some(unit.quantity) {
            return Err(at_header(
                index + 1,
                format!(
                    "the mapping says column `{}` is in `{given}` but the file says `{file}`; \
                     remove the unit from the mapping or correct it",
                    reference.name
                ),
            ));
        }
    }
    let name = &reference.name;
    let to_si = match (role, unit.quantity) {
        ("time", Quantity::Time { to_s }) => {
            if (to_s - 1.0).abs() > 0.0 {
                conversions.push(format!("time `{name}`: {unit} → s (× {to_s})"));
            }
            to_s
        }
        ("force" | "normal force", Quantity::Force { to_n }) => {
            if (to_n - 1.0).abs() > 0.0 {
                conversions.push(format!("{role} `{name}`: {unit} → N (× {to_n:e})"));
            }
            to_n
        }
        ("force", Quantity::Torque { to_n_m }) => {
            if !(moment_arm_m.is_finite() && moment_arm_m > 0.0) {
                return Err(DataError::Unsupported {
                    path: path.to_owned(),
                    message: format!(
                        "moment arm {moment_arm_m} m must be > 0 to convert torque to force"
                    ),
                });
            }
            conversions.push(format!(
                "force from torque `{name}`: {unit} → N·m (× {to_n_m:e}), F = M / r with \
                 moment arm r = {moment_arm_m} m"
            ));
            to_n_m / moment_arm_m
        }
        _ => {
            return Err(at_header(
                index + 1,
                format!(
                    "column `{name}` is in `{unit}`, which is not a unit of {}; map the {role} \
                     to a column in {}",
                    if role == "time" {
                        "time"
                    } else {
                        "force or torque"
                    },
                    if role == "time" {
                        "s, min or h"
                    } else if role == "force" {
                        "N, mN, µN or N·m, mN·m, µN·m"
                    } else {
                        "N, mN or µN"
                    }
                ),
            ))
        }
    };
    Ok(Resolved {
        index,
        role,
        unit,
        to_si,
    })
}

fn map_table(
    table: &Table,
    path: &Path,
    format: Format,
    options: &ImportOptions,
) -> Result<Imported, DataError> {
    let rows = table.lines.len();
    if rows == 0 {
        return Err(DataError::Malformed {
            path: path.to_owned(),
            line: table.header_line,
            column: 1,
            message: "the file has no data rows; export the measurement with its data points"
                .into(),
        });
    }
    let map = match &options.columns {
        Some(map) => map.clone(),
        None => default_map(table, path)?,
    };
    let mut conversions = Vec::new();
    let arm = options.moment_arm_m;
    let mut mapped = vec![
        resolve(table, path, &map.time, "time", arm, &mut conversions)?,
        resolve(table, path, &map.force, "force", arm, &mut conversions)?,
    ];
    if let Some(normal) = &map.normal_force {
        mapped.push(resolve(
            table,
            path,
            normal,
            "normal force",
            arm,
            &mut conversions,
        )?);
    }
    let mut found = table.found.clone();
    found.push(format!(
        "columns used: {}",
        mapped
            .iter()
            .map(|r| format!("{} = `{}` [{}]", r.role, table.names[r.index], r.unit))
            .collect::<Vec<_>>()
            .join(", ")
    ));

    let mut series = Series {
        normal_force_n: map.normal_force.as_ref().map(|_| Vec::new()),
        ..Series::default()
    };
    let mut lines = Vec::new();
    let mut dropped_invalid = 0;
    'rows: for row in 0..rows {
        let line = table.lines[row];
        let mut values = [0.0; 3];
        for (slot, r) in mapped.iter().enumerate() {
            let cell = &table.cells[r.index][row];
            let bad = match cell {
                Cell::Number(v) if (v * r.to_si).abs() <= MAX_MAGNITUDE_SI => {
                    values[slot] = v * r.to_si;
                    continue;
                }
                Cell::Number(v) if v.is_finite() => format!(
                    "{v:e} ({:e} in {}) is beyond ±{MAX_MAGNITUDE_SI:e}: not a measurement \
                     (and its square would overflow the likelihood)",
                    v * r.to_si,
                    if r.role == "time" { "s" } else { "N" }
                ),
                Cell::Number(v) => format!("{v} is not a finite number"),
                Cell::Text(t) if t.is_empty() => "an empty cell is not a finite number".to_owned(),
                Cell::Text(t) => format!("`{t}` is not a finite number"),
            };
            if options.drop_invalid {
                dropped_invalid += 1;
                continue 'rows;
            }
            return Err(DataError::Malformed {
                path: path.to_owned(),
                line,
                column: r.index + 1,
                message: format!(
                    "column `{}` ({}): {bad}; fix the point, or drop such points explicitly \
                     (model file: `drop_invalid = true`; command line: --drop-invalid) and \
                     they are counted in the report",
                    table.names[r.index], r.role
                ),
            });
        }
        if let Some(&previous) = series.time_s.last() {
            if values[0] <= previous {
                let what = if values[0] < previous {
                    "earlier than"
                } else {
                    "equal to"
                };
                return Err(DataError::Malformed {
                    path: path.to_owned(),
                    line,
                    column: mapped[0].index + 1,
                    message: format!(
                        "time {} s is {what} the previous point's {previous} s; times must \
                         strictly increase (sort the rows, remove duplicates, or map a \
                         continuous time column rather than one that restarts per interval)",
                        values[0]
                    ),
                });
            }
        }
        series.time_s.push(values[0]);
        series.force_n.push(values[1]);
        if let Some(normal) = series.normal_force_n.as_mut() {
            normal.push(values[2]);
        }
        lines.push(line);
    }
    if series.is_empty() {
        return Err(DataError::Unsupported {
            path: path.to_owned(),
            message: format!("all {rows} points were invalid and dropped; nothing is left to fit"),
        });
    }
    Ok(Imported {
        series,
        lines,
        format,
        points_read: rows,
        dropped_invalid,
        conversions,
        found,
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
    /// Points entering the likelihood (bins when binned).
    pub points_used: usize,
    /// Rows dropped because they held no finite number (explicit `drop_invalid`).
    pub dropped_invalid: usize,
    /// Time window kept (s), if any.
    pub window_s: Option<[f64; 2]>,
    /// Binning, if any.
    pub binning: Option<Binning>,
    /// Unit conversions applied.
    pub conversions: Vec<String>,
}

/// Binning of a run's points into bins of consecutive points.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Binning {
    /// Number of bins.
    pub bins: usize,
    /// Mean number of points per bin.
    pub points_per_bin: f64,
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
