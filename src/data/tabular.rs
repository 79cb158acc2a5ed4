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

use super::import::{Cell, Table};
use super::rheocompass::decode;
use super::DataError;

fn unsupported(path: &Path, message: String) -> DataError {
    DataError::Unsupported {
        path: path.to_owned(),
        message,
    }
}

/// Reads a delimited text table with one header line: comma, semicolon or tab separated
/// (judged from the header), UTF-8 or UTF-16 with a byte-order mark.
///
/// # Errors
/// [`DataError`] naming the file for an empty file or text polars cannot split into a table.
pub fn read_csv(bytes: &[u8], path: &Path) -> Result<Table, DataError> {
    let (text, encoding) = decode(bytes);
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
        .into_reader_with_file_handle(Cursor::new(text.trim_start_matches('\u{feff}').as_bytes()))
        .finish()
        .map_err(|e| unsupported(path, format!("not a readable CSV table: {e}")))?;
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
    let mut table = table_of(&frame, path, lines)?;
    table.header_line = header_index + 1;
    drop_blank_rows(&mut table);
    table.found.insert(
        0,
        format!(
            "CSV, {encoding}, separator `{}`, {} columns, {} rows",
            if separator == b'\t' {
                "\\t".to_owned()
            } else {
                char::from(separator).to_string()
            },
            table.names.len(),
            frame.height()
        ),
    );
    Ok(table)
}

/// Reads a Parquet file; numeric columns are cast to f64, text columns parsed per cell.
///
/// # Errors
/// [`DataError::Unsupported`] naming the file when polars cannot read it.
pub fn read_parquet(bytes: &[u8], path: &Path) -> Result<Table, DataError> {
    let frame = ParquetReader::new(Cursor::new(bytes))
        .finish()
        .map_err(|e| unsupported(path, format!("not a readable Parquet file: {e}")))?;
    let mut table = table_of(&frame, path, (1..=frame.height()).collect())?;
    table.found.insert(
        0,
        format!(
            "Parquet, {} columns, {} rows (positions below are row numbers)",
            table.names.len(),
            frame.height()
        ),
    );
    Ok(table)
}

/// Removes rows whose every cell is empty: blank lines, not data points.
fn drop_blank_rows(table: &mut Table) {
    let blank = |row: usize| {
        table
            .cells
            .iter()
            .all(|c| matches!(&c[row], Cell::Text(t) if t.is_empty()))
    };
    let keep: Vec<usize> = (0..table.lines.len()).filter(|&r| !blank(r)).collect();
    if keep.len() == table.lines.len() {
        return;
    }
    table.lines = keep.iter().map(|&r| table.lines[r]).collect();
    for column in &mut table.cells {
        *column = keep.iter().map(|&r| column[r].clone()).collect();
    }
}

fn table_of(frame: &DataFrame, path: &Path, lines: Vec<usize>) -> Result<Table, DataError> {
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
    Ok(Table {
        units: vec![None; names.len()],
        names,
        lines,
        cells,
        header_line: 1,
        found: Vec::new(),
    })
}

fn cells_of(column: &Column, path: &Path) -> Result<Vec<Cell>, DataError> {
    let fail = |e: polars_core::error::PolarsError| {
        unsupported(path, format!("column `{}`: {e}", column.name()))
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
