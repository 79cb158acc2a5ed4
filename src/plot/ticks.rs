//! Scales and their ticks: where ticks go on a linear or logarithmic axis of any range, and
//! how their labels are written so that they stay short and distinct.
//!
//! Linear ticks are multiples of 1, 2, 2.5 or 5 × 10ⁿ. Labels are exact (written from integer
//! multiples, never from rounded floats). When plain numbers would be long the labels are
//! scaled (`×10⁻³`: a label of 4 means 4×10⁻³) or offset (`+10`: a label of 0.002 means
//! 10.002), as matplotlib does; the axis shows that note at its end. Logarithmic axes tick
//! decades (every k-th when there are many), or 1-2-5 within a few decades, and fall back to
//! linear ticks inside less than one.

/// How values map onto an axis.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Scale {
    /// Linear from `lo` to `hi`.
    Linear {
        /// Value at the start of the axis.
        lo: f64,
        /// Value at its end.
        hi: f64,
    },
    /// Logarithmic from `lo` to `hi` (both positive).
    Log {
        /// Value at the start of the axis.
        lo: f64,
        /// Value at its end.
        hi: f64,
    },
}

impl Scale {
    /// A linear scale over `range`, widened when it is empty or narrower than float precision
    /// can tick.
    pub fn linear(range: (f64, f64)) -> Self {
        let (lo, hi) = widen(range);
        let mid = 0.5 * (lo + hi);
        let min_span = mid.abs() * 1e-11;
        let (lo, hi) = if hi - lo < min_span {
            (mid - min_span, mid + min_span)
        } else {
            (lo, hi)
        };
        Self::Linear { lo, hi }
    }

    /// A logarithmic scale over `range`; a range that is not positive becomes (1, 10) and an
    /// empty one is widened by a factor 2 each way.
    pub fn log((lo, hi): (f64, f64)) -> Self {
        let (lo, hi) = if lo.is_finite() && hi.is_finite() && lo > 0.0 && hi > 0.0 {
            (lo.min(hi), lo.max(hi))
        } else if hi.is_finite() && hi > 0.0 {
            (hi / 1e3, hi)
        } else {
            (1.0, 10.0)
        };
        if hi / lo < 1.0 + 1e-9 {
            Self::Log {
                lo: lo / 2.0,
                hi: hi * 2.0,
            }
        } else {
            Self::Log { lo, hi }
        }
    }

    /// The range (start, end).
    pub fn range(&self) -> (f64, f64) {
        match *self {
            Self::Linear { lo, hi } | Self::Log { lo, hi } => (lo, hi),
        }
    }

    /// Where `v` falls along the axis, 0 at its start and 1 at its end; `None` when it cannot
    /// be shown (not finite, or not positive on a log scale). Values outside the range give
    /// fractions outside [0, 1].
    pub fn fraction(&self, v: f64) -> Option<f64> {
        if !v.is_finite() {
            return None;
        }
        match *self {
            Self::Linear { lo, hi } => Some((v - lo) / (hi - lo)),
            Self::Log { lo, hi } => (v > 0.0).then(|| (v.ln() - lo.ln()) / (hi.ln() - lo.ln())),
        }
    }

    /// Tick sets for this scale, densest first, each with at least two ticks inside the range
    /// (at least one set, whatever the range).
    pub(crate) fn candidates(&self) -> Vec<Ticks> {
        self.tick_sets(false)
    }

    /// The same tick sets as [`candidates`](Self::candidates), labelled as briefly as an
    /// offset and a scale allow (`−2, 0, 2` and `×10⁻³ +10` for 9.998, 10, 10.002): for axes
    /// too short for plain labels.
    pub(crate) fn compact_candidates(&self) -> Vec<Ticks> {
        self.tick_sets(true)
    }

    fn tick_sets(&self, compact: bool) -> Vec<Ticks> {
        let out = match *self {
            Self::Linear { lo, hi } => linear_candidates(lo, hi, compact),
            Self::Log { lo, hi } => {
                let mut c = log_candidates(lo, hi);
                if c.is_empty() {
                    c = linear_candidates(lo, hi, compact);
                }
                c
            }
        };
        if out.is_empty() {
            // Only for ranges float precision cannot divide: the two ends.
            let (lo, hi) = self.range();
            vec![Ticks {
                labels: vec![significant(lo, 6), significant(hi, 6)],
                values: vec![lo, hi],
                minor: Vec::new(),
                note: String::new(),
            }]
        } else {
            out
        }
    }
}

/// The ticks of an axis: values, their labels, lighter grid lines between them, and the note
/// that completes the labels (`×10⁻³`, `+10`, or both; empty when labels are plain).
#[derive(Debug, Clone, PartialEq)]
pub struct Ticks {
    /// Tick values, increasing.
    pub values: Vec<f64>,
    /// One label per value.
    pub labels: Vec<String>,
    /// Values of the light grid lines.
    pub minor: Vec<f64>,
    /// What the labels leave out: a scale factor and/or an offset.
    pub note: String,
}

/// Most ticks an axis is given.
const MAX_TICKS: i64 = 15;
/// Plain labels are at most this long; longer ones are scaled or offset.
const PLAIN_LEN: usize = 6;
/// Labels with more significant digits than this are offset.
const OFFSET_DIGITS: i64 = 6;

fn linear_candidates(lo: f64, hi: f64, compact: bool) -> Vec<Ticks> {
    let span = hi - lo;
    if !(span > 0.0 && span.is_finite()) {
        return Vec::new();
    }
    let top = span.log10().floor() as i32;
    let mut out = Vec::new();
    for e in (top - 2)..=(top + 1) {
        // step = mantissa × 10^(e - 1), mantissa 10, 20, 25 or 50.
        for mantissa in [10_i64, 20, 25, 50] {
            let exp = e - 1;
            let step = mantissa as f64 * 10f64.powi(exp);
            let k0 = (lo / step - 1e-9).ceil();
            let k1 = (hi / step + 1e-9).floor();
            let n = k1 - k0 + 1.0;
            if n > MAX_TICKS as f64 {
                continue;
            }
            if n < 2.0 {
                return out;
            }
            out.push(linear_set(lo, hi, mantissa, exp, compact));
        }
    }
    out
}

/// The ticks k·step in [lo, hi], step = mantissa × 10^exp; `compact`: labels as short as an
/// offset and a scale make them, whatever their length plain.
fn linear_set(lo: f64, hi: f64, mantissa: i64, exp: i32, compact: bool) -> Ticks {
    let step = mantissa as f64 * 10f64.powi(exp);
    let magnitude = lo.abs().max(hi.abs());
    // Significant digits of the labels: from the leading digit of the largest value down to
    // the step's last digit.
    let last_digit = if mantissa == 25 { exp } else { exp + 1 };
    let digits = magnitude.log10().floor() as i64 - i64::from(last_digit) + 1;
    let (offset, origin) = if digits > OFFSET_DIGITS || (compact && digits > 2) {
        // Round the middle to a power of ten above the span: labels become small differences.
        let q = ((hi - lo).log10().ceil() as i32).max(exp + 2);
        let unit = 10f64.powi(q);
        let r = (0.5 * (lo + hi) / unit).round();
        // Divide by an exact power of ten: 1e7 / 1e6 is 10, 1e7 × 1e-6 need not be.
        let origin = if q >= 0 { r * unit } else { r / 10f64.powi(-q) };
        if r == 0.0 {
            (None, 0.0)
        } else {
            (Some((r as i64, q)), origin)
        }
    } else {
        (None, 0.0)
    };
    let j0 = ((lo - origin) / step - 1e-9).ceil() as i64;
    let j1 = ((hi - origin) / step + 1e-9).floor() as i64;
    let values: Vec<f64> = (j0..=j1).map(|j| origin + j as f64 * step).collect();
    // Exact labels: the ticks are integers `j × mantissa` times 10^exp.
    let ints: Vec<i64> = (j0..=j1).map(|j| j * mantissa).collect();
    let (labels, scale) = decimal_labels(&ints, exp, offset.is_none(), compact);
    let mut note = scale.map_or_else(String::new, |p| format!("×{}", power_of_ten(p)));
    if let Some((r, q)) = offset {
        if !note.is_empty() {
            note.push(' ');
        }
        let (mut r, mut q) = (r, q);
        while q < 0 && r % 10 == 0 {
            r /= 10;
            q += 1;
        }
        let text = decimal(r, q);
        note.push_str(&if r < 0 { text } else { format!("+{text}") });
    }
    let sub = if mantissa == 20 { 4.0 } else { 5.0 };
    let minor_step = step / sub;
    let m0 = ((lo - origin) / minor_step - 1e-9).ceil() as i64;
    let m1 = ((hi - origin) / minor_step + 1e-9).floor() as i64;
    let minor = if m1 - m0 < 200 {
        (m0..=m1).map(|m| origin + m as f64 * minor_step).collect()
    } else {
        Vec::new()
    };
    Ticks {
        values,
        labels,
        minor,
        note,
    }
}

/// Decimal digits of `n` (positive).
fn digits_of(n: i64) -> i64 {
    n.abs().max(1).to_string().len() as i64
}

/// Labels of the integers `ints` × 10^`exp`: plain when short, otherwise scaled by a power of
/// 10 (a multiple of 3) that is returned. `allow_plain_only_in_range`: plain labels only for
/// magnitudes from 1e-3 to 1e5 (offset labels are differences and may be plain at any size).
/// `compact`: scaled whenever a scale shortens them.
fn decimal_labels(
    ints: &[i64],
    exp: i32,
    plain_only_in_range: bool,
    compact: bool,
) -> (Vec<String>, Option<i32>) {
    // Drop the zeros every label ends with.
    let (mut ints, mut exp) = (ints.to_vec(), exp);
    while exp < 0 && ints.iter().all(|n| n % 10 == 0) {
        ints.iter_mut().for_each(|n| *n /= 10);
        exp += 1;
    }
    let biggest = ints.iter().map(|n| n.abs()).max().unwrap_or(0);
    if biggest == 0 {
        return (ints.iter().map(|_| "0".to_owned()).collect(), None);
    }
    let plain: Vec<String> = ints.iter().map(|&n| decimal(n, exp)).collect();
    let magnitude = (digits_of(biggest) - 1) as i32 + exp;
    let long = plain.iter().any(|l| l.chars().count() > PLAIN_LEN);
    let outside = plain_only_in_range && !(-3..5).contains(&magnitude);
    // Engineering power: labels between 1 and 999 (times the step's digits).
    let p = 3 * magnitude.div_euclid(3);
    if (!long && !outside && !compact) || p == 0 {
        return (plain, None);
    }
    (ints.iter().map(|&n| decimal(n, exp - p)).collect(), Some(p))
}

/// The integer `n` × 10^`exp` in plain decimal notation, with `−` for negatives.
fn decimal(n: i64, exp: i32) -> String {
    let sign = if n < 0 { "−" } else { "" };
    let digits = n.unsigned_abs().to_string();
    if n == 0 {
        return "0".to_owned();
    }
    if exp >= 0 {
        return format!("{sign}{digits}{}", "0".repeat(exp as usize));
    }
    let decimals = (-exp) as usize;
    let padded = format!("{digits:0>width$}", width = decimals + 1);
    let (int, frac) = padded.split_at(padded.len() - decimals);
    format!("{sign}{int}.{frac}")
}

/// `10⁻³`, `10⁶`.
pub(crate) fn power_of_ten(p: i32) -> String {
    let mut s = "10".to_owned();
    for c in p.to_string().chars() {
        s.push(match c {
            '-' => '⁻',
            '0' => '⁰',
            '1' => '¹',
            '2' => '²',
            '3' => '³',
            '4' => '⁴',
            '5' => '⁵',
            '6' => '⁶',
            '7' => '⁷',
            '8' => '⁸',
            _ => '⁹',
        });
    }
    s
}

fn log_candidates(lo: f64, hi: f64) -> Vec<Ticks> {
    let (a, b) = (lo.log10(), hi.log10());
    let d0 = (a - 1e-9).ceil() as i32;
    let d1 = (b + 1e-9).floor() as i32;
    let inside = |v: f64| v >= lo * (1.0 - 1e-9) && v <= hi * (1.0 + 1e-9);
    let mut out = Vec::new();
    for set in [&[1, 2, 3, 4, 5, 6, 7, 8, 9][..], &[1, 2, 5], &[1, 3]] {
        if b - a <= if set.len() > 3 { 2.0 } else { 4.0 } {
            let mut ticks: Vec<(i64, i32)> = Vec::new();
            for d in (a.floor() as i32)..=(b.ceil() as i32) {
                for &m in set {
                    if inside(m as f64 * 10f64.powi(d)) {
                        ticks.push((m, d));
                    }
                }
            }
            if (2..=MAX_TICKS as usize).contains(&ticks.len()) {
                let mut t = log_set(&ticks);
                t.minor = log_minor(lo, hi, a, b);
                out.push(t);
            }
        }
    }
    for every in [1, 2, 3, 4, 5, 10, 20, 50, 100] {
        let ticks: Vec<(i64, i32)> = (d0..=d1)
            .filter(|d| d.rem_euclid(every) == 0)
            .map(|d| (1, d))
            .collect();
        if (2..=MAX_TICKS as usize).contains(&ticks.len()) {
            let mut t = log_set(&ticks);
            t.minor = if every == 1 {
                log_minor(lo, hi, a, b)
            } else {
                Vec::new()
            };
            out.push(t);
        }
    }
    out
}

/// Light grid lines at 1…9 × 10ⁿ.
fn log_minor(lo: f64, hi: f64, a: f64, b: f64) -> Vec<f64> {
    if b - a > 6.0 {
        return Vec::new();
    }
    let mut minor = Vec::new();
    for d in (a.floor() as i32)..=(b.ceil() as i32) {
        for m in 1..10 {
            let v = m as f64 * 10f64.powi(d);
            if v >= lo && v <= hi {
                minor.push(v);
            }
        }
    }
    minor
}

/// Ticks m × 10^d: plain labels from 0.001 to 10⁵, otherwise `10⁻⁴` or `2×10⁻⁴`.
fn log_set(ticks: &[(i64, i32)]) -> Ticks {
    Ticks {
        values: ticks
            .iter()
            .map(|&(m, d)| m as f64 * 10f64.powi(d))
            .collect(),
        labels: ticks
            .iter()
            .map(|&(m, d)| {
                if (-3..5).contains(&d) {
                    decimal(m, d)
                } else if m == 1 {
                    power_of_ten(d)
                } else {
                    format!("{m}×{}", power_of_ten(d))
                }
            })
            .collect(),
        minor: Vec::new(),
        note: String::new(),
    }
}

/// A range that is not empty: a degenerate one is widened around its value, a non-finite one
/// becomes (0, 1).
pub fn widen((lo, hi): (f64, f64)) -> (f64, f64) {
    if !(lo.is_finite() && hi.is_finite()) {
        return (0.0, 1.0);
    }
    if hi > lo {
        (lo, hi)
    } else {
        let pad = if lo == 0.0 { 1.0 } else { lo.abs() * 0.05 };
        (lo - pad, hi + pad)
    }
}

/// The finite range of `values`, padded by `pad` of its width on each side.
pub fn range_of<'v>(values: impl IntoIterator<Item = &'v f64>, pad: f64) -> (f64, f64) {
    padded(
        values
            .into_iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |b, &v| {
                extend_bounds(b, v)
            }),
        pad,
    )
}

/// `(lo, hi)` extended to take in `v` when it is finite: folded from (∞, −∞) over values,
/// their finite range, as [`range_of`] takes it (so that a figure can take the range of
/// values it does not keep).
pub fn extend_bounds((lo, hi): (f64, f64), v: f64) -> (f64, f64) {
    if v.is_finite() {
        (lo.min(v), hi.max(v))
    } else {
        (lo, hi)
    }
}

/// The range `(lo, hi)` made non-empty ([`widen`]) and padded by `pad` of its width on each
/// side.
pub fn padded((lo, hi): (f64, f64), pad: f64) -> (f64, f64) {
    let (lo, hi) = widen((lo, hi));
    let w = hi - lo;
    (lo - pad * w, hi + pad * w)
}

/// A short number for text: four significant digits at most, without float noise or
/// trailing zeros (neighbouring values such as 0.00405 and 0.0041 stay distinct).
pub fn tick(v: f64) -> String {
    // Values at zero come out as float noise such as -2.8e-17.
    if v.abs() < 1e-12 {
        return "0".to_owned();
    }
    let s = significant(v, 4);
    match s.split_once('e') {
        Some((mantissa, exponent)) => {
            let m = mantissa.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{exponent}")
        }
        None if s.contains('.') => s.trim_end_matches('0').trim_end_matches('.').to_owned(),
        None => s,
    }
}

/// `x` with `digits` significant digits, in plain notation between 1e-3 and 1e5 and in
/// scientific notation (`1.23e-7`) outside; `–` for a missing (NaN) value.
pub fn significant(x: f64, digits: usize) -> String {
    if x.is_nan() {
        return "–".to_owned();
    }
    if x.is_infinite() {
        return if x > 0.0 { "∞" } else { "−∞" }.to_owned();
    }
    if x == 0.0 {
        return "0".to_owned();
    }
    let digits = digits.max(1);
    let magnitude = x.abs().log10().floor() as i32;
    if (-3..5).contains(&magnitude) {
        let decimals = (digits as i32 - 1 - magnitude).max(0) as usize;
        format!("{x:.decimals$}")
    } else {
        format!("{x:.prec$e}", prec = digits - 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn first(scale: Scale) -> Ticks {
        scale.candidates().remove(0)
    }

    /// The sparsest set with at least `n` ticks.
    fn with_at_least(scale: Scale, n: usize) -> Ticks {
        scale
            .candidates()
            .into_iter()
            .rev()
            .find(|t| t.values.len() >= n)
            .unwrap()
    }

    #[test]
    fn plain_ranges_get_plain_labels() {
        let t = with_at_least(Scale::linear((0.0, 20.0)), 4);
        assert_eq!(t.labels, vec!["0", "5", "10", "15", "20"]);
        assert_eq!(t.note, "");
        let t = with_at_least(Scale::linear((-0.3, 0.3)), 5);
        assert_eq!(
            t.labels,
            vec!["−0.3", "−0.2", "−0.1", "0", "0.1", "0.2", "0.3"]
        );
        let t = with_at_least(Scale::linear((0.0, 1.5)), 3);
        assert_eq!(t.labels, vec!["0", "0.5", "1.0", "1.5"]);
    }

    #[test]
    fn a_tiny_relative_range_still_gets_distinct_labels() {
        // The F_d panel: 10.000 ± 0.003 mN.
        let candidates = Scale::linear((9.9968, 10.0031)).candidates();
        assert!(candidates
            .iter()
            .any(|t| t.labels == ["9.998", "10.000", "10.002"] && t.note.is_empty()));
        for t in &candidates {
            let distinct: std::collections::BTreeSet<&String> = t.labels.iter().collect();
            assert_eq!(distinct.len(), t.labels.len(), "{:?}", t.labels);
        }
        // Far narrower: labels are offsets from 10, scaled.
        let t = with_at_least(Scale::linear((10.0 - 3e-7, 10.0 + 3e-7)), 3);
        assert_eq!(t.note, "×10⁻⁹ +10", "{t:?}");
        assert!(
            t.labels.iter().all(|l| l.chars().count() <= 6),
            "{:?}",
            t.labels
        );
        for (v, l) in t.values.iter().zip(&t.labels) {
            let shown: f64 = l.replace('−', "-").parse().unwrap();
            assert!((10.0 + shown * 1e-9 - v).abs() < 1e-12, "{l} for {v}");
        }
    }

    #[test]
    fn compact_labels_are_offset_and_scaled() {
        let t = Scale::linear((9.9968, 10.0031))
            .compact_candidates()
            .into_iter()
            .find(|t| t.values.len() == 3)
            .unwrap();
        assert_eq!(t.labels, ["−2", "0", "2"]);
        assert_eq!(t.note, "×10⁻³ +10");
        // Around zero nothing is offset.
        let t = Scale::linear((-0.3, 0.3)).compact_candidates().remove(0);
        assert!(!t.note.contains('+'), "{t:?}");
    }

    #[test]
    fn large_and_small_values_are_scaled() {
        let t = with_at_least(Scale::linear((0.0, 138_240.0)), 3);
        assert_eq!(t.note, "×10³");
        assert!(t.labels.contains(&"100".to_owned()), "{:?}", t.labels);
        let t = with_at_least(Scale::linear((1.2e-7, 1.5e-7)), 3);
        assert_eq!(t.note, "×10⁻⁹");
        assert!(t.labels.contains(&"130".to_owned()), "{:?}", t.labels);
        let t = with_at_least(Scale::linear((11_985.0, 12_021.0)), 3);
        assert_eq!(t.note, "");
        assert!(t.labels.contains(&"12000".to_owned()), "{:?}", t.labels);
        let t = with_at_least(Scale::linear((12_000.0 - 0.03, 12_000.0 + 0.03)), 3);
        assert_eq!(t.note, "+12000", "{t:?}");
    }

    #[test]
    fn every_range_has_two_ticks_inside_it() {
        for (lo, hi) in [
            (0.0, 1e-300),
            (1e300, 1.0001e300),
            (-5.0, -4.999_999),
            (0.37, 0.38),
            (7.0, 7.0),
            (1e6, 1e6 + 1.0),
        ] {
            let scale = Scale::linear((lo, hi));
            let (a, b) = scale.range();
            for t in scale.candidates() {
                assert!(t.values.len() >= 2, "{lo}..{hi}: {t:?}");
                assert_eq!(t.values.len(), t.labels.len());
                assert!(t
                    .values
                    .iter()
                    .all(|&v| v >= a - 1e-9 * (b - a) && v <= b + 1e-9 * (b - a)));
            }
        }
    }

    #[test]
    fn log_axes_tick_decades_or_fill_in() {
        let t = Scale::log((1e-3, 1e3))
            .candidates()
            .into_iter()
            .find(|t| t.values.len() == 7)
            .unwrap();
        assert_eq!(
            t.labels,
            vec!["0.001", "0.01", "0.1", "1", "10", "100", "1000"]
        );
        let t = Scale::log((0.03, 40.0))
            .candidates()
            .into_iter()
            .find(|t| t.labels.contains(&"0.05".to_owned()))
            .unwrap();
        assert!(t.labels.contains(&"20".to_owned()), "{t:?}");
        let t = first(Scale::log((1e-9, 1e-3)));
        assert_eq!(t.labels[0], "10⁻⁹");
        // Less than a decade without a power of ten: linear ticks.
        let t = first(Scale::log((3.1, 3.9)));
        assert!(t.values.len() >= 2);
        assert!(first(Scale::log((-1.0, 5.0))).values.len() >= 2);
    }

    #[test]
    fn numbers_for_text() {
        assert_eq!(tick(0.0), "0");
        assert_eq!(tick(-2.8e-17), "0");
        assert_eq!(tick(12.5), "12.5");
        assert_eq!(tick(2e-7), "2e-7");
        assert_eq!(tick(0.00405), "0.00405");
        assert_eq!(significant(921_691.2, 4), "9.217e5");
        assert_eq!(significant(-0.5, 2), "-0.50");
        assert_eq!(significant(f64::NAN, 3), "–");
        assert_eq!(decimal(-25, -3), "−0.025");
        assert_eq!(decimal(12, 2), "1200");
        assert_eq!(power_of_ten(-12), "10⁻¹²");
        assert_eq!(widen((1.0, 1.0)), (0.95, 1.05));
        assert_eq!(range_of(&[1.0, f64::NAN, 3.0], 0.5), (0.0, 4.0));
    }
}
