//! Any bytes through the RheoCompass reader and the column mapping: an error or a series,
//! never a panic, and a series that satisfies the importer's promises.
#![no_main]

mod common;

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use slipbayes::data::import::import_bytes;
use slipbayes::data::{Format, ImportOptions, IntervalChoice};

fuzz_target!(|data: &[u8]| {
    // The first byte picks the options, so one corpus explores all of them.
    let (choice, bytes) = data.split_first().map_or((0, data), |(c, rest)| (*c, rest));
    let options = ImportOptions {
        format: Some(Format::Rheocompass),
        drop_invalid: choice & 1 == 1,
        intervals: match choice >> 1 & 3 {
            0 => IntervalChoice::All,
            1 => IntervalChoice::Numbers(vec![1]),
            2 => IntervalChoice::Numbers(vec![2]),
            _ => IntervalChoice::Numbers(vec![1, 2]),
        },
        ..ImportOptions::default()
    };
    if let Ok(imported) = import_bytes(bytes, Path::new("fuzz.txt"), &options) {
        common::check(&imported);
    }
});
