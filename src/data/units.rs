//! Units of instrument columns and their conversion to SI.
//!
//! Rheometers record time in s, min or h, friction as a force (N, mN, µN) or as a torque
//! (N·m, mN·m, µN·m) that becomes a force through the moment arm: F = M / r.

use std::fmt;

/// What a column holds, once its unit is known.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Quantity {
    /// A time; the factor converts to seconds.
    Time {
        /// Seconds per unit.
        to_s: f64,
    },
    /// A force; the factor converts to newtons.
    Force {
        /// Newtons per unit.
        to_n: f64,
    },
    /// A torque; the factor converts to N·m.
    Torque {
        /// Newton-metres per unit.
        to_n_m: f64,
    },
}

/// A recognised unit, as written in the file (for the record) and as understood.
#[derive(Debug, Clone, PartialEq)]
pub struct Unit {
    /// The unit as written, without brackets.
    pub written: String,
    /// Its meaning.
    pub quantity: Quantity,
}

impl fmt::Display for Unit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.written)
    }
}

/// The units a column may carry, for messages.
pub const KNOWN_UNITS: &str = "time: s, min, h; force: N, mN, µN (or uN); \
                               torque: N·m, mN·m, µN·m (also written Nm, mN.m, uNm)";

/// Parses a unit such as `[mN·m]`, `min` or `µN` (brackets and spaces optional).
/// `None` for a unit slipbayes does not know.
pub(crate) fn parse_unit(text: &str) -> Option<Unit> {
    let written = text
        .trim()
        .trim_start_matches('[')
        .trim_end_matches(']')
        .trim()
        .to_owned();
    // N·m, N.m, N*m, N m and Nm are the same unit.
    let compact: String = written
        .chars()
        .filter(|c| !matches!(c, '·' | '⋅' | '.' | '*' | ' '))
        .map(|c| if c == 'μ' { 'µ' } else { c })
        .collect();
    let quantity = match compact.as_str() {
        "s" => Quantity::Time { to_s: 1.0 },
        "ms" => Quantity::Time { to_s: 1e-3 },
        "min" => Quantity::Time { to_s: 60.0 },
        "h" => Quantity::Time { to_s: 3600.0 },
        "N" => Quantity::Force { to_n: 1.0 },
        "mN" => Quantity::Force { to_n: 1e-3 },
        "µN" | "uN" => Quantity::Force { to_n: 1e-6 },
        "Nm" => Quantity::Torque { to_n_m: 1.0 },
        "mNm" => Quantity::Torque { to_n_m: 1e-3 },
        "µNm" | "uNm" => Quantity::Torque { to_n_m: 1e-6 },
        _ => return None,
    };
    Some(Unit { written, quantity })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spellings_of_torque_agree() {
        for text in ["[mN·m]", "mN.m", "mNm", "mN m", "mN*m"] {
            assert_eq!(
                parse_unit(text).map(|u| u.quantity),
                Some(Quantity::Torque { to_n_m: 1e-3 }),
                "{text}"
            );
        }
        for text in ["µN·m", "μN·m", "uNm"] {
            assert_eq!(
                parse_unit(text).map(|u| u.quantity),
                Some(Quantity::Torque { to_n_m: 1e-6 }),
                "{text}"
            );
        }
    }

    #[test]
    fn times_and_forces() {
        assert_eq!(
            parse_unit("[min]").unwrap().quantity,
            Quantity::Time { to_s: 60.0 }
        );
        assert_eq!(
            parse_unit("h").unwrap().quantity,
            Quantity::Time { to_s: 3600.0 }
        );
        assert_eq!(
            parse_unit("µN").unwrap().quantity,
            Quantity::Force { to_n: 1e-6 }
        );
        assert!(parse_unit("[mrad]").is_none());
        assert!(parse_unit("[1/min]").is_none());
    }
}
