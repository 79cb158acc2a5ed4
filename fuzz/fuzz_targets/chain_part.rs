//! Any bytes as a complete chain part: footer, metadata and columns read back.
//! An error naming the file or a result that keeps the reader's promises, never a panic
//! (tests/hostile/mod.rs, shared with the seeded mutation tests of tests/hostile_inputs.rs).
#![no_main]

#[path = "../../tests/hostile/mod.rs"]
mod hostile;

libfuzzer_sys::fuzz_target!(|data: &[u8]| hostile::fuzz("chain_part", data));
