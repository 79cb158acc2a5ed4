//! Helpers shared by integration tests: reading committed reference tables.
#![allow(dead_code)]

use std::path::PathBuf;

/// Path of a file under `tests/reference/`.
pub fn reference_path(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests")
        .join("reference")
        .join(name)
}

/// A CSV reference table: header names and rows of raw strings.
pub struct Table {
    pub header: Vec<String>,
    pub rows: Vec<Vec<String>>,
}

impl Table {
    pub fn load(name: &str) -> Self {
        let text = std::fs::read_to_string(reference_path(name))
            .unwrap_or_else(|e| panic!("reading reference {name}: {e}"));
        let mut lines = text.lines();
        let header = lines
            .next()
            .unwrap()
            .split(',')
            .map(str::to_owned)
            .collect();
        let rows = lines
            .filter(|l| !l.trim().is_empty())
            .map(|l| l.split(',').map(str::to_owned).collect())
            .collect();
        Self { header, rows }
    }

    pub fn col(&self, name: &str) -> usize {
        self.header
            .iter()
            .position(|h| h == name)
            .unwrap_or_else(|| panic!("no column {name}"))
    }

    /// Value of `name` in `row`, parsed to the nearest double.
    pub fn f64(&self, row: &[String], name: &str) -> f64 {
        row[self.col(name)].parse().unwrap()
    }

    pub fn str<'a>(&self, row: &'a [String], name: &str) -> &'a str {
        &row[self.col(name)]
    }
}
