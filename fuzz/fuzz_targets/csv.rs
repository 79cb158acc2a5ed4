//! Any bytes through the CSV table reader (polars) and the column mapping: an error or a
//! series, never a panic, and a series that satisfies the importer's promises.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use slipbayes::data::import::import_bytes;
use slipbayes::data::{Format, ImportOptions};

fuzz_target!(|data: &[u8]| {
    let (choice, bytes) = data.split_first().map_or((0, data), |(c, rest)| (*c, rest));
    let options = ImportOptions {
        format: Some(Format::Csv),
        drop_invalid: choice & 1 == 1,
        ..ImportOptions::default()
    };
    if let Ok(imported) = import_bytes(bytes, Path::new("fuzz.csv"), &options) {
        common::check(&imported);
    }
});
