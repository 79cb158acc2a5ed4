//! Any text through the reader of slipbayes' own CSV: an error or a series, never a panic;
//! a series read is written back and read again to the same bits.
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
        let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&series.time_s), bits(&again.time_s));
        assert_eq!(bits(&series.force_n), bits(&again.force_n));
    }
});
