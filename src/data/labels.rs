//! What the columns of an instrument export mean, in the languages rheometer software writes
//! them: one table, [`LANGUAGES`], with a row per language (add a row to add a language), read
//! by every vendor's parser.
//!
//! A column is found by its label first (case and spacing ignored), and only when its unit
//! agrees with what the label means. Where no label matches, time and torque are still found
//! by their units (a time unit: the first such column is the continuous time, the second the
//! step's; a torque unit: the torque); forces are never guessed from a unit alone, since a
//! friction force and a normal force are both in newtons.

use super::units::{parse_unit, Quantity};

/// What a column means for an import.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Role {
    /// Continuous instrument time (RheoCompass `Time`, TRIOS `Time`, rSpace `Time (sequence)`).
    Time,
    /// Time restarting with each interval, step or action.
    StepTime,
    /// Torque, turned into force through the moment arm.
    Torque,
    /// Friction force.
    Force,
    /// Normal force.
    NormalForce,
    /// Deflection angle (recognised so that it is never taken for something else).
    DeflectionAngle,
}

impl Role {
    /// Every role, in the order they are reported.
    pub const ALL: [Role; 6] = [
        Role::Time,
        Role::StepTime,
        Role::Torque,
        Role::Force,
        Role::NormalForce,
        Role::DeflectionAngle,
    ];

    /// The role in words.
    pub fn name(self) -> &'static str {
        match self {
            Self::Time => "time",
            Self::StepTime => "step time",
            Self::Torque => "torque",
            Self::Force => "force",
            Self::NormalForce => "normal force",
            Self::DeflectionAngle => "deflection angle",
        }
    }

    /// Whether a column's unit fits the role (the deflection angle's units are not read). A
    /// column without a unit may still hold the role; its unit is asked for later.
    fn accepts(self, unit: Option<&str>) -> bool {
        let Some(unit) = unit.filter(|u| !u.trim().is_empty()) else {
            return true;
        };
        matches!(
            (self, parse_unit(unit).map(|u| u.quantity)),
            (Self::DeflectionAngle, _)
                | (Self::Time | Self::StepTime, Some(Quantity::Time { .. }))
                | (Self::Torque, Some(Quantity::Torque { .. }))
                | (
                    Self::Force | Self::NormalForce,
                    Some(Quantity::Force { .. })
                )
        )
    }
}

/// The labels one language uses. Section labels are RheoCompass's (the line before each
/// interval's number and point count, the line with its column names, the result line); column
/// labels gather every vendor's spelling.
#[derive(Debug, PartialEq, Eq)]
pub struct Language {
    /// The language in English.
    pub name: &'static str,
    /// RheoCompass `Interval and data points:` (without the colon).
    pub interval: &'static str,
    /// RheoCompass `Interval data:`.
    pub interval_data: &'static str,
    /// RheoCompass `Result:`.
    pub result: &'static str,
    /// Continuous time.
    pub time: &'static [&'static str],
    /// Time of the interval, step or action.
    pub step_time: &'static [&'static str],
    /// Torque.
    pub torque: &'static [&'static str],
    /// Friction force.
    pub force: &'static [&'static str],
    /// Normal force.
    pub normal_force: &'static [&'static str],
    /// Deflection angle.
    pub deflection_angle: &'static [&'static str],
    /// Where these labels were seen.
    pub source: &'static str,
}

impl Language {
    fn labels(&self, role: Role) -> &'static [&'static str] {
        match role {
            Role::Time => self.time,
            Role::StepTime => self.step_time,
            Role::Torque => self.torque,
            Role::Force => self.force,
            Role::NormalForce => self.normal_force,
            Role::DeflectionAngle => self.deflection_angle,
        }
    }

    fn sections(&self) -> [&'static str; 3] {
        [self.interval, self.interval_data, self.result]
    }
}

/// The languages slipbayes reads, English first (it also holds slipbayes' own CSV names and the
/// TRIOS and rSpace labels).
pub const LANGUAGES: &[Language] = &[
    Language {
        name: "English",
        interval: "Interval and data points",
        interval_data: "Interval data",
        result: "Result",
        time: &["Time", "Time (sequence)", "time_s"],
        step_time: &["Interval Time", "Step time", "Time (action)"],
        torque: &["Torque"],
        force: &["force_N", "Friction Force", "Force"],
        normal_force: &[
            "normal_force_N",
            "Normal Force",
            "Axial force",
            "normal_force",
        ],
        deflection_angle: &["Deflection Angle", "Angular displacement", "Displacement"],
        source: "RheoCompass: real exports (jg9zk/APRheoPlotR, bsaintmichel/read-rheol); TRIOS: \
                 real exports (3mcloud/hermes-rheo); rSpace: a real export (read-rheol)",
    },
    Language {
        name: "French",
        interval: "Intervalle et points de données",
        interval_data: "Interval données",
        result: "Résultat",
        time: &["Temps"],
        step_time: &["Intervalle Temps"],
        torque: &["Couple"],
        force: &["Force", "Force de Frottement"],
        normal_force: &["Force Normale"],
        deflection_angle: &["Angle de Déviation"],
        source: "a real RheoCompass export (read-rheol sample_AntonPaar.csv) for all but the \
                 force and deflection-angle labels, which are translations",
    },
    Language {
        name: "German",
        interval: "Intervall und Datenpunkte",
        interval_data: "Intervalldaten",
        result: "Ergebnis",
        time: &["Zeit"],
        step_time: &["Intervallzeit", "Intervall-Zeit"],
        torque: &["Drehmoment"],
        force: &["Kraft", "Reibkraft"],
        normal_force: &["Normalkraft"],
        deflection_angle: &["Auslenkwinkel"],
        source: "translations; no German export was found to check them against",
    },
    Language {
        name: "Spanish",
        interval: "Intervalo y puntos de datos",
        interval_data: "Datos del intervalo",
        result: "Resultado",
        time: &["Tiempo"],
        step_time: &["Tiempo del intervalo", "Tiempo de intervalo"],
        torque: &["Par", "Par de torsión"],
        force: &["Fuerza", "Fuerza de fricción"],
        normal_force: &["Fuerza normal"],
        deflection_angle: &["Ángulo de deflexión"],
        source: "translations; no Spanish export was found to check them against",
    },
    Language {
        name: "Italian",
        interval: "Intervallo e punti dati",
        interval_data: "Dati intervallo",
        result: "Risultato",
        time: &["Tempo"],
        step_time: &["Tempo intervallo", "Tempo dell'intervallo"],
        torque: &["Coppia"],
        force: &["Forza", "Forza di attrito"],
        normal_force: &["Forza normale"],
        deflection_angle: &["Angolo di deflessione"],
        source: "translations; no Italian export was found to check them against",
    },
];

/// Lower case, single spaces, no trailing colon: how labels are compared.
pub(crate) fn normalise(label: &str) -> String {
    let mut out = String::with_capacity(label.len());
    for word in label.trim().trim_end_matches(':').split_whitespace() {
        if !out.is_empty() {
            out.push(' ');
        }
        out.extend(word.chars().flat_map(char::to_lowercase));
    }
    out
}

/// How a column was found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FoundBy {
    /// Its label is in [`LANGUAGES`].
    Label,
    /// Its unit (no label matched).
    Unit,
}

/// The columns that hold each role, as found in a table's header.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Roles {
    found: Vec<(Role, usize, FoundBy)>,
    /// The language whose labels matched most, if any did.
    pub language: Option<&'static Language>,
}

impl Roles {
    /// The column holding `role`, if one was found.
    pub fn column(&self, role: Role) -> Option<usize> {
        self.found
            .iter()
            .find(|(r, _, _)| *r == role)
            .map(|&(_, c, _)| c)
    }

    /// How the column holding `role` was found.
    pub(crate) fn found_by(&self, role: Role) -> Option<FoundBy> {
        self.found
            .iter()
            .find(|(r, _, _)| *r == role)
            .map(|&(_, _, by)| by)
    }

    /// Finds the roles of a table's columns from their names and units; `sections` are the
    /// file's own section labels (RheoCompass), which also tell its language.
    pub fn identify(names: &[String], units: &[Option<String>], sections: &[&str]) -> Self {
        let quantity = |c: usize| {
            units
                .get(c)
                .and_then(|u| u.as_deref())
                .and_then(parse_unit)
                .map(|u| u.quantity)
        };
        let normalised: Vec<String> = names.iter().map(|n| normalise(n)).collect();
        let sections: Vec<String> = sections.iter().map(|s| normalise(s)).collect();
        let mut roles = Self::default();
        let mut best = 0;
        for language in LANGUAGES {
            let mut matches = sections
                .iter()
                .filter(|s| language.sections().iter().any(|l| normalise(l) == **s))
                .count();
            let mut found = Vec::new();
            for role in Role::ALL {
                let column = language.labels(role).iter().find_map(|label| {
                    let label = normalise(label);
                    (0..names.len()).find(|&c| {
                        normalised[c] == label
                            && role.accepts(units.get(c).and_then(|u| u.as_deref()))
                            && !found.iter().any(|&(_, used, _)| used == c)
                    })
                });
                if let Some(c) = column {
                    found.push((role, c, FoundBy::Label));
                    matches += 1;
                }
            }
            if matches > best {
                best = matches;
                roles = Self {
                    found,
                    language: Some(language),
                };
            }
        }
        // Units where labels were not found: times in file order, then the torque.
        let taken = |roles: &Self, c: usize| roles.found.iter().any(|&(_, used, _)| used == c);
        let times: Vec<usize> = (0..names.len())
            .filter(|&c| matches!(quantity(c), Some(Quantity::Time { .. })))
            .collect();
        for (role, nth) in [(Role::Time, 0), (Role::StepTime, 1)] {
            if roles.column(role).is_none() {
                if let Some(&c) = times.get(nth).filter(|&&c| !taken(&roles, c)) {
                    roles.found.push((role, c, FoundBy::Unit));
                }
            }
        }
        if roles.column(Role::Torque).is_none() {
            let torque = (0..names.len()).find(|&c| {
                matches!(quantity(c), Some(Quantity::Torque { .. })) && !taken(&roles, c)
            });
            if let Some(c) = torque {
                roles.found.push((Role::Torque, c, FoundBy::Unit));
            }
        }
        roles
    }

    /// The roles found, in words, for the record: ``time `Temps` (label), torque `Couple`
    /// (label)``.
    pub fn describe(&self, names: &[String]) -> String {
        let mut parts = Vec::new();
        for role in Role::ALL {
            if let (Some(c), Some(by)) = (self.column(role), self.found_by(role)) {
                parts.push(format!(
                    "{} `{}`{}",
                    role.name(),
                    names[c],
                    if by == FoundBy::Unit {
                        " (by its unit)"
                    } else {
                        ""
                    }
                ));
            }
        }
        if parts.is_empty() {
            "none".into()
        } else {
            parts.join(", ")
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn strings(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| (*s).to_owned()).collect()
    }

    fn units(v: &[&str]) -> Vec<Option<String>> {
        v.iter()
            .map(|s| (!s.is_empty()).then(|| (*s).to_owned()))
            .collect()
    }

    #[test]
    fn french_labels_and_language() {
        let names = strings(&[
            "Point No.",
            "Temps",
            "Intervalle Temps",
            "Couple",
            "Force Normale",
        ]);
        let roles = Roles::identify(
            &names,
            &units(&["", "[s]", "[s]", "[mN·m]", "[N]"]),
            &["Intervalle et points de données:", "Interval données:"],
        );
        assert_eq!(roles.language.map(|l| l.name), Some("French"));
        assert_eq!(roles.column(Role::Time), Some(1));
        assert_eq!(roles.column(Role::StepTime), Some(2));
        assert_eq!(roles.column(Role::Torque), Some(3));
        assert_eq!(roles.column(Role::NormalForce), Some(4));
        assert_eq!(roles.found_by(Role::Torque), Some(FoundBy::Label));
    }

    #[test]
    fn unknown_labels_fall_back_to_units_but_never_for_forces() {
        let names = strings(&["Punkt", "Zeitpunkt", "Intervall Zeit", "Moment", "Kraft N"]);
        let roles = Roles::identify(&names, &units(&["", "[min]", "[s]", "[µN·m]", "[N]"]), &[]);
        assert!(roles.language.is_none());
        assert_eq!(roles.column(Role::Time), Some(1));
        assert_eq!(roles.column(Role::StepTime), Some(2));
        assert_eq!(roles.column(Role::Torque), Some(3));
        assert_eq!(roles.found_by(Role::Torque), Some(FoundBy::Unit));
        assert_eq!(roles.column(Role::Force), None);
        assert_eq!(roles.column(Role::NormalForce), None);
    }

    #[test]
    fn a_label_with_the_wrong_unit_is_not_taken() {
        // `Time` in rad is not a time.
        let names = strings(&["Time", "Torque"]);
        let roles = Roles::identify(&names, &units(&["[rad]", "[N]"]), &[]);
        assert_eq!(roles.column(Role::Time), None);
        assert_eq!(roles.column(Role::Torque), None);
    }

    #[test]
    fn every_language_has_every_label() {
        for l in LANGUAGES {
            for role in Role::ALL {
                assert!(!l.labels(role).is_empty(), "{} {}", l.name, role.name());
            }
            assert!(
                !l.interval.is_empty() && !l.interval_data.is_empty(),
                "{}",
                l.name
            );
        }
    }
}
