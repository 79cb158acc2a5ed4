//! Malvern (Netzsch) Kinexus rSpace CSV exports, as seen in a real file (docs/model.md §9):
//! one header line whose columns carry their unit in parentheses (`Time (sequence)(s)`,
//! `Torque(N m)`, `Normal force(N)`), a column naming the action each row belongs to
//! (`Action Name`), then one row per point — semicolons and decimal commas on a European
//! computer (`4,013E+003`), commas and decimal points elsewhere. An action is a run of rows
//! with the same action name; actions are chosen like RheoCompass intervals. `Time (sequence)`
//! runs on across actions, `Time (action)` restarts.

use std::path::Path;

use super::blocks::{not_recognised, Block, Export};
use super::rheocompass::IntervalChoice;
use super::table::{Table, TextRow};
use super::text::{is_blank, lines, split_fields, unquote, Encoding, NumberFormat};
use super::units::{parse_unit, Quantity};
use super::DataError;

/// How many rows feed the number-format detection.
const SAMPLE_ROWS: usize = 2000;

/// Splits `Time (sequence)(s)` into `Time (sequence)` and `s`; a name without a trailing
/// parenthesised group has no unit.
pub(crate) fn name_and_unit(header: &str) -> (String, Option<String>) {
    let t = header.trim();
    if let Some(inner) = t.strip_suffix(')') {
        let mut depth = 0usize;
        for (i, c) in inner.char_indices().rev() {
            match c {
                ')' => depth += 1,
                '(' if depth == 0 => {
                    let name = inner[..i].trim();
                    let unit = inner[i + 1..].trim();
                    if !name.is_empty() && !unit.is_empty() {
                        return (name.to_owned(), Some(unit.to_owned()));
                    }
                    break;
                }
                '(' => depth -= 1,
                _ => {}
            }
        }
    }
    (t.to_owned(), None)
}

/// The header's separator, its columns, and the column naming the action.
struct Header {
    separator: u8,
    names: Vec<String>,
    units: Vec<Option<String>>,
    action: usize,
    line: usize,
}

/// Whether a text has an rSpace export's shape; the reason if not.
fn header(text: &str) -> Result<Header, String> {
    let mut all = lines(text).filter(|l| !text[l.start..l.end].trim().is_empty());
    let head = all.next().ok_or("the file is empty")?;
    let raw = &text[head.start..head.end];
    let separator = [b';', b',', b'\t']
        .into_iter()
        .max_by_key(|&s| raw.bytes().filter(|&b| b == s).count())
        .unwrap_or(b';');
    let mut fields = Vec::new();
    split_fields(raw, separator, usize::MAX, &mut fields);
    let (names, units): (Vec<String>, Vec<Option<String>>) =
        fields.iter().map(|f| name_and_unit(unquote(f))).unzip();
    let times = units
        .iter()
        .flatten()
        .filter(|u| {
            matches!(
                parse_unit(u).map(|u| u.quantity),
                Some(Quantity::Time { .. })
            )
        })
        .count();
    let with_units = units.iter().flatten().count();
    if with_units < 2 || times == 0 {
        return Err(format!(
            "the first line is not a header of columns with their units in parentheses \
             (`Time (sequence)(s)`, `Torque(N m)`): {with_units} columns with a unit, {times} \
             of them a time"
        ));
    }
    let first = all.next().ok_or("a header but no data rows")?;
    split_fields(
        &text[first.start..first.end],
        separator,
        usize::MAX,
        &mut fields,
    );
    let action = (0..names.len())
        .find(|&c| {
            units[c].is_none()
                && fields
                    .get(c)
                    .is_some_and(|f| !unquote(f).is_empty() && !NumberFormat::reads_as_number(f))
        })
        .ok_or("no column naming the action of each row (`Action Name`)")?;
    Ok(Header {
        separator,
        names,
        units,
        action,
        line: head.number,
    })
}

/// Whether a text has an rSpace export's shape; the reason if not. Returns the separator.
pub(crate) fn recognise(text: &str) -> Result<u8, String> {
    header(text).map(|h| h.separator)
}

/// Parses an rSpace export and keeps the actions `choice` names.
///
/// # Errors
/// [`DataError::Unsupported`] when the text is not an rSpace export;
/// [`DataError::NoSuchInterval`] when a chosen action is not in it.
pub fn parse(
    text: String,
    encoding: Encoding,
    path: &Path,
    choice: &IntervalChoice,
) -> Result<Table, DataError> {
    let head = header(&text).map_err(not_recognised(path, "a Malvern rSpace export"))?;
    let separator = head.separator;
    let mut blocks: Vec<Block> = Vec::new();
    let mut current: Option<String> = None;
    let mut fields = Vec::new();
    let mut sample: Vec<String> = Vec::new();
    let mut sampled = 0;
    for line in lines(&text).skip_while(|l| l.number <= head.line) {
        let raw = &text[line.start..line.end];
        if is_blank(raw, separator) {
            continue;
        }
        split_fields(raw, separator, head.action + 2, &mut fields);
        let action = fields.get(head.action).map_or("", |f| unquote(f));
        if current.as_deref() != Some(action) {
            current = Some(action.to_owned());
            blocks.push(Block {
                number: blocks.len() + 1,
                label: Some(format!("`{action}`")),
                names: head.names.clone(),
                units: head.units.clone(),
                fields: (0..head.names.len()).collect(),
                header_line: head.line,
                ..Block::default()
            });
        }
        if let Some(block) = blocks.last_mut() {
            block.rows.push(TextRow {
                start: line.start,
                end: line.end,
                line: line.number,
                flagged: false,
            });
        }
        if sampled < SAMPLE_ROWS {
            sampled += 1;
            split_fields(raw, separator, usize::MAX, &mut fields);
            sample.extend(fields.iter().map(|f| (*f).to_owned()));
        }
    }
    Export {
        vendor: "Malvern rSpace export",
        kind: "action",
        numbers: NumberFormat::detect(sample.iter().map(String::as_str), separator),
        text,
        encoding,
        separator,
        found: Vec::new(),
        sections: Vec::new(),
        blocks,
    }
    .into_table(choice, path)
}

#[cfg(test)]
mod tests {
    use super::super::table::Cell;
    use super::*;

    const EXPORT: &str =
        "Action Name;Time (sequence)(s);Time (action)(s);Torque(N m);Normal force(N)\n\
        Pre Shear;112,3;1,000;1,284E-003;0,2044\n\
        Pre Shear;113,3;2,000;2,223E-003;0,2019\n\
        Rest;4,013E+003;0,09375;;0,1828\n";

    #[test]
    fn units_in_parentheses() {
        assert_eq!(
            name_and_unit("Time (sequence)(s)"),
            ("Time (sequence)".to_owned(), Some("s".to_owned()))
        );
        assert_eq!(
            name_and_unit("Shear modulus (elastic component)(Pa)"),
            (
                "Shear modulus (elastic component)".to_owned(),
                Some("Pa".to_owned())
            )
        );
        assert_eq!(
            name_and_unit("Action Name"),
            ("Action Name".to_owned(), None)
        );
    }

    #[test]
    fn actions_are_blocks() {
        assert_eq!(recognise(EXPORT), Ok(b';'));
        let table = parse(
            EXPORT.to_owned(),
            Encoding::Utf8 { bom: false },
            Path::new("m.csv"),
            &IntervalChoice::Numbers(vec![1]),
        )
        .unwrap();
        assert_eq!(table.names[3], "Torque");
        assert_eq!(table.units[3].as_deref(), Some("N m"));
        assert_eq!(
            table.column(3),
            [Cell::Number(1.284e-3), Cell::Number(2.223e-3)]
        );
        assert_eq!(table.column(1)[1], Cell::Number(113.3));
        assert!(
            table
                .found
                .iter()
                .any(|f| f.contains("action 2 (`Rest`): 1 point")),
            "{:?}",
            table.found
        );
    }

    #[test]
    fn plain_tables_are_not_rspace() {
        let reason = recognise("time_s,force_N\n0,1\n").unwrap_err();
        assert!(reason.contains("units in parentheses"), "{reason}");
        let reason = recognise("a;Time(s);Torque(N m)\n1;2;3\n").unwrap_err();
        assert!(reason.contains("action"), "{reason}");
    }
}
