//! `slipbayes import`: an instrument file in, our CSV out, and a plain account of what was
//! found and converted. The column-mapping flags are shared with the quick path of `fit`.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;

use slipbayes::data::import::DEFAULT_MOMENT_ARM_M;
use slipbayes::data::{import, Clock, ColumnMap, ColumnRef, Format, ImportOptions, IntervalChoice};
use slipbayes::output_dir::claim_files;

/// How to read an instrument file: format, columns by name and unit, intervals.
#[derive(Debug, Args, Clone)]
pub(super) struct ImportArgs {
    /// Format: csv, parquet, rheocompass, trios or rspace (default: recognised from the
    /// file's content, whatever its name).
    #[arg(long)]
    format: Option<Format>,
    /// Column holding time (default: found by its label in any known language, or its unit:
    /// `time_s`, RheoCompass `Time`/`Temps`/`Zeit`, TRIOS `Time`, rSpace `Time (sequence)`).
    #[arg(long = "time-column", requires = "force_column")]
    time_column: Option<String>,
    /// Unit of the time column: s, min or h (default: from the file).
    #[arg(long = "time-unit", requires = "time_column")]
    time_unit: Option<String>,
    /// Column holding the friction force or torque (default: `force_N`, `Force`, or the torque
    /// by its label or unit: `Torque`, `Couple`, `Drehmoment`, …).
    #[arg(long = "force-column", requires = "time_column")]
    force_column: Option<String>,
    /// Unit of that column: N, mN, µN, N·m, mN·m, µN·m (default: from the file).
    #[arg(long = "force-unit", requires = "force_column")]
    force_unit: Option<String>,
    /// Column holding the normal force (optional).
    #[arg(long = "normal-force-column", requires = "force_column")]
    normal_force_column: Option<String>,
    /// Unit of the normal force column: N, mN or µN.
    #[arg(long = "normal-force-unit", requires = "normal_force_column")]
    normal_force_unit: Option<String>,
    /// Moment arm (m) converting torque to force, F = M / r.
    #[arg(long = "moment-arm-m", default_value_t = DEFAULT_MOMENT_ARM_M)]
    moment_arm_m: f64,
    /// Intervals (RheoCompass), steps (TRIOS) or actions (rSpace) to keep: `all`, a number,
    /// or numbers like 1,2.
    #[arg(long, default_value = "all")]
    interval: IntervalChoice,
    /// Time of an export's points: global (the instrument's continuous time) or step (each
    /// interval's, step's or action's own time, restarting in each).
    #[arg(long, default_value = "global")]
    clock: Clock,
    /// Drop points whose cells are not finite numbers (they are counted) instead of stopping.
    #[arg(long = "drop-invalid")]
    drop_invalid: bool,
}

impl ImportArgs {
    /// The column mapping the flags give, if any.
    pub(super) fn columns(&self) -> Option<ColumnMap> {
        let (time, force) = (self.time_column.as_ref()?, self.force_column.as_ref()?);
        let column = |name: &String, unit: &Option<String>| ColumnRef {
            name: name.clone(),
            unit: unit.clone(),
        };
        Some(ColumnMap {
            time: column(time, &self.time_unit),
            force: column(force, &self.force_unit),
            normal_force: self
                .normal_force_column
                .as_ref()
                .map(|n| column(n, &self.normal_force_unit)),
        })
    }

    pub(super) fn options(&self) -> ImportOptions {
        ImportOptions {
            format: self.format,
            columns: self.columns(),
            moment_arm_m: self.moment_arm_m,
            intervals: self.interval.clone(),
            clock: self.clock,
            drop_invalid: self.drop_invalid,
        }
    }
}

/// Convert an instrument file (CSV, Parquet, or an export of Anton Paar RheoCompass in any
/// language, TA Instruments TRIOS or Malvern rSpace) to slipbayes' CSV
/// (`time_s,force_N[,normal_force_N]`, SI units) and print what was found: vendor, language,
/// encoding and number format, intervals or steps with their points, columns and units.
///
///   slipbayes import data/rheocompass-ptfe-c1.txt --interval 1,2 --drop-invalid --out ptfe.csv
///   slipbayes import trios-export.txt --interval 3 --moment-arm-m 7e-3 --out slide.csv
///   slipbayes import run.csv --time-column t --time-unit min \
///       --force-column torque --force-unit mN·m --moment-arm-m 7e-3 --out run-si.csv
#[derive(Debug, Args)]
#[command(verbatim_doc_comment)]
pub(super) struct ImportCommandArgs {
    /// The instrument file.
    file: PathBuf,
    /// Output CSV.
    #[arg(long)]
    out: PathBuf,
    /// Replace the output CSV if it exists.
    #[arg(long)]
    overwrite: bool,
    #[command(flatten)]
    import: ImportArgs,
}

pub(super) fn run(args: &ImportCommandArgs) -> anyhow::Result<ExitCode> {
    if args.out.exists() && args.out.canonicalize().ok() == args.file.canonicalize().ok() {
        bail!(
            "--out {} is the input file; write the conversion elsewhere",
            args.out.display()
        );
    }
    claim_files(&[&args.out], args.overwrite)?;
    let imported = import(&args.file, &args.import.options())?;
    imported
        .series
        .write_csv(&args.out)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!("{}: {}", args.file.display(), imported.format);
    for line in &imported.found {
        println!("  {line}");
    }
    if imported.conversions.is_empty() {
        println!("  conversions: none (already SI)");
    }
    for c in &imported.conversions {
        println!("  conversion: {c}");
    }
    let s = &imported.series;
    println!(
        "  points: {} read, {} written, {} invalid dropped; time {} s to {} s",
        imported.points_read,
        s.len(),
        imported.dropped_invalid,
        s.time_s[0],
        s.time_s[s.len() - 1]
    );
    println!("wrote {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}
