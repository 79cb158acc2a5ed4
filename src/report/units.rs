//! The units users think in, and numbers written for people.
//!
//! Everything inside slipbayes is SI; a report shows forces in mN, α in µm⁻¹, distances in
//! µm, times in s and stiffness in N/m, as the paper does.

/// How a quantity in an SI unit is shown: the unit's label and the factor from SI to it.
#[derive(Debug, Clone, PartialEq)]
pub struct DisplayUnit {
    /// The unit shown (`"mN"`, `"µm⁻¹"`, ...); empty for a pure number.
    pub label: String,
    /// Multiply an SI value by this to get the shown value.
    pub factor: f64,
}

impl DisplayUnit {
    /// The shown unit of an SI unit as `summary.json` writes it (`"N"`, `"1/m"`, `"s"`,
    /// `"N/m"`, `"m"`, `"1"`); an unknown unit is shown as it is, in its own scale.
    pub fn of_si(unit: &str) -> Self {
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

    #[test]
    fn significant_digits() {
        assert_eq!(significant(12.345, 3), "12.3");
        assert_eq!(significant(0.0123456, 3), "0.0123");
        assert_eq!(significant(921691.2, 4), "9.217e5");
        assert_eq!(significant(1.0094, 4), "1.009");
        assert_eq!(significant(-0.5, 2), "-0.50");
        assert_eq!(significant(f64::NAN, 3), "–");
        assert_eq!(significant(0.0, 3), "0");
        assert_eq!(significant(2.5e-7, 2), "2.5e-7");
    }
}
