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
use slipbayes::fit::{FitSummary, RunDir};

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
    /// Also write a report into this directory: compare.html and compare.md with the table
    /// and, run by run, the fits overlaid on the data (figures/compare-RUN.svg).
    #[cfg(feature = "report")]
    #[arg(long)]
    report: Option<PathBuf>,
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
    /// Its forward model, as the model file names it.
    law: String,
    points: Vec<Observed>,
    loo: Loo,
}

/// Which observation a pointwise value belongs to.
struct Observed {
    run: String,
    point: usize,
    observed_n: f64,
}

impl Observed {
    fn of(run: String, point: usize, observed_n: f64) -> Self {
        Self {
            run,
            point,
            observed_n,
        }
    }
}

pub(super) fn run(args: &CompareArgs) -> anyhow::Result<ExitCode> {
    let dirs: Vec<RunDir> = args.dirs.iter().map(RunDir::new).collect();
    let summaries = dirs
        .iter()
        .map(RunDir::read_summary)
        .collect::<Result<Vec<_>, _>>()?;
    let criterion = criterion(&summaries, args.loo);
    let fits = dirs
        .iter()
        .zip(summaries)
        .map(|(dir, summary)| match criterion {
            Criterion::Loo => read_loo(dir, summary),
            Criterion::KFold(_) => read_kfold(dir, summary),
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    same_data(&fits)?;
    let named: Vec<(&str, &Loo)> = fits.iter().map(|f| (f.name.as_str(), &f.loo)).collect();
    let table = compare(&named)?;
    let ranking = Ranking::new(&table, &fits, criterion);
    let text = ranking.markdown();
    print!("{text}");
    if let Some(path) = &args.out {
        write_atomically(path, text.as_bytes())
            .with_context(|| format!("writing {}", path.display()))?;
        println!("written to {}", path.display());
    }
    #[cfg(feature = "report")]
    if let Some(out) = &args.report {
        // Best first: the figures measure every fit against the best one.
        let named_dirs: Vec<(String, RunDir)> = table
            .iter()
            .map(|row| {
                let i = fits
                    .iter()
                    .position(|f| f.name == row.name)
                    .expect("a fit per row");
                (row.name.clone(), dirs[i].clone())
            })
            .collect();
        let files = slipbayes::report::write_comparison(out, ranking.blocks(), &named_dirs)?;
        println!(
            "report: {} and {} ({} figures)",
            files.html.display(),
            files.markdown.display(),
            files.figures.len()
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// K-fold where every fit has it with the same number of folds (and not `--loo`), else LOO.
fn criterion(summaries: &[FitSummary], force_loo: bool) -> Criterion {
    let folds: Vec<Option<usize>> = summaries
        .iter()
        .map(|s| s.kfold.as_ref().map(|k| k.folds))
        .collect();
    match folds[..] {
        [Some(k), ..] if !force_loo && folds.iter().all(|f| *f == Some(k)) => Criterion::KFold(k),
        _ => Criterion::Loo,
    }
}

fn read_kfold(dir: &RunDir, summary: FitSummary) -> anyhow::Result<Fitted> {
    let shown = dir.path().display();
    let kfold = summary
        .kfold
        .with_context(|| format!("{shown} has no K-fold result; run slipbayes kfold {shown}"))?;
    let points = dir.read_kfold()?;
    Ok(Fitted {
        name: shown.to_string(),
        law: forward_model(dir)?,
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
            .map(|p| Observed::of(p.run, p.point, p.observed_n))
            .collect(),
    })
}

/// The forward model the fit in `dir` used, from its `model.toml`.
fn forward_model(dir: &RunDir) -> anyhow::Result<String> {
    let run_file = dir
        .read_model()
        .with_context(|| format!("reading the model of {}", dir.path().display()))?;
    Ok(run_file.model.forward().to_string())
}

fn read_loo(dir: &RunDir, summary: FitSummary) -> anyhow::Result<Fitted> {
    let shown = dir.path().display();
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
        law: forward_model(dir)?,
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
            .map(|p| Observed::of(p.run, p.point, p.observed_n))
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

/// The ranking as a table (header and cells), the sentences under it, and the criterion's
/// introduction (K-fold only).
struct Ranking {
    intro: Option<String>,
    header: Vec<String>,
    rows: Vec<Vec<String>>,
    sentences: Vec<String>,
}

impl Ranking {
    fn new(table: &[Compared], fits: &[Fitted], criterion: Criterion) -> Self {
        let (intro, names) = match criterion {
            Criterion::Loo => (None, ["elpd_loo", "p_loo"]),
            Criterion::KFold(k) => (
                Some(format!(
                    "Ranked by K-fold cross-validation by time blocks ({k} folds; slipbayes kfold)."
                )),
                ["elpd_kfold", "p_kfold"],
            ),
        };
        let mut header: Vec<String> = ["rank", "model", "law", names[0], "se", names[1]]
            .into_iter()
            .chain(["elpd_diff", "dse", "weight"])
            .map(String::from)
            .collect();
        if criterion == Criterion::Loo {
            header.push("points with k̂ > good k̂".into());
        }
        let rows = table
            .iter()
            .map(|row| {
                let fit = fits
                    .iter()
                    .find(|f| f.name == row.name)
                    .expect("a fit per row");
                let mut cells = vec![
                    row.rank.to_string(),
                    row.name.clone(),
                    fit.law.clone(),
                    format!("{:.2}", row.elpd),
                    format!("{:.2}", row.se),
                    format!("{:.2}", row.p_loo),
                    format!("{:.2}", row.elpd_diff),
                    format!("{:.2}", row.dse),
                    format!("{:.3}", row.weight),
                ];
                if criterion == Criterion::Loo {
                    cells.push(format!(
                        "{} of {} (k̂ > {:.2})",
                        fit.loo.unreliable_points().len(),
                        fit.loo.pointwise.len(),
                        fit.loo.good_k
                    ));
                }
                cells
            })
            .collect();
        let best = &table[0];
        let mut sentences: Vec<String> = table[1..]
            .iter()
            .map(|row| {
                let verdict = if row.elpd_diff > 2.0 * row.dse {
                    format!("{} predicts worse than {}", row.name, best.name)
                } else {
                    format!(
                        "{} and {} predict equally well within 2 standard errors",
                        row.name, best.name
                    )
                };
                format!(
                    "{verdict}: elpd_diff {:.2} ± {:.2}.",
                    row.elpd_diff, row.dse
                )
            })
            .collect();
        if table.iter().any(|row| row.warning) {
            sentences.push(
                "Some points have Pareto k̂ above the good k̂: their leave-one-out estimates are \
                 unreliable, and so are differences that rest on them. Cross-validate each fit \
                 by refitting without blocks of its points (`slipbayes kfold DIR` for every \
                 DIR), then compare again: the fits are then ranked by elpd_kfold."
                    .into(),
            );
        }
        Self {
            intro,
            header,
            rows,
            sentences,
        }
    }

    fn markdown(&self) -> String {
        let mut text = self
            .intro
            .as_ref()
            .map_or(String::new(), |intro| format!("{intro}\n\n"));
        let _ = writeln!(text, "| {} |", self.header.join(" | "));
        let align: Vec<&str> = (0..self.header.len())
            .map(|i| if i == 1 || i == 2 { "---" } else { "---:" })
            .collect();
        let _ = writeln!(text, "|{}|", align.join("|"));
        for row in &self.rows {
            let _ = writeln!(text, "| {} |", row.join(" | "));
        }
        for sentence in &self.sentences {
            let _ = writeln!(text, "\n{sentence}");
        }
        text
    }

    #[cfg(feature = "report")]
    fn blocks(&self) -> Vec<slipbayes::report::Block> {
        use slipbayes::report::Block;
        let mut blocks: Vec<Block> = self.intro.iter().cloned().map(Block::Paragraph).collect();
        blocks.push(Block::Table {
            header: self.header.clone(),
            rows: self.rows.clone(),
            flagged: vec![false; self.rows.len()],
        });
        blocks.extend(self.sentences.iter().cloned().map(Block::Paragraph));
        blocks
    }
}
