//! Exports made of blocks — RheoCompass intervals, TRIOS steps, rSpace actions — and how the
//! blocks a user chooses become one table. Every vendor's parser finds its blocks; choosing
//! them (`interval = …`, `--interval …`), joining their columns and describing what was found
//! happens here, once for all.

use std::path::Path;

use super::labels::Roles;
use super::rheocompass::IntervalChoice;
use super::table::{BlockRows, Data, Segment, Table, TextData, TextRow};
use super::text::{Encoding, NumberFormat};
use super::DataError;

/// One block of an export as found.
#[derive(Debug, Default)]
pub(crate) struct Block {
    /// The number a user chooses it by (1-based).
    pub number: usize,
    /// Where it is in the file, for the user (`result "Flow Curve 1", interval 2`).
    pub label: Option<String>,
    /// Point count the file declares, if it does.
    pub declared: Option<usize>,
    /// Column names and units.
    pub names: Vec<String>,
    pub units: Vec<Option<String>>,
    /// Field of each column in a data row.
    pub fields: Vec<usize>,
    /// Field of the point number, if rows carry one.
    pub point_field: Option<usize>,
    /// Line of the column names.
    pub header_line: usize,
    pub rows: Vec<TextRow>,
    /// Rows that are not points (RheoCompass waveform samples), skipped and counted.
    pub skipped: usize,
}

/// An export parsed into blocks, before any is chosen.
#[derive(Debug)]
pub(crate) struct Export {
    /// `Anton Paar RheoCompass export`, …
    pub vendor: &'static str,
    /// What a block is called: `interval`, `step`, `action`.
    pub kind: &'static str,
    pub text: String,
    pub encoding: Encoding,
    pub separator: u8,
    pub numbers: NumberFormat,
    /// Header facts (project, instrument), for the user.
    pub found: Vec<String>,
    /// The file's section labels (they tell its language).
    pub sections: Vec<String>,
    pub blocks: Vec<Block>,
}

fn separator_name(separator: u8) -> &'static str {
    match separator {
        b'\t' => "tab-separated",
        b';' => "semicolon-separated",
        b',' => "comma-separated",
        _ => "separated",
    }
}

/// The error for a text a vendor's parser was given but does not recognise, with the reason.
pub(crate) fn not_recognised<'a>(
    path: &'a Path,
    export: &'static str,
) -> impl FnOnce(String) -> DataError + 'a {
    move |reason| DataError::Unsupported {
        path: path.to_owned(),
        message: format!("not {export}: {reason}"),
    }
}

/// `a`, `b`, `c` as a list for messages.
pub(crate) fn quoted<'a>(names: impl Iterator<Item = &'a str>) -> String {
    names
        .map(|n| format!("`{n}`"))
        .collect::<Vec<_>>()
        .join(", ")
}

fn columns_with_units(names: &[String], units: &[Option<String>]) -> String {
    names
        .iter()
        .zip(units)
        .map(|(n, u)| match u {
            Some(u) if u.starts_with('[') => format!("{n} {u}"),
            Some(u) => format!("{n} [{u}]"),
            None => n.clone(),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

impl Export {
    /// The chosen blocks as one table, their rows in the order chosen.
    ///
    /// # Errors
    /// [`DataError::Unsupported`] when the file has no block or a chosen one is not in it;
    /// [`DataError::Malformed`] when blocks to be joined give one column two units.
    pub(crate) fn into_table(
        self,
        choice: &IntervalChoice,
        path: &Path,
    ) -> Result<Table, DataError> {
        let kind = self.kind;
        if self.blocks.is_empty() {
            return Err(DataError::Unsupported {
                path: path.to_owned(),
                message: format!(
                    "a {} with no {kind} holding data; export the measurement with its data points",
                    self.vendor
                ),
            });
        }
        let mut found = self.describe();
        let chosen = chosen_blocks(&self.blocks, choice, kind, path)?;
        let Some(&first) = chosen.first() else {
            return Err(DataError::Unsupported {
                path: path.to_owned(),
                message: format!("no {kind} chosen; give `all` or {kind} numbers"),
            });
        };
        let JoinedColumns {
            names,
            units,
            left_out,
        } = joined_columns(&chosen, kind, path)?;
        let left_out = (!left_out.is_empty()).then(|| {
            format!(
                "columns not in every chosen {kind} are left out ({}): choose {kind}s that \
                 have the columns you need (model file: `interval = N`; command line: \
                 --interval N)",
                quoted(left_out.into_iter())
            )
        });
        found.extend(left_out.clone());
        found.push(format!("{kind}s kept: {choice}"));
        let (rows, segments, ranges) = joined_rows(&chosen, &names, kind);
        let sections: Vec<&str> = self.sections.iter().map(String::as_str).collect();
        let roles = Roles::identify(&names, &units, &sections);
        found.push(format!("columns recognised: {}", roles.describe(&names)));
        Ok(Table {
            header_line: first.header_line.max(1),
            names,
            units,
            found,
            roles,
            data: Data::Text(TextData {
                text: self.text,
                separator: self.separator,
                numbers: self.numbers,
                rows,
                segments,
            }),
            blocks: ranges,
            tried: None,
            left_out,
        })
    }

    /// What was found, for the user: the vendor and language, the encoding and formats, the
    /// header's facts, each block with its points (and its columns, unless all blocks share
    /// them).
    fn describe(&self) -> Vec<String> {
        let kind = self.kind;
        let roles_all = {
            let first = &self.blocks[0];
            let sections: Vec<&str> = self.sections.iter().map(String::as_str).collect();
            Roles::identify(&first.names, &first.units, &sections)
        };
        let mut found = vec![format!(
            "{}, {}",
            self.vendor,
            match roles_all.language {
                Some(l) => format!("labels in {}", l.name),
                None =>
                    "labels in no language slipbayes knows (columns found by their units)".into(),
            }
        )];
        found.push(format!(
            "{}, {}, {}",
            self.encoding,
            separator_name(self.separator),
            self.numbers
        ));
        found.extend(self.found.iter().cloned());
        let same_columns = self
            .blocks
            .iter()
            .all(|b| b.names == self.blocks[0].names && b.units == self.blocks[0].units);
        for b in &self.blocks {
            let declared = match b.declared {
                Some(n) if n != b.rows.len() => format!(" (the file declares {n})"),
                _ => String::new(),
            };
            let skipped = match b.skipped {
                0 => String::new(),
                1 => " and 1 waveform row (not a point, skipped)".to_owned(),
                n => format!(" and {n} waveform rows (not points, skipped)"),
            };
            let columns = if same_columns {
                String::new()
            } else {
                format!(", columns {}", columns_with_units(&b.names, &b.units))
            };
            found.push(format!(
                "{kind} {}{}: {} point{}{skipped}{declared}{columns}",
                b.number,
                b.label
                    .as_deref()
                    .map(|l| format!(" ({l})"))
                    .unwrap_or_default(),
                b.rows.len(),
                if b.rows.len() == 1 { "" } else { "s" },
            ));
        }
        if same_columns {
            found.push(format!(
                "columns: {}",
                columns_with_units(&self.blocks[0].names, &self.blocks[0].units)
            ));
        }
        found
    }
}

/// The blocks `choice` names, in its order.
///
/// # Errors
/// [`DataError::NoSuchInterval`] for a number no block has.
fn chosen_blocks<'b>(
    blocks: &'b [Block],
    choice: &IntervalChoice,
    kind: &'static str,
    path: &Path,
) -> Result<Vec<&'b Block>, DataError> {
    match choice {
        IntervalChoice::All => Ok(blocks.iter().collect()),
        IntervalChoice::Numbers(numbers) => numbers
            .iter()
            .map(|&n| {
                blocks
                    .iter()
                    .find(|b| b.number == n)
                    .ok_or_else(|| DataError::NoSuchInterval {
                        path: path.to_owned(),
                        kind,
                        asked: n,
                        intervals: blocks.iter().map(|b| (b.number, b.rows.len())).collect(),
                        table: None,
                    })
            })
            .collect(),
    }
}

/// Columns of every chosen block, in the first one's order, with their units, and the first
/// block's columns that some other lacks.
struct JoinedColumns<'b> {
    names: Vec<String>,
    units: Vec<Option<String>>,
    left_out: Vec<&'b str>,
}

/// The [`JoinedColumns`] of the chosen blocks.
///
/// # Errors
/// [`DataError::Malformed`] for a column the blocks disagree on the unit of: it cannot be
/// joined.
fn joined_columns<'b>(
    chosen: &[&'b Block],
    kind: &'static str,
    path: &Path,
) -> Result<JoinedColumns<'b>, DataError> {
    let first = chosen[0];
    let mut names = Vec::new();
    let mut units = Vec::new();
    let mut left_out = Vec::new();
    for (c, name) in first.names.iter().enumerate() {
        let mut everywhere = true;
        for other in &chosen[1..] {
            match other.names.iter().position(|n| n == name) {
                Some(o) if other.units[o] != first.units[c] => {
                    return Err(DataError::Malformed {
                        path: path.to_owned(),
                        line: other.header_line.max(1),
                        column: o + 1,
                        message: format!(
                            "column `{name}` is in {} in {kind} {} but in {} in {kind} {}; \
                             choose {kind}s that agree (model file: `interval = N`; \
                             command line: --interval N)",
                            other.units[o].as_deref().unwrap_or("no unit"),
                            other.number,
                            first.units[c].as_deref().unwrap_or("no unit"),
                            first.number
                        ),
                    });
                }
                Some(_) => {}
                None => everywhere = false,
            }
        }
        if everywhere {
            names.push(name.clone());
            units.push(first.units[c].clone());
        } else {
            left_out.push(name.as_str());
        }
    }
    Ok(JoinedColumns {
        names,
        units,
        left_out,
    })
}

/// The chosen blocks' rows one after the other, each block's fields for the joined columns
/// `names`, and the range of rows each block holds.
fn joined_rows(
    chosen: &[&Block],
    names: &[String],
    kind: &'static str,
) -> (Vec<TextRow>, Vec<Segment>, Vec<BlockRows>) {
    let mut rows: Vec<TextRow> = Vec::new();
    let mut segments = Vec::new();
    let mut ranges = Vec::new();
    for block in chosen {
        let start = rows.len();
        rows.extend_from_slice(&block.rows);
        let fields = names
            .iter()
            .map(|n| {
                let at = block.names.iter().position(|b| b == n).unwrap_or(0);
                block.fields[at]
            })
            .collect();
        segments.push(Segment {
            rows: start..rows.len(),
            fields,
            point_field: block.point_field,
        });
        let label = block
            .label
            .as_deref()
            .map(|l| format!(" ({l})"))
            .unwrap_or_default();
        ranges.push(BlockRows {
            rows: start..rows.len(),
            kind,
            name: format!("{kind} {}{label}", block.number),
        });
    }
    (rows, segments, ranges)
}
