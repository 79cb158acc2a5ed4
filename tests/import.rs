//! Instrument files in: the column mapping and its units, the RheoCompass export fitted end to
//! end, every validation error naming file, line and column, and the bit-exact read back of
//! what `simulate` writes.

use std::path::{Path, PathBuf};

use proptest::prelude::*;
use slipbayes::data::import::{import_bytes, Cell};
use slipbayes::data::{
    import, ColumnMap, ColumnRef, DataError, Format, ImportOptions, IntervalChoice,
};
use slipbayes::law::{LawParams, Scene};
use slipbayes::run_file::RunFile;
use slipbayes::simulate::{simulate, SimulationSpec};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn options() -> ImportOptions {
    ImportOptions::default()
}

fn mapped(time: (&str, &str), force: (&str, &str)) -> ImportOptions {
    let column = |(name, unit): (&str, &str)| ColumnRef {
        name: name.into(),
        unit: (!unit.is_empty()).then(|| unit.into()),
    };
    ImportOptions {
        columns: Some(ColumnMap {
            time: column(time),
            force: column(force),
            normal_force: None,
        }),
        ..ImportOptions::default()
    }
}

fn error(text: &str, name: &str, options: &ImportOptions) -> String {
    import_bytes(text.as_bytes(), Path::new(name), options)
        .unwrap_err()
        .to_string()
}

#[cfg(feature = "tabular")]
fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-12 * b.abs().max(1e-300)
}

/// CSV tables are read through polars.
#[cfg(feature = "tabular")]
#[test]
fn units_convert_to_si() {
    // Semicolons and decimal commas, time in minutes, torque in mN·m through a 5 mm arm.
    let text = "t;M;FN\n0,5;1,4;0,05\n1;2,8;0,05\n1,5;3,5;0,05\n";
    let mut o = mapped(("t", "min"), ("M", "mN·m"));
    o.moment_arm_m = 5e-3;
    let imported = import_bytes(text.as_bytes(), Path::new("m.csv"), &o).unwrap();
    let s = &imported.series;
    assert_eq!(s.len(), 3);
    assert!(close(s.time_s[0], 30.0) && close(s.time_s[2], 90.0));
    assert!(close(s.force_n[0], 1.4e-3 / 5e-3), "{}", s.force_n[0]);
    assert_eq!(imported.conversions.len(), 2, "{:?}", imported.conversions);
    // Hours and µN, and a force column with the unit in the mapping.
    let text = "hours,friction\n1,250\n2,500\n";
    let imported = import_bytes(
        text.as_bytes(),
        Path::new("h.csv"),
        &mapped(("hours", "h"), ("friction", "µN")),
    )
    .unwrap();
    assert!(close(imported.series.time_s[1], 7200.0));
    assert!(close(imported.series.force_n[1], 500e-6));
}

#[test]
fn rheocompass_export_reads_as_written() {
    let path = repo("data/rheocompass-ptfe-c1.txt");
    let bytes = std::fs::read(&path).unwrap();
    assert!(
        bytes.starts_with(&[0xFF, 0xFE]),
        "the example is UTF-16LE with BOM"
    );
    assert_eq!(Format::detect(&bytes).format, Format::Rheocompass);
    // Without asking, the invalid point stops the import at its line and column.
    let err = import(&path, &options()).unwrap_err().to_string();
    assert!(err.contains("rheocompass-ptfe-c1.txt:146:4:"), "{err}");
    assert!(
        err.contains("Invalid") && err.contains("drop_invalid"),
        "{err}"
    );
    let dropped = ImportOptions {
        drop_invalid: true,
        intervals: IntervalChoice::Numbers(vec![1, 2]),
        ..options()
    };
    let first = import(&path, &dropped).unwrap();
    assert_eq!((first.points_read, first.dropped_invalid), (841, 1));
    // The export's torque is the simulator's force times the 7 mm arm, written with a
    // decimal comma; converted back it agrees to rounding.
    let truth = slipbayes::data::Series::read_csv(&repo("data/ptfe-c1-first.csv")).unwrap();
    for (t, f) in first.series.time_s.iter().zip(&first.series.force_n) {
        let i = truth.time_s.iter().position(|x| x == t).unwrap();
        assert!((f - truth.force_n[i]).abs() <= 1e-15, "{t}: {f}");
    }
    // Interval 3 on its own clock is the repeat slide.
    let mut repeat = mapped(("Interval Time", ""), ("Torque", ""));
    repeat.intervals = IntervalChoice::Numbers(vec![3]);
    let r = import(&path, &repeat).unwrap();
    assert_eq!((r.series.len(), r.series.time_s[0]), (501, 0.0));
    // All intervals with the restarting clock: the error says to map the continuous one.
    let mut all = mapped(("Interval Time", ""), ("Torque", ""));
    all.drop_invalid = true;
    let err = import(&path, &all).unwrap_err().to_string();
    assert!(err.contains("continuous time column"), "{err}");
}

/// Each problem a user's file can have, and where the message must point.
/// CSV tables are read through polars.
#[cfg(feature = "tabular")]
#[test]
fn validation_names_file_line_and_column() {
    let o = options();
    let cases: [(&str, &str, &ImportOptions, &[&str]); 9] = [
        ("", "e.csv", &o, &["e.csv:1:1:", "empty"]),
        (
            "time_s,force_N\n",
            "h.csv",
            &o,
            &["h.csv:1:1:", "no data rows"],
        ),
        (
            "time_s,friction\n0,1\n",
            "m.csv",
            &o,
            &["m.csv:1:1:", "no force or torque column", "`friction`"],
        ),
        (
            "t,F\n0,1\n",
            "u.csv",
            &mapped(("t", "s"), ("F", "")),
            &["u.csv:1:2:", "column `F` has no unit"],
        ),
        (
            "t,F\n0,1\n",
            "k.csv",
            &mapped(("t", "s"), ("F", "lbf")),
            &["k.csv:1:2:", "unknown unit `lbf`"],
        ),
        (
            "time_s,force_N\n0,1\n1,NaN\n",
            "n.csv",
            &o,
            &["n.csv:3:2:", "not a finite number"],
        ),
        (
            "time_s,force_N\n0,1\n\n1,inf\n",
            "i.csv",
            &o,
            &[
                "i.csv:4:2:",
                "inf in column `force_N` (force) is not a finite number",
            ],
        ),
        (
            "time_s,force_N\n0,1\n2,1\n1,1\n",
            "d.csv",
            &o,
            &["d.csv:4:1:", "earlier than", "strictly increase"],
        ),
        (
            "time_s,force_N\n0,1\n1,1\n1,1\n",
            "s.csv",
            &o,
            &["s.csv:4:1:", "equal to"],
        ),
    ];
    for (text, name, options, expected) in cases {
        let message = error(text, name, options);
        for part in expected {
            assert!(
                message.contains(part),
                "{name}: `{part}` not in `{message}`"
            );
        }
    }
    // A unit that is not one of the column's kind.
    let message = error("t,F\n0,1\n", "w.csv", &mapped(("t", "N"), ("F", "N")));
    assert!(message.contains("w.csv:1:1:") && message.contains("not a unit of time"));
}

/// CSV tables are read through polars.
#[cfg(feature = "tabular")]
#[test]
fn dropping_invalid_points_is_explicit_and_counted() {
    let text = "time_s,force_N\n0,1\n1,oops\n2,\n3,1.5\n";
    let message = error(text, "x.csv", &options());
    assert!(message.contains("x.csv:3:2:") && message.contains("`oops`"));
    let o = ImportOptions {
        drop_invalid: true,
        ..options()
    };
    let imported = import_bytes(text.as_bytes(), Path::new("x.csv"), &o).unwrap();
    assert_eq!(imported.points_read, 4);
    assert_eq!(imported.dropped_invalid, 2);
    assert_eq!(imported.series.time_s, [0.0, 3.0]);
    assert_eq!(imported.lines, [2, 5]);
}

fn spec_error(run_extra: &str, velocity: &str) -> String {
    let text = format!(
        "[[material]]\nname = \"m\"\n[[contact]]\nname = \"c\"\nmaterial = \"m\"\n\
         [[run]]\nname = \"r\"\ncontact = \"c\"\ndata = \"{}\"\nvelocity_m_per_s = {velocity}\n\
         scene = \"first\"\n{run_extra}\n",
        repo("data/ptfe-c1-first.csv").display()
    );
    RunFile::parse(&text, Path::new("model.toml"))
        .unwrap_err()
        .to_string()
}

#[test]
fn model_file_errors_name_the_key() {
    let e = spec_error("", "0.0");
    assert!(e.contains("run[0].velocity_m_per_s"), "{e}");
    let e = spec_error("", "-1e-9");
    assert!(e.contains("run[0].velocity_m_per_s"), "{e}");
    let e = spec_error(
        "columns = { time = { name = \"t\" }, force = { name = \"F\", unit = \"kgf\" } }",
        "1e-9",
    );
    assert!(
        e.contains("run[0].columns.force.unit") && e.contains("kgf"),
        "{e}"
    );
    let e = spec_error("moment_arm_m = 0", "1e-9");
    assert!(e.contains("run[0].moment_arm_m"), "{e}");
    // Means of consecutive points are refused, with what to do instead.
    let e = spec_error("bins = 300", "1e-9");
    assert!(
        e.contains("run[0].bins") && e.contains("likelihood_tolerance"),
        "{e}"
    );
    let e = spec_error("likelihood_tolerance = -1", "1e-9");
    assert!(e.contains("run[0].likelihood_tolerance"), "{e}");
    let e = spec_error("interval = 0", "1e-9");
    assert!(e.contains("interval"), "{e}");
}

#[test]
fn fewer_points_than_parameters_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = dir.path().join("short.csv");
    std::fs::write(&data, "time_s,force_N\n0,1\n1,2\n2,3\n3,4\n").unwrap();
    let text = "[[material]]\nname = \"m\"\n[[contact]]\nname = \"c\"\nmaterial = \"m\"\n\
         [[run]]\nname = \"r\"\ncontact = \"c\"\ndata = \"short.csv\"\nvelocity_m_per_s = 1e-9\n\
         scene = \"first\"\n";
    let spec = RunFile::parse(text, &dir.path().join("model.toml")).unwrap();
    let e = spec.posterior().unwrap_err().to_string();
    assert!(e.contains("short.csv") && e.contains("at least 7"), "{e}");
}

#[cfg(feature = "tabular")]
#[test]
fn parquet_through_polars() {
    use polars_core::prelude::*;
    use polars_io::parquet::write::ParquetWriter;
    let mut frame = DataFrame::new(vec![
        Column::new("Time".into(), [0.0, 1.0, 2.0, 3.0]),
        Column::new("Force".into(), [Some(1.5), Some(2.5), None, Some(3.0)]),
    ])
    .unwrap();
    let mut bytes = Vec::new();
    ParquetWriter::new(&mut bytes).finish(&mut frame).unwrap();
    let o = mapped(("Time", "s"), ("Force", "mN"));
    let err = import_bytes(&bytes, Path::new("f.parquet"), &o)
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("f.parquet:3:2:") && err.contains("empty cell"),
        "{err}"
    );
    let o = ImportOptions {
        drop_invalid: true,
        ..o
    };
    let imported = import_bytes(&bytes, Path::new("f.parquet"), &o).unwrap();
    assert_eq!(imported.format, Format::Parquet);
    assert_eq!(imported.dropped_invalid, 1);
    assert!(close(imported.series.force_n[2], 3e-3));
}

#[test]
fn decimal_comma_cells() {
    assert_eq!(Cell::parse("0,25"), Cell::Number(0.25));
    assert_eq!(Cell::parse("1e-3"), Cell::Number(1e-3));
    assert!(matches!(Cell::parse("n/a"), Cell::Text(_)));
}

#[test]
fn io_error_names_the_file() {
    let err = import(Path::new("/nonexistent/run.csv"), &options()).unwrap_err();
    assert!(matches!(err, DataError::Io(_)));
    assert!(err.to_string().contains("/nonexistent/run.csv"));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// What `simulate` writes, `import` reads back bit for bit (through polars when built
    /// with it).
    #[test]
    fn simulated_csv_reads_back_bit_exactly(
        seed in 0u64..1000,
        ln_alpha in 12.0f64..15.0,
        ratio in 0.1f64..2.0,
        f_d in 1e-3f64..5e-2,
        sigma in 1e-6f64..1e-3,
        normal in proptest::option::of(0.01f64..1.0),
    ) {
        let spec = SimulationSpec {
            scene: Scene::First,
            params: LawParams::new(ln_alpha.exp(), ratio * f_d, f_d, 10.0).unwrap(),
            stiffness_n_per_m: Some(1e5),
            law: Default::default(),
            rigid: false,
            velocity_m_per_s: 1e-9,
            duration_s: 5000.0,
            interval_s: 37.0,
            noise_sd_n: sigma,
            seed,
            f_end_n: None,
            after_first_s: None,
            normal_force_n: normal,
            normal_noise_sd_n: 1e-4,
        };
        // Some combinations slip (stick-slip) with this machine; they make no data file.
        let simulated = simulate(&spec);
        prop_assume!(simulated.is_ok());
        let series = simulated.unwrap().series;
        let text = series.to_csv().unwrap();
        let back = import_bytes(text.as_bytes(), Path::new("sim.csv"), &options()).unwrap();
        prop_assert_eq!(back.series.len(), series.len());
        for (a, b) in series.time_s.iter().zip(&back.series.time_s) {
            prop_assert_eq!(a.to_bits(), b.to_bits());
        }
        for (a, b) in series.force_n.iter().zip(&back.series.force_n) {
            prop_assert_eq!(a.to_bits(), b.to_bits());
        }
        match (&series.normal_force_n, &back.series.normal_force_n) {
            (Some(a), Some(b)) => {
                for (x, y) in a.iter().zip(b) {
                    prop_assert_eq!(x.to_bits(), y.to_bits());
                }
            }
            (None, None) => {}
            _ => prop_assert!(false, "normal force column lost or invented"),
        }
    }
}

/// A number that overflows when converted to SI (1e308 min) is an invalid point, not an
/// infinite time.
#[test]
fn overflow_in_conversion_is_invalid() {
    let text = "Interval and data points:\t1\t2\nInterval data:\tTime\tForce\n\t[min]\t[N]\n\
                \t1\t0,5\n\t1e308\t0,5\n";
    let o = ImportOptions {
        format: Some(Format::Rheocompass),
        ..options()
    };
    let message = error(text, "o.txt", &o);
    assert!(
        message.contains("o.txt:5:1:") && message.contains("beyond ±1e100"),
        "{message}"
    );
}

/// A finite but absurd value (1e308 N: its square overflows, and the fit then found no
/// finite start and printed a vector of log-coordinates) is refused where it is written.
#[test]
fn an_absurdly_large_value_is_refused_at_its_line_and_column() {
    let text = "time_s,force_N\n0,1e-3\n10,1e308\n20,1e-3\n";
    let message = error(text, "a.csv", &options());
    assert!(
        message.contains("a.csv:3:2:")
            && message.contains("1e308")
            && message.contains("beyond ±1e100")
            && message.contains("drop_invalid"),
        "{message}"
    );
    // Dropping such points is explicit, and counted, as for text in a numeric cell.
    let o = ImportOptions {
        drop_invalid: true,
        ..options()
    };
    let imported = import_bytes(text.as_bytes(), Path::new("a.csv"), &o).unwrap();
    assert_eq!((imported.points_read, imported.dropped_invalid), (3, 1));
    // The same value in a series handed over in memory.
    let series = slipbayes::data::Series {
        time_s: (0..10).map(f64::from).collect(),
        force_n: (0..10)
            .map(|i| if i == 4 { -1e300 } else { 1e-3 })
            .collect(),
        normal_force_n: None,
    };
    let e = slipbayes::model::data::RunData::from_series(
        series,
        Path::new("m.csv"),
        None,
        Scene::First,
    )
    .unwrap_err()
    .to_string();
    assert!(e.contains("m.csv:6:") && e.contains("-1e300"), "{e}");
}

/// Only RheoCompass exports have intervals: an interval asked of a table is an error naming
/// what the file is, where it used to be ignored and the whole table fitted.
#[test]
fn an_interval_of_a_table_without_intervals_is_refused() {
    let o = ImportOptions {
        intervals: IntervalChoice::Numbers(vec![2]),
        ..options()
    };
    let message = error("time_s,force_N\n0,1\n1,2\n", "t.csv", &o);
    assert!(
        message.contains("t.csv: no interval 2")
            && message.contains("csv table of 2 data rows")
            && message.contains("remove `interval`"),
        "{message}"
    );
}

/// A model file naming an interval the export does not have: the error names the model file,
/// the run, the interval asked and the intervals there are with their points.
#[test]
fn a_missing_interval_names_the_model_run_and_the_intervals_there_are() {
    let text = format!(
        "[[material]]\nname = \"m\"\n[[contact]]\nname = \"c\"\nmaterial = \"m\"\n\
         [[run]]\nname = \"c-repeat\"\ncontact = \"c\"\ndata = \"{}\"\n\
         velocity_m_per_s = 1e-9\nscene = \"first\"\ninterval = 7\n\
         columns = {{ time = {{ name = \"Interval Time\" }}, force = {{ name = \"Torque\" }} }}\n",
        repo("data/rheocompass-ptfe-c1.txt").display()
    );
    let spec = RunFile::parse(&text, Path::new("dir/model.toml")).unwrap();
    let e = spec.posterior().unwrap_err().to_string();
    for part in [
        "dir/model.toml: run `c-repeat`:",
        "rheocompass-ptfe-c1.txt: no interval 7",
        "intervals 1 (300 points), 2 (541 points), 3 (501 points)",
    ] {
        assert!(e.contains(part), "`{part}` not in `{e}`");
    }
}

/// Inputs on which the fuzz targets (fuzz/) once panicked, read with every combination of
/// options (the targets pick them from the first byte): each must give a result or an error.
#[test]
fn fuzz_regressions_do_not_panic() {
    let dir = repo("tests/fuzz-regressions");
    let mut seen = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            // A folder per fuzz target (tests/hostile_inputs.rs replays those).
            continue;
        }
        let data = std::fs::read(&path).unwrap();
        for bytes in [&data[..], &data[1..]] {
            for drop_invalid in [false, true] {
                for intervals in [vec![], vec![1], vec![2], vec![1, 2]] {
                    let o = ImportOptions {
                        format: Some(Format::Rheocompass),
                        drop_invalid,
                        intervals: if intervals.is_empty() {
                            IntervalChoice::All
                        } else {
                            IntervalChoice::Numbers(intervals)
                        },
                        ..options()
                    };
                    let _ = import_bytes(bytes, &path, &o);
                }
            }
        }
        seen += 1;
    }
    assert!(seen >= 1);
}

/// The crash the RheoCompass fuzz target found: a second column header inside an interval.
#[test]
fn second_column_header_in_an_interval_is_an_error() {
    let text = "Interval and data points:\t1\t2\nInterval data:\tTime\n\t[s]\n\t1\n\
                Interval data:\tTime\tTorque\n\t2\t3\n";
    let o = ImportOptions {
        format: Some(Format::Rheocompass),
        ..options()
    };
    let message = error(text, "two.txt", &o);
    assert!(
        message.contains("two.txt:5:1:") && message.contains("second `Interval data:`"),
        "{message}"
    );
}
