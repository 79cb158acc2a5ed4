//! Any text through the reader of slipbayes' own CSV: an error or a series, never a panic;
//! a series read is written back and read again to the same numbers, bit for bit.
#![no_main]

use std::path::Path;

use libfuzzer_sys::fuzz_target;
use slipbayes::data::Series;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(series) = Series::parse_csv(text, Path::new("fuzz.csv")) {
        let again = Series::parse_csv(&series.to_csv().unwrap(), Path::new("again.csv")).unwrap();
        // Bit-exact for numbers; a NaN stays a NaN (its sign and payload are not promised).
        let same = |a: &[f64], b: &[f64]| {
            a.len() == b.len()
                && a.iter()
                    .zip(b)
                    .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
        };
        assert!(same(&series.time_s, &again.time_s));
        assert!(same(&series.force_n, &again.force_n));
    }
});
