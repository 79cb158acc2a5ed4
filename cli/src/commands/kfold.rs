//! `slipbayes kfold DIR`: K-fold cross-validation by time blocks of a finished fit, the
//! fallback where its PSIS-LOO is unreliable (points with Pareto k̂ above the good k̂).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use clap::Args;

use slipbayes::fit::kfold::{kfold, Folds, DEFAULT_BLOCKS_PER_FOLD, DEFAULT_FOLDS};
use slipbayes::fit::{FitError, RunDir};

use crate::interrupt::{self, EXIT_INTERRUPTED};
use crate::progress::{ProgressBarObserver, DEFAULT_LINE_EVERY};
use slipbayes::fit::RunLock;

/// Cross-validate a finished fit (a `fit --out` directory) by blocks of time: each run's
/// record is cut into FOLDS × BLOCKS contiguous blocks, dealt to the folds in turn; fold j
/// leaves out its blocks of every run and is fitted with the fit's own settings (into
/// DIR/kfold/fold-j); every left-out point is scored by its log predictive density under the
/// fold that did not see it. Writes DIR/kfold.csv and
/// the `kfold` section of DIR/summary.json; `slipbayes compare` then ranks fits by it.
/// Use it where PSIS-LOO flags points with Pareto k̂ above the good k̂. It costs FOLDS fits;
/// an interrupted run continues with --resume (finished folds are kept).
#[derive(Debug, Args)]
#[command(verbatim_doc_comment)]
pub(super) struct KFoldArgs {
    /// The run directory of the fit.
    dir: PathBuf,
    /// Blocks of time per run (each fold must keep at least 7 points of every run).
    #[arg(long, default_value_t = DEFAULT_FOLDS)]
    folds: usize,
    /// Blocks of time each fold leaves out of each run, spread over the record (1: one
    /// stretch of a FOLDSth of it).
    #[arg(long = "blocks-per-fold", default_value_t = DEFAULT_BLOCKS_PER_FOLD)]
    blocks_per_fold: usize,
    /// Keep the folds already fitted and continue an interrupted one.
    #[arg(long)]
    resume: bool,
    /// No progress output.
    #[arg(long)]
    quiet: bool,
}

pub(super) fn run(args: &KFoldArgs) -> anyhow::Result<ExitCode> {
    let dir = RunDir::new(&args.dir);
    let shown = args.dir.display();
    let run_file = dir
        .read_model()
        .with_context(|| format!("reading the fit in {shown}"))?;
    let mut summary = dir.read_summary()?;
    let mut settings = dir.read_record()?.settings;
    settings.quiet = args.quiet;
    let posterior = run_file.posterior()?;
    let _lock = RunLock::acquire(&args.dir)?;
    interrupt::install();
    let mut observer =
        ProgressBarObserver::new(args.quiet, DEFAULT_LINE_EVERY).stop_when(&interrupt::INTERRUPTED);
    // The full fit's log predictive density of its own data, elpd_loo + p_loo.
    let lpd = summary.loo.as_ref().map(|l| l.elpd_loo + l.p_loo);
    let result = match kfold(
        &posterior,
        Folds {
            folds: args.folds,
            blocks_per_fold: args.blocks_per_fold,
        },
        &settings,
        &dir,
        args.resume,
        lpd,
        &mut observer,
    ) {
        Err(FitError::Interrupted { dir: fold, step }) => {
            eprintln!(
                "interrupted at step {step} of the fold in {}; its checkpoint is written. \
                 Continue with:\n  slipbayes kfold {shown} --folds {} --blocks-per-fold {} --resume",
                fold.display(),
                args.folds,
                args.blocks_per_fold
            );
            return Ok(ExitCode::from(EXIT_INTERRUPTED));
        }
        result => result?,
    };
    dir.write_kfold(&result.points)?;
    let k = &result.summary;
    println!(
        "K-fold by time blocks ({} folds, {} draws each): elpd_kfold {:.2} ± {:.2}{}",
        k.folds,
        k.draws,
        k.elpd_kfold,
        k.se,
        k.p_kfold
            .map_or(String::new(), |p| format!(", p_kfold {p:.2}"))
    );
    if let Some(loo) = &summary.loo {
        println!(
            "PSIS-LOO of the same fit: elpd_loo {:.2} ± {:.2} ({} points with k̂ > {:.2})",
            loo.elpd_loo, loo.se, loo.unreliable_points, loo.good_k
        );
    }
    if !k.unconverged_folds.is_empty() {
        eprintln!(
            "warning: folds {:?} did not meet the convergence standard; their scores are less \
             certain (see DIR/kfold/fold-J/summary.json)",
            k.unconverged_folds
        );
    }
    summary.kfold = Some(result.summary);
    dir.write_summary(&summary)?;
    println!("written to {shown} (kfold.csv, summary.json)");
    Ok(ExitCode::SUCCESS)
}
