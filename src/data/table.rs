//! A table as read from a file, before its columns are mapped: names, units, the line each row
//! came from, and the cells. Cells are held either as values (CSV through polars, Parquet) or
//! as the rows' spans in the decoded text of an instrument export, and then only the columns
//! an import maps are ever parsed (an export of 10⁶ points has many columns nobody fits).

use std::ops::Range;

use super::labels::Roles;
use super::text::{split_fields, unquote, NumberFormat};

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

/// A table read from a file, before mapping: named columns, the units the file declares, and
/// where each row came from.
#[derive(Debug, Clone)]
pub struct Table {
    /// Column names.
    pub names: Vec<String>,
    /// Units declared by the file (a units row, or a unit in the column's name), per column.
    pub units: Vec<Option<String>>,
    /// 1-based line of the header (where a missing column is reported).
    pub header_line: usize,
    /// What the reader found, for the user (vendor, language, intervals, encoding).
    pub found: Vec<String>,
    /// Which columns hold time, torque, forces, from their labels or units.
    pub roles: Roles,
    pub(crate) data: Data,
    /// The rows of each block (interval, step or action) kept.
    pub(crate) blocks: Vec<BlockRows>,
    /// For a file detected as a plain table: the formats tried first and why they did not fit.
    pub(crate) tried: Option<String>,
    /// Columns left out because not every chosen block has them, in words.
    pub(crate) left_out: Option<String>,
}

/// The rows one block of an export contributed to a table.
#[derive(Debug, Clone)]
pub(crate) struct BlockRows {
    pub rows: Range<usize>,
    /// `interval`, `step` or `action`.
    pub kind: &'static str,
    /// `interval 4 (result `LAOS 1`, its interval 1)`.
    pub name: String,
}

/// Where a table's cells are.
#[derive(Debug, Clone)]
pub(crate) enum Data {
    /// Cells in memory, column-major: `cells[column][row]`, with each row's 1-based line (the
    /// row number for Parquet).
    Cells {
        lines: Vec<usize>,
        cells: Vec<Vec<Cell>>,
    },
    /// Rows of a decoded text, parsed on demand.
    Text(TextData),
}

/// The rows of an export as spans of its decoded text.
#[derive(Debug, Clone)]
pub(crate) struct TextData {
    pub text: String,
    pub separator: u8,
    pub numbers: NumberFormat,
    pub rows: Vec<TextRow>,
    /// Consecutive rows sharing one layout of fields (a block's), in row order.
    pub segments: Vec<Segment>,
}

/// One data row: its span in the text and its line.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TextRow {
    pub start: usize,
    pub end: usize,
    pub line: usize,
    /// The instrument marked the point invalid (RheoCompass: `12 (invalid)` as point number).
    pub flagged: bool,
}

/// Rows laid out alike: table column `c` is field `fields[c]` of each row's line.
#[derive(Debug, Clone)]
pub(crate) struct Segment {
    pub rows: Range<usize>,
    pub fields: Vec<usize>,
    /// The field holding the point number, quoted when a point is flagged.
    pub point_field: Option<usize>,
}

/// Why a mapped cell holds no usable number.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Bad {
    /// Empty or missing.
    Empty,
    /// Text where a number belongs.
    Text(String),
    /// The instrument marked the point invalid; the point number as written.
    Flagged(String),
}

impl Bad {
    /// A cell's text that is not a number.
    fn of(text: &str) -> Self {
        if text.is_empty() {
            Self::Empty
        } else {
            Self::Text(text.to_owned())
        }
    }
}

/// The values of some columns, row by row, with the cells that were not numbers.
#[derive(Debug, Clone)]
pub(crate) struct Extracted {
    /// `values[slot][row]`; NaN where the cell was bad.
    pub values: Vec<Vec<f64>>,
    /// Bad cells, sorted by row then slot.
    pub bad: Vec<(usize, usize, Bad)>,
}

impl Table {
    /// A table of cells in memory.
    pub(crate) fn of_cells(
        names: Vec<String>,
        units: Vec<Option<String>>,
        lines: Vec<usize>,
        cells: Vec<Vec<Cell>>,
        header_line: usize,
    ) -> Self {
        let roles = Roles::identify(&names, &units, &[]);
        Self {
            names,
            units,
            header_line,
            found: Vec::new(),
            roles,
            data: Data::Cells { lines, cells },
            blocks: Vec::new(),
            tried: None,
            left_out: None,
        }
    }

    /// The position of a column by name (spaces around it ignored).
    pub fn position(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n.trim() == name.trim())
    }

    /// Number of data rows.
    pub fn rows(&self) -> usize {
        match &self.data {
            Data::Cells { lines, .. } => lines.len(),
            Data::Text(t) => t.rows.len(),
        }
    }

    /// 1-based line (or Parquet row) of a data row.
    pub fn line(&self, row: usize) -> usize {
        match &self.data {
            Data::Cells { lines, .. } => lines[row],
            Data::Text(t) => t.rows[row].line,
        }
    }

    /// The block (interval, step, action) a row belongs to.
    pub(crate) fn block_of(&self, row: usize) -> Option<&BlockRows> {
        self.blocks.iter().find(|b| b.rows.contains(&row))
    }

    /// The cells of one column, parsed (for tests and small tables).
    pub fn column(&self, column: usize) -> Vec<Cell> {
        let extracted = self.extract(&[column]);
        let mut bad = extracted.bad.into_iter().peekable();
        extracted.values[0]
            .iter()
            .enumerate()
            .map(|(row, &v)| match bad.next_if(|(r, _, _)| *r == row) {
                Some((_, _, Bad::Empty)) => Cell::Text(String::new()),
                Some((_, _, Bad::Text(t) | Bad::Flagged(t))) => Cell::Text(t),
                None => Cell::Number(v),
            })
            .collect()
    }

    /// The values of `columns`, row by row, in one pass over the rows.
    pub(crate) fn extract(&self, columns: &[usize]) -> Extracted {
        let rows = self.rows();
        let mut values: Vec<Vec<f64>> = columns.iter().map(|_| Vec::with_capacity(rows)).collect();
        let mut bad = Vec::new();
        match &self.data {
            Data::Cells { cells, .. } => {
                for (slot, &c) in columns.iter().enumerate() {
                    for (row, cell) in cells[c].iter().enumerate() {
                        match cell {
                            Cell::Number(v) => values[slot].push(*v),
                            Cell::Text(t) => {
                                values[slot].push(f64::NAN);
                                bad.push((row, slot, Bad::of(t)));
                            }
                        }
                    }
                }
                bad.sort_by_key(|&(row, slot, _)| (row, slot));
            }
            Data::Text(data) => {
                let mut fields = Vec::new();
                for segment in &data.segments {
                    let wanted: Vec<usize> = columns.iter().map(|&c| segment.fields[c]).collect();
                    let limit = wanted
                        .iter()
                        .chain(&segment.point_field)
                        .max()
                        .map_or(1, |m| m + 2);
                    for row in segment.rows.clone() {
                        let r = data.rows[row];
                        split_fields(
                            &data.text[r.start..r.end],
                            data.separator,
                            limit,
                            &mut fields,
                        );
                        let field = |f: usize| fields.get(f).copied().unwrap_or("");
                        if r.flagged {
                            let point = segment.point_field.map_or("", field);
                            for (slot, column) in values.iter_mut().enumerate() {
                                column.push(f64::NAN);
                                bad.push((row, slot, Bad::Flagged(unquote(point).to_owned())));
                            }
                            continue;
                        }
                        for (slot, &f) in wanted.iter().enumerate() {
                            let cell = field(f);
                            match data.numbers.parse(cell) {
                                Some(v) => values[slot].push(v),
                                None => {
                                    values[slot].push(f64::NAN);
                                    bad.push((row, slot, Bad::of(unquote(cell))));
                                }
                            }
                        }
                    }
                }
            }
        }
        Extracted { values, bad }
    }
}
