//! The replications of a validation run as one table, `replications.csv`: a row per
//! replication, appended as each finishes, so that a run stopped at any moment continues where
//! it stopped, and one file (not one per replication) holds the run's results.
//!
//! Columns: `index`, `fit_seed`, `redraws`, `converged`, `r_hat_max`, `tau_max`, `burn_in`,
//! `min_gap_over_tau`, `wall_s`, `failure`, then per ranked quantity Q `truth:Q`, `rank:Q`
//! and `quantile:Q`. An empty cell is a value the replication does not have (a failed fit has
//! no ranks). Numbers are written as Rust's shortest representation that reads back to the
//! same bits; text is quoted as RFC 4180 says when it holds a comma, a quote or a line break.
//!
//! A row is appended in one write and flushed to disk before the replication counts as done.
//! A kill during that write leaves a last row without its line end, which reading drops (the
//! replication runs again); opening a run rewrites the table without it, atomically. When a
//! run ends the table is rewritten in index order, so that the same replications give the
//! same file whatever the order they finished in.

use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

use slipbayes::data::write_atomically;

use super::Replication;

/// File name of the table in a validation run's directory.
pub const REPLICATIONS_TABLE: &str = "replications.csv";

/// Columns before the per-quantity ones.
const FIXED: [&str; 10] = [
    "index",
    "fit_seed",
    "redraws",
    "converged",
    "r_hat_max",
    "tau_max",
    "burn_in",
    "min_gap_over_tau",
    "wall_s",
    "failure",
];
const TRUTH: &str = "truth:";
const RANK: &str = "rank:";
const QUANTILE: &str = "quantile:";

/// Why a table cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// The header is not a replications table's, or names other quantities than the run's.
    #[error("{path}: {problem}")]
    Header {
        /// The table.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// Reading or writing failed.
    #[error(transparent)]
    Io(#[from] slipbayes::IoError),
}

fn io(action: &'static str, path: &Path) -> impl FnOnce(std::io::Error) -> TableError {
    let path = path.to_path_buf();
    move |source| slipbayes::IoError::new(action, path, source).into()
}

/// The header row of a table ranking `quantities`.
pub fn header(quantities: &[String]) -> Vec<String> {
    let mut cells: Vec<String> = FIXED.iter().map(|c| (*c).to_owned()).collect();
    for q in quantities {
        for prefix in [TRUTH, RANK, QUANTILE] {
            cells.push(format!("{prefix}{q}"));
        }
    }
    cells
}

/// A number that reads back to the same bits (`{:?}` is the shortest such representation).
fn number(v: f64) -> String {
    format!("{v:?}")
}

fn optional(v: Option<f64>) -> String {
    v.map_or_else(String::new, number)
}

/// A cell as CSV writes it: quoted when it holds a separator, a quote or a line break.
fn quoted(cell: &str) -> String {
    if cell.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", cell.replace('"', "\"\""))
    } else {
        cell.to_owned()
    }
}

fn line(cells: &[String]) -> String {
    let mut text = cells
        .iter()
        .map(|c| quoted(c))
        .collect::<Vec<_>>()
        .join(",");
    text.push('\n');
    text
}

/// `rep` as one line of a table ranking `quantities`.
pub fn row(rep: &Replication, quantities: &[String]) -> String {
    let mut cells = vec![
        rep.index.to_string(),
        rep.fit_seed.to_string(),
        rep.redraws.to_string(),
        rep.converged.to_string(),
        optional(rep.r_hat_max),
        optional(rep.tau_max),
        rep.burn_in.to_string(),
        optional(rep.min_gap_over_tau),
        number(rep.wall_s),
        rep.failure.clone().unwrap_or_default(),
    ];
    for q in quantities {
        cells.push(optional(rep.truth.get(q).copied()));
        cells.push(rep.ranks.get(q).map_or_else(String::new, usize::to_string));
        cells.push(optional(rep.quantiles.get(q).copied()));
    }
    line(&cells)
}

/// The records of a CSV text, each with whether its line end was read; quoted cells may
/// hold separators, doubled quotes and line breaks.
fn records(text: &str) -> Vec<(Vec<String>, bool)> {
    let mut out = Vec::new();
    let mut cells = Vec::new();
    let mut cell = String::new();
    let mut in_quotes = false;
    let mut chars = text.chars().peekable();
    let mut started = false;
    while let Some(c) = chars.next() {
        started = true;
        if in_quotes {
            match c {
                '"' if chars.peek() == Some(&'"') => {
                    chars.next();
                    cell.push('"');
                }
                '"' => in_quotes = false,
                _ => cell.push(c),
            }
            continue;
        }
        match c {
            '"' => in_quotes = true,
            ',' => cells.push(std::mem::take(&mut cell)),
            '\r' if chars.peek() == Some(&'\n') => {}
            '\n' => {
                cells.push(std::mem::take(&mut cell));
                out.push((std::mem::take(&mut cells), true));
                started = false;
            }
            _ => cell.push(c),
        }
    }
    if started {
        cells.push(cell);
        out.push((cells, false));
    }
    out
}

/// The quantities a header ranks, or what is wrong with it.
fn quantities_of(header: &[String]) -> Result<Vec<String>, String> {
    let fixed: Vec<&str> = header
        .iter()
        .take(FIXED.len())
        .map(String::as_str)
        .collect();
    if fixed != FIXED {
        return Err(format!(
            "not a table of replications: its header starts {fixed:?}, expected {FIXED:?}"
        ));
    }
    let rest = &header[FIXED.len()..];
    if rest.len() % 3 != 0 {
        return Err("the per-quantity columns do not come in threes".into());
    }
    rest.chunks(3)
        .map(|c| {
            let q = c[0].strip_prefix(TRUTH).unwrap_or_default();
            let expected = [
                format!("{TRUTH}{q}"),
                format!("{RANK}{q}"),
                format!("{QUANTILE}{q}"),
            ];
            if q.is_empty() || c != expected {
                Err(format!("columns {c:?}: expected {expected:?}"))
            } else {
                Ok(q.to_owned())
            }
        })
        .collect()
}

/// One record as a replication, or `None` when a cell does not parse (a row cut short).
fn replication(cells: &[String], quantities: &[String]) -> Option<Replication> {
    if cells.len() != FIXED.len() + 3 * quantities.len() {
        return None;
    }
    let float = |s: &str| -> Option<Option<f64>> {
        if s.is_empty() {
            Some(None)
        } else {
            s.parse().ok().map(Some)
        }
    };
    let mut rep = Replication {
        index: cells[0].parse().ok()?,
        fit_seed: cells[1].parse().ok()?,
        redraws: cells[2].parse().ok()?,
        converged: cells[3].parse().ok()?,
        r_hat_max: float(&cells[4])?,
        tau_max: float(&cells[5])?,
        burn_in: cells[6].parse().ok()?,
        min_gap_over_tau: float(&cells[7])?,
        wall_s: cells[8].parse().ok()?,
        failure: Some(cells[9].clone()).filter(|f| !f.is_empty()),
        truth: BTreeMap::new(),
        ranks: BTreeMap::new(),
        quantiles: BTreeMap::new(),
    };
    for (q, c) in quantities.iter().zip(cells[FIXED.len()..].chunks(3)) {
        if let Some(v) = float(&c[0])? {
            rep.truth.insert(q.clone(), v);
        }
        if !c[1].is_empty() {
            rep.ranks.insert(q.clone(), c[1].parse().ok()?);
        }
        if let Some(v) = float(&c[2])? {
            rep.quantiles.insert(q.clone(), v);
        }
    }
    Some(rep)
}

/// A table read back.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// The quantities it ranks, in its columns' order.
    pub quantities: Vec<String>,
    /// Its whole rows, by index.
    pub rows: BTreeMap<usize, Replication>,
}

/// The table at `path`: a later row of an index replaces an earlier one; a row without its
/// line end, or whose cells do not parse, is left out. `None` for a file that does not exist.
///
/// # Errors
/// [`TableError`] when the file cannot be read or its header is not a table's.
pub fn read(path: &Path) -> Result<Option<Table>, TableError> {
    let text = match std::fs::read_to_string(path) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(io("read", path)(e)),
    };
    let mut records = records(&text).into_iter();
    let Some((header, true)) = records.next() else {
        // An empty file, or a header cut short: nothing was recorded yet.
        return Ok(Some(Table {
            quantities: Vec::new(),
            rows: BTreeMap::new(),
        }));
    };
    let quantities = quantities_of(&header).map_err(|problem| TableError::Header {
        path: path.to_path_buf(),
        problem,
    })?;
    let rows = records
        .filter(|(_, whole)| *whole)
        .filter_map(|(cells, _)| replication(&cells, &quantities))
        .map(|r| (r.index, r))
        .collect();
    Ok(Some(Table { quantities, rows }))
}

/// Writes the table of `reps` (in index order) over `path`, atomically.
///
/// # Errors
/// [`TableError::Io`] when it cannot be written.
pub fn write(
    path: &Path,
    quantities: &[String],
    reps: &BTreeMap<usize, Replication>,
) -> Result<(), TableError> {
    let mut text = line(&header(quantities));
    for rep in reps.values() {
        text.push_str(&row(rep, quantities));
    }
    write_atomically(path, text.as_bytes()).map_err(io("write", path))
}

/// A table open for appending rows, from any thread.
#[derive(Debug)]
pub struct Appender {
    path: PathBuf,
    quantities: Vec<String>,
    file: Mutex<File>,
}

impl Appender {
    /// Opens `path`, which [`write()`] has written, to append rows of `quantities`.
    ///
    /// # Errors
    /// [`TableError::Io`] when it cannot be opened.
    pub fn open(path: &Path, quantities: &[String]) -> Result<Self, TableError> {
        let file = OpenOptions::new()
            .append(true)
            .open(path)
            .map_err(io("open", path))?;
        Ok(Self {
            path: path.to_path_buf(),
            quantities: quantities.to_vec(),
            file: Mutex::new(file),
        })
    }

    /// Appends `rep`'s row in one write and flushes it to disk.
    ///
    /// # Errors
    /// [`TableError::Io`] when it cannot be written.
    pub fn append(&self, rep: &Replication) -> Result<(), TableError> {
        let bytes = row(rep, &self.quantities);
        let mut file = self.file.lock().unwrap_or_else(|p| p.into_inner());
        file.write_all(bytes.as_bytes())
            .and_then(|()| file.sync_data())
            .map_err(io("append to", &self.path))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quantities() -> Vec<String> {
        vec!["alpha[PTFE]".into(), "t0[first, \"odd\" name]".into()]
    }

    fn done(index: usize) -> Replication {
        Replication {
            index,
            truth: BTreeMap::from([
                ("alpha[PTFE]".to_string(), 1086686.0085166846),
                ("t0[first, \"odd\" name]".to_string(), 1e-20),
            ]),
            redraws: 2,
            fit_seed: 7424550030962593201,
            ranks: BTreeMap::from([
                ("alpha[PTFE]".to_string(), 83),
                ("t0[first, \"odd\" name]".to_string(), 0),
            ]),
            quantiles: BTreeMap::from([
                ("alpha[PTFE]".to_string(), 0.7967456004140787),
                ("t0[first, \"odd\" name]".to_string(), 0.0),
            ]),
            converged: true,
            r_hat_max: Some(1.001470092669835),
            tau_max: Some(16.893384658321004),
            burn_in: 34,
            min_gap_over_tau: None,
            wall_s: 1.023752976,
            failure: None,
        }
    }

    fn failed(index: usize) -> Replication {
        Replication {
            truth: BTreeMap::new(),
            ranks: BTreeMap::new(),
            quantiles: BTreeMap::new(),
            converged: false,
            r_hat_max: None,
            tau_max: None,
            failure: Some("fit: \"stick-slip\", at t = 3 s\nsecond line".into()),
            ..done(index)
        }
    }

    #[test]
    fn rows_read_back_to_the_same_replications() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(REPLICATIONS_TABLE);
        let reps = BTreeMap::from([(0, done(0)), (3, failed(3))]);
        write(&path, &quantities(), &reps).unwrap();
        let back = read(&path).unwrap().unwrap();
        assert_eq!(back.quantities, quantities());
        assert_eq!(back.rows, reps);
    }

    #[test]
    fn a_row_cut_short_is_not_finished_and_appending_continues_after_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(REPLICATIONS_TABLE);
        write(&path, &quantities(), &BTreeMap::new()).unwrap();
        let table = Appender::open(&path, &quantities()).unwrap();
        table.append(&failed(4)).unwrap();
        table.append(&done(1)).unwrap();
        // A kill in the middle of the next row: every prefix of it is dropped.
        let whole = std::fs::read_to_string(&path).unwrap();
        let next = row(&done(2), &quantities());
        for cut in 1..next.len() {
            std::fs::write(&path, format!("{whole}{}", &next[..cut])).unwrap();
            let back = read(&path).unwrap().unwrap().rows;
            assert_eq!(
                back.keys().copied().collect::<Vec<_>>(),
                [1, 4],
                "cut at {cut}"
            );
        }
        std::fs::write(&path, &whole).unwrap();
        let back = read(&path).unwrap().unwrap().rows;
        assert_eq!(back, BTreeMap::from([(1, done(1)), (4, failed(4))]));
    }

    #[test]
    fn a_file_that_is_not_a_table_is_refused_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join(REPLICATIONS_TABLE);
        std::fs::write(&path, "time_s,force_N\n1,2\n").unwrap();
        let err = read(&path).unwrap_err().to_string();
        assert!(
            err.contains(REPLICATIONS_TABLE) && err.contains("not a table of replications"),
            "{err}"
        );
        assert!(read(&dir.path().join("missing.csv")).unwrap().is_none());
    }
}
