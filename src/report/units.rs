//! The units users think in, and numbers written for people.
//!
//! Everything inside slipbayes is SI; a report shows forces in mN, α in µm⁻¹, distances in
//! µm, times in s and stiffness in N/m, as the paper does.

// Numbers are written by the plotting layer's rule, which tick labels need without the
// `report` feature; the report's tables use the same.
pub use crate::plot::significant;

/// How a quantity in an SI unit is shown: the unit's label and the factor from SI to it.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct DisplayUnit {
    /// The unit shown (`"mN"`, `"µm⁻¹"`, ...); empty for a pure number.
    pub label: String,
    /// Multiply an SI value by this to get the shown value.
    pub factor: f64,
}

impl DisplayUnit {
    /// The shown unit of an SI unit as `summary.json` writes it (`"N"`, `"1/m"`, `"s"`,
    /// `"N/m"`, `"m"`, `"1"`); an unknown unit is shown as it is, in its own scale.
    pub(crate) fn of_si(unit: &str) -> Self {
        let (label, factor) = match unit {
            "N" => ("mN", 1e3),
            "1/m" => ("µm⁻¹", 1e-6),
            "m" => ("µm", 1e6),
            "N/s" => ("mN/s", 1e3),
            "1" => ("", 1.0),
            other => (other, 1.0),
        };
        Self {
            label: label.to_owned(),
            factor,
        }
    }

    /// `value` (SI) in this unit.
    pub fn show(&self, value: f64) -> f64 {
        value * self.factor
    }

    /// ` (unit)` for an axis or column label, or nothing for a pure number.
    pub fn suffix(&self) -> String {
        if self.label.is_empty() {
            String::new()
        } else {
            format!(" ({})", self.label)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn si_units_are_shown_as_users_read_them() {
        let force = DisplayUnit::of_si("N");
        assert_eq!(force.label, "mN");
        assert!((force.show(0.0123) - 12.3).abs() < 1e-12);
        let alpha = DisplayUnit::of_si("1/m");
        assert_eq!(alpha.label, "µm⁻¹");
        assert!((alpha.show(0.92e6) - 0.92).abs() < 1e-12);
        assert_eq!(DisplayUnit::of_si("m").label, "µm");
        assert_eq!(DisplayUnit::of_si("N/m").suffix(), " (N/m)");
        assert_eq!(DisplayUnit::of_si("1").suffix(), "");
        assert_eq!(DisplayUnit::of_si("kg").label, "kg");
    }
}
