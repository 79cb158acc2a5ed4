//! SVG plots of error against wall time, on the crate's plotting layer ([`slipbayes::plot`]).

use std::path::Path;

use super::BenchError;
use slipbayes::data::write_atomically;
use slipbayes::plot::{
    ink, svg_figure, Axis, DrawError, LegendEntry, Marker, Panel, Rgb, Series, Stroke, Swatch,
};

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

/// Size of the plot (pixels).
const SIZE: (u32, u32) = (820, 540);

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
    let name = path.display().to_string();
    let svg = draw(&name, title, y_label, points)
        .map_err(|e| BenchError::run(format!("plot {name}"))(e.message))?;
    write_atomically(path, svg.as_bytes()).map_err(BenchError::io(path))
}

fn draw(
    name: &str,
    title: &str,
    y_label: &str,
    points: &[ErrorPoint],
) -> Result<String, DrawError> {
    let finite: Vec<&ErrorPoint> = points
        .iter()
        .filter(|p| p.wall_s.is_finite() && p.wall_s > 0.0 && p.error.is_finite())
        .collect();
    if finite.is_empty() {
        return Err(DrawError::new(name, "no finite points to plot"));
    }
    let y = |p: &ErrorPoint| p.error.max(ERROR_FLOOR);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, 0.0_f64, f64::INFINITY, 0.0_f64);
    for p in &finite {
        x0 = x0.min(p.wall_s);
        x1 = x1.max(p.wall_s);
        y0 = y0.min(y(p));
        y1 = y1.max(y(p));
    }
    Ok(svg_figure(SIZE, |c| {
        let mut panel = Panel::new(
            title,
            Axis::log((x0 / 1.5, x1 * 1.5), "wall time (s)"),
            Axis::log((y0 / 2.0, y1 * 2.0), y_label),
        );
        let mut series: Vec<&'static str> = Vec::new();
        for p in &finite {
            if !series.contains(&p.series) {
                series.push(p.series);
            }
        }
        // Knobs differ in marker shape as well as ink, as every series of the crate's figures.
        for (k, label) in series.iter().enumerate() {
            let these: Vec<(f64, f64)> = finite
                .iter()
                .filter(|p| p.series == *label)
                .map(|p| (p.wall_s, y(p)))
                .collect();
            panel.markers(these, Marker::of(k), ink(k), Some(label));
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
        panel.line(stairs, Stroke::solid(Rgb::BLACK, 1.5), Some("Pareto front"));
        let ringed: Vec<(f64, f64)> = finite
            .iter()
            .filter(|p| p.default)
            .map(|p| (p.wall_s, y(p)))
            .collect();
        panel.add(
            Series::Markers {
                points: ringed,
                marker: Marker::Circle,
                color: Rgb::BLACK,
                radius: 10.0,
            },
            Some(LegendEntry::new(
                "default (ringed)",
                Swatch::Marker(Marker::Circle, Rgb::BLACK, 6.0),
            )),
        );
        let whole = c.bounds();
        panel.draw(c, whole);
    }))
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
        let svg = draw(
            "t.svg",
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
        let err = draw("e.svg", "t", "e", &[]).unwrap_err();
        assert_eq!(err.figure, "e.svg");
    }
}
