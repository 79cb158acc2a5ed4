//! `slipbayes report DIR`: rebuild a finished run's report without refitting.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;

use slipbayes::fit::run_dir::{CHAINS_DIR, FIGURES_DIR, RUN_OUTPUT, SETTINGS_JSON};
use slipbayes::fit::RunDir;
use slipbayes::output_dir::{OutputDir, Ownership, MARKER};
use slipbayes::report::{write_report, ReportFiles};
use slipbayes::storage::{verify_run, Integrity};

/// Rebuild `report.html`, `report.md` and `figures/` of a finished run from its files
/// (summary.json, settings.json, model.toml, predictive.csv, curves.json, truth.json,
/// chains/) and nothing else, without refitting: the directory may be moved or copied to
/// another machine, without the run's data files.
#[derive(Debug, Args)]
pub(super) struct ReportArgs {
    /// The run directory (what `fit --out` or `demo` wrote).
    dir: PathBuf,
}

pub(super) fn run(args: &ReportArgs) -> anyhow::Result<ExitCode> {
    let dir = RunDir::new(&args.dir);
    if let Ownership::Foreign { marked_as, .. } = OutputDir::ownership(dir.path(), &RUN_OUTPUT)? {
        bail!(
            "{} is not a run directory slipbayes wrote ({}): `report` writes report.html, \
             report.md and figures/ only into the --out of a fit",
            dir.path().display(),
            match marked_as {
                Some(kind) => format!("its {MARKER} marks it as a slipbayes {kind} directory"),
                None => format!(
                    "it has no {MARKER} marker, and no checkpoint, chains or run record of a fit"
                ),
            }
        );
    }
    if let Some(problem) = missing_chains(&dir) {
        bail!("{problem}");
    }
    // A corrupted file is refused by the readers; a run that cannot be verified is said to be.
    if let Ok(Integrity::Unverified { reason }) = verify_run(&dir.chain_files()) {
        eprintln!("note: {reason}; the run's files are read unverified");
    }
    write_and_print(&dir)?;
    Ok(ExitCode::SUCCESS)
}

/// Writes the report of the run in `dir` and says where it is.
pub(super) fn write_and_print(dir: &RunDir) -> anyhow::Result<()> {
    let files = write_report(dir)
        .with_context(|| format!("writing the report of {}", dir.path().display()))?;
    print_written(dir, &files);
    Ok(())
}

/// A finished run (its `settings.json` is written last) whose chains are gone, as in a fresh
/// clone of the repository, where chains are not committed: what is missing and the command
/// that wrote them.
fn missing_chains(dir: &RunDir) -> Option<String> {
    let chains = dir.file(CHAINS_DIR);
    let has_parts = std::fs::read_dir(&chains).is_ok_and(|entries| {
        entries
            .flatten()
            .any(|e| e.path().extension().is_some_and(|x| x == "parquet"))
    });
    if has_parts || !dir.file(SETTINGS_JSON).exists() {
        return None;
    }
    let command = dir
        .read_record()
        .ok()
        .filter(|r| !r.command.is_empty())
        .map_or_else(
            || "the fit that wrote it".to_owned(),
            |r| {
                // A `demo` recorded without --out wrote to the default of its day
                // (`reports/demo` before it became `runs/demo`): name the directory.
                let mut command = r.command;
                if !command
                    .iter()
                    .any(|a| a == "--out" || a.starts_with("--out="))
                {
                    command.extend(["--out".to_owned(), dir.path().display().to_string()]);
                }
                format!("`{}`", command.join(" "))
            },
        );
    Some(format!(
        "the chains of {} are missing ({} holds no Parquet files; chains are not kept in git): \
         regenerate them by running {command} again, then rerun `slipbayes report {}`",
        dir.path().display(),
        chains.display(),
        dir.path().display()
    ))
}

fn print_written(dir: &RunDir, files: &ReportFiles) {
    println!(
        "report: {} and {} ({} figures in {})",
        files.html.display(),
        files.markdown.display(),
        files.figures.len(),
        dir.file(FIGURES_DIR).display()
    );
}
