//! The mapping from a table's columns to the series a fit reads: which columns (named by the
//! user, or found by their labels and units), their units to SI, and every row checked.

use std::path::Path;

use super::{
    read_as_csv, Clock, ColumnMap, ColumnRef, Format, ImportOptions, Imported, MAX_MAGNITUDE_SI,
};
use crate::data::labels::{Role, LANGUAGES};
use crate::data::table::{Bad, Table};
use crate::data::units::{parse_unit, Quantity, Unit, KNOWN_UNITS};
use crate::data::{DataError, Series};

/// The table's columns with their units, for messages.
fn columns_listed(table: &Table) -> String {
    table
        .names
        .iter()
        .zip(&table.units)
        .map(|(n, u)| match u {
            Some(u) if u.starts_with('[') => format!("`{n}` {u}"),
            Some(u) => format!("`{n}` [{u}]"),
            None => format!("`{n}`"),
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// The columns the table's labels and units point to: time on the clock asked for, force (or
/// else torque), and the normal force when there is one.
fn default_map(table: &Table, path: &Path, clock: Clock) -> Result<ColumnMap, DataError> {
    let roles = &table.roles;
    let named = |c: usize| ColumnRef::named(&table.names[c]);
    let (time_role, other) = match clock {
        Clock::Global => (Role::Time, Role::StepTime),
        Clock::Step => (Role::StepTime, Role::Time),
    };
    let languages = LANGUAGES
        .iter()
        .map(|l| l.name)
        .collect::<Vec<_>>()
        .join(", ");
    let missing = |what: &str, hint: String| {
        let tried = table
            .tried
            .as_deref()
            .map(|t| format!(" — {}", read_as_csv(t)))
            .unwrap_or_default();
        let left_out = table
            .left_out
            .as_deref()
            .map(|l| format!("; {l}"))
            .unwrap_or_default();
        DataError::Malformed {
            path: path.to_owned(),
            line: table.header_line,
            column: 1,
            message: format!(
                "no {what} column among the columns {}: none has a {what} label known in \
                 {languages}{hint}; name the column with a mapping (model file: `columns = \
                 {{ time = {{ name = \"…\", unit = \"s\" }}, … }}`; command line: \
                 --time-column/--force-column){left_out}{tried}",
                columns_listed(table),
            ),
        }
    };
    let time = roles.column(time_role).ok_or_else(|| {
        let hint = match (clock, roles.column(other)) {
            (Clock::Global, Some(c)) => format!(
                "; `{}` is the time of each interval or step: read the file with \
                 --clock step (model file: `clock = \"step\"`) to use it",
                table.names[c]
            ),
            (Clock::Step, Some(c)) => format!(
                "; `{}` is the continuous time: leave out --clock step (model file: \
                 `clock = \"global\"`) to use it",
                table.names[c]
            ),
            _ => " or a time unit".to_owned(),
        };
        let what = match clock {
            Clock::Global => "time",
            Clock::Step => "step time",
        };
        missing(what, hint)
    })?;
    let force = roles
        .column(Role::Force)
        .or_else(|| roles.column(Role::Torque))
        .ok_or_else(|| missing("force or torque", " or a torque unit".to_owned()))?;
    Ok(ColumnMap {
        time: named(time),
        force: named(force),
        normal_force: roles.column(Role::NormalForce).map(named),
    })
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
                "no column `{}` (the {role} column); the file has {}{}",
                reference.name,
                columns_listed(table),
                table
                    .left_out
                    .as_deref()
                    .map(|l| format!("; {l}"))
                    .unwrap_or_default()
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
    // `Time (s)`, `Force [mN]`: a unit in brackets or parentheses ending the name.
    let embedded =
        super::rspace::name_and_unit(&reference.name.replace('[', "(").replace(']', ")")).1;
    let embedded = embedded.as_deref().filter(|s| parse_unit(s).is_some());
    let written = reference
        .unit
        .as_deref()
        .or(declared)
        .or(suffix)
        .or(embedded);
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
    let to_si = si_factor(
        path,
        &reference.name,
        role,
        &unit,
        moment_arm_m,
        conversions,
        |message| at_header(index + 1, message),
    )?;
    Ok(Resolved {
        index,
        role,
        unit,
        to_si,
    })
}

/// The factor from the mapped column's `unit` to SI for its `role` (a torque divided by the
/// moment arm gives a force), each conversion noted in `conversions`.
///
/// # Errors
/// [`DataError::Unsupported`] for a torque without a positive moment arm;
/// `not_of_role`'s error (naming the column) when its unit is not one of the role's.
fn si_factor(
    path: &Path,
    name: &str,
    role: &'static str,
    unit: &Unit,
    moment_arm_m: f64,
    conversions: &mut Vec<String>,
    not_of_role: impl FnOnce(String) -> DataError,
) -> Result<f64, DataError> {
    Ok(match (role, unit.quantity) {
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
            return Err(not_of_role(format!(
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
            )))
        }
    })
}

pub(super) fn map_table(
    table: &Table,
    path: &Path,
    format: Format,
    options: &ImportOptions,
) -> Result<Imported, DataError> {
    let rows = table.rows();
    if rows == 0 {
        let tried = table
            .tried
            .as_deref()
            .map(|t| format!(" — {}", read_as_csv(t)))
            .unwrap_or_default();
        return Err(DataError::Malformed {
            path: path.to_owned(),
            line: table.header_line,
            column: 1,
            message: format!(
                "the file has no data rows; export the measurement with its data points{tried}"
            ),
        });
    }
    let map = match &options.columns {
        Some(map) => map.clone(),
        None => default_map(table, path, options.clock)?,
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

    let indices: Vec<usize> = mapped.iter().map(|r| r.index).collect();
    let extracted = table.extract(&indices);
    let mut bad = extracted.bad.iter().peekable();
    let mut series = Series {
        normal_force_n: map.normal_force.as_ref().map(|_| Vec::with_capacity(rows)),
        time_s: Vec::with_capacity(rows),
        force_n: Vec::with_capacity(rows),
    };
    let mut lines = Vec::with_capacity(rows);
    let mut dropped_invalid = 0;
    for row in 0..rows {
        let mut bad_here: [Option<&Bad>; 3] = [None; 3];
        while let Some((_, slot, b)) = bad.next_if(|(r, _, _)| *r == row) {
            bad_here[*slot] = Some(b);
        }
        let Some(values) = row_values(
            table,
            path,
            &mapped,
            &extracted.values,
            row,
            bad_here,
            options.drop_invalid,
        )?
        else {
            dropped_invalid += 1;
            continue;
        };
        if let Some(&previous) = series.time_s.last() {
            check_time_order(table, path, row, values[0], previous, mapped[0].index)?;
        }
        series.time_s.push(values[0]);
        series.force_n.push(values[1]);
        if let Some(normal) = series.normal_force_n.as_mut() {
            normal.push(values[2]);
        }
        lines.push(table.line(row));
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

/// The SI values of the mapped columns in `row` (`bad_here`: its bad cells by slot), or
/// `None` when a cell is bad or beyond any measurement and `drop_invalid` drops the row.
///
/// # Errors
/// [`DataError::Malformed`] naming the line and column of such a cell otherwise.
fn row_values(
    table: &Table,
    path: &Path,
    mapped: &[Resolved],
    values_read: &[Vec<f64>],
    row: usize,
    bad_here: [Option<&Bad>; 3],
    drop_invalid: bool,
) -> Result<Option<[f64; 3]>, DataError> {
    let mut values = [0.0; 3];
    for (slot, r) in mapped.iter().enumerate() {
        let v = values_read[slot][row];
        let problem = match bad_here[slot] {
            Some(Bad::Flagged(point)) => Problem::Flagged(point),
            Some(Bad::Empty) => Problem::Cell("an empty cell".to_owned()),
            Some(Bad::Text(t)) => Problem::Cell(format!("`{t}`")),
            None if (v * r.to_si).abs() <= MAX_MAGNITUDE_SI => {
                values[slot] = v * r.to_si;
                continue;
            }
            None if v.is_finite() => Problem::Beyond(format!(
                "{v:e} ({:e} in {}) is beyond ±{MAX_MAGNITUDE_SI:e}: not a measurement \
                 (and its square would overflow the likelihood)",
                v * r.to_si,
                if r.role == "time" { "s" } else { "N" }
            )),
            None => Problem::Cell(v.to_string()),
        };
        if drop_invalid {
            return Ok(None);
        }
        let drop_hint = "drop such points explicitly (model file: `drop_invalid = true`; \
                         command line: --drop-invalid) and they are counted in the report";
        return Err(DataError::Malformed {
            path: path.to_owned(),
            line: table.line(row),
            column: r.index + 1,
            message: match problem {
                Problem::Flagged(point) => format!(
                    "the instrument marked point `{point}` invalid; choose intervals without \
                     it, or {drop_hint}"
                ),
                Problem::Beyond(bad) => format!(
                    "column `{}` ({}): {bad}; fix the point, or {drop_hint}",
                    table.names[r.index], r.role
                ),
                Problem::Cell(bad) => format!(
                    "{bad} in column `{}` ({}) is not a finite number; fix the point, or \
                     {drop_hint}",
                    table.names[r.index], r.role
                ),
            },
        });
    }
    Ok(Some(values))
}

/// Checks that the time of `row` follows the previous point's.
///
/// # Errors
/// [`DataError::Malformed`] naming the line, and the block the row starts if it does.
fn check_time_order(
    table: &Table,
    path: &Path,
    row: usize,
    time: f64,
    previous: f64,
    time_column: usize,
) -> Result<(), DataError> {
    if time <= previous {
        let what = if time < previous {
            "earlier than"
        } else {
            "equal to"
        };
        let restart = match table.block_of(row) {
            Some(block) if block.rows.start == row => format!(
                "; it is the first point of {}: keep {}s whose times follow on \
                 (model file: `interval = …`; command line: --interval)",
                block.name, block.kind
            ),
            _ => String::new(),
        };
        return Err(DataError::Malformed {
            path: path.to_owned(),
            line: table.line(row),
            column: time_column + 1,
            message: format!(
                "time {time} s is {what} the previous point's {previous} s; times must \
                 strictly increase (sort the rows, remove duplicates, or map a \
                 continuous time column rather than one that restarts per interval){restart}"
            ),
        });
    }
    Ok(())
}

/// What is wrong with a mapped cell.
enum Problem<'a> {
    /// The instrument marked the point invalid.
    Flagged(&'a str),
    /// The cell, described.
    Cell(String),
    /// A number no measurement reaches, described.
    Beyond(String),
}
