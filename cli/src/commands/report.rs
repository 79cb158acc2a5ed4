//! `slipbayes report DIR`: rebuild a finished run's report without refitting.

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;

use slipbayes::fit::run_dir::FIGURES_DIR;
use slipbayes::fit::RunDir;
use slipbayes::model::Posterior;
use slipbayes::report::{rebuild_report, write_report, ReportFiles};

/// Rebuild `report.html`, `report.md` and `figures/` of a finished run from its files
/// (summary.json, settings.json, model.toml, predictive.csv, chains/), without refitting.
/// The run's data files must still be where its model says (curves in interface time are
/// redrawn through the model).
#[derive(Debug, Args)]
pub(super) struct ReportArgs {
    /// The run directory (what `fit --out` or `demo` wrote).
    dir: PathBuf,
}

pub(super) fn run(args: &ReportArgs) -> anyhow::Result<ExitCode> {
    let dir = RunDir::new(&args.dir);
    let files = rebuild_report(&dir)
        .with_context(|| format!("writing the report of {}", dir.path().display()))?;
    print_written(&dir, &files);
    Ok(ExitCode::SUCCESS)
}

/// Writes the report of the run in `dir` and says where it is.
pub(super) fn write_and_print(dir: &RunDir, posterior: &Posterior) -> anyhow::Result<()> {
    let files = write_report(dir, posterior)
        .with_context(|| format!("writing the report of {}", dir.path().display()))?;
    print_written(dir, &files);
    Ok(())
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
