//! `slipbayes compare DIR DIR...`: rank finished fits of the same data by their leave-one-out
//! predictive accuracy (PSIS-LOO, or K-fold by time blocks where every fit has it), with elpd
//! differences, their standard errors and stacking weights, as ArviZ's `compare`.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{bail, Context};
use clap::Args;

use slipbayes::data::write_atomically;
use slipbayes::diagnostics::{compare, Compared, Loo};
use slipbayes::fit::RunDir;

/// Compare finished fits of the same data (each `fit --out` directory) by PSIS-LOO: the best
/// first, how much lower each other model's elpd_loo is (elpd_diff) with the standard error of
/// that difference (dse), and stacking weights. A difference within about 2 dse is no evidence
/// that one model predicts the data better than the other. When every fit has been
/// cross-validated (`slipbayes kfold DIR`, the same folds for each), the fits are ranked by
/// elpd_kfold instead, unless --loo.
#[derive(Debug, Args)]
pub(super) struct CompareArgs {
    /// The run directories (at least two), fitted to the same observations.
    #[arg(required = true, num_args = 2..)]
    dirs: Vec<PathBuf>,
    /// Also write the table as Markdown to this file.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Rank by PSIS-LOO even where every fit has K-fold results.
    #[arg(long)]
    loo: bool,
}

/// What the fits are ranked by.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Criterion {
    Loo,
    /// K-fold cross-validation with this many folds.
    KFold(usize),
}

/// One fit's predictive accuracy, read back from its run directory: `loo` holds either its
/// PSIS-LOO or its K-fold values (whose points carry no Pareto k̂).
struct Fitted {
    name: String,
    points: Vec<Observed>,
    loo: Loo,
}

/// Which observation a pointwise value belongs to.
struct Observed {
    run: String,
    point: usize,
    observed_n: f64,
}

pub(super) fn run(args: &CompareArgs) -> anyhow::Result<ExitCode> {
    let dirs: Vec<RunDir> = args.dirs.iter().map(RunDir::new).collect();
    let criterion = criterion(&dirs, args.loo)?;
    let fits = dirs
        .iter()
        .map(|dir| match criterion {
            Criterion::Loo => read_loo(dir),
            Criterion::KFold(_) => read_kfold(dir),
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    same_data(&fits)?;
    let named: Vec<(&str, &Loo)> = fits.iter().map(|f| (f.name.as_str(), &f.loo)).collect();
    let table = compare(&named)?;
    let text = markdown(&table, &fits, criterion);
    print!("{text}");
    if let Some(path) = &args.out {
        write_atomically(path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        println!("written to {}", path.display());
    }
    Ok(ExitCode::SUCCESS)
}

/// K-fold where every fit has it with the same number of folds (and not `--loo`), else LOO.
fn criterion(dirs: &[RunDir], force_loo: bool) -> anyhow::Result<Criterion> {
    if force_loo {
        return Ok(Criterion::Loo);
    }
    let folds = dirs
        .iter()
        .map(|dir| Ok(dir.read_summary()?.kfold.map(|k| k.folds)))
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(match folds[..] {
        [Some(k), ..] if folds.iter().all(|f| *f == Some(k)) => Criterion::KFold(k),
        _ => Criterion::Loo,
    })
}

fn read_kfold(dir: &RunDir) -> anyhow::Result<Fitted> {
    let shown = dir.path().display();
    let kfold = dir
        .read_summary()?
        .kfold
        .with_context(|| format!("{shown} has no K-fold result; run slipbayes kfold {shown}"))?;
    let points = dir.read_kfold()?;
    Ok(Fitted {
        name: shown.to_string(),
        loo: Loo {
            elpd: kfold.elpd_kfold,
            se: kfold.se,
            p_loo: kfold.p_kfold.unwrap_or(f64::NAN),
            pointwise: points.iter().map(|p| p.elpd_kfold).collect(),
            // Refits, not importance sampling: no point's value rests on a Pareto tail.
            pareto_k: Vec::new(),
            good_k: f64::INFINITY,
            draws: kfold.draws,
        },
        points: points
            .into_iter()
            .map(|p| Observed {
                run: p.run,
                point: p.point,
                observed_n: p.observed_n,
            })
            .collect(),
    })
}

fn read_loo(dir: &RunDir) -> anyhow::Result<Fitted> {
    let shown = dir.path().display();
    let summary = dir.read_summary()?;
    let Some(loo) = summary.loo else {
        let why = summary.loo_not_computed.unwrap_or_else(|| {
            "it was fitted by an earlier release; fit it again to compute it".to_owned()
        });
        bail!("{shown} has no leave-one-out result: {why}");
    };
    let points = dir.read_loo()?;
    let draws = loo.draws;
    Ok(Fitted {
        name: shown.to_string(),
        loo: Loo {
            elpd: loo.elpd_loo,
            se: loo.se,
            p_loo: loo.p_loo,
            pointwise: points.iter().map(|p| p.elpd_loo).collect(),
            pareto_k: points.iter().map(|p| p.pareto_k).collect(),
            good_k: loo.good_k,
            draws,
        },
        points: points
            .into_iter()
            .map(|p| Observed {
                run: p.run,
                point: p.point,
                observed_n: p.observed_n,
            })
            .collect(),
    })
}

/// Refuses fits whose observations differ: LOO values of different data do not compare.
fn same_data(fits: &[Fitted]) -> anyhow::Result<()> {
    let first = &fits[0];
    for other in &fits[1..] {
        if other.points.len() != first.points.len() {
            bail!(
                "{} has {} observations but {} has {}: models are compared on the same data",
                other.name,
                other.points.len(),
                first.name,
                first.points.len()
            );
        }
        let differs = first.points.iter().zip(&other.points).find(|(a, b)| {
            a.run != b.run || a.point != b.point || a.observed_n.to_bits() != b.observed_n.to_bits()
        });
        if let Some((a, b)) = differs {
            bail!(
                "{} and {} were fitted to different data: run {:?} point {} observed {:?} N \
                 against run {:?} point {} observed {:?} N; compare fits of the same runs",
                first.name,
                other.name,
                a.run,
                a.point,
                a.observed_n,
                b.run,
                b.point,
                b.observed_n
            );
        }
    }
    Ok(())
}

fn markdown(table: &[Compared], fits: &[Fitted], criterion: Criterion) -> String {
    let mut text = match criterion {
        Criterion::Loo => String::from(
            "| rank | model | elpd_loo | se | p_loo | elpd_diff | dse | weight | points with k̂ > good k̂ |\n\
             |---:|---|---:|---:|---:|---:|---:|---:|---:|\n",
        ),
        Criterion::KFold(k) => format!(
            "Ranked by K-fold cross-validation by time blocks ({k} folds; slipbayes kfold).\n\n\
             | rank | model | elpd_kfold | se | p_kfold | elpd_diff | dse | weight |\n\
             |---:|---|---:|---:|---:|---:|---:|---:|\n"
        ),
    };
    for row in table {
        let fit = fits
            .iter()
            .find(|f| f.name == row.name)
            .expect("a fit per row");
        if let Criterion::KFold(_) = criterion {
            let _ = writeln!(
                text,
                "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} |",
                row.rank, row.name, row.elpd, row.se, row.p_loo, row.elpd_diff, row.dse, row.weight
            );
            continue;
        }
        let _ = writeln!(
            text,
            "| {} | {} | {:.2} | {:.2} | {:.2} | {:.2} | {:.2} | {:.3} | {} of {} (k̂ > {:.2}) |",
            row.rank,
            row.name,
            row.elpd,
            row.se,
            row.p_loo,
            row.elpd_diff,
            row.dse,
            row.weight,
            fit.loo.unreliable_points().len(),
            fit.loo.pointwise.len(),
            fit.loo.good_k
        );
    }
    let best = &table[0];
    for row in &table[1..] {
        let verdict = if row.elpd_diff > 2.0 * row.dse {
            format!("{} predicts worse than {}", row.name, best.name)
        } else {
            format!(
                "{} and {} predict equally well within 2 standard errors",
                row.name, best.name
            )
        };
        let _ = writeln!(
            text,
            "\n{verdict}: elpd_diff {:.2} ± {:.2}.",
            row.elpd_diff, row.dse
        );
    }
    if table.iter().any(|row| row.warning) {
        text.push_str(
            "\nSome points have Pareto k̂ above the good k̂: their leave-one-out estimates are \
             unreliable, and so are differences that rest on them. Cross-validate each fit by \
             refitting without blocks of its points (`slipbayes kfold DIR` for every DIR), \
             then compare again: the fits are then ranked by elpd_kfold.\n",
        );
    }
    text
}
