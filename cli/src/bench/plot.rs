//! SVG plots of error against wall time (plotters, SVG backend, no font libraries).

use std::path::Path;

use plotters::prelude::*;

use super::BenchError;
use slipbayes::data::write_atomically;

/// One point of an error-against-cost plot.
#[derive(Debug, Clone)]
pub struct ErrorPoint {
    /// Series (the knob).
    pub series: &'static str,
    /// Wall time (s).
    pub wall_s: f64,
    /// Error.
    pub error: f64,
    /// On the Pareto front.
    pub pareto: bool,
    /// The default setting.
    pub default: bool,
}

/// Errors are shown on a log axis; exact zeros (the reference against itself) sit at its floor.
const ERROR_FLOOR: f64 = 1e-3;

const PALETTE: [RGBColor; 5] = [
    RGBColor(0, 114, 178),
    RGBColor(230, 159, 0),
    RGBColor(0, 158, 115),
    RGBColor(204, 121, 167),
    RGBColor(213, 94, 0),
];

/// Writes an error-against-wall-time plot (both axes logarithmic) with the Pareto front as a
/// staircase and the default setting ringed.
///
/// # Errors
/// [`BenchError::Io`] when the file cannot be written, [`BenchError::Run`] on a drawing error.
pub fn error_vs_time(
    path: &Path,
    title: &str,
    y_label: &str,
    points: &[ErrorPoint],
) -> Result<(), BenchError> {
    let mut svg = String::new();
    draw(&mut svg, title, y_label, points)
        .map_err(|e| BenchError::run(format!("plot {}", path.display()))(e))?;
    write_atomically(path, svg.as_bytes()).map_err(BenchError::io(path))
}

fn draw(svg: &mut String, title: &str, y_label: &str, points: &[ErrorPoint]) -> Result<(), String> {
    let e = |err: &dyn std::fmt::Display| err.to_string();
    let finite: Vec<&ErrorPoint> = points
        .iter()
        .filter(|p| p.wall_s.is_finite() && p.wall_s > 0.0 && p.error.is_finite())
        .collect();
    if finite.is_empty() {
        return Err("no finite points to plot".into());
    }
    let y = |p: &ErrorPoint| p.error.max(ERROR_FLOOR);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0_f64, f64::INFINITY, 0.0_f64);
    for p in &finite {
        x0 = x0.min(p.wall_s);
        x1 = x1.max(p.wall_s);
        y0 = y0.min(y(p));
        y1 = y1.max(y(p));
    }
    let root = SVGBackend::with_string(svg, (820, 540)).into_drawing_area();
    root.fill(&WHITE).map_err(|err| e(&err))?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(45)
        .y_label_area_size(70)
        .build_cartesian_2d(
            (x0 / 1.5..x1 * 1.5).log_scale(),
            (y0 / 2.0..y1 * 2.0).log_scale(),
        )
        .map_err(|err| e(&err))?;
    chart
        .configure_mesh()
        .x_desc("wall time (s)")
        .y_desc(y_label)
        .draw()
        .map_err(|err| e(&err))?;

    let mut series: Vec<&'static str> = Vec::new();
    for p in &finite {
        if !series.contains(&p.series) {
            series.push(p.series);
        }
    }
    for (i, name) in series.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        let these: Vec<(f64, f64)> = finite
            .iter()
            .filter(|p| p.series == *name)
            .map(|p| (p.wall_s, y(p)))
            .collect();
        chart
            .draw_series(these.iter().map(|&c| Circle::new(c, 5, color.filled())))
            .map_err(|err| e(&err))?
            .label(*name)
            .legend(move |(x, y)| Circle::new((x, y), 5, color.filled()));
    }
    let mut front: Vec<(f64, f64)> = finite
        .iter()
        .filter(|p| p.pareto)
        .map(|p| (p.wall_s, y(p)))
        .collect();
    front.sort_by(|a, b| a.0.total_cmp(&b.0));
    // A staircase: each front point holds until a later, better one.
    let mut stairs = Vec::with_capacity(2 * front.len());
    for (i, &(x, yv)) in front.iter().enumerate() {
        if i > 0 {
            stairs.push((x, front[i - 1].1));
        }
        stairs.push((x, yv));
    }
    chart
        .draw_series(LineSeries::new(stairs, BLACK.stroke_width(1)))
        .map_err(|err| e(&err))?
        .label("Pareto front")
        .legend(|(x, y)| PathElement::new(vec![(x - 8, y), (x + 8, y)], BLACK));
    chart
        .draw_series(
            finite
                .iter()
                .filter(|p| p.default)
                .map(|p| Circle::new((p.wall_s, y(p)), 10, BLACK.stroke_width(2))),
        )
        .map_err(|err| e(&err))?
        .label("default (ringed)")
        .legend(|(x, y)| Circle::new((x, y), 6, BLACK.stroke_width(2)));
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(|err| e(&err))?;
    root.present().map_err(|err| e(&err))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plot_holds_every_series_and_the_front() {
        let p = |series, wall_s, error, pareto, default| ErrorPoint {
            series,
            wall_s,
            error,
            pareto,
            default,
        };
        let mut svg = String::new();
        draw(
            &mut svg,
            "t",
            "err",
            &[
                p("walkers", 1.0, 0.5, true, false),
                p("chain length", 2.0, 0.1, true, true),
                p("chain length", 4.0, 0.0, true, false),
            ],
        )
        .unwrap();
        assert!(svg.contains("<svg") && svg.contains("walkers") && svg.contains("Pareto front"));
        assert!(draw(&mut String::new(), "t", "e", &[]).is_err());
    }
}
