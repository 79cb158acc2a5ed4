//! The report of `slipbayes compare`: the ranking of fits of the same data (built by the
//! caller) followed, run by run, by the fits overlaid on the data with their residuals.

use std::path::Path;

use super::document::{render_html, render_markdown, Block};
use super::plots::overlay_figure;
use super::{write_figures, ReportError, ReportFiles};
use crate::fit::RunDir;

/// The comparison report's Markdown file.
pub(crate) const COMPARE_MD: &str = "compare.md";
/// The comparison report's HTML file.
pub(crate) const COMPARE_HTML: &str = "compare.html";

/// Writes `compare.md`, `compare.html` and `figures/compare-<run>.svg` into `out`: `ranking`
/// (the table and verdicts), then one figure per run with every fit of `fits` (name, run
/// directory) overlaid on its data, from each fit's `predictive.csv`.
///
/// # Errors
/// [`ReportError::RunDir`] when a fit's `predictive.csv` cannot be read or a file cannot be
/// written; [`ReportError::Mismatch`] when the fits' runs differ.
pub fn write_comparison(
    out: &Path,
    ranking: Vec<Block>,
    fits: &[(String, RunDir)],
) -> Result<ReportFiles, ReportError> {
    let bands = fits
        .iter()
        .map(|(_, dir)| dir.read_predictive())
        .collect::<Result<Vec<_>, _>>()?;
    let mut blocks = ranking;
    blocks.push(Block::Heading {
        level: 1,
        id: "overlaid".into(),
        text: "The fits overlaid on the data".into(),
    });
    let first = &bands[0];
    for (i, run) in first.iter().enumerate() {
        let mut overlaid = Vec::with_capacity(fits.len());
        for ((name, dir), fit_bands) in fits.iter().zip(&bands) {
            match fit_bands.get(i) {
                Some(b) if b.run == run.run && b.time_s == run.time_s => {
                    overlaid.push((name.as_str(), b));
                }
                _ => {
                    return Err(ReportError::Mismatch {
                        dir: dir.path().to_path_buf(),
                        problem: format!(
                            "its predictive.csv has no band of run `{}` at the times of {}'s",
                            run.run, fits[0].0
                        ),
                    })
                }
            }
        }
        blocks.push(Block::Figure {
            file: format!("compare-{}.svg", run.run),
            caption: format!(
                "Run `{}`: each fit's posterior median over the data; under it, the data and \
                 each fit's median less the best fit's median.",
                run.run
            ),
            svg: overlay_figure(&run.run, &overlaid),
        });
    }
    let dir = RunDir::new(out);
    let figures = write_figures(&dir, &blocks)?;
    let title = "Which model predicts the data better";
    let markdown = dir.write(COMPARE_MD, render_markdown(title, &blocks).as_bytes())?;
    let html = dir.write(COMPARE_HTML, render_html(title, &blocks).as_bytes())?;
    Ok(ReportFiles {
        html,
        markdown,
        figures,
    })
}
