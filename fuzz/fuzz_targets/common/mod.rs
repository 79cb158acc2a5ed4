//! What every import that succeeds must promise, whatever the bytes were.

use slipbayes::data::Imported;

/// Panics (a fuzz finding) when a successful import breaks a promise of `import`.
pub fn check(imported: &Imported) {
    let s = &imported.series;
    assert!(!s.is_empty());
    assert!(s.time_s.windows(2).all(|w| w[0] < w[1]));
    assert!(s.time_s.iter().chain(&s.force_n).all(|v| v.is_finite()));
    assert_eq!(imported.lines.len(), s.len());
    assert_eq!(imported.points_read, s.len() + imported.dropped_invalid);
}
