//! Data sets: friction force against instrument time, as CSV, and files written atomically.
//!
//! The simplest format is the one `slipbayes simulate` writes: a header `time_s,force_N`
//! (optionally `,normal_force_N`) and one row per sample, numbers in shortest round-trip
//! notation so that a file reads back bit-exactly. Every output file goes through
//! [`write_atomically`], so no half-written file is ever left looking complete.
//!
//! Users' instrument files come in through [`mod@import`]: CSV and Parquet tables (through polars,
//! feature `tabular`) and the exports of rotational rheometers — Anton Paar RheoCompass
//! ([`rheocompass`], in any interface language), TA Instruments TRIOS ([`trios`]) and Malvern
//! rSpace ([`rspace`]) — recognised by their structure ([`text`] decodes them and reads their
//! numbers in any locale, [`labels`] knows their column labels in several languages). Columns
//! are mapped by name and unit ([`units`]), converted to SI and checked before any fit.
//!
//! This module knows nothing of the friction law.

pub mod atomic;
mod blocks;
pub mod follow;
pub mod import;
pub mod labels;
#[cfg(any(feature = "parquet", feature = "tabular"))]
pub(crate) mod parquet_footer;
pub mod rheocompass;
pub mod rspace;
mod table;
#[cfg(feature = "tabular")]
mod tabular;
pub mod text;
pub mod trios;
pub mod units;

pub use atomic::write_atomically;
pub use import::{
    import, Clock, ColumnMap, ColumnRef, Detection, Format, ImportOptions, Imported, Provenance,
};
pub use rheocompass::IntervalChoice;

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

/// Column names of the simple CSV format.
pub const TIME_COLUMN: &str = "time_s";
/// Friction force column.
pub const FORCE_COLUMN: &str = "force_N";
/// Optional normal force column.
pub const NORMAL_FORCE_COLUMN: &str = "normal_force_N";

/// Errors reading or writing data sets.
#[derive(Debug, thiserror::Error)]
pub enum DataError {
    /// The file could not be read or written.
    #[error(transparent)]
    Io(#[from] crate::IoError),
    /// The content is malformed at a known place.
    #[error("{path}:{line}:{column}: {message}")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: usize,
        /// 1-based column (field number).
        column: usize,
        /// What is wrong and what to do.
        message: String,
    },
    /// The file as a whole cannot be used (empty, unknown format, missing feature).
    #[error("{path}: {message}")]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is wrong and what to do.
        message: String,
    },
    /// An interval (TRIOS step, rSpace action) was asked for that the file does not have: an
    /// export without that number, or a table (CSV, Parquet) that has no intervals at all.
    #[error("{path}: no {kind} {asked}; {}", interval_list(kind, intervals, *table))]
    NoSuchInterval {
        /// The file.
        path: PathBuf,
        /// What the export calls its blocks: `interval`, `step` or `action`.
        kind: &'static str,
        /// The first interval number asked for that the file does not have.
        asked: usize,
        /// The intervals the export has: (number, data points), in file order.
        intervals: Vec<(usize, usize)>,
        /// For a file without intervals: its format and data rows.
        table: Option<(Format, usize)>,
    },
    /// Columns of a series differ in length.
    #[error("series columns differ in length: {what}")]
    Ragged {
        /// Which columns.
        what: String,
    },
}

/// What a file holds instead of the interval asked for, and what to write.
fn interval_list(
    kind: &str,
    intervals: &[(usize, usize)],
    table: Option<(Format, usize)>,
) -> String {
    if let Some((format, rows)) = table {
        return format!(
            "the file is a {format} table of {rows} data rows without intervals (intervals, \
             steps and actions are those of RheoCompass, TRIOS and rSpace exports): remove \
             `interval` (command line: --interval), or give `format = \"rheocompass\"`, \
             `\"trios\"` or `\"rspace\"` if the file is such an export"
        );
    }
    let listed: Vec<String> = intervals
        .iter()
        .map(|&(n, points)| format!("{n} ({points} point{})", if points == 1 { "" } else { "s" }))
        .collect();
    format!(
        "the file has {kind}s {}: give one of them (model file: `interval = N` or a list; \
         command line: --interval N)",
        listed.join(", ")
    )
}

/// A recorded slide: force against instrument time, SI units.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Instrument time (s), strictly increasing.
    pub time_s: Vec<f64>,
    /// Friction force (N).
    pub force_n: Vec<f64>,
    /// Normal force (N), when recorded.
    pub normal_force_n: Option<Vec<f64>>,
}

impl Series {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Whether the series has no samples.
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }

    fn check_shape(&self) -> Result<(), DataError> {
        let n = self.time_s.len();
        let normal_ok = self.normal_force_n.as_ref().is_none_or(|v| v.len() == n);
        if self.force_n.len() != n || !normal_ok {
            return Err(DataError::Ragged {
                what: format!(
                    "{} times, {} forces, {} normal forces",
                    n,
                    self.force_n.len(),
                    self.normal_force_n.as_ref().map_or(0, Vec::len)
                ),
            });
        }
        Ok(())
    }

    /// The series as CSV text in the simple format.
    ///
    /// # Errors
    /// [`DataError::Ragged`] when the columns differ in length.
    pub fn to_csv(&self) -> Result<String, DataError> {
        self.check_shape()?;
        let mut out = String::with_capacity(40 * (self.len() + 1));
        out.push_str(TIME_COLUMN);
        out.push(',');
        out.push_str(FORCE_COLUMN);
        if self.normal_force_n.is_some() {
            out.push(',');
            out.push_str(NORMAL_FORCE_COLUMN);
        }
        out.push('\n');
        for i in 0..self.len() {
            // `{:?}` is Rust's shortest representation that reads back to the same double.
            let _ = write!(out, "{:?},{:?}", self.time_s[i], self.force_n[i]);
            if let Some(normal) = &self.normal_force_n {
                let _ = write!(out, ",{:?}", normal[i]);
            }
            out.push('\n');
        }
        Ok(out)
    }

    /// Writes the series to `path` atomically.
    ///
    /// # Errors
    /// [`DataError::Io`] naming the path, or [`DataError::Ragged`].
    pub fn write_csv(&self, path: &Path) -> Result<(), DataError> {
        let text = self.to_csv()?;
        write_atomically(path, text.as_bytes()).map_err(crate::IoError::at("write", path))?;
        Ok(())
    }

    /// Reads a series in the simple format (`time_s,force_N[,normal_force_N]`).
    ///
    /// # Errors
    /// [`DataError::Io`] when the file cannot be read; [`DataError::Malformed`] naming line and
    /// column for a wrong header, a missing or extra field, or a number that does not parse.
    pub fn read_csv(path: &Path) -> Result<Self, DataError> {
        let text = fs::read_to_string(path).map_err(crate::IoError::at("read", path))?;
        Self::parse_csv(&text, path)
    }

    /// Parses CSV text in the simple format; `path` is used in error messages only.
    ///
    /// # Errors
    /// As [`Series::read_csv`].
    pub fn parse_csv(text: &str, path: &Path) -> Result<Self, DataError> {
        let malformed = |line: usize, column: usize, message: String| DataError::Malformed {
            path: path.to_owned(),
            line,
            column,
            message,
        };
        let mut lines = text.lines().enumerate();
        let (_, header) = lines.next().ok_or_else(|| {
            malformed(
                1,
                1,
                "the file is empty; expected a header line `time_s,force_N`".into(),
            )
        })?;
        let names: Vec<&str> = header
            .trim_start_matches('\u{feff}')
            .split(',')
            .map(str::trim)
            .collect();
        let with_normal = match names.as_slice() {
            [TIME_COLUMN, FORCE_COLUMN] => false,
            [TIME_COLUMN, FORCE_COLUMN, NORMAL_FORCE_COLUMN] => true,
            _ => {
                return Err(malformed(
                    1,
                    1,
                    format!(
                        "header is `{header}`; expected `{TIME_COLUMN},{FORCE_COLUMN}` \
                         optionally followed by `,{NORMAL_FORCE_COLUMN}`"
                    ),
                ))
            }
        };
        let width = names.len();
        let mut series = Series {
            normal_force_n: with_normal.then(Vec::new),
            ..Series::default()
        };
        for (index, line) in lines {
            let line_no = index + 1;
            if line.trim().is_empty() {
                continue;
            }
            let fields: Vec<&str> = line.split(',').collect();
            if fields.len() != width {
                return Err(malformed(
                    line_no,
                    fields.len().min(width) + 1,
                    format!(
                        "expected {width} comma-separated fields, found {}",
                        fields.len()
                    ),
                ));
            }
            let mut values = [0.0; 3];
            for (column, field) in fields.iter().enumerate() {
                values[column] = field.trim().parse::<f64>().map_err(|_| {
                    malformed(
                        line_no,
                        column + 1,
                        format!(
                            "`{}` in column `{}` is not a number",
                            field.trim(),
                            names[column]
                        ),
                    )
                })?;
            }
            series.time_s.push(values[0]);
            series.force_n.push(values[1]);
            if let Some(normal) = series.normal_force_n.as_mut() {
                normal.push(values[2]);
            }
        }
        Ok(series)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn csv_round_trip_is_bit_exact() {
        let series = Series {
            time_s: vec![0.0, 0.1, 1.0 / 3.0, 1e300, 5e-324],
            force_n: vec![
                0.0,
                -1.5e-3,
                std::f64::consts::PI,
                1e-300,
                2.2250738585072014e-308,
            ],
            normal_force_n: Some(vec![0.05, 0.05, 0.0501, 1.0, 2.0]),
        };
        let text = series.to_csv().unwrap();
        let back = Series::parse_csv(&text, Path::new("mem.csv")).unwrap();
        for (a, b) in series.force_n.iter().zip(&back.force_n) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
        for (a, b) in series.time_s.iter().zip(&back.time_s) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }

    #[test]
    fn malformed_number_names_line_and_column() {
        let err =
            Series::parse_csv("time_s,force_N\n0,1\n1,abc\n", Path::new("x.csv")).unwrap_err();
        let msg = err.to_string();
        assert!(msg.starts_with("x.csv:3:2:"), "{msg}");
        assert!(msg.contains("force_N"), "{msg}");
    }

    #[test]
    fn wrong_header_is_rejected() {
        let err = Series::parse_csv("t,F\n0,1\n", Path::new("x.csv")).unwrap_err();
        assert!(err.to_string().contains("expected `time_s,force_N`"));
    }
}
