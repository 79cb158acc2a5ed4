//! Rheometer exports in: every fixture of `tests/fixtures/import/` (a real TRIOS export, and
//! exact reproductions of real RheoCompass, TRIOS CSV and rSpace layouts; its README.md says
//! where each was seen) imports to the file's own numbers in SI units, as an independent
//! reader (`expected.py`) finds them; formats are recognised whatever a file is called; errors
//! say what was tried; and exports written in every language, encoding and number format read
//! back to the values written.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use serde_json::Value;
use slipbayes::data::import::import_bytes;
use slipbayes::data::labels::{Language, LANGUAGES};
use slipbayes::data::{import, Clock, Format, ImportOptions, IntervalChoice};
use slipbayes::prec::IMPORT_REL_TOL;
use slipbayes::run_file::RunFile;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures/import")
        .join(name)
}

/// The message of an import of `text` (named `name`) with the default options, which must fail.
fn import_error(text: &str, name: &str) -> String {
    import_bytes(text.as_bytes(), Path::new(name), &ImportOptions::default())
        .unwrap_err()
        .to_string()
}

fn options_of(case: &Value) -> ImportOptions {
    let o = &case["options"];
    ImportOptions {
        intervals: match o["interval"].as_array() {
            Some(n) => {
                IntervalChoice::Numbers(n.iter().map(|v| v.as_u64().unwrap() as usize).collect())
            }
            None => IntervalChoice::All,
        },
        clock: o["clock"]
            .as_str()
            .map_or(Clock::Global, |c| c.parse().unwrap()),
        drop_invalid: o["drop_invalid"].as_bool().unwrap_or(false),
        moment_arm_m: o["moment_arm_m"].as_f64().unwrap_or(7e-3),
        ..ImportOptions::default()
    }
}

/// Largest relative difference, or `None` when the lengths differ.
fn max_rel_diff(got: &[f64], want: &[f64]) -> Option<f64> {
    (got.len() == want.len()).then(|| {
        got.iter()
            .zip(want)
            .map(|(g, w)| (g - w).abs() / w.abs().max(f64::MIN_POSITIVE))
            .fold(0.0, f64::max)
    })
}

fn numbers(v: &Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

#[test]
fn every_fixture_imports_to_the_files_numbers() {
    let cases: Vec<Value> =
        serde_json::from_str(&std::fs::read_to_string(fixture("cases.json")).unwrap()).unwrap();
    let expected: Value =
        serde_json::from_str(&std::fs::read_to_string(fixture("expected.json")).unwrap()).unwrap();
    let mut worst: f64 = 0.0;
    for case in &cases {
        let name = case["name"].as_str().unwrap();
        let path = fixture(case["file"].as_str().unwrap());
        let result = import(&path, &options_of(case));
        if let Some(error) = case["error"].as_str() {
            let message = result
                .map(|_| String::new())
                .unwrap_or_else(|e| e.to_string());
            assert!(
                message.contains(error),
                "{name}: `{error}` not in `{message}`"
            );
            continue;
        }
        let imported = result.unwrap_or_else(|e| panic!("{name}: {e}"));
        let want = &expected[name];
        assert_eq!(
            imported.points_read as u64,
            want["points_read"].as_u64().unwrap(),
            "{name}"
        );
        assert_eq!(
            imported.dropped_invalid as u64,
            want["dropped_invalid"].as_u64().unwrap(),
            "{name}"
        );
        let s = &imported.series;
        let mut pairs = vec![
            ("time", s.time_s.clone(), numbers(&want["time_s"])),
            ("force", s.force_n.clone(), numbers(&want["force_n"])),
        ];
        match (&s.normal_force_n, want["normal_force_n"].is_null()) {
            (Some(n), false) => {
                pairs.push(("normal force", n.clone(), numbers(&want["normal_force_n"])))
            }
            (None, true) => {}
            _ => panic!("{name}: normal force column found where the oracle has none, or missed"),
        }
        for (what, got, want) in pairs {
            let diff = max_rel_diff(&got, &want).unwrap_or_else(|| {
                panic!(
                    "{name}: {what}: {} points, expected {}",
                    got.len(),
                    want.len()
                )
            });
            assert!(
                diff <= IMPORT_REL_TOL,
                "{name}: {what} differs by {diff:e} relative"
            );
            worst = worst.max(diff);
        }
    }
    // Report the measured agreement (quoted in tests/fixtures/import/README.md).
    println!("largest relative difference over every fixture: {worst:e}");
}

/// The report of issue 21, as a new user meets it: a French RheoCompass export with a `.csv`
/// name. It is recognised (not handed to polars), the intervals are listed, and its invalid
/// points stop the import with a message about them rather than a library's hint.
#[test]
fn a_french_export_is_recognised_as_a_new_user_tries_it() {
    let path = fixture("rheocompass-fr.csv");
    let message = import(&path, &ImportOptions::default())
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("rheocompass-fr.csv:76:2:") && message.contains("(invalide)"),
        "{message}"
    );
    for internal in ["Schema", "truncate_ragged_lines", "polars"] {
        assert!(!message.contains(internal), "{message}");
    }
    let first = import(
        &path,
        &ImportOptions {
            intervals: IntervalChoice::Numbers(vec![1]),
            ..ImportOptions::default()
        },
    )
    .unwrap();
    assert_eq!(first.format, Format::Rheocompass);
    let found = first.found.join("\n");
    for part in [
        "Anton Paar RheoCompass export, labels in French",
        "UTF-16LE with BOM, tab-separated, decimal comma",
        "interval 2 (result `Glissement 1`, its interval 2): 20 points",
        "interval 5 (result `LAOS 1`, its interval 2): 3 points and 24 waveform rows",
        "columns used: time = `Temps` [s], force = `Couple` [mN·m], normal force = `Force Normale` [N]",
    ] {
        assert!(found.contains(part), "`{part}` not in:\n{found}");
    }
}

#[test]
fn formats_are_recognised_whatever_the_file_is_called() {
    for (file, format) in [
        ("rheocompass-fr.csv", Format::Rheocompass),
        ("rheocompass-en-comma.csv", Format::Rheocompass),
        ("trios-multi-technique.txt", Format::Trios),
        ("trios-export.csv", Format::Trios),
        ("rspace-kinexus.csv", Format::Rspace),
    ] {
        let bytes = std::fs::read(fixture(file)).unwrap();
        let detection = Format::detect(&bytes);
        assert_eq!(detection.format, format, "{file}: {:?}", detection.tried);
        // The same bytes under another name import alike.
        let options = ImportOptions {
            intervals: IntervalChoice::Numbers(vec![1]),
            clock: if file == "trios-export.csv" {
                Clock::Step
            } else {
                Clock::Global
            },
            ..ImportOptions::default()
        };
        let a = import(&fixture(file), &options).unwrap();
        let b = import_bytes(&bytes, Path::new("measurement.dat"), &options).unwrap();
        assert_eq!(a.series, b.series, "{file}");
        assert_eq!(b.format, format);
    }
    let plain = "time_s,force_N\n0,1\n1,2\n";
    let detection = Format::detect(plain.as_bytes());
    assert_eq!(detection.format, Format::Csv);
    assert_eq!(detection.tried.len(), 3);
}

/// A file that is none of the formats: the message names each format tried and why it did
/// not fit, then what went wrong as a plain table, in slipbayes' words. Plain tables are read
/// through polars.
#[cfg(feature = "tabular")]
/// A step or action the export lacks is refused, listing those it has with their points.
#[test]
fn a_missing_step_or_action_lists_those_there_are() {
    let options = ImportOptions {
        intervals: IntervalChoice::Numbers(vec![9]),
        ..ImportOptions::default()
    };
    let message = import(&fixture("trios-multi-technique.txt"), &options)
        .unwrap_err()
        .to_string();
    assert!(
        message
            .contains("no step 9; the file has steps 1 (29 points), 2 (29 points), 3 (223 points)"),
        "{message}"
    );
    let message = import(&fixture("rspace-kinexus.csv"), &options)
        .unwrap_err()
        .to_string();
    assert!(
        message.contains("no action 9; the file has actions 1 ("),
        "{message}"
    );
}

#[test]
fn a_file_of_no_known_format_says_what_was_tried() {
    let text = "t;M\n1;2\n3;4;5\n";
    let message = import_error(text, "x.txt");
    for part in [
        "x.txt:3:3: 3 fields where the header (line 1) has 2",
        "not an Anton Paar RheoCompass export: no interval header",
        "not a TA Instruments TRIOS export: no `[step]` line",
        "not a Malvern rSpace export: the first line is not a header of columns with their units",
    ] {
        assert!(message.contains(part), "`{part}` not in `{message}`");
    }
    for internal in ["Schema", "truncate_ragged_lines", "Consider"] {
        assert!(!message.contains(internal), "{message}");
    }
}

/// A recognised export without a time or a force/torque column lists the columns it has.
#[test]
fn a_recognised_export_without_time_or_torque_lists_its_columns() {
    let text = "Intervalle et points de données:\t1\t2\n\
        Interval données:\tPoint No.\tTemps\tContrainte de Cisaillement\n\
        \t\t[s]\t[Pa]\n\t1\t1\t5,5\n\t2\t2\t5,6\n";
    let message = import_error(text, "fr.txt");
    assert!(
        message.contains(
            "fr.txt:2:1: no force or torque column among the columns `Point No.`, `Temps` \
             [s], `Contrainte de Cisaillement` [Pa]"
        ),
        "{message}"
    );
    let text = text.replace("[s]", "[Pa]");
    let message = import_error(&text, "fr.txt");
    assert!(
        message.contains("no time column among the columns `Point No.`, `Temps` [Pa]"),
        "{message}"
    );
}

/// How numbers are written: the decimal mark and the mark between digit groups.
#[derive(Debug, Clone, Copy)]
struct Locale {
    decimal: char,
    group: Option<char>,
}

const LOCALES: [Locale; 8] = [
    Locale {
        decimal: '.',
        group: None,
    },
    Locale {
        decimal: '.',
        group: Some(','),
    },
    Locale {
        decimal: '.',
        group: Some('\''),
    },
    Locale {
        decimal: ',',
        group: None,
    },
    Locale {
        decimal: ',',
        group: Some('.'),
    },
    Locale {
        decimal: ',',
        group: Some(' '),
    },
    Locale {
        decimal: ',',
        group: Some('\u{a0}'),
    },
    Locale {
        decimal: ',',
        group: Some('\u{202f}'),
    },
];

/// `x` as a computer with `locale` writes it: plain with grouped digits, or `2,21E+04`
/// (`E+004` in rSpace's style when `wide_exponent`). The digits are Rust's shortest round trip,
/// so they read back to `x` exactly.
fn write_number(x: f64, locale: Locale, exponent: bool, wide_exponent: bool) -> String {
    if exponent {
        let s = format!("{x:e}");
        let (mantissa, e) = s.split_once('e').unwrap();
        let e: i32 = e.parse().unwrap();
        let sign = if e < 0 { '-' } else { '+' };
        let digits = if wide_exponent { 3 } else { 2 };
        let mantissa = mantissa.replace('.', &locale.decimal.to_string());
        return format!("{mantissa}E{sign}{:0digits$}", e.abs());
    }
    let s = format!("{x}");
    let (sign, s) = s.strip_prefix('-').map_or(("", s.as_str()), |r| ("-", r));
    let (int, frac) = s.split_once('.').unwrap_or((s, ""));
    let int = match locale.group {
        Some(g) if int.len() > 3 => {
            let mut out = String::new();
            for (i, c) in int.chars().enumerate() {
                if i > 0 && (int.len() - i) % 3 == 0 {
                    out.push(g);
                }
                out.push(c);
            }
            out
        }
        _ => int.to_owned(),
    };
    if frac.is_empty() {
        format!("{sign}{int}")
    } else {
        format!("{sign}{int}{}{frac}", locale.decimal)
    }
}

/// The bytes of `text` in encoding `which`: UTF-8 with or without BOM, UTF-16LE/BE with or
/// without BOM.
fn encode(text: &str, which: usize) -> Vec<u8> {
    let utf16 = |little: bool, bom: bool| {
        let mut out = Vec::new();
        if bom {
            out.extend_from_slice(if little { &[0xFF, 0xFE] } else { &[0xFE, 0xFF] });
        }
        for u in text.encode_utf16() {
            out.extend_from_slice(&if little {
                u.to_le_bytes()
            } else {
                u.to_be_bytes()
            });
        }
        out
    };
    match which {
        0 => text.as_bytes().to_vec(),
        1 => [&[0xEF, 0xBB, 0xBF][..], text.as_bytes()].concat(),
        2 => utf16(true, true),
        3 => utf16(true, false),
        4 => utf16(false, true),
        _ => utf16(false, false),
    }
}

/// Units written and their factors to SI (torque in N·m).
const TIME_UNITS: [(&str, f64); 3] = [("s", 1.0), ("min", 60.0), ("h", 3600.0)];
const TORQUE_UNITS: [(&str, f64); 3] = [("mN·m", 1e-3), ("µN·m", 1e-6), ("N·m", 1.0)];
const FORCE_UNITS: [(&str, f64); 2] = [("N", 1.0), ("mN", 1e-3)];

/// One generated export's numbers.
#[derive(Debug, Clone)]
struct Points {
    /// Per block: rows of (time, step time, torque, normal force).
    blocks: Vec<Vec<[f64; 4]>>,
}

fn points() -> impl Strategy<Value = Points> {
    let row = (1e-3f64..500.0, -1e4f64..1e4, 1e-3f64..20.0);
    prop::collection::vec(prop::collection::vec(row, 1..12), 1..4).prop_map(|blocks| {
        let mut t = 0.0;
        Points {
            blocks: blocks
                .into_iter()
                .map(|rows| {
                    let mut step = 0.0;
                    rows.into_iter()
                        .map(|(dt, torque, normal)| {
                            t += dt;
                            step += dt;
                            // Torque never zero, so that relative errors are defined.
                            [t, step, if torque == 0.0 { 1.5 } else { torque }, normal]
                        })
                        .collect()
                })
                .collect(),
        }
    })
}

/// The separators a locale allows (a comma cannot separate fields that hold decimal commas).
fn separator(locale: Locale, pick: usize) -> char {
    let allowed: &[char] = if locale.decimal == ',' || locale.group == Some(',') {
        &['\t', ';']
    } else {
        &['\t', ';', ',']
    };
    allowed[pick % allowed.len()]
}

/// Checks an import against the numbers written, converted with the same factors.
fn check(
    imported: &slipbayes::data::Imported,
    points: &Points,
    factors: [f64; 3],
    step_clock: bool,
) -> Result<(), TestCaseError> {
    let rows: Vec<&[f64; 4]> = points.blocks.iter().flatten().collect();
    let s = &imported.series;
    prop_assert_eq!(s.len(), rows.len());
    let normal = s.normal_force_n.as_ref().expect("normal force found");
    for (i, r) in rows.iter().enumerate() {
        let t = if step_clock { r[1] } else { r[0] } * factors[0];
        let want = [t, r[2] * factors[1], r[3] * factors[2]];
        let got = [s.time_s[i], s.force_n[i], normal[i]];
        for (g, w) in got.iter().zip(want) {
            prop_assert!(
                (g - w).abs() <= IMPORT_REL_TOL * w.abs(),
                "row {}: {} against {}",
                i,
                g,
                w
            );
        }
    }
    Ok(())
}

fn label(labels: &[&str], pick: usize) -> String {
    labels[pick % labels.len()].to_owned()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// RheoCompass exports written in every language of the labels table, every encoding and
    /// every number format read back to the numbers written, with the language named.
    #[test]
    fn rheocompass_in_every_language_and_number_format(
        points in points(),
        language in 0..LANGUAGES.len(),
        locale in 0..LOCALES.len(),
        encoding in 0..6usize,
        sep in 0..3usize,
        exponents in prop::collection::vec(any::<bool>(), 4),
        picks in prop::collection::vec(0..8usize, 5),
        units in (0..3usize, 0..3usize, 0..2usize),
        arm_mm in 1.0f64..20.0,
    ) {
        let l: &Language = &LANGUAGES[language];
        let loc = LOCALES[locale];
        let sep = separator(loc, sep);
        let (tu, mu, nu) = (TIME_UNITS[units.0], TORQUE_UNITS[units.1], FORCE_UNITS[units.2]);
        let num = |x: f64, column: usize| write_number(x, loc, exponents[column], false);
        let names = [
            "Point No.".to_owned(),
            label(l.time, picks[0]),
            label(l.step_time, picks[1]),
            label(l.torque, picks[2]),
            label(l.deflection_angle, picks[3]),
            label(l.normal_force, picks[4]),
            "Status".to_owned(),
        ];
        let s = sep.to_string();
        let mut lines = vec![format!("{}:{s}friction test", l.result), String::new()];
        let mut point = 0;
        for (k, rows) in points.blocks.iter().enumerate() {
            lines.push(format!("{}:{s}{}{s}{}", l.interval, k + 1, rows.len()));
            lines.push(format!("{}:{s}{}", l.interval_data, names.join(&s)));
            lines.push(
                ["", "", tu.0, tu.0, mu.0, "mrad", nu.0, ""]
                    .iter()
                    .enumerate()
                    .map(|(i, u)| if i < 2 || u.is_empty() { String::new() } else { format!("[{u}]") })
                    .collect::<Vec<_>>()
                    .join(&s),
            );
            for r in rows {
                point += 1;
                lines.push(
                    [String::new(), point.to_string(), num(r[0], 0), num(r[1], 1), num(r[2], 2),
                     num(r[2] * 0.05, 2), num(r[3], 3), "Dy_auto".to_owned()]
                        .join(&s),
                );
            }
            lines.push(String::new());
        }
        let bytes = encode(&(lines.join("\r\n") + "\r\n"), encoding);
        let arm = arm_mm * 1e-3;
        for step_clock in [false, true] {
            // On the step clock, each interval's times restart: one interval at a time.
            let chosen = if step_clock { vec![points.blocks.len()] } else { vec![] };
            let options = ImportOptions {
                intervals: if step_clock {
                    IntervalChoice::Numbers(chosen.clone())
                } else {
                    IntervalChoice::All
                },
                clock: if step_clock { Clock::Step } else { Clock::Global },
                moment_arm_m: arm,
                ..ImportOptions::default()
            };
            let imported = import_bytes(&bytes, Path::new("export.csv"), &options)
                .map_err(|e| TestCaseError::fail(format!("{e}\n{}", lines.join("\n"))))?;
            prop_assert_eq!(imported.format, Format::Rheocompass);
            let language_found = format!("labels in {}", l.name);
            prop_assert!(imported.found[0].contains(&language_found), "{:?}", imported.found);
            let written = if step_clock {
                Points { blocks: vec![points.blocks.last().unwrap().clone()] }
            } else {
                points.clone()
            };
            check(&imported, &written, [tu.1, mu.1 / arm, nu.1], step_clock)?;
        }
    }

    /// TRIOS (text or CSV) and rSpace exports in every number format read back.
    #[test]
    fn trios_and_rspace_in_every_number_format(
        points in points(),
        locale in 0..LOCALES.len(),
        sep in 0..3usize,
        exponents in prop::collection::vec(any::<bool>(), 4),
        units in (0..3usize, 0..3usize),
        rspace in any::<bool>(),
    ) {
        let loc = LOCALES[locale];
        let sep = separator(loc, sep);
        let s = sep.to_string();
        let (tu, mu) = (TIME_UNITS[units.0], TORQUE_UNITS[units.1]);
        let num = |x: f64, column: usize| write_number(x, loc, exponents[column], rspace);
        let mut lines = Vec::new();
        if rspace {
            lines.push(
                [
                    "Action Name".to_owned(),
                    format!("Time (sequence)({})", tu.0),
                    format!("Time (action)({})", tu.0),
                    format!("Torque({})", mu.0.replace('·', " ")),
                    "Normal force(N)".to_owned(),
                ]
                .join(&s),
            );
            for (k, rows) in points.blocks.iter().enumerate() {
                for r in rows {
                    lines.push(
                        [format!("Action {}", k + 1), num(r[0], 0), num(r[1], 1), num(r[2], 2),
                         num(r[3], 3)]
                            .join(&s),
                    );
                }
            }
        } else {
            lines.extend([format!("Filename{s}x"), format!("Trios version{s}5.1"),
                          "[File Parameters]".to_owned(), format!("Name{s}x")]);
            for (k, rows) in points.blocks.iter().enumerate() {
                lines.extend([
                    "[step]".to_owned(),
                    format!("Slide - {}", k + 1),
                    format!("Number of points{s}{}", rows.len()),
                    ["Torque", "Step time", "Axial force", "Time", "Date and time"].join(&s),
                    [mu.0, tu.0, "N", tu.0, ""].join(&s),
                ]);
                for r in rows {
                    lines.push(
                        [num(r[2], 2), num(r[1], 1), num(r[3], 3), num(r[0], 0),
                         "10/17/2022 10:27:02 AM".to_owned()]
                            .join(&s),
                    );
                }
                lines.push(String::new());
            }
        }
        let bytes = (lines.join("\n") + "\n").into_bytes();
        let imported = import_bytes(&bytes, Path::new("export.txt"), &ImportOptions::default())
            .map_err(|e| TestCaseError::fail(format!("{e}\n{}", lines.join("\n"))))?;
        prop_assert_eq!(imported.format, if rspace { Format::Rspace } else { Format::Trios });
        check(&imported, &points, [tu.1, mu.1 / 7e-3, 1.0], false)?;
    }
}

/// `data = …` in a model file reads any export whatever its name, with `interval` choosing
/// TRIOS steps or rSpace actions and `clock` the time they are placed on.
#[test]
fn model_files_read_exports_by_content() {
    use slipbayes::model::data::RunData;
    let dir = tempfile::tempdir().unwrap();
    // A TRIOS export under a name that says nothing of its format.
    let renamed = dir.path().join("slide.dat");
    std::fs::copy(fixture("trios-multi-technique.txt"), &renamed).unwrap();
    let text = format!(
        "[[material]]\nname = \"m\"\n[[contact]]\nname = \"c\"\nmaterial = \"m\"\n\
         [[run]]\nname = \"trios\"\ncontact = \"c\"\ndata = \"slide.dat\"\n\
         velocity_m_per_s = 1e-9\nscene = \"first\"\ninterval = 3\n\
         [[run]]\nname = \"rspace\"\ncontact = \"c\"\ndata = \"{}\"\n\
         velocity_m_per_s = 1e-9\nscene = \"repeat\"\ninterval = 3\nclock = \"step\"\n",
        fixture("rspace-kinexus.csv").display()
    );
    let spec = RunFile::parse(&text, &dir.path().join("model.toml")).unwrap();
    let trios = RunData::for_run(&spec.model, 0).unwrap();
    assert_eq!(trios.provenance.format, "trios");
    assert_eq!(trios.provenance.points_read, 223);
    let rspace = RunData::for_run(&spec.model, 1).unwrap();
    assert_eq!(rspace.provenance.format, "rspace");
    assert_eq!(rspace.provenance.points_read, 40);
    // On the action clock the slide starts at its first row's 5 s, not at 157.3 s.
    assert!(
        (rspace.model_times[0] - 5.0).abs() < 1e-12,
        "{}",
        rspace.model_times[0]
    );
    assert!(rspace
        .provenance
        .conversions
        .iter()
        .any(|c| c.contains("F = M / r")));
    let text = text.replace("clock = \"step\"", "clock = \"sideways\"");
    let err = RunFile::parse(&text, &dir.path().join("model.toml"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("clock"), "{err}");
}

/// What every successful import promises, whatever the bytes were.
fn promises_kept(imported: &slipbayes::data::Imported) -> Result<(), TestCaseError> {
    let s = &imported.series;
    prop_assert!(!s.is_empty());
    prop_assert!(s.time_s.windows(2).all(|w| w[0] < w[1]));
    prop_assert!(s.time_s.iter().chain(&s.force_n).all(|v| v.is_finite()));
    prop_assert_eq!(imported.lines.len(), s.len());
    prop_assert_eq!(imported.points_read, s.len() + imported.dropped_invalid);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Damaged exports (bytes changed, cut out or cut off) through detection, every parser and
    /// the mapping, with any options: a result that keeps the importer's promises, or an error;
    /// never a panic.
    #[test]
    fn damaged_exports_give_a_result_or_an_error(
        file in 0..5usize,
        edits in prop::collection::vec((0..3u8, any::<prop::sample::Index>(), any::<u8>()), 1..6),
        choice in 0..16u8,
    ) {
        let name = ["rheocompass-fr.csv", "rheocompass-en-comma.csv", "trios-export.csv",
                    "rspace-kinexus.csv", "trios-multi-technique.txt"][file];
        let mut bytes = std::fs::read(fixture(name)).unwrap();
        for (kind, at, value) in edits {
            if bytes.is_empty() {
                break;
            }
            let i = at.index(bytes.len());
            match kind {
                0 => bytes[i] = value,
                1 => {
                    let end = (i + usize::from(value) % 64).min(bytes.len());
                    bytes.drain(i..end);
                }
                _ => bytes.truncate(i),
            }
        }
        let options = ImportOptions {
            drop_invalid: choice & 1 == 1,
            clock: if choice & 2 == 2 { Clock::Step } else { Clock::Global },
            intervals: match choice >> 2 {
                0 => IntervalChoice::All,
                1 => IntervalChoice::Numbers(vec![1]),
                2 => IntervalChoice::Numbers(vec![3]),
                _ => IntervalChoice::Numbers(vec![1, 2]),
            },
            ..ImportOptions::default()
        };
        if let Ok(imported) = import_bytes(&bytes, Path::new(name), &options) {
            promises_kept(&imported)?;
        }
    }
}
