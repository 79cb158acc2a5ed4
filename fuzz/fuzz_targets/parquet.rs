//! Any bytes as a Parquet data file (polars; needs `--features tabular`) and the column mapping.
//! An error naming the file or a result that keeps the reader's promises, never a panic
//! (tests/hostile/mod.rs, shared with the seeded mutation tests of tests/hostile_inputs.rs).
#![no_main]

#[path = "../../tests/hostile/mod.rs"]
mod hostile;

libfuzzer_sys::fuzz_target!(|data: &[u8]| hostile::fuzz("parquet", data));
