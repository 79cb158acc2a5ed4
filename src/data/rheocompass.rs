//! Anton Paar RheoCompass text exports (docs/model.md §9): a header block (`Project:`, `Test:`,
//! `Result:`), then per interval a line `Interval and data points:<TAB>i<TAB>n`, a line
//! `Interval data:` with the column names, a units row (`[s]`, `[mN·m]`, …) and data rows that
//! start with an empty field. Tabs or commas separate fields; the text is UTF-8, UTF-16 with a
//! byte-order mark, or Latin-1; numbers may use a decimal comma; invalid points carry text
//! where numbers belong. The reader keeps every cell as found and leaves judging them to the
//! mapping ([`mod@super::import`]).

use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::import::{Cell, Table};
use super::DataError;

/// Which intervals of an export to keep.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(try_from = "IntervalSpec", into = "IntervalSpec")]
pub enum IntervalChoice {
    /// Every interval, in file order (their `Time` column is continuous).
    #[default]
    All,
    /// These interval numbers (1-based, as in the file), in this order.
    Numbers(Vec<usize>),
}

impl fmt::Display for IntervalChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::All => f.write_str("all"),
            Self::Numbers(n) => {
                f.write_str(&n.iter().map(usize::to_string).collect::<Vec<_>>().join(","))
            }
        }
    }
}

impl std::str::FromStr for IntervalChoice {
    type Err = String;

    /// `all`, a number, or numbers separated by commas.
    fn from_str(text: &str) -> Result<Self, String> {
        if text.trim().eq_ignore_ascii_case("all") {
            return Ok(Self::All);
        }
        let numbers = text
            .split(',')
            .map(|s| s.trim().parse::<usize>())
            .collect::<Result<Vec<_>, _>>()
            .map_err(|_| format!("`{text}`: give `all`, an interval number or numbers like 1,2"))?;
        Self::try_from(IntervalSpec::Many(numbers))
    }
}

/// How a model file writes the choice: `interval = 2`, `[1, 2]` or `"all"`.
#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(untagged)]
pub enum IntervalSpec {
    /// One interval.
    One(usize),
    /// Several intervals.
    Many(Vec<usize>),
    /// `"all"`.
    Word(String),
}

impl TryFrom<IntervalSpec> for IntervalChoice {
    type Error = String;

    fn try_from(spec: IntervalSpec) -> Result<Self, String> {
        let numbers = match spec {
            IntervalSpec::Word(w) if w.eq_ignore_ascii_case("all") => return Ok(Self::All),
            IntervalSpec::Word(w) => {
                return Err(format!(
                    "`{w}`: give \"all\", a number or a list of numbers"
                ))
            }
            IntervalSpec::One(n) => vec![n],
            IntervalSpec::Many(n) => n,
        };
        if numbers.is_empty() || numbers.contains(&0) {
            return Err("interval numbers start at 1, as in the file; give at least one".into());
        }
        Ok(Self::Numbers(numbers))
    }
}

impl From<IntervalChoice> for IntervalSpec {
    fn from(choice: IntervalChoice) -> Self {
        match choice {
            IntervalChoice::All => Self::Word("all".into()),
            IntervalChoice::Numbers(n) if n.len() == 1 => Self::One(n[0]),
            IntervalChoice::Numbers(n) => Self::Many(n),
        }
    }
}

const INTERVAL_MARK: &str = "Interval and data points:";
const COLUMNS_MARK: &str = "Interval data:";

/// Whether the bytes look like a RheoCompass export (its interval markers near the start).
pub fn looks_like(bytes: &[u8]) -> bool {
    let head = &bytes[..bytes.len().min(8192)];
    let (text, _) = decode(head);
    text.contains(INTERVAL_MARK) || text.contains(COLUMNS_MARK)
}

/// Decodes the text and names the encoding found.
pub(super) fn decode(bytes: &[u8]) -> (String, &'static str) {
    let utf16 = |rest: &[u8], little: bool| {
        let units = rest.chunks_exact(2).map(|p| {
            if little {
                u16::from_le_bytes([p[0], p[1]])
            } else {
                u16::from_be_bytes([p[0], p[1]])
            }
        });
        char::decode_utf16(units)
            .map(|c| c.unwrap_or(char::REPLACEMENT_CHARACTER))
            .collect::<String>()
    };
    if let Some(rest) = bytes.strip_prefix(&[0xFF, 0xFE]) {
        return (utf16(rest, true), "UTF-16LE with BOM");
    }
    if let Some(rest) = bytes.strip_prefix(&[0xFE, 0xFF]) {
        return (utf16(rest, false), "UTF-16BE with BOM");
    }
    if let Some(rest) = bytes.strip_prefix(&[0xEF, 0xBB, 0xBF]) {
        if let Ok(text) = std::str::from_utf8(rest) {
            return (text.to_owned(), "UTF-8 with BOM");
        }
    }
    match std::str::from_utf8(bytes) {
        Ok(text) => (text.to_owned(), "UTF-8"),
        // Older Windows exports: one byte per character (µ = 0xB5).
        Err(_) => (bytes.iter().map(|&b| char::from(b)).collect(), "Latin-1"),
    }
}

/// Splits a line at `separator`, honouring double quotes (a status text may hold commas).
fn split_fields(line: &str, separator: char) -> Vec<String> {
    let mut fields = Vec::new();
    let mut field = String::new();
    let mut quoted = false;
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                field.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            c if c == separator && !quoted => fields.push(std::mem::take(&mut field)),
            c => field.push(c),
        }
    }
    fields.push(field);
    fields
}

/// One interval as found.
#[derive(Debug, Default)]
struct Interval {
    number: usize,
    declared: Option<usize>,
    names: Vec<String>,
    units: Vec<Option<String>>,
    header_line: usize,
    lines: Vec<usize>,
    rows: Vec<Vec<Cell>>,
}

/// Parses an export and keeps the intervals `choice` names, concatenated.
///
/// # Errors
/// [`DataError::Malformed`] naming the line for an interval without column names, data before
/// any interval, or intervals to be joined whose columns differ; [`DataError::Unsupported`]
/// when no interval is found; [`DataError::NoSuchInterval`] when a chosen interval is not in
/// the file.
pub fn parse(bytes: &[u8], path: &Path, choice: &IntervalChoice) -> Result<Table, DataError> {
    let (text, encoding) = decode(bytes);
    let malformed = |line: usize, column: usize, message: String| DataError::Malformed {
        path: path.to_owned(),
        line,
        column,
        message,
    };
    let separator = text
        .lines()
        .find(|l| l.trim_start_matches('\u{feff}').starts_with(COLUMNS_MARK))
        .map_or('\t', |l| if l.contains('\t') { '\t' } else { ',' });
    let mut found = vec![format!(
        "RheoCompass export, {encoding}, {}-separated",
        if separator == '\t' { "tab" } else { "comma" }
    )];
    let mut intervals: Vec<Interval> = Vec::new();
    let mut expect_units = false;
    let mut decimal_comma = false;
    for (index, raw) in text.lines().enumerate() {
        let line_no = index + 1;
        let line = raw.trim_start_matches('\u{feff}').trim_end_matches('\r');
        if line.trim().is_empty() {
            continue;
        }
        let fields = split_fields(line, separator);
        let first = fields[0].trim();
        if first.starts_with(INTERVAL_MARK) {
            let number = fields.get(1).and_then(|s| s.trim().parse::<usize>().ok());
            let Some(number) = number else {
                return Err(malformed(
                    line_no,
                    2,
                    format!("`{INTERVAL_MARK}` must be followed by the interval number"),
                ));
            };
            intervals.push(Interval {
                number,
                declared: fields.get(2).and_then(|s| s.trim().parse().ok()),
                ..Interval::default()
            });
            continue;
        }
        if first.starts_with(COLUMNS_MARK) {
            let Some(interval) = intervals.last_mut() else {
                return Err(malformed(
                    line_no,
                    1,
                    format!("`{COLUMNS_MARK}` before any `{INTERVAL_MARK}` line"),
                ));
            };
            // Rows already read have the first header's width (a fuzzing find).
            if !interval.names.is_empty() {
                return Err(malformed(
                    line_no,
                    1,
                    format!(
                        "a second `{COLUMNS_MARK}` line in interval {}; each interval has one \
                         (was the file joined from two exports?)",
                        interval.number
                    ),
                ));
            }
            interval.names = fields[1..].iter().map(|s| s.trim().to_owned()).collect();
            interval.units = vec![None; interval.names.len()];
            interval.header_line = line_no;
            expect_units = true;
            continue;
        }
        if !first.is_empty() {
            // Header block (`Project:`, `Test:`, `Result:`, …): for the record.
            if intervals.is_empty() && found.len() < 8 {
                let value: Vec<&str> = fields[1..]
                    .iter()
                    .map(|s| s.trim())
                    .filter(|s| !s.is_empty())
                    .collect();
                found.push(format!("{first} {}", value.join(" ")).trim().to_owned());
            }
            expect_units = false;
            continue;
        }
        let Some(interval) = intervals.last_mut().filter(|i| !i.names.is_empty()) else {
            return Err(malformed(
                line_no,
                1,
                format!(
                    "a data row before any `{COLUMNS_MARK}` line; is this a RheoCompass export? \
                     (for a plain table use format = \"csv\")"
                ),
            ));
        };
        let values = &fields[1..];
        if expect_units {
            expect_units = false;
            let is_units = values
                .iter()
                .all(|v| v.trim().is_empty() || v.trim().starts_with('['));
            if is_units {
                for (unit, v) in interval.units.iter_mut().zip(values) {
                    let v = v.trim();
                    *unit = (!v.is_empty()).then(|| v.to_owned());
                }
                continue;
            }
        }
        let row: Vec<Cell> = (0..interval.names.len())
            .map(|c| {
                let text = values.get(c).map_or("", |s| s.as_str());
                decimal_comma |= separator != ',' && text.contains(',');
                Cell::parse(text)
            })
            .collect();
        interval.rows.push(row);
        interval.lines.push(line_no);
    }
    if intervals.is_empty() {
        return Err(DataError::Unsupported {
            path: path.to_owned(),
            message: format!(
                "no `{INTERVAL_MARK}` line: not a RheoCompass export, or an empty one; export \
                 the test with its data points"
            ),
        });
    }
    if decimal_comma {
        found.push("decimal commas".into());
    }
    for i in &intervals {
        let declared = match i.declared {
            Some(n) if n != i.rows.len() => format!(" (the file declares {n})"),
            _ => String::new(),
        };
        found.push(format!(
            "interval {}: {} points{declared}, columns {}",
            i.number,
            i.rows.len(),
            i.names
                .iter()
                .zip(&i.units)
                .map(|(n, u)| match u {
                    Some(u) => format!("{n} {u}"),
                    None => n.clone(),
                })
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let chosen: Vec<&Interval> = match choice {
        IntervalChoice::All => intervals.iter().collect(),
        IntervalChoice::Numbers(numbers) => numbers
            .iter()
            .map(|&n| {
                intervals
                    .iter()
                    .find(|i| i.number == n)
                    .ok_or_else(|| DataError::NoSuchInterval {
                        path: path.to_owned(),
                        asked: n,
                        intervals: intervals.iter().map(|i| (i.number, i.rows.len())).collect(),
                        table: None,
                    })
            })
            .collect::<Result<_, _>>()?,
    };
    let Some(&first) = chosen.first() else {
        return Err(DataError::Unsupported {
            path: path.to_owned(),
            message: "no interval chosen; give `all` or interval numbers".into(),
        });
    };
    if first.names.is_empty() {
        return Err(DataError::Unsupported {
            path: path.to_owned(),
            message: format!(
                "interval {} has no `{COLUMNS_MARK}` line with column names",
                first.number
            ),
        });
    }
    for other in &chosen[1..] {
        if other.names != first.names || other.units != first.units {
            return Err(malformed(
                other.header_line.max(1),
                1,
                format!(
                    "interval {} has other columns or units than interval {}; choose one \
                     interval (model file: `interval = N`; command line: --interval N)",
                    other.number, first.number
                ),
            ));
        }
    }
    found.push(format!("intervals kept: {choice}"));
    let width = first.names.len();
    let mut cells: Vec<Vec<Cell>> = vec![Vec::new(); width];
    let mut lines = Vec::new();
    for interval in &chosen {
        for (row, &line) in interval.rows.iter().zip(&interval.lines) {
            for (column, cell) in cells.iter_mut().zip(row) {
                column.push(cell.clone());
            }
            lines.push(line);
        }
    }
    Ok(Table {
        names: first.names.clone(),
        units: first.units.clone(),
        lines,
        cells,
        header_line: first.header_line.max(1),
        found,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn utf16_with_bom(text: &str) -> Vec<u8> {
        let mut bytes = vec![0xFF, 0xFE];
        for unit in text.encode_utf16() {
            bytes.extend_from_slice(&unit.to_le_bytes());
        }
        bytes
    }

    const EXPORT: &str = "Project:\tdemo\nTest:\tslide\nResult:\tslide 1\n\
        Interval and data points:\t1\t2\n\
        Interval data:\tPoint No.\tTime\tInterval Time\tTorque\tStatus\n\
        \t\t[s]\t[s]\t[µN·m]\t\n\
        \t1\t10,0\t10,0\t70,5\tDy_auto, ok\n\
        \t2\t20,0\t20,0\tInvalid\t\n\
        Interval and data points:\t2\t1\n\
        Interval data:\tPoint No.\tTime\tInterval Time\tTorque\tStatus\n\
        \t\t[s]\t[s]\t[µN·m]\t\n\
        \t3\t30,0\t10,0\t71,25\t\n";

    #[test]
    fn utf16_export_with_intervals() {
        let bytes = utf16_with_bom(EXPORT);
        assert!(looks_like(&bytes));
        let table = parse(&bytes, Path::new("x.txt"), &IntervalChoice::All).unwrap();
        assert_eq!(
            table.names,
            ["Point No.", "Time", "Interval Time", "Torque", "Status"]
        );
        assert_eq!(table.units[3].as_deref(), Some("[µN·m]"));
        assert_eq!(table.lines, [7, 8, 12]);
        assert_eq!(
            table.cells[1],
            [Cell::Number(10.0), Cell::Number(20.0), Cell::Number(30.0)]
        );
        assert_eq!(table.cells[3][1], Cell::Text("Invalid".into()));
        assert!(table.found[0].contains("UTF-16LE"), "{:?}", table.found);

        let second = parse(
            &bytes,
            Path::new("x.txt"),
            &IntervalChoice::Numbers(vec![2]),
        )
        .unwrap();
        assert_eq!(second.lines, [12]);
        let err = parse(
            &bytes,
            Path::new("x.txt"),
            &IntervalChoice::Numbers(vec![3]),
        )
        .unwrap_err();
        assert!(
            err.to_string()
                .contains("intervals 1 (2 points), 2 (1 point)"),
            "{err}"
        );
    }

    #[test]
    fn interval_choice_from_text() {
        assert_eq!("all".parse::<IntervalChoice>(), Ok(IntervalChoice::All));
        assert_eq!(
            "1, 3".parse::<IntervalChoice>(),
            Ok(IntervalChoice::Numbers(vec![1, 3]))
        );
        assert!("0".parse::<IntervalChoice>().is_err());
        assert!("x".parse::<IntervalChoice>().is_err());
    }
}
