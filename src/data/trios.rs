//! TA Instruments TRIOS exports, text (`.txt`, tab-separated) and CSV, as seen in real files
//! (docs/model.md §9): a header block of `key<TAB>value` lines and `[Section]` lines (file,
//! geometry, instrument parameters), then one block per procedure step —
//!
//! ```text
//! [step]
//! Flow ramp - 3
//! Number of points<TAB>17        (some versions)
//! Torque<TAB>Velocity<TAB>Step time<TAB>…<TAB>Time
//! µN.m<TAB>rad/s<TAB>min<TAB>…<TAB>min
//! 16.289<TAB>…
//! ```
//!
//! — ended by a blank line, the next `[step]` or the end. Each step has its own columns, in
//! its own order; units stand alone on their row (`s`, `min`, `µN.m`, `N`). `Time` runs on
//! across steps, `Step time` restarts; numbers as the computer formats them.

use std::path::Path;

use super::blocks::{not_recognised, Block, Export};
use super::rheocompass::IntervalChoice;
use super::table::{Table, TextRow};
use super::text::{is_blank, lines, split_fields, unquote, Encoding, Line, NumberFormat};
use super::DataError;

/// How far the recogniser looks for the first `[step]` (the header block of a real export is
/// about 170 lines).
const HEAD_LINES: usize = 2000;

/// How many data rows of each step feed the number-format detection.
const SAMPLE_ROWS: usize = 200;

fn is_step_marker(line: &str) -> bool {
    unquote(line.trim_end_matches([',', ';', '\t'])) == "[step]"
}

/// The separator that splits a step's column-names line (the one giving the most fields).
fn separator_of(names_line: &str) -> Option<u8> {
    [b'\t', b',', b';']
        .into_iter()
        .map(|s| (s, names_line.bytes().filter(|&b| b == s).count()))
        .filter(|&(_, n)| n > 0)
        .max_by_key(|&(_, n)| n)
        .map(|(s, _)| s)
}

/// The lines after a `[step]` marker: the step's name, maybe its point count, its column names
/// and its units, as (line, declared count).
fn step_head(
    text: &str,
    after: &mut impl Iterator<Item = Line>,
) -> Result<(Line, Option<usize>, Line, Line), String> {
    let mut next = || {
        after
            .by_ref()
            .find(|l| !text[l.start..l.end].trim().is_empty())
    };
    let name = next().ok_or("a `[step]` line with nothing after it")?;
    let mut names = next().ok_or("a `[step]` without column names")?;
    let mut declared = None;
    // `Number of points<TAB>17`: two fields, the second a count.
    let raw = &text[names.start..names.end];
    if let Some(separator) = separator_of(raw) {
        let mut fields = Vec::new();
        split_fields(raw, separator, usize::MAX, &mut fields);
        let fields: Vec<&str> = fields
            .into_iter()
            .filter(|f| !unquote(f).is_empty())
            .collect();
        if fields.len() == 2 {
            if let Ok(n) = unquote(fields[1]).parse::<usize>() {
                declared = Some(n);
                names = next().ok_or("a `[step]` without column names")?;
            }
        }
    }
    let units = next().ok_or("a `[step]` without a row of units")?;
    Ok((name, declared, names, units))
}

/// Whether a text has a TRIOS export's shape; the reason if not. Returns the separator.
pub(crate) fn recognise(text: &str) -> Result<u8, String> {
    let mut all = lines(text).take(HEAD_LINES);
    let Some(_) = all.by_ref().find(|l| is_step_marker(&text[l.start..l.end])) else {
        return Err(format!("no `[step]` line in the first {HEAD_LINES} lines"));
    };
    let (_, _, names, units) = step_head(text, &mut all)?;
    let names_raw = &text[names.start..names.end];
    let separator = separator_of(names_raw).ok_or(format!(
        "the column names at line {} are not separated by tabs, commas or semicolons",
        names.number
    ))?;
    let mut fields = Vec::new();
    split_fields(names_raw, separator, usize::MAX, &mut fields);
    let width = fields.len();
    split_fields(
        &text[units.start..units.end],
        separator,
        usize::MAX,
        &mut fields,
    );
    let units = fields.iter().filter(|f| !unquote(f).is_empty()).count();
    let numeric = fields
        .iter()
        .filter(|f| NumberFormat::DecimalPoint.parse(f).is_some())
        .count();
    if 2 * numeric > units || fields.len() > width + 1 {
        return Err(format!(
            "the column names at line {} are not followed by a row of units",
            names.number
        ));
    }
    Ok(separator)
}

/// The step number at the end of a step's name (`Flow ramp - 3`).
fn number_in_name(name: &str) -> Option<usize> {
    let (_, n) = name.rsplit_once(" - ")?;
    n.trim().parse().ok()
}

/// Parses a TRIOS export and keeps the steps `choice` names, joined by column name.
///
/// # Errors
/// [`DataError::Unsupported`] when the text is not a TRIOS export;
/// [`DataError::NoSuchInterval`] when a chosen step is not in it; [`DataError::Malformed`]
/// naming the line of a step whose head is incomplete.
pub fn parse(
    text: String,
    encoding: Encoding,
    path: &Path,
    choice: &IntervalChoice,
) -> Result<Table, DataError> {
    let separator =
        recognise(&text).map_err(not_recognised(path, "a TA Instruments TRIOS export"))?;
    let mut found = Vec::new();
    let mut steps: Vec<(String, Block)> = Vec::new();
    let mut fields = Vec::new();
    let mut sample: Vec<String> = Vec::new();
    let mut all = lines(&text);
    let mut in_data = false;
    while let Some(line) = all.next() {
        let raw = &text[line.start..line.end];
        if is_step_marker(raw) {
            let (name, declared, names, units) =
                step_head(&text, &mut all).map_err(|reason| DataError::Malformed {
                    path: path.to_owned(),
                    line: line.number,
                    column: 1,
                    message: format!("{reason}; each `[step]` has a name, column names and units"),
                })?;
            steps.push(step_block(
                &text,
                separator,
                (name, declared, names, units),
                &mut fields,
            ));
            in_data = true;
            continue;
        }
        if is_blank(raw, separator) {
            in_data = false;
            continue;
        }
        if !in_data {
            // Header block: a few facts for the record.
            if steps.is_empty() && found.len() < 3 {
                split_fields(raw, separator, usize::MAX, &mut fields);
                let key = unquote(fields[0]);
                if ["Instrument type", "Trios version", "Procedure name"].contains(&key) {
                    found.push(format!(
                        "{key} {}",
                        fields.get(1).map_or("", |f| unquote(f))
                    ));
                }
            }
            continue;
        }
        let Some((_, block)) = steps.last_mut() else {
            continue;
        };
        block.rows.push(TextRow {
            start: line.start,
            end: line.end,
            line: line.number,
            flagged: false,
        });
        if block.rows.len() <= SAMPLE_ROWS {
            split_fields(raw, separator, usize::MAX, &mut fields);
            sample.extend(fields.iter().map(|f| (*f).to_owned()));
        }
    }
    let blocks = numbered(steps);
    drop(all);
    Export {
        vendor: "TA Instruments TRIOS export",
        kind: "step",
        numbers: NumberFormat::detect(sample.iter().map(String::as_str), separator),
        text,
        encoding,
        separator,
        found,
        sections: Vec::new(),
        blocks,
    }
    .into_table(choice, path)
}

/// A step's name and its block, from the lines `step_head` found: its columns named and
/// their units, no rows yet.
fn step_block<'t>(
    text: &'t str,
    separator: u8,
    (name, declared, names, units): (Line, Option<usize>, Line, Line),
    fields: &mut Vec<&'t str>,
) -> (String, Block) {
    split_fields(&text[names.start..names.end], separator, usize::MAX, fields);
    let mut column_names: Vec<String> = fields.iter().map(|f| unquote(f).to_owned()).collect();
    while column_names.last().is_some_and(String::is_empty) {
        column_names.pop();
    }
    split_fields(&text[units.start..units.end], separator, usize::MAX, fields);
    let column_units = (0..column_names.len())
        .map(|c| {
            fields
                .get(c)
                .map(|u| unquote(u))
                .filter(|u| !u.is_empty())
                .map(str::to_owned)
        })
        .collect();
    let step_name =
        unquote(text[name.start..name.end].trim_end_matches([',', ';', '\t'])).to_owned();
    (
        step_name,
        Block {
            declared,
            fields: (0..column_names.len()).collect(),
            names: column_names,
            units: column_units,
            header_line: names.number,
            ..Block::default()
        },
    )
}

/// The steps' blocks numbered: by the number their name ends with when every name has a
/// distinct one (TRIOS numbers the procedure's steps), else by their order; labelled by their
/// name.
fn numbered(steps: Vec<(String, Block)>) -> Vec<Block> {
    let numbers: Vec<Option<usize>> = steps.iter().map(|(n, _)| number_in_name(n)).collect();
    let mut distinct: Vec<usize> = numbers.iter().flatten().copied().collect();
    distinct.sort_unstable();
    distinct.dedup();
    let by_name = distinct.len() == steps.len() && numbers.iter().all(Option::is_some);
    steps
        .into_iter()
        .zip(numbers)
        .enumerate()
        .map(|(index, ((name, mut block), number))| {
            block.number = if by_name {
                number.unwrap_or(index + 1)
            } else {
                index + 1
            };
            block.label = Some(format!("`{name}`"));
            block
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    const EXPORT: &str = "Filename\tx\nTrios version\t5.1\n[File Parameters]\nName\tx\n\
        [step]\nPeak hold - 1\nTime\tStep time\tStress\nmin\tmin\tPa\n0\t0\t1.5\n1.5\t1.5\t2\n\n\
        [step]\nFlow ramp - 2\nNumber of points\t2\nTorque\tStep time\tTime\tDate and time\n\
        µN.m\tmin\tmin\t\n16.5\t0.1\t0.05\t10/17/2022 10:27:02 AM\n17\t0.2\t0.0666\tx\n";

    fn read(text: &str, choice: &IntervalChoice) -> Result<Table, DataError> {
        parse(
            text.to_owned(),
            Encoding::Utf8 { bom: false },
            Path::new("t.txt"),
            choice,
        )
    }

    #[test]
    fn steps_by_number_with_their_own_columns() {
        assert_eq!(recognise(EXPORT), Ok(b'\t'));
        let table = read(EXPORT, &IntervalChoice::Numbers(vec![2])).unwrap();
        assert_eq!(
            table.names,
            ["Torque", "Step time", "Time", "Date and time"]
        );
        assert_eq!(table.units[0].as_deref(), Some("µN.m"));
        assert_eq!(table.line(0), 17);
        assert!(
            table
                .found
                .iter()
                .any(|f| f.contains("step 2 (`Flow ramp - 2`): 2 points")),
            "{:?}",
            table.found
        );
        // Both steps: only the columns they share.
        let both = read(EXPORT, &IntervalChoice::All).unwrap();
        assert_eq!(both.names, ["Time", "Step time"]);
        assert_eq!(both.rows(), 4);
    }

    #[test]
    fn csv_export_and_reasons() {
        let csv = EXPORT.replace('\t', ",");
        assert_eq!(recognise(&csv), Ok(b','));
        let reason = recognise("a,b\n1,2\n").unwrap_err();
        assert!(reason.contains("no `[step]`"), "{reason}");
        let reason = recognise("[step]\nx\nTime\tTorque\n1\t2\n").unwrap_err();
        assert!(reason.contains("row of units"), "{reason}");
    }
}
