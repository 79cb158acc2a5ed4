//! `summary.csv`: one row per parameter and derived quantity, ArviZ's column names.

use super::summary::{FitSummary, QuantitySummary};
use crate::density::QuantityKind;

/// Columns of `summary.csv`, in order.
pub const CSV_COLUMNS: [&str; 16] = [
    "kind",
    "name",
    "group",
    "unit",
    "mean",
    "sd",
    "median",
    "ci_low",
    "ci_high",
    "ci_prob",
    "hdi_low",
    "hdi_high",
    "ess_bulk",
    "ess_tail",
    "r_hat",
    "mcse_mean",
];

/// Numbers between these magnitudes are written in plain decimal, others in scientific
/// notation; both forms are the shortest that read back to the same `f64`.
const PLAIN_RANGE: (f64, f64) = (1e-4, 1e15);

/// The text of `summary.csv` (RFC 4180, `\n` line ends): parameters first, then derived
/// quantities, in the order of `summary`. A missing value (R̂ with one ensemble) is an empty
/// field; NaN and infinities are written `NaN`, `inf`, `-inf` (as pandas reads them).
pub(crate) fn summary_csv(summary: &FitSummary) -> String {
    let mut out = CSV_COLUMNS.join(",");
    out.push('\n');
    let rows = summary
        .parameters
        .iter()
        .map(|q| (QuantityKind::Parameter, q))
        .chain(summary.derived.iter().map(|q| (QuantityKind::Derived, q)));
    for (kind, q) in rows {
        out.push_str(&row(kind, q).join(","));
        out.push('\n');
    }
    out
}

fn row(kind: QuantityKind, q: &QuantitySummary) -> Vec<String> {
    let s = &q.stats;
    let mut fields = vec![
        kind.as_str().to_owned(),
        text(&q.name),
        text(&q.group),
        text(&q.unit),
    ];
    fields.extend(
        [
            s.mean, s.sd, s.median, s.ci_low, s.ci_high, s.ci_prob, s.hdi_low, s.hdi_high,
            s.ess_bulk, s.ess_tail,
        ]
        .map(number),
    );
    fields.push(s.r_hat.map(number).unwrap_or_default());
    fields.push(number(s.mcse_mean));
    fields
}

/// A text field, quoted when it holds a comma, quote or line break.
fn text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// The shortest text that reads back to `x` exactly.
fn number(x: f64) -> String {
    if x.is_nan() {
        "NaN".to_owned()
    } else if x.is_infinite() {
        if x > 0.0 { "inf" } else { "-inf" }.to_owned()
    } else if x.abs() >= PLAIN_RANGE.1 || (x.abs() < PLAIN_RANGE.0 && x.abs() > 0.0) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_read_back_exactly() {
        for x in [
            0.0,
            -0.0,
            1.0,
            0.95,
            1e-4,
            9.99e-5,
            1e15,
            123456.789,
            -3.2e-300,
            f64::MAX,
            f64::MIN_POSITIVE,
            5e-324,
            0.1 + 0.2,
        ] {
            let back: f64 = number(x).parse().expect("parses");
            assert_eq!(back.to_bits(), x.to_bits(), "{x} written as {}", number(x));
        }
        assert_eq!(number(f64::NAN), "NaN");
        assert_eq!(number(f64::NEG_INFINITY), "-inf");
        assert_eq!(number(0.95), "0.95");
        assert_eq!(number(2e-7), "2e-7");
    }

    #[test]
    fn text_fields_are_quoted_only_when_needed() {
        assert_eq!(text("ptfe-c1"), "ptfe-c1");
        assert_eq!(text("a,b"), "\"a,b\"");
        assert_eq!(text("say \"hi\""), "\"say \"\"hi\"\"\"");
    }
}
