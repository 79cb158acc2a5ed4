//! The text of instrument exports: encodings, lines, fields and numbers as the computer that
//! wrote them formats them.
//!
//! Rheometer software writes in the encoding and number format of the computer it runs on:
//! UTF-16 with or without a byte-order mark, UTF-8, or a Windows code page; a decimal point or
//! a decimal comma, digits grouped by a point, a comma, a space (also the no-break spaces
//! U+00A0 and U+202F) or an apostrophe; exponents written `2,21E+04` or `4,013E+003`. This
//! module decodes such text once, splits lines into fields without copying them, and reads
//! each number exactly (Rust's parser rounds correctly, so a number reads back to the same
//! double as the same digits in a plain CSV).

use std::fmt;

/// The encoding a file was found in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// UTF-8, with or without a byte-order mark.
    Utf8 {
        /// Whether the file starts with a byte-order mark.
        bom: bool,
    },
    /// UTF-16, little- or big-endian, with or without a byte-order mark.
    Utf16 {
        /// Little-endian (as Windows writes it).
        little_endian: bool,
        /// Whether the file starts with a byte-order mark.
        bom: bool,
    },
    /// One byte per character (older Windows exports: µ = 0xB5).
    Latin1,
}

impl fmt::Display for Encoding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let with = |bom: bool| if bom { "with BOM" } else { "without BOM" };
        match *self {
            Self::Utf8 { bom: false } => f.write_str("UTF-8"),
            Self::Utf8 { bom: true } => f.write_str("UTF-8 with BOM"),
            Self::Utf16 { little_endian, bom } => write!(
                f,
                "UTF-16{} {}",
                if little_endian { "LE" } else { "BE" },
                with(bom)
            ),
            Self::Latin1 => f.write_str("Latin-1"),
        }
    }
}

/// Decodes a file's bytes and names the encoding found: a byte-order mark decides; without
/// one, UTF-16 is recognised by its zero bytes (ASCII text in UTF-16 has a zero in every other
/// byte), then UTF-8 is tried, and anything else is read as Latin-1.
pub(crate) fn decode(bytes: &[u8]) -> (String, Encoding) {
    decode_owned(std::borrow::Cow::Borrowed(bytes))
}

/// As [`decode`], without copying bytes that are UTF-8 already.
pub(crate) fn decode_owned(bytes: std::borrow::Cow<'_, [u8]>) -> (String, Encoding) {
    if let Some(rest) = bytes.strip_prefix(&[0xFF, 0xFE]) {
        return (
            decode_utf16(rest, true),
            Encoding::Utf16 {
                little_endian: true,
                bom: true,
            },
        );
    }
    if let Some(rest) = bytes.strip_prefix(&[0xFE, 0xFF]) {
        return (
            decode_utf16(rest, false),
            Encoding::Utf16 {
                little_endian: false,
                bom: true,
            },
        );
    }
    if let Some(rest) = bytes.strip_prefix(&[0xEF, 0xBB, 0xBF]) {
        if let Ok(text) = std::str::from_utf8(rest) {
            return (text.to_owned(), Encoding::Utf8 { bom: true });
        }
    }
    if let Some(little_endian) = utf16_without_bom(&bytes) {
        return (
            decode_utf16(&bytes, little_endian),
            Encoding::Utf16 {
                little_endian,
                bom: false,
            },
        );
    }
    match String::from_utf8(bytes.into_owned()) {
        Ok(text) => (text, Encoding::Utf8 { bom: false }),
        Err(e) => (
            e.as_bytes().iter().map(|&b| char::from(b)).collect(),
            Encoding::Latin1,
        ),
    }
}

/// Whether bytes without a byte-order mark are UTF-16 (and which byte order): in the first
/// kilobyte, most of one byte of each pair is zero and almost none of the other.
fn utf16_without_bom(bytes: &[u8]) -> Option<bool> {
    let head = &bytes[..bytes.len().min(1024) & !1];
    let pairs = head.len() / 2;
    if pairs < 2 {
        return None;
    }
    let zeros = |offset: usize| {
        head.iter()
            .skip(offset)
            .step_by(2)
            .filter(|&&b| b == 0)
            .count()
    };
    let (even, odd) = (zeros(0), zeros(1));
    // Text is mostly ASCII; 40 % leaves room for accented labels and non-Latin names.
    if odd * 10 >= pairs * 4 && even * 20 < pairs {
        Some(true)
    } else if even * 10 >= pairs * 4 && odd * 20 < pairs {
        Some(false)
    } else {
        None
    }
}

/// UTF-16 to a `String`, ASCII eight characters at a time (exports are mostly digits and
/// separators); unpaired surrogates become U+FFFD and an odd last byte is ignored.
fn decode_utf16(bytes: &[u8], little_endian: bool) -> String {
    let unit = |at: usize| {
        let pair = [bytes[at], bytes[at + 1]];
        if little_endian {
            u16::from_le_bytes(pair)
        } else {
            u16::from_be_bytes(pair)
        }
    };
    // Eight units are ASCII when every high byte is zero and no low byte has its top bit set;
    // read as a little-endian u64, the low bytes sit at even positions for UTF-16LE (`shift`
    // moves them there for UTF-16BE).
    let (not_ascii, shift) = if little_endian {
        (0xFF80_FF80_FF80_FF80u64, 0)
    } else {
        (0x80FF_80FF_80FF_80FFu64, 8)
    };
    // The four low bytes of a word of four ASCII units, packed.
    let pack = |w: u64| {
        let w = (w >> shift) & 0x00FF_00FF_00FF_00FF;
        let w = (w | (w >> 8)) & 0x0000_FFFF_0000_FFFF;
        ((w | (w >> 16)) as u32).to_le_bytes()
    };
    let n = bytes.len() & !1;
    let mut out: Vec<u8> = Vec::with_capacity(n / 2 + 16);
    let mut i = 0;
    while i < n {
        if i + 16 <= n {
            let word = |at: usize| {
                let mut w = [0u8; 8];
                w.copy_from_slice(&bytes[at..at + 8]);
                u64::from_le_bytes(w)
            };
            let (a, b) = (word(i), word(i + 8));
            if (a | b) & not_ascii == 0 {
                out.extend_from_slice(&pack(a));
                out.extend_from_slice(&pack(b));
                i += 16;
                continue;
            }
        }
        let u = unit(i);
        i += 2;
        let c = match u {
            0..=0x7F => char::from(u as u8),
            0xD800..=0xDBFF if i + 2 <= n && (0xDC00..=0xDFFF).contains(&unit(i)) => {
                let code =
                    0x10000 + ((u32::from(u) - 0xD800) << 10) + (u32::from(unit(i)) - 0xDC00);
                i += 2;
                char::from_u32(code).unwrap_or(char::REPLACEMENT_CHARACTER)
            }
            _ => char::from_u32(u32::from(u)).unwrap_or(char::REPLACEMENT_CHARACTER),
        };
        let mut buf = [0u8; 4];
        out.extend_from_slice(c.encode_utf8(&mut buf).as_bytes());
    }
    // Valid by construction; the lossy path only keeps this free of a panic.
    String::from_utf8(out).unwrap_or_else(|e| String::from_utf8_lossy(e.as_bytes()).into_owned())
}

/// A line of a text: its 1-based number and where it is, without its line end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Line {
    /// 1-based line number.
    pub number: usize,
    /// Byte offset of the line's first character.
    pub start: usize,
    /// Byte offset after its last character (before `\r\n` or `\n`).
    pub end: usize,
}

/// The lines of a text with their numbers and byte ranges (`\n` or `\r\n` ends a line; a
/// byte-order mark left at the start is skipped).
pub fn lines(text: &str) -> impl Iterator<Item = Line> + '_ {
    let bytes = text.as_bytes();
    let mut start = if text.starts_with('\u{feff}') { 3 } else { 0 };
    let mut number = 0;
    std::iter::from_fn(move || {
        if start >= bytes.len() {
            return None;
        }
        number += 1;
        let next = memchr::memchr(b'\n', &bytes[start..]).map_or(bytes.len(), |i| start + i);
        let mut end = next;
        if end > start && bytes[end - 1] == b'\r' {
            end -= 1;
        }
        let line = Line { number, start, end };
        start = next + 1;
        Some(line)
    })
}

/// Whether a line holds nothing but separators and spaces (RheoCompass writes its blank lines
/// as a row of commas when it exports comma-separated).
pub(crate) fn is_blank(line: &str, separator: u8) -> bool {
    line.bytes()
        .all(|b| b == separator || b == b' ' || b == b'\t')
}

/// Splits `line` at `separator` into `out` (cleared first), at most `limit` fields (the last
/// one then holds the rest of the line). A field in double quotes may hold the separator; the
/// quotes stay in the field (see [`unquote`]).
pub(crate) fn split_fields<'a>(line: &'a str, separator: u8, limit: usize, out: &mut Vec<&'a str>) {
    out.clear();
    let mut start = 0;
    let mut quoted = false;
    if limit > 1 {
        for (i, &b) in line.as_bytes().iter().enumerate() {
            // A doubled quote inside quotes toggles twice and stays quoted.
            if b == b'"' {
                quoted = !quoted;
            } else if b == separator && !quoted {
                out.push(&line[start..i]);
                start = i + 1;
                if out.len() + 1 == limit {
                    break;
                }
            }
        }
    }
    out.push(&line[start..]);
}

/// A field without the spaces around it and without enclosing double quotes.
pub(crate) fn unquote(field: &str) -> &str {
    let t = field.trim();
    t.strip_prefix('"')
        .and_then(|s| s.strip_suffix('"'))
        .map_or(t, str::trim)
}

/// How numbers are written: the decimal mark (the mark grouping digits is whatever else stands
/// between groups of three digits).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) enum NumberFormat {
    /// `1234.5`, `1,234.5`, `1.2345E+03`.
    #[default]
    DecimalPoint,
    /// `1234,5`, `1.234,5`, `1 234,5`, `2,21E+04`.
    DecimalComma,
}

impl fmt::Display for NumberFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::DecimalPoint => "decimal point",
            Self::DecimalComma => "decimal comma",
        })
    }
}

/// What one field says about the decimal mark.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Evidence {
    Point,
    Comma,
    /// `1,234` or `1.234`: a decimal mark or a thousands group.
    Either,
    None,
}

fn evidence(field: &str) -> Evidence {
    let t = unquote(field).trim_start_matches(['-', '+']);
    let (mantissa, exponent) = match t.find(['e', 'E']) {
        Some(i) => (&t[..i], Some(&t[i + 1..])),
        None => (t, None),
    };
    let numeric = !mantissa.is_empty()
        && mantissa.bytes().any(|b| b.is_ascii_digit())
        && mantissa
            .bytes()
            .all(|b| b.is_ascii_digit() || b == b'.' || b == b',')
        && exponent.is_none_or(|e| {
            let e = e.trim_start_matches(['-', '+']);
            !e.is_empty() && e.bytes().all(|b| b.is_ascii_digit())
        });
    if !numeric {
        return Evidence::None;
    }
    match (mantissa.rfind('.'), mantissa.rfind(',')) {
        (Some(p), Some(c)) => {
            if p > c {
                Evidence::Point
            } else {
                Evidence::Comma
            }
        }
        (None, None) => Evidence::None,
        (point, comma) => {
            let (mark, at, decided) = match (point, comma) {
                (Some(p), None) => ('.', p, Evidence::Point),
                (None, Some(c)) => (',', c, Evidence::Comma),
                _ => unreachable!(),
            };
            let marks = mantissa.matches(mark).count();
            let integer = &mantissa[..at];
            let fraction = &mantissa[at + 1..];
            if marks > 1 {
                // Only digit groups repeat: `1.234.567` groups with the point.
                if decided == Evidence::Point {
                    Evidence::Comma
                } else {
                    Evidence::Point
                }
            } else if exponent.is_some()
                || fraction.len() != 3
                || integer.is_empty()
                || integer.starts_with('0')
                || integer.len() > 3
            {
                decided
            } else {
                Evidence::Either
            }
        }
    }
}

impl NumberFormat {
    /// Whether a field reads as a number in either decimal format.
    pub(crate) fn reads_as_number(field: &str) -> bool {
        Self::DecimalPoint.parse(field).is_some() || Self::DecimalComma.parse(field).is_some()
    }

    /// The number format of a file from a sample of its data fields: the decimal mark that
    /// fields like `0,05`, `2,21E+04` or `1.234,5` show. Where every field could read either
    /// way (`1,234`), a comma is read as the decimal mark unless it separates the fields.
    pub fn detect<'a>(fields: impl IntoIterator<Item = &'a str>, separator: u8) -> Self {
        if separator == b',' {
            return Self::DecimalPoint;
        }
        let (mut point, mut comma, mut either) = (0usize, 0usize, 0usize);
        for field in fields {
            match evidence(field) {
                Evidence::Point => point += 1,
                Evidence::Comma => comma += 1,
                Evidence::Either => either += 1,
                Evidence::None => {}
            }
        }
        if comma > point || (comma == point && point == 0 && either > 0) {
            Self::DecimalComma
        } else {
            Self::DecimalPoint
        }
    }

    /// Reads a field as a number written in this format; `None` for anything else (text, an
    /// empty field). Digit groups are accepted only in groups of three before the decimal mark.
    /// `NaN` and `inf` read as themselves and are judged by the caller.
    pub fn parse(self, field: &str) -> Option<f64> {
        let t = unquote(field);
        if t.is_empty() {
            return None;
        }
        let (decimal, group) = match self {
            Self::DecimalPoint => (b'.', b','),
            Self::DecimalComma => (b',', b'.'),
        };
        let bytes = t.as_bytes();
        // Fast path: digits, sign, exponent and at most the decimal mark, no grouping.
        let mut buf = [0u8; 64];
        if bytes.len() <= buf.len()
            && bytes.iter().all(|&b| {
                b.is_ascii_digit() || matches!(b, b'-' | b'+' | b'e' | b'E') || b == decimal
            })
        {
            for (slot, &b) in buf.iter_mut().zip(bytes) {
                *slot = if b == decimal { b'.' } else { b };
            }
            return std::str::from_utf8(&buf[..bytes.len()]).ok()?.parse().ok();
        }
        self.parse_grouped(t, decimal, group)
            .or_else(|| t.parse::<f64>().ok().filter(|v| !v.is_finite()))
    }

    /// The slow path: digit groups separated by `group`, a space, U+00A0, U+202F or `'`.
    fn parse_grouped(self, t: &str, decimal: u8, group: u8) -> Option<f64> {
        let mut clean = String::with_capacity(t.len());
        let mut chars = t.char_indices().peekable();
        let (mut digits_in_group, mut grouped, mut seen_decimal, mut in_exponent) =
            (0usize, false, false, false);
        let mut first_group = true;
        while let Some((_, c)) = chars.next() {
            let is_group_mark =
                c == char::from(group) || matches!(c, ' ' | '\u{a0}' | '\u{202f}' | '\'');
            if is_group_mark && !seen_decimal && !in_exponent {
                // A group mark must follow 1-3 digits (first group) or exactly 3, and be
                // followed by a digit.
                let ok = if first_group {
                    (1..=3).contains(&digits_in_group)
                } else {
                    digits_in_group == 3
                };
                if !ok || !chars.peek().is_some_and(|(_, n)| n.is_ascii_digit()) {
                    return None;
                }
                grouped = true;
                first_group = false;
                digits_in_group = 0;
                continue;
            }
            match c {
                '0'..='9' => {
                    if !seen_decimal && !in_exponent {
                        digits_in_group += 1;
                    }
                    clean.push(c);
                }
                c if c == char::from(decimal) && !seen_decimal && !in_exponent => {
                    if grouped && digits_in_group != 3 {
                        return None;
                    }
                    seen_decimal = true;
                    clean.push('.');
                }
                'e' | 'E' if !in_exponent => {
                    if grouped && !seen_decimal && digits_in_group != 3 {
                        return None;
                    }
                    in_exponent = true;
                    clean.push('e');
                }
                '-' | '+' => clean.push(c),
                _ => return None,
            }
        }
        if grouped && !seen_decimal && !in_exponent && digits_in_group != 3 {
            return None;
        }
        clean.parse().ok()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn utf16(text: &str, little: bool, bom: bool) -> Vec<u8> {
        let mut bytes = Vec::new();
        if bom {
            bytes.extend_from_slice(if little { &[0xFF, 0xFE] } else { &[0xFE, 0xFF] });
        }
        for unit in text.encode_utf16() {
            bytes.extend_from_slice(&if little {
                unit.to_le_bytes()
            } else {
                unit.to_be_bytes()
            });
        }
        bytes
    }

    #[test]
    fn every_encoding_decodes() {
        let text = "Intervalle et points de données:\t1\t60\r\n\t\t[mN·m]\t😀\r\n";
        for little in [true, false] {
            for bom in [true, false] {
                let (decoded, encoding) = decode(&utf16(text, little, bom));
                assert_eq!(decoded, text, "{encoding}");
                assert_eq!(
                    encoding,
                    Encoding::Utf16 {
                        little_endian: little,
                        bom
                    }
                );
            }
        }
        let mut bom8 = vec![0xEF, 0xBB, 0xBF];
        bom8.extend_from_slice(text.as_bytes());
        assert_eq!(
            decode(&bom8),
            (text.to_owned(), Encoding::Utf8 { bom: true })
        );
        assert_eq!(
            decode(text.as_bytes()),
            (text.to_owned(), Encoding::Utf8 { bom: false })
        );
        assert_eq!(decode(b"\xb5N\xb7m").0, "µN·m");
    }

    #[test]
    fn lines_and_fields() {
        let text = "a\tb\r\n\r\n\"x\ty\"\tz\n";
        let got: Vec<&str> = lines(text).map(|l| &text[l.start..l.end]).collect();
        assert_eq!(got, ["a\tb", "", "\"x\ty\"\tz"]);
        let mut fields = Vec::new();
        split_fields(got[2], b'\t', usize::MAX, &mut fields);
        assert_eq!(fields, ["\"x\ty\"", "z"]);
        assert_eq!(unquote(fields[0]), "x\ty");
        split_fields("1;2;3;4", b';', 2, &mut fields);
        assert_eq!(fields, ["1", "2;3;4"]);
        assert!(is_blank(",,,, ,", b','));
    }

    #[test]
    fn numbers_in_every_format() {
        let comma = NumberFormat::DecimalComma;
        let point = NumberFormat::DecimalPoint;
        for (text, value) in [
            ("2,21E+04", 2.21e4),
            ("4,013E+003", 4.013e3),
            ("-0,01", -0.01),
            ("1.234,5", 1234.5),
            ("1 234 567,25", 1_234_567.25),
            ("12\u{202f}345,5", 12345.5),
            ("12\u{a0}345", 12345.0),
            ("\"0,5\"", 0.5),
        ] {
            assert_eq!(comma.parse(text), Some(value), "{text}");
        }
        for (text, value) in [
            ("1,234.5", 1234.5),
            ("1.3641852265019602e-06", 1.3641852265019602e-06),
            ("12'345.25", 12345.25),
            ("-5", -5.0),
        ] {
            assert_eq!(point.parse(text), Some(value), "{text}");
        }
        for text in ["", "Dy_auto", "1,23,4", "12.34.5", "1 2", "1.2345,6"] {
            assert_eq!(comma.parse(text), None, "{text}");
        }
        assert!(comma.parse("NaN").is_some_and(f64::is_nan));
    }

    #[test]
    fn decimal_mark_from_the_fields() {
        let detect = |fields: &[&str], sep| NumberFormat::detect(fields.iter().copied(), sep);
        assert_eq!(
            detect(&["73,196", "2,21E+04"], b'\t'),
            NumberFormat::DecimalComma
        );
        assert_eq!(
            detect(&["73,196", "0,05"], b';'),
            NumberFormat::DecimalComma
        );
        assert_eq!(detect(&["1,234.5", "7"], b'\t'), NumberFormat::DecimalPoint);
        assert_eq!(
            detect(&["1.234.567", "12"], b'\t'),
            NumberFormat::DecimalComma
        );
        assert_eq!(detect(&["12", "7", "x"], b'\t'), NumberFormat::DecimalPoint);
        assert_eq!(detect(&["1,234"], b'\t'), NumberFormat::DecimalComma);
        assert_eq!(detect(&["0,5"], b','), NumberFormat::DecimalPoint);
    }
}
