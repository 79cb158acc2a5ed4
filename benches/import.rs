//! Import of a 10⁶-point instrument export against reading the same numbers from a plain CSV,
//! measured in the same run (issue 21's target: an export takes at most twice as long).
//!
//! Writes, under `target/import-bench/`, one slide of 10⁶ points as
//! - a plain CSV `time_s,force_N,normal_force_N` (the baseline),
//! - an Anton Paar RheoCompass export as a European computer writes it (UTF-16LE with BOM,
//!   CRLF, tabs, decimal commas, eight columns with a status text: the bundled example's
//!   layout),
//! - a TA Instruments TRIOS text export (ten columns of a flow step),
//! - a Malvern rSpace CSV (semicolons, decimal commas, the 17 columns of a real export),
//!
//! all holding the same digits for time, torque (force in the plain CSV) and normal force.
//! Then it times `slipbayes::data::import` on each, and slipbayes' dependency-free reader of
//! its own CSV (`Series::read_csv`) as a second baseline, and prints and writes
//! `reports/import-speed.md` with the ratios.
//!
//! Not criterion: criterion measures one benchmark after the other, and on a shared machine
//! load that changes between them biases a ratio of their times; here every round times all
//! readers back to back and the ratio is taken within each round.
//!
//! Run: `cargo bench --bench import` (about a minute on 2 idle cores).

use std::fmt::Write as _;
use std::hint::black_box;
use std::path::{Path, PathBuf};

use std::time::Instant;

use slipbayes::data::{import, ImportOptions, Series};

const POINTS: usize = 1_000_000;

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("target/import-bench")
}

/// A slide: time (s), torque-or-force, normal force, as Rust's shortest round-trip digits.
fn numbers() -> Vec<[String; 3]> {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut noise = move || {
        // splitmix64: deterministic noise without a dependency.
        state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    (0..POINTS)
        .map(|i| {
            let t = 0.1 * i as f64;
            let force = 0.01 * (1.0 - (-t / 3000.0).exp()) + 1e-5 * noise();
            let normal = 0.05 + 1e-4 * noise();
            [
                format!("{t:?}"),
                format!("{force:?}"),
                format!("{normal:?}"),
            ]
        })
        .collect()
}

fn comma(s: &str) -> String {
    s.replace('.', ",")
}

fn write_files(numbers: &[[String; 3]]) -> Vec<(&'static str, PathBuf)> {
    let dir = dir();
    std::fs::create_dir_all(&dir).expect("create target/import-bench");
    let mut plain = String::from("time_s,force_N,normal_force_N\n");
    for [t, f, n] in numbers {
        let _ = writeln!(plain, "{t},{f},{n}");
    }
    let mut rheocompass = String::from(
        "Project:\tbench\r\nTest:\tslide\r\nResult:\tslide 1\r\n\r\n\
         Interval and data points:\t1\t1000000\r\n\
         Interval data:\tPoint No.\tTime\tInterval Time\tTorque\tDeflection Angle\tSpeed\t\
         Normal Force\tStatus\r\n\t\t[s]\t[s]\t[µN·m]\t[mrad]\t[1/min]\t[N]\t\r\n",
    );
    for (i, [t, f, n]) in numbers.iter().enumerate() {
        let _ = write!(
            rheocompass,
            "\t{}\t{}\t{}\t{}\t0,0301343838948477\t1,3641852265019602e-06\t{}\tDy_auto, M_Ok\r\n",
            i + 1,
            comma(t),
            comma(t),
            comma(f),
            comma(n)
        );
    }
    let mut utf16 = vec![0xFF, 0xFE];
    for unit in rheocompass.encode_utf16() {
        utf16.extend_from_slice(&unit.to_le_bytes());
    }
    let mut trios = String::from(
        "Filename\tbench\nInstrument name\t5332-XXXX\n[File Parameters]\nTrios version\t5.1\n\
         [step]\nFlow ramp - 1\nTorque\tVelocity\tStep time\tTemperature\tAxial force\tGap\t\
         Displacement\tRun time\tTime\tStress\nµN.m\trad/s\ts\t°C\tN\tµm\trad\tmin\ts\tMPa\n",
    );
    for [t, f, n] in numbers {
        let _ = writeln!(
            trios,
            "{f}\t0.000685095496010035\t{t}\t44.9870147705078\t{n}\t1000.04684645683\t\
             0.00012111352407\t2.17524744669596\t{t}\t0.0005"
        );
    }
    let mut rspace = String::from(
        "Action Name;Time (sequence)(s);Time (action)(s);Shear stress(Pa);Shear rate(s-¹);\
         Shear strain(%);Normal force(N);Complex shear strain(%);Frequency(Hz);\
         Complex shear stress(Pa);Shear modulus (elastic component)(Pa);\
         Shear modulus (viscous component)(Pa);Shear modulus (complex component)(Pa);\
         Torque(N m);Angular displacement(rad);Temperature(°C);Gap(mm)\n",
    );
    for [t, f, n] in numbers {
        let _ = writeln!(
            rspace,
            "Slide;{};{};30,54;47,57;4,75275E+003;{};;;;;;;{};4,516;20,93;9,1500",
            comma(t),
            comma(t),
            comma(n),
            comma(f)
        );
    }
    let files = [
        ("plain CSV", "plain.csv", plain.into_bytes()),
        ("RheoCompass UTF-16LE", "rheocompass.txt", utf16),
        ("TRIOS text", "trios.txt", trios.into_bytes()),
        ("rSpace CSV", "rspace.csv", rspace.into_bytes()),
    ];
    files
        .into_iter()
        .map(|(name, file, bytes)| {
            let path = dir.join(file);
            std::fs::write(&path, bytes).expect("write a benchmark file");
            (name, path)
        })
        .collect()
}

/// The median of some durations (s).
fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Today's date (UTC) from the system clock, `YYYY-MM-DD`.
fn today() -> String {
    let days = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs() / 86_400) as i64;
    // Civil date from days since 1970-01-01 (H. Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!("{year:04}-{month:02}-{day:02}")
}

fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .and_then(|l| l.split_whitespace().next().map(str::to_owned))
        .unwrap_or_else(|| "unknown".into())
}

/// Rounds of measurements; each round times every reader once, in an order that rotates.
const ROUNDS: usize = 9;

fn main() {
    let numbers = numbers();
    let files = write_files(&numbers);
    drop(numbers);
    let options = ImportOptions::default();
    for (name, path) in &files {
        let imported = import(path, &options).expect("the benchmark file imports");
        assert_eq!(imported.series.len(), POINTS, "{name}");
    }
    let plain = files[0].1.clone();
    // Readers: `import` of each file, and the dependency-free reader of the plain CSV.
    let mut readers: Vec<(String, PathBuf, bool)> = files
        .iter()
        .map(|(name, path)| ((*name).to_owned(), path.clone(), false))
        .collect();
    readers.push(("plain CSV, `Series::read_csv`".into(), plain.clone(), true));
    let load_before = load_average();
    let mut seconds = vec![Vec::new(); readers.len()];
    for round in 0..ROUNDS {
        for k in 0..readers.len() {
            let r = (k + round) % readers.len();
            let (_, path, minimal) = &readers[r];
            let start = Instant::now();
            if *minimal {
                black_box(Series::read_csv(black_box(path)).expect("reads"));
            } else {
                black_box(import(black_box(path), &options).expect("imports"));
            }
            seconds[r].push(start.elapsed().as_secs_f64());
        }
    }
    let load_after = load_average();
    // Ratios within each round (the readers ran seconds apart), then their median.
    let ratio = |r: usize, base: usize| {
        median(
            seconds[r]
                .iter()
                .zip(&seconds[base])
                .map(|(a, b)| a / b)
                .collect(),
        )
    };
    let minimal = readers.len() - 1;
    let mut report = format!(
        "# Import speed: 10⁶-point exports against a plain CSV\n\n\
         `cargo bench --bench import` (benches/import.rs), run on {} on the 2-core AMD EPYC \
         (Zen 4) VM; load average {} before and {} after (other builds running beside it when \
         above 2). Each file is one slide of 10⁶ points holding the same digits for time, \
         torque (force in the plain CSV) and normal force; `import` reads it from disk (page \
         cache), recognises the format, parses and converts to SI. {ROUNDS} rounds, each \
         timing every reader once in a rotating order; a ratio is the median over rounds of \
         the two readers' times in the same round, so that load changing during the run \
         cancels out. Issue 21's target: an export at most 2× the plain CSV.\n\n\
         | file | size (MB) | median (ms) | ÷ plain CSV through `import` | ÷ minimal CSV reader |\n\
         |---|---|---|---|---|\n",
        today(),
        load_before,
        load_after
    );
    for (r, (name, path, _)) in readers.iter().enumerate() {
        let size = std::fs::metadata(path).map_or(0.0, |m| m.len() as f64 / 1e6);
        let _ = writeln!(
            report,
            "| {name} | {size:.0} | {:.0} | {:.2} | {:.2} |",
            median(seconds[r].clone()) * 1e3,
            ratio(r, 0),
            ratio(r, minimal)
        );
    }
    report.push_str(
        "\nThe plain CSV goes through `import` as any user file does (polars' CSV reader, cells \
         as text, each parsed by slipbayes); the minimal reader is slipbayes' own parser of \
         the `time_s,force_N,normal_force_N` format, which accepts nothing else.\n",
    );
    println!("{report}");
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("reports/import-speed.md");
    if let Err(e) = std::fs::write(&out, &report) {
        eprintln!("could not write {}: {e}", out.display());
    }
}
