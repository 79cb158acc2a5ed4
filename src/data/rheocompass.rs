//! Anton Paar RheoCompass text exports (docs/model.md §9), recognised by their structure, not
//! their words: RheoCompass writes its labels in the language of its interface and its numbers
//! in the format of the computer, so an export is found by its shape —
//!
//! - a header block of `label:` lines (`Project:`, `Test:`, `Result:`; `Projet:`, …), a new
//!   `Result:` starting each test of a multi-test export;
//! - per interval, a line of a label, the interval number and its point count
//!   (`Interval and data points:<TAB>1<TAB>300`, `Intervalle et points de données:<TAB>1<TAB>60`),
//!   then a line of a label and the column names (`Interval data:`, `Interval données:`), maybe
//!   rows qualifying the names (`Sinusoïdes`, `Fundamental`), a row of units in brackets
//!   (`[s]`, `[mN·m]`), and data rows whose first field is empty;
//! - a point the instrument marked invalid has its number written `12 (invalid)` (`(invalide)`);
//!   rows without a point number are waveform samples of the point before (LAOS), not points;
//! - tabs, semicolons or commas between fields; UTF-16 (either byte order, with or without a
//!   byte-order mark), UTF-8 or Latin-1; numbers in the computer's format ([`super::text`]).
//!
//! Labels only tell the language and which column is which ([`super::labels`]). The reader keeps
//! every cell as found and leaves judging them to the mapping ([`mod@super::import`]).

use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::blocks::{not_recognised, Block, Export};
use super::labels::{normalise, LANGUAGES};
use super::table::{Table, TextRow};
use super::text::{is_blank, lines, split_fields, unquote, Encoding, Line, NumberFormat};
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
pub(crate) enum IntervalSpec {
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

/// The separators RheoCompass writes between fields, in the order they are tried.
const SEPARATORS: [u8; 3] = [b'\t', b';', b','];

/// How much of a file the recognisers look at (a RheoCompass header block is a few lines).
const HEAD_LINES: usize = 200;

/// A label line's label: a first field ending in `:` that is not a number.
fn label(field: &str) -> Option<&str> {
    let t = unquote(field);
    (t.len() > 1 && t.ends_with(':') && !t.starts_with(|c: char| c.is_ascii_digit())).then_some(t)
}

/// The interval header's shape: a label, the interval number, the point count, nothing else.
fn interval_header<'a>(fields: &[&'a str]) -> Option<(&'a str, usize, usize)> {
    let label = label(fields.first()?)?;
    let number = unquote(fields.get(1)?).parse().ok()?;
    let count = unquote(fields.get(2)?).parse().ok()?;
    fields[3..]
        .iter()
        .all(|f| unquote(f).is_empty())
        .then_some((label, number, count))
}

/// A row of units: only bracketed units (and empty fields) after the empty first field.
fn units_row(fields: &[&str]) -> bool {
    if !unquote(fields[0]).is_empty() {
        return false;
    }
    let values = fields.iter().skip(1).map(|f| unquote(f));
    let mut any = false;
    for v in values {
        if v.is_empty() {
            continue;
        }
        if !(v.starts_with('[') && v.ends_with(']')) {
            return false;
        }
        any = true;
    }
    any
}

/// Whether the first lines of a text have a RheoCompass export's shape; the reason if not.
/// Returns the separator.
pub(crate) fn recognise(text: &str) -> Result<u8, String> {
    let mut fields = Vec::new();
    for separator in SEPARATORS {
        let mut header_at = None;
        let mut columns_at = None;
        for line in lines(text).take(HEAD_LINES) {
            let raw = &text[line.start..line.end];
            if is_blank(raw, separator) {
                continue;
            }
            split_fields(raw, separator, usize::MAX, &mut fields);
            if columns_at.is_some() {
                if units_row(&fields) {
                    return Ok(separator);
                }
                // Rows qualifying the names may come first; anything else ends the search.
                if unquote(fields[0]).is_empty()
                    && !fields[1..].iter().any(|f| NumberFormat::reads_as_number(f))
                {
                    continue;
                }
                return Err(format!(
                    "the column names at line {} are not followed by a row of units in brackets \
                     ([s], [mN·m]) but by line {}",
                    columns_at.unwrap_or(0),
                    line.number
                ));
            }
            if header_at.is_some() {
                let names = fields[1..]
                    .iter()
                    .filter(|f| !unquote(f).is_empty())
                    .count();
                if label(fields[0]).is_some() && names >= 1 {
                    columns_at = Some(line.number);
                    continue;
                }
                return Err(format!(
                    "the interval header at line {} is not followed by a line of a label and \
                     column names",
                    header_at.unwrap_or(0)
                ));
            }
            if interval_header(&fields).is_some() {
                header_at = Some(line.number);
            }
        }
        if header_at.is_some() {
            return Err("an interval header but no column names after it".into());
        }
    }
    Err(format!(
        "no interval header in the first {HEAD_LINES} lines (a label ending in `:`, then the \
         interval number and its point count, e.g. `Interval and data points:<TAB>1<TAB>300`)"
    ))
}

/// Where the parser is within an interval.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum State {
    /// Outside any interval, or after its interval header.
    Outside,
    /// After the column names: qualifying rows or the units row may come.
    Header,
    /// In the data rows.
    Data,
}

/// An interval being read, before its number is final.
struct Found {
    block: Block,
    /// The interval number as written, and the test (result) it belongs to.
    written: usize,
    result: Option<String>,
}

/// How many data rows of each interval feed the number-format detection.
const SAMPLE_ROWS: usize = 200;

/// Parses an export and keeps the intervals `choice` names, joined.
///
/// # Errors
/// [`DataError::Malformed`] naming the line for an interval header without its number, column
/// names without an interval, a second line of column names in one interval, or data before any
/// column names; [`DataError::Unsupported`] when the text is not a RheoCompass export or has no
/// interval; [`DataError::NoSuchInterval`] when a chosen interval is not in the file.
pub fn parse(
    text: String,
    encoding: Encoding,
    path: &Path,
    choice: &IntervalChoice,
) -> Result<Table, DataError> {
    let separator =
        recognise(&text).map_err(not_recognised(path, "an Anton Paar RheoCompass export"))?;
    let mut reader = Reader::new(path, separator);
    let mut fields = Vec::new();
    for line in lines(&text) {
        let raw = &text[line.start..line.end];
        let bytes = raw.as_bytes();
        // Data rows start with the separator: the common case, handled without splitting.
        if reader.state == State::Data && bytes.first() == Some(&separator) {
            reader.data_row(&line, raw, &mut fields);
            continue;
        }
        if is_blank(raw, separator) {
            continue;
        }
        split_fields(raw, separator, usize::MAX, &mut fields);
        let first = unquote(fields[0]);
        if first.is_empty() {
            reader.unlabelled_row(&line, &fields)?;
        } else if reader.is_interval_header(first, &fields) {
            reader.interval_header(&line, first, &fields)?;
        } else if reader.is_column_names(first, &fields) {
            reader.column_names(&line, first, &fields)?;
        } else {
            reader.label_line(first, &fields);
        }
    }
    reader.into_export(text, encoding)?.into_table(choice, path)
}

/// A malformed line of the export at `path`.
fn malformed(path: &Path, line: usize, column: usize, message: String) -> DataError {
    DataError::Malformed {
        path: path.to_owned(),
        line,
        column,
        message,
    }
}

/// What [`parse`] has read so far, line after line.
struct Reader<'p> {
    path: &'p Path,
    separator: u8,
    /// The header block's first lines and remarks on the intervals, for the record.
    found_lines: Vec<String>,
    /// The labels of the export's sections, in the order first met.
    sections: Vec<String>,
    /// The labels of an interval header and of column names, once the first of each is met.
    interval_label: Option<String>,
    columns_label: Option<String>,
    intervals: Vec<Found>,
    /// The test (result) of the interval being read.
    result: Option<String>,
    /// Label lines since the last interval header: the next interval's test is named there.
    meta_since_interval: Vec<(String, String)>,
    state: State,
    /// Fields of the first data rows, for the number-format detection.
    sample: Vec<String>,
    sampled: usize,
}

impl<'p> Reader<'p> {
    fn new(path: &'p Path, separator: u8) -> Self {
        Self {
            path,
            separator,
            found_lines: Vec::new(),
            sections: Vec::new(),
            interval_label: None,
            columns_label: None,
            intervals: Vec::new(),
            result: None,
            meta_since_interval: Vec::new(),
            state: State::Outside,
            sample: Vec::new(),
            sampled: 0,
        }
    }

    /// A data row starting with the separator: a point, or (without a point number) a waveform
    /// sample of the point before.
    fn data_row<'t>(&mut self, line: &Line, raw: &'t str, fields: &mut Vec<&'t str>) {
        let separator = self.separator;
        let Some(current) = self.intervals.last_mut() else {
            return;
        };
        let block = &mut current.block;
        let rest = &raw[1..];
        if block.point_field.is_some() {
            let end = memchr::memchr(separator, rest.as_bytes()).unwrap_or(rest.len());
            let point = unquote(&rest[..end]);
            if point.is_empty() {
                // No point number: a waveform sample of the point before, or a blank row.
                if !is_blank(raw, separator) {
                    block.skipped += 1;
                }
                return;
            }
            let digits = point.bytes().take_while(u8::is_ascii_digit).count();
            let flagged = digits > 0 && digits < point.len();
            block.rows.push(TextRow {
                start: line.start,
                end: line.end,
                line: line.number,
                flagged,
            });
        } else {
            if is_blank(raw, separator) {
                return;
            }
            block.rows.push(TextRow {
                start: line.start,
                end: line.end,
                line: line.number,
                flagged: false,
            });
        }
        if block.rows.len() <= SAMPLE_ROWS && self.sampled < 20 * SAMPLE_ROWS {
            self.sampled += 1;
            split_fields(raw, separator, usize::MAX, fields);
            self.sample
                .extend(fields.iter().skip(1).map(|f| (*f).to_owned()));
        }
    }

    /// Whether a line labelled `first` opens an interval: the label of the first interval
    /// header, or before one, an interval header's shape.
    fn is_interval_header(&self, first: &str, fields: &[&str]) -> bool {
        match &self.interval_label {
            Some(l) => first == l,
            None => interval_header(fields).is_some(),
        }
    }

    /// Opens an interval, in the test (result) named since the interval before.
    fn interval_header(
        &mut self,
        line: &Line,
        first: &str,
        fields: &[&str],
    ) -> Result<(), DataError> {
        let Some(number) = fields.get(1).and_then(|f| unquote(f).parse::<usize>().ok()) else {
            return Err(malformed(
                self.path,
                line.number,
                2,
                format!("`{first}` must be followed by the interval number"),
            ));
        };
        if self.interval_label.is_none() {
            self.sections.push(first.to_owned());
            self.interval_label = Some(first.to_owned());
        }
        // The result (test) this interval belongs to: the last `Result:`-like line since
        // the interval before, else the last label line.
        if !self.meta_since_interval.is_empty() {
            let results: Vec<String> = LANGUAGES.iter().map(|l| normalise(l.result)).collect();
            let named = self
                .meta_since_interval
                .iter()
                .rev()
                .find(|(l, _)| results.contains(&normalise(l)))
                .or(self.meta_since_interval.last());
            self.result = named.map(|(_, v)| v.clone()).filter(|v| !v.is_empty());
            self.meta_since_interval.clear();
        }
        self.intervals.push(Found {
            block: Block {
                declared: fields.get(2).and_then(|f| unquote(f).parse().ok()),
                ..Block::default()
            },
            written: number,
            result: self.result.clone(),
        });
        self.state = State::Outside;
        Ok(())
    }

    /// Whether a line labelled `first` holds column names: the label of the first such line,
    /// or before one, any label right after an interval header that has none yet.
    fn is_column_names(&self, first: &str, fields: &[&str]) -> bool {
        match &self.columns_label {
            Some(l) => first == l,
            None => {
                label(fields[0]).is_some()
                    && self
                        .intervals
                        .last()
                        .is_some_and(|i| i.block.names.is_empty())
                    && self.state == State::Outside
            }
        }
    }

    /// The column names of the interval being read.
    fn column_names(&mut self, line: &Line, first: &str, fields: &[&str]) -> Result<(), DataError> {
        let Some(current) = self.intervals.last_mut() else {
            return Err(malformed(
                self.path,
                line.number,
                1,
                format!("`{first}` (column names) before any interval header"),
            ));
        };
        // Rows already read have the first header's width (a fuzzing find).
        if !current.block.names.is_empty() {
            return Err(malformed(
                self.path,
                line.number,
                1,
                format!(
                    "a second `{first}` line in interval {}; each interval has one \
                     (was the file joined from two exports?)",
                    current.written
                ),
            ));
        }
        if self.columns_label.is_none() {
            self.sections.push(first.to_owned());
            self.columns_label = Some(first.to_owned());
        }
        let mut names: Vec<String> = fields[1..].iter().map(|f| unquote(f).to_owned()).collect();
        while names.last().is_some_and(String::is_empty) {
            names.pop();
        }
        let block = &mut current.block;
        block.units = vec![None; names.len()];
        block.fields = (1..=names.len()).collect();
        block.names = names;
        block.header_line = line.number;
        self.state = State::Header;
        Ok(())
    }

    /// A line of the header block (`Project:`, `Test:`, `Result:`, …): for the record.
    fn label_line(&mut self, first: &str, fields: &[&str]) {
        let value: Vec<&str> = fields[1..]
            .iter()
            .map(|f| unquote(f))
            .filter(|s| !s.is_empty())
            .collect();
        if self.intervals.is_empty() && self.found_lines.len() < 7 {
            self.found_lines
                .push(format!("{first} {}", value.join(" ")).trim().to_owned());
        }
        if label(fields[0]).is_some() && !self.sections.iter().any(|s| s == first) {
            self.sections.push(first.to_owned());
        }
        self.meta_since_interval
            .push((first.to_owned(), value.join(" ")));
        self.state = State::Outside;
    }

    /// A line whose first field is empty that is not a data row starting with the separator:
    /// a row qualifying the names, the units, or a data row with spaces before the separator.
    fn unlabelled_row(&mut self, line: &Line, fields: &[&str]) -> Result<(), DataError> {
        let Some(current) = self
            .intervals
            .last_mut()
            .filter(|i| !i.block.names.is_empty())
        else {
            return Err(malformed(
                self.path,
                line.number,
                1,
                "a data row before any interval's column names (a line of a label such as \
                 `Interval data:` and the names); is this a RheoCompass export? (for a plain \
                 table use format = \"csv\")"
                    .into(),
            ));
        };
        let block = &mut current.block;
        if self.state == State::Header {
            if units_row(fields) {
                for (unit, f) in block.units.iter_mut().zip(&fields[1..]) {
                    let v = unquote(f);
                    *unit = (!v.is_empty()).then(|| v.to_owned());
                }
                // A first column without a unit is the point number.
                block.point_field = block
                    .units
                    .first()
                    .is_some_and(Option::is_none)
                    .then_some(1);
                self.state = State::Data;
                return Ok(());
            }
            if !fields[1..].iter().any(|f| NumberFormat::reads_as_number(f)) {
                // A row qualifying the names (`Sinusoïdes`, `Fundamental`).
                return Ok(());
            }
            self.state = State::Data;
        }
        // A data row that did not start with the separator byte (spaces before it).
        block.rows.push(TextRow {
            start: line.start,
            end: line.end,
            line: line.number,
            flagged: false,
        });
        Ok(())
    }

    /// The export read: its intervals numbered (in file order when tests repeat the numbers)
    /// and labelled by their test where the file has several.
    fn into_export(self, text: String, encoding: Encoding) -> Result<Export, DataError> {
        if self.intervals.is_empty() {
            return Err(DataError::Unsupported {
                path: self.path.to_owned(),
                message: "no interval header: not a RheoCompass export, or an empty one; export \
                          the test with its data points"
                    .into(),
            });
        }
        let separator = self.separator;
        let intervals = self.intervals;
        let mut found_lines = self.found_lines;
        let numbers = NumberFormat::detect(self.sample.iter().map(String::as_str), separator);
        let mut written: Vec<usize> = intervals.iter().map(|i| i.written).collect();
        written.sort_unstable();
        let repeated = written.windows(2).any(|w| w[0] == w[1]);
        let results = {
            let mut r: Vec<&Option<String>> = intervals.iter().map(|i| &i.result).collect();
            r.dedup();
            r.len()
        };
        if repeated {
            found_lines.push(format!(
                "{results} tests (results) whose interval numbers repeat: intervals are numbered \
                 1–{} in file order",
                intervals.len()
            ));
        }
        for i in intervals.iter().filter(|i| i.block.names.is_empty()) {
            found_lines.push(format!(
                "interval {} has no column names (no data exported); left out",
                i.written
            ));
        }
        let blocks = intervals
            .into_iter()
            .enumerate()
            .map(|(index, i)| {
                let mut block = i.block;
                let test = i.result.as_deref().map(|r| format!("result `{r}`"));
                if repeated {
                    block.number = index + 1;
                    block.label = Some(match test {
                        Some(t) => format!("{t}, its interval {}", i.written),
                        None => format!("its interval {}", i.written),
                    });
                } else {
                    block.number = i.written;
                    block.label = if results > 1 { test } else { None };
                }
                block
            })
            .filter(|b| !b.names.is_empty())
            .collect();
        Ok(Export {
            vendor: "Anton Paar RheoCompass export",
            kind: "interval",
            text,
            encoding,
            separator,
            numbers,
            found: found_lines,
            sections: self.sections,
            blocks,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::super::table::Cell;
    use super::super::text::decode;
    use super::*;

    fn utf16_with_bom(text: &str) -> Vec<u8> {
        let mut bytes = vec![0xFF, 0xFE];
        for unit in text.encode_utf16() {
            bytes.extend_from_slice(&unit.to_le_bytes());
        }
        bytes
    }

    fn read(bytes: &[u8], choice: &IntervalChoice) -> Result<Table, DataError> {
        let (text, encoding) = decode(bytes);
        parse(text, encoding, Path::new("x.txt"), choice)
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
        let table = read(&bytes, &IntervalChoice::All).unwrap();
        assert_eq!(
            table.names,
            ["Point No.", "Time", "Interval Time", "Torque", "Status"]
        );
        assert_eq!(table.units[3].as_deref(), Some("[µN·m]"));
        let lines: Vec<usize> = (0..table.rows()).map(|r| table.line(r)).collect();
        assert_eq!(lines, [7, 8, 12]);
        assert_eq!(
            table.column(1),
            [Cell::Number(10.0), Cell::Number(20.0), Cell::Number(30.0)]
        );
        assert_eq!(table.column(3)[1], Cell::Text("Invalid".into()));
        assert!(
            table.found.iter().any(|f| f.contains("UTF-16LE")),
            "{:?}",
            table.found
        );

        let second = read(&bytes, &IntervalChoice::Numbers(vec![2])).unwrap();
        assert_eq!(second.line(0), 12);
        let err = read(&bytes, &IntervalChoice::Numbers(vec![3])).unwrap_err();
        assert!(
            err.to_string()
                .contains("intervals 1 (2 points), 2 (1 point)"),
            "{err}"
        );
    }

    /// The shapes of the real exports: French with rows qualifying the names, waveform rows
    /// and flagged points; English comma-separated with blank lines of commas.
    #[test]
    fn recognised_by_shape_in_any_language() {
        let french = "Projet:\tp\r\n\r\nRésultat:\tLAOS 1\r\n\r\n\
            Intervalle et points de données:\t1\t3\r\n\
            Interval données:\tPoint No.\tTemps\tCouple\tContrainte (sinusoïdale)\r\n\
            \t\t\t\tSinusoïdes\r\n\
            \t\t[s]\t[mN·m]\t[Pa]\r\n\
            \t1\t250\t0,053306\t0,24376\r\n\
            \t\t\t\t0,26373\r\n\
            \t2  (invalide)\t\t\t\r\n\
            \t3\t2,7E+02\t0,1\t\r\n";
        assert_eq!(recognise(french), Ok(b'\t'));
        let table = read(&utf16_with_bom(french), &IntervalChoice::All).unwrap();
        assert_eq!(table.rows(), 3);
        assert_eq!(table.roles.language.map(|l| l.name), Some("French"));
        assert!(
            table.found.iter().any(|f| f.contains("1 waveform row")),
            "{:?}",
            table.found
        );
        assert_eq!(table.column(1)[2], Cell::Number(270.0));
        assert_eq!(table.column(2)[0], Cell::Number(0.053306));
        assert_eq!(table.column(1)[1], Cell::Text("2  (invalide)".into()));

        let english = "\u{feff}Project:,P,,,\n,,,,\nResult:,R,,,\n,,,,\n\
            Interval and data points:,1,2,,\n\
            Interval data:,Point No.,Time,Torque,Status\n\
            ,,,Fundamental,\n\
            ,,[s],[µN·m],\n\
            ,1,0.1,-37.51,Dy_auto\n\
            ,2,0.201,3.2195,Dy_auto\n,,,,\n";
        assert_eq!(recognise(english), Ok(b','));
        let table = read(english.as_bytes(), &IntervalChoice::All).unwrap();
        assert_eq!(
            table.column(2),
            [Cell::Number(-37.51), Cell::Number(3.2195)]
        );
    }

    #[test]
    fn other_text_is_not_recognised_and_says_why() {
        let reason = recognise("time_s,force_N\n0,1\n").unwrap_err();
        assert!(reason.contains("no interval header"), "{reason}");
        let reason = recognise("Interval and data points:\t1\t2\n\t1\t2\n").unwrap_err();
        assert!(reason.contains("column names"), "{reason}");
        let reason =
            recognise("Interval and data points:\t1\t2\nInterval data:\tTime\n\t1\n").unwrap_err();
        assert!(reason.contains("row of units"), "{reason}");
    }

    #[test]
    fn repeated_interval_numbers_are_numbered_in_file_order() {
        let text =
            "Result:\ta\nInterval and data points:\t1\t1\nInterval data:\tTime\n\t[s]\n\t1\n\
            Result:\tb\nInterval and data points:\t1\t1\nInterval data:\tTime\n\t[s]\n\t2\n";
        let table = read(text.as_bytes(), &IntervalChoice::Numbers(vec![2])).unwrap();
        assert_eq!(table.line(0), 10);
        assert!(
            table
                .found
                .iter()
                .any(|f| f.contains("interval 2 (result `b`, its interval 1)")),
            "{:?}",
            table.found
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
