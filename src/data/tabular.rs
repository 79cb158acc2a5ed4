//! CSV and Parquet tables read through polars (feature `tabular`).
//!
//! CSV cells are read as text and parsed here, so that a decimal comma is understood, text in
//! a numeric column is reported at its line and column instead of turning the column into
//! text, and numbers read back bit-exactly (Rust's parser rounds correctly).

use std::io::Cursor;
use std::path::Path;

use polars_core::prelude::{Column, DataFrame, DataType};
use polars_io::csv::read::{CsvParseOptions, CsvReadOptions};
use polars_io::parquet::read::ParquetReader;
use polars_io::SerReader;

use super::table::{Cell, Table};
use super::text::{lines, split_fields, Encoding};
use super::DataError;

fn unsupported(path: &Path, message: String) -> DataError {
    DataError::Unsupported {
        path: path.to_owned(),
        message,
    }
}

/// Why text polars could not read is not a table, in our words (polars' own message names
/// options of polars, which a user cannot set): the first line whose field count differs from
/// the header's.
fn diagnose(text: &str, separator: u8, header_index: usize, path: &Path) -> DataError {
    let mut fields = Vec::new();
    let mut width = None;
    for line in lines(text).skip(header_index) {
        let raw = &text[line.start..line.end];
        if raw.trim().is_empty() {
            continue;
        }
        split_fields(raw, separator, usize::MAX, &mut fields);
        match width {
            None => width = Some((fields.len(), line.number)),
            Some((w, header)) if fields.len() > w => {
                return DataError::Malformed {
                    path: path.to_owned(),
                    line: line.number,
                    column: w + 1,
                    message: format!(
                        "{} fields where the header (line {header}) has {w}; a plain table has \
                         one header line and at most as many fields on every line (is this an \
                         instrument export with a header block?)",
                        fields.len()
                    ),
                };
            }
            Some(_) => {}
        }
    }
    unsupported(
        path,
        "not a table slipbayes can read: no header line with the same fields as the data".into(),
    )
}

/// Reads a delimited text table with one header line: comma, semicolon or tab separated
/// (judged from the header), from text already decoded.
///
/// # Errors
/// [`DataError`] naming the file for an empty file, and the line for a row with more fields
/// than the header.
pub fn read_csv(text: &str, encoding: Encoding, path: &Path) -> Result<Table, DataError> {
    let text = text.trim_start_matches('\u{feff}');
    let Some((header_index, header)) = text.lines().enumerate().find(|(_, l)| !l.trim().is_empty())
    else {
        return Err(DataError::Malformed {
            path: path.to_owned(),
            line: 1,
            column: 1,
            message: "the file is empty; expected a header line (e.g. `time_s,force_N`) and data"
                .into(),
        });
    };
    let separator = if header.contains('\t') {
        b'\t'
    } else if header.contains(';') && !header.contains(',') {
        b';'
    } else {
        b','
    };
    let parse_options = CsvParseOptions::default()
        .with_separator(separator)
        .with_truncate_ragged_lines(false);
    let frame = CsvReadOptions::default()
        .with_has_header(true)
        .with_skip_rows(header_index)
        // Every column as text: numbers are parsed in `Cell::parse`.
        .with_infer_schema_length(Some(0))
        .with_parse_options(parse_options)
        .with_n_threads(Some(1))
        .into_reader_with_file_handle(Cursor::new(text.as_bytes()))
        .finish()
        .map_err(|_| diagnose(text, separator, header_index, path))?;
    // Line of each row. Polars reads a blank line inside the data as a row of empty cells
    // (such rows are removed below); a quoted field spanning lines breaks the correspondence,
    // and then rows are counted from the header instead.
    let after_header: Vec<(usize, &str)> = text
        .lines()
        .enumerate()
        .skip(header_index + 1)
        .map(|(i, l)| (i + 1, l))
        .collect();
    let non_blank: Vec<usize> = after_header
        .iter()
        .filter(|(_, l)| !l.trim().is_empty())
        .map(|&(i, _)| i)
        .collect();
    let lines: Vec<usize> = if after_header.len() == frame.height() {
        after_header.iter().map(|&(i, _)| i).collect()
    } else if non_blank.len() == frame.height() {
        non_blank
    } else {
        (0..frame.height()).map(|r| header_index + r + 2).collect()
    };
    let (names, mut cells) = columns_of(&frame, path)?;
    let lines = drop_blank_rows(lines, &mut cells);
    let mut table = Table::of_cells(
        names.clone(),
        vec![None; names.len()],
        lines,
        cells,
        header_index + 1,
    );
    table.found.push(format!(
        "CSV, {encoding}, separator `{}`, {} columns, {} rows",
        if separator == b'\t' {
            "\\t".to_owned()
        } else {
            char::from(separator).to_string()
        },
        table.names.len(),
        frame.height()
    ));
    Ok(table)
}

/// Reads a Parquet file; numeric columns are cast to f64, text columns parsed per cell.
///
/// # Errors
/// [`DataError::Unsupported`] naming the file when it is not a readable Parquet file.
pub(crate) fn read_parquet(bytes: &[u8], path: &Path) -> Result<Table, DataError> {
    super::parquet_footer::check_footer(&mut Cursor::new(bytes))
        .map_err(|problem| unsupported(path, format!("not a readable Parquet file: {problem}")))?;
    let frame = ParquetReader::new(Cursor::new(bytes))
        .finish()
        .map_err(|_| {
            unsupported(
                path,
                "not a readable Parquet file (its footer or column chunks are damaged or of a \
                 kind polars cannot read)"
                    .into(),
            )
        })?;
    let (names, cells) = columns_of(&frame, path)?;
    let mut table = Table::of_cells(
        names.clone(),
        vec![None; names.len()],
        (1..=frame.height()).collect(),
        cells,
        1,
    );
    table.found.push(format!(
        "Parquet, {} columns, {} rows (positions below are row numbers)",
        table.names.len(),
        frame.height()
    ));
    Ok(table)
}

/// Removes rows whose every cell is empty: blank lines, not data points. Returns the lines of
/// the rows kept.
fn drop_blank_rows(lines: Vec<usize>, cells: &mut [Vec<Cell>]) -> Vec<usize> {
    let blank = |row: usize| {
        cells
            .iter()
            .all(|c| matches!(&c[row], Cell::Text(t) if t.is_empty()))
    };
    let keep: Vec<usize> = (0..lines.len()).filter(|&r| !blank(r)).collect();
    if keep.len() == lines.len() {
        return lines;
    }
    for column in cells.iter_mut() {
        *column = keep.iter().map(|&r| column[r].clone()).collect();
    }
    keep.iter().map(|&r| lines[r]).collect()
}

fn columns_of(frame: &DataFrame, path: &Path) -> Result<(Vec<String>, Vec<Vec<Cell>>), DataError> {
    let names: Vec<String> = frame
        .get_column_names()
        .iter()
        .map(|n| n.to_string())
        .collect();
    let cells = frame
        .get_columns()
        .iter()
        .map(|c| cells_of(c, path))
        .collect::<Result<Vec<_>, _>>()?;
    Ok((names, cells))
}

fn cells_of(column: &Column, path: &Path) -> Result<Vec<Cell>, DataError> {
    let fail = |_: polars_core::error::PolarsError| {
        unsupported(
            path,
            format!(
                "column `{}` holds values of type {} that are not numbers or text",
                column.name(),
                column.dtype()
            ),
        )
    };
    if column.dtype() == &DataType::String {
        let text = column.str().map_err(fail)?;
        return Ok(text
            .into_iter()
            .map(|v| v.map_or(Cell::Text(String::new()), Cell::parse))
            .collect());
    }
    let numbers = column.cast(&DataType::Float64).map_err(fail)?;
    let numbers = numbers.f64().map_err(fail)?;
    Ok(numbers
        .into_iter()
        .map(|v| v.map_or(Cell::Text(String::new()), Cell::Number))
        .collect())
}
