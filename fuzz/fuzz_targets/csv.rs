//! Any bytes through the CSV importer (polars with `--features tabular`, else the built-in reader) and the column mapping.
//! An error naming the file or a result that keeps the reader's promises, never a panic
//! (tests/hostile/mod.rs, shared with the seeded mutation tests of tests/hostile_inputs.rs).
#![no_main]

#[path = "../../tests/hostile/mod.rs"]
mod hostile;

libfuzzer_sys::fuzz_target!(|data: &[u8]| hostile::fuzz("csv", data));
