//! The report's figures: fits in observed time, interface time and sliding distance, the
//! peak's density and its dependence on t0, the material forest plot, traces and corners.
//! Values arrive in SI and are shown in mN, µm, µm⁻¹, s.

use plotters::prelude::*;

use super::curves::{kernel_density, InterfaceCurve, PeakVsT0};
use crate::law::Scene;
use crate::model::Band;
use crate::plot::{
    band, band_fills, caption_font, grid, ink, label_font, legend, line, linear_chart, markers,
    padded, panel_grid, range_of, significant, small_font, svg_figure, tick, tint, widen, Area,
    DrawError, Drawn, LinearChart, PANEL,
};

/// N to mN.
const MN: f64 = 1e3;
/// m to µm.
const UM: f64 = 1e6;

/// A run as the report names it.
#[derive(Debug, Clone, PartialEq)]
pub struct RunView {
    /// Run name.
    pub name: String,
    /// Scene.
    pub scene: Scene,
    /// Sliding velocity (m/s).
    pub velocity_m_per_s: f64,
    /// Contact name.
    pub contact: String,
    /// Material name.
    pub material: String,
}

/// A velocity as people say it: `1 nm/s`, `4 µm/s`.
pub fn velocity_text(v: f64) -> String {
    let (value, unit) = if v >= 1e-3 {
        (v * 1e3, "mm/s")
    } else if v >= 1e-6 {
        (v * 1e6, "µm/s")
    } else {
        (v * 1e9, "nm/s")
    };
    format!("{} {unit}", tick(value))
}

/// Data in observed time with the posterior median and the 50 %/95 % predictive bands; for a
/// slide with a law, a second panel in interface time with the elastic part removed.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn fit_figure(
    name: &str,
    run: &RunView,
    predictive: &Band,
    curve: Option<&InterfaceCurve>,
) -> Result<String, DrawError> {
    let panels = if curve.is_some() { 2 } else { 1 };
    svg_figure(
        name,
        (PANEL.0 * panels, PANEL.1 + RESIDUAL_HEIGHT),
        |root| {
            let (top, bottom) = root.split_vertically(PANEL.1);
            let areas = top.split_evenly((1, panels as usize));
            let p = predictive;
            residual_panel(&bottom.split_horizontally(PANEL.0).0, name, p)?;
            let y_all = p
                .observed_n
                .iter()
                .chain(&p.predictive_n[0])
                .chain(&p.predictive_n[3])
                .chain(std::iter::once(&0.0));
            let (y0, y1) = range_of(y_all, 0.04);
            let y = (y0 * MN, y1 * MN);
            let x = range_of(p.time_s.iter(), 0.0);
            let mut chart = linear_chart(
                &areas[0],
                name,
                &format!(
                    "{}: observed time ({})",
                    run.name,
                    velocity_text(run.velocity_m_per_s)
                ),
                x,
                y,
                "instrument time t (s)",
                "friction force F (mN)",
            )?;
            let scaled = |v: &[f64]| v.iter().map(|f| f * MN).collect::<Vec<f64>>();
            predictive_bands(
                &mut chart,
                name,
                &p.time_s,
                [0, 1, 2, 3].map(|q| scaled(&p.predictive_n[q])),
                true,
            )?;
            markers(
                &mut chart,
                name,
                &in_mn(&p.time_s, &p.observed_n),
                0,
                Some("data"),
            )?;
            let median = in_mn(&p.time_s, &p.model_n[1]);
            line(
                &mut chart,
                name,
                median.clone(),
                1,
                2,
                Some("posterior median"),
            )?;
            legend(&mut chart, name, SeriesLabelPosition::LowerRight)?;

            if let Some(c) = curve {
                let tau_data: Vec<(f64, f64)> = p
                    .time_s
                    .iter()
                    .zip(&p.observed_n)
                    .map(|(&t, &f)| (c.interface_time(t, f), f * MN))
                    .collect();
                let x = range_of(c.tau_s.iter(), 0.0);
                let mut chart = linear_chart(
                    &areas[1],
                    name,
                    &format!("{}: interface time, elastic part removed", run.name),
                    x,
                    y,
                    "interface time τ = t − F/(kv) (s)",
                    "friction force F (mN)",
                )?;
                band(
                    &mut chart,
                    name,
                    &c.tau_s,
                    &scaled(&c.force_n[0]),
                    &scaled(&c.force_n[2]),
                    band_fills().0,
                    Some("95 % posterior of F(τ)"),
                )?;
                markers(&mut chart, name, &tau_data, 0, Some("data at τ (median k)"))?;
                let law = in_mn(&c.tau_s, &c.force_n[1]);
                line(&mut chart, name, law, 1, 2, Some("law F(τ), median"))?;
                if c.kv_n_per_s.is_some() {
                    line(&mut chart, name, median, 3, 1, Some("median in observed t"))?;
                }
                legend(&mut chart, name, SeriesLabelPosition::LowerRight)?;
            }
            Ok(())
        },
    )
}

/// Points (x, force in mN) from forces in N.
fn in_mn(xs: &[f64], forces_n: &[f64]) -> Vec<(f64, f64)> {
    xs.iter()
        .zip(forces_n)
        .map(|(&x, &f)| (x, f * MN))
        .collect()
}

/// The 95 % (light) and 50 % (darker) predictive bands from the 2.5, 25, 75 and 97.5 %
/// quantiles `q`, labelled in the legend when `labelled`.
fn predictive_bands(
    chart: &mut LinearChart<'_, '_>,
    name: &str,
    xs: &[f64],
    q: [Vec<f64>; 4],
    labelled: bool,
) -> Result<(), DrawError> {
    let (light, dark) = band_fills();
    let label = |text: &'static str| labelled.then_some(text);
    band(
        chart,
        name,
        xs,
        &q[0],
        &q[3],
        light,
        label("95 % predictive"),
    )?;
    band(
        chart,
        name,
        xs,
        &q[1],
        &q[2],
        dark,
        label("50 % predictive"),
    )
}

/// Height of the residual strip under a fit.
const RESIDUAL_HEIGHT: u32 = 230;

/// Data minus the posterior median in observed time, with the 50 % and 95 % predictive bands
/// around it: where the bands are too thin to see on the force scale, misfit shows here.
fn residual_panel(area: &Area, name: &str, p: &Band) -> Result<(), DrawError> {
    let median = &p.model_n[1];
    let minus = |v: &[f64]| {
        v.iter()
            .zip(median)
            .map(|(a, m)| (a - m) * MN)
            .collect::<Vec<f64>>()
    };
    let residual = minus(&p.observed_n);
    let (lo95, hi95) = (minus(&p.predictive_n[0]), minus(&p.predictive_n[3]));
    let (lo50, hi50) = (minus(&p.predictive_n[1]), minus(&p.predictive_n[2]));
    let y = range_of(residual.iter().chain(&lo95).chain(&hi95), 0.05);
    let mut chart = linear_chart(
        area,
        name,
        "residual: data − posterior median",
        range_of(p.time_s.iter(), 0.0),
        y,
        "instrument time t (s)",
        "residual (mN)",
    )?;
    predictive_bands(&mut chart, name, &p.time_s, [lo95, lo50, hi50, hi95], false)?;
    let zero: Vec<(f64, f64)> = p.time_s.iter().map(|&t| (t, 0.0)).collect();
    line(&mut chart, name, zero, 0, 1, None)?;
    let points: Vec<(f64, f64)> = p.time_s.iter().copied().zip(residual).collect();
    markers(&mut chart, name, &points, 0, None)
}

/// The slides of one contact against sliding distance x = vτ (the paper's Fig. 2 inset):
/// slides at different velocities fall on one curve when the law holds.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn distance_figure(
    name: &str,
    contact: &str,
    slides: &[(&RunView, &Band, &InterfaceCurve)],
) -> Result<String, DrawError> {
    svg_figure(name, (PANEL.0 + 140, PANEL.1 + 20), |root| {
        let xs: Vec<f64> = slides
            .iter()
            .flat_map(|(r, _, c)| c.tau_s.iter().map(|t| t * r.velocity_m_per_s * UM))
            .collect();
        let ys: Vec<f64> = slides
            .iter()
            .flat_map(|(_, p, _)| p.observed_n.iter().map(|f| f * MN))
            .chain(std::iter::once(0.0))
            .collect();
        let mut chart = linear_chart(
            root,
            name,
            &format!("contact {contact}: against sliding distance"),
            range_of(xs.iter(), 0.0),
            range_of(ys.iter(), 0.04),
            "sliding distance x = vτ (µm)",
            "friction force F (mN)",
        )?;
        for (k, (run, p, c)) in slides.iter().enumerate() {
            let v = run.velocity_m_per_s;
            let data: Vec<(f64, f64)> = p
                .time_s
                .iter()
                .zip(&p.observed_n)
                .map(|(&t, &f)| (c.interface_time(t, f) * v * UM, f * MN))
                .collect();
            let label = format!("{} ({}): data", run.name, velocity_text(v));
            markers(&mut chart, name, &data, k, Some(&label))?;
            let law: Vec<(f64, f64)> = c
                .tau_s
                .iter()
                .zip(&c.force_n[1])
                .map(|(&t, &f)| (t * v * UM, f * MN))
                .collect();
            let label = format!("{}: law median", run.name);
            line(&mut chart, name, law, k, 2, Some(&label))?;
        }
        legend(&mut chart, name, SeriesLabelPosition::LowerRight)
    })
}

/// One panel of the peak density figure: title, the density of the F_peak draws in mN
/// ([`peak_density`]), and (2.5 %, 50 %, 97.5 %) in N.
pub type PeakDraws = (String, (Vec<f64>, Vec<f64>), [f64; 3]);

/// The density a panel of [`peak_density_figure`] draws, of F_peak draws in N: what a panel
/// keeps of its draws, so that the figure holds no draws.
pub fn peak_density(draws_n: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mn: Vec<f64> = draws_n.iter().map(|f| f * MN).collect();
    kernel_density(&mn, 200)
}

/// Posterior density of the peak static friction, one panel per run and per material mean:
/// the density, its 95 % interval shaded under it, and the median as a dashed line.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn peak_density_figure(name: &str, panels: &[PeakDraws]) -> Result<String, DrawError> {
    let (rows, cols) = panel_grid(panels.len(), 3);
    let (w, h) = (420u32, 300u32);
    svg_figure(name, (w * cols as u32, h * rows as u32), |root| {
        let areas = root.split_evenly((rows, cols));
        for ((title, (grid_x, dens), q), area) in panels.iter().zip(&areas) {
            let top = dens.iter().copied().fold(0.0_f64, f64::max);
            let mut chart = linear_chart(
                area,
                name,
                title,
                range_of(grid_x.iter(), 0.0),
                (0.0, top * 1.1),
                "F_peak (mN)",
                "density (1/mN)",
            )?;
            let (lo, med, hi) = (q[0] * MN, q[1] * MN, q[2] * MN);
            let inside: Vec<usize> = (0..grid_x.len())
                .filter(|&j| grid_x[j] >= lo && grid_x[j] <= hi)
                .collect();
            let xs: Vec<f64> = inside.iter().map(|&j| grid_x[j]).collect();
            let ds: Vec<f64> = inside.iter().map(|&j| dens[j]).collect();
            let (light, _) = band_fills();
            band(
                &mut chart,
                name,
                &xs,
                &vec![0.0; xs.len()],
                &ds,
                light,
                Some("95 % interval"),
            )?;
            let pts: Vec<(f64, f64)> = grid_x.iter().copied().zip(dens.iter().copied()).collect();
            line(&mut chart, name, pts, 0, 2, Some("posterior density"))?;
            let label = format!("median {} mN", tick_mn(q[1]));
            line(
                &mut chart,
                name,
                vec![(med, 0.0), (med, top * 1.05)],
                1,
                2,
                Some(&label),
            )?;
            legend(&mut chart, name, SeriesLabelPosition::UpperRight)?;
        }
        Ok(())
    })
}

fn tick_mn(f_n: f64) -> String {
    significant(f_n * MN, 4)
}

/// The peak against t0 (the paper's Fig. 4) per material: for each slide, the median and
/// 95 % band of F_peak when t0 is varied with the other parameters drawn from the posterior,
/// and the posterior draws of (t0, F_peak) themselves.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn peak_t0_figure(
    name: &str,
    materials: &[(String, Vec<(String, PeakVsT0)>)],
) -> Result<String, DrawError> {
    let n = materials.len().max(1);
    svg_figure(name, (PANEL.0 * n as u32, PANEL.1 + 40), |root| {
        let areas = root.split_evenly((1, n));
        for ((material, runs), area) in materials.iter().zip(&areas) {
            let t0s = runs.iter().flat_map(|(_, c)| c.t0_s.iter());
            let (lo, hi) = t0s.fold((f64::INFINITY, 0.0_f64), |(lo, hi), &t| {
                (lo.min(t), hi.max(t))
            });
            let (lo, hi) = if lo.is_finite() && hi > lo {
                (lo, hi)
            } else {
                (1e-3, 1e3)
            };
            let ys: Vec<f64> = runs
                .iter()
                .flat_map(|(_, c)| c.peak_n[0].iter().chain(&c.peak_n[2]).map(|f| f * MN))
                .collect();
            let (y0, y1) = range_of(ys.iter(), 0.05);
            let mut chart = ChartBuilder::on(area)
                .caption(format!("{material}: F_peak against t0"), caption_font())
                .margin(10)
                .x_label_area_size(48)
                .y_label_area_size(70)
                .build_cartesian_2d((lo..hi).log_scale(), y0..y1)
                .drawn(name)?;
            let (light, bold) = grid();
            chart
                .configure_mesh()
                .light_line_style(light)
                .bold_line_style(bold)
                .x_desc("t0, short-time cut-off (s, log scale)")
                .y_desc("peak static friction F_peak (mN)")
                .x_label_formatter(&|v| tick(*v))
                .y_label_formatter(&|v| tick(*v))
                .label_style(label_font())
                .draw()
                .drawn(name)?;
            for (k, (run, c)) in runs.iter().enumerate() {
                let scaled = |v: &[f64]| v.iter().map(|f| f * MN).collect::<Vec<f64>>();
                band(
                    &mut chart,
                    name,
                    &c.t0_s,
                    &scaled(&c.peak_n[0]),
                    &scaled(&c.peak_n[2]),
                    tint(k),
                    None,
                )?;
                let median: Vec<(f64, f64)> =
                    c.t0_s.iter().copied().zip(scaled(&c.peak_n[1])).collect();
                line(
                    &mut chart,
                    name,
                    median,
                    k,
                    2,
                    Some(&format!("{run}: t0 varied")),
                )?;
                let own: Vec<(f64, f64)> = c.draws.iter().map(|&(t, f)| (t, f * MN)).collect();
                markers(
                    &mut chart,
                    name,
                    &own,
                    k,
                    Some(&format!("{run}: posterior draws")),
                )?;
            }
            legend(&mut chart, name, SeriesLabelPosition::LowerLeft)?;
        }
        Ok(())
    })
}

/// One row of a forest panel: a group's median and 95 % interval, in display units.
#[derive(Debug, Clone, PartialEq)]
pub struct ForestRow {
    /// Group (material, contact or run).
    pub label: String,
    /// Median.
    pub median: f64,
    /// 2.5 % quantile.
    pub low: f64,
    /// 97.5 % quantile.
    pub high: f64,
    /// Whether the group is a material (drawn filled).
    pub material: bool,
}

/// One panel of the forest plot.
#[derive(Debug, Clone, PartialEq)]
pub struct ForestPanel {
    /// Title (quantity and comparison).
    pub title: String,
    /// Axis label with unit.
    pub axis: String,
    /// Rows, top to bottom.
    pub rows: Vec<ForestRow>,
}

const FOREST_ROW_PX: u32 = 30;
const FOREST_FRAME_PX: u32 = 110;

/// The forest plot: per quantity, each material and contact (or run) as a median dot with its
/// 95 % interval; materials filled, contacts and runs open.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn forest_figure(name: &str, panels: &[ForestPanel]) -> Result<String, DrawError> {
    let heights: Vec<u32> = panels
        .iter()
        .map(|p| FOREST_FRAME_PX + FOREST_ROW_PX * p.rows.len() as u32)
        .collect();
    let width = 760;
    svg_figure(name, (width, heights.iter().sum::<u32>().max(1)), |root| {
        let mut rest = root.clone();
        for (panel, &h) in panels.iter().zip(&heights) {
            let (area, below) = rest.split_vertically(h);
            rest = below;
            let n = panel.rows.len();
            let xs = panel
                .rows
                .iter()
                .flat_map(|r| [r.low, r.high])
                .collect::<Vec<_>>();
            let (x0, x1) = range_of(xs.iter(), 0.08);
            let labels: Vec<String> = panel.rows.iter().map(|r| r.label.clone()).collect();
            let mut chart = ChartBuilder::on(&area)
                .caption(&panel.title, caption_font())
                .margin(8)
                .x_label_area_size(44)
                .y_label_area_size(150)
                .build_cartesian_2d(x0..x1, widen((-0.6, n as f64 - 0.4)).0..(n as f64 - 0.4))
                .drawn(name)?;
            let (light, bold) = grid();
            // Rows are drawn at integer heights from the top; label exactly those.
            let row_label = |y: &f64| {
                let i = (n as f64 - 1.0 - y).round();
                if (y - y.round()).abs() < 1e-6 && i >= 0.0 && (i as usize) < n {
                    labels[i as usize].clone()
                } else {
                    String::new()
                }
            };
            chart
                .configure_mesh()
                .light_line_style(light)
                .bold_line_style(bold)
                .disable_y_mesh()
                .y_labels(n.max(1) * 4 + 1)
                .y_label_formatter(&row_label)
                .x_labels(6)
                .x_label_formatter(&|v| tick(*v))
                .x_desc(panel.axis.as_str())
                .label_style(label_font())
                .draw()
                .drawn(name)?;
            for (i, row) in panel.rows.iter().enumerate() {
                let y = (n - 1 - i) as f64;
                chart
                    .draw_series(std::iter::once(PathElement::new(
                        vec![(row.low, y), (row.high, y)],
                        BLACK.stroke_width(2),
                    )))
                    .drawn(name)?;
                let style = if row.material {
                    BLACK.filled()
                } else {
                    WHITE.filled()
                };
                chart
                    .draw_series(std::iter::once(Circle::new((row.median, y), 5, style)))
                    .drawn(name)?;
                chart
                    .draw_series(std::iter::once(Circle::new(
                        (row.median, y),
                        5,
                        BLACK.stroke_width(2),
                    )))
                    .drawn(name)?;
            }
        }
        Ok(())
    })
}

/// One trace panel: a parameter's walkers per ensemble, as drawn: every
/// [`trace_stride`]-th step, and the range of every step.
#[derive(Debug, Clone, PartialEq)]
pub struct TracePanel {
    /// Title (parameter and unit).
    pub title: String,
    /// Steps of the run (the x axis spans them).
    pub steps: usize,
    /// `points[ensemble][walker]`: (step, value in display units) at every
    /// [`trace_stride`]`(steps)`-th step from step 0.
    pub points: Vec<Vec<Vec<(f64, f64)>>>,
    /// The finite range of the values of these walkers at every step, in display units
    /// (before padding; [`extend_bounds`](crate::plot::extend_bounds) folded over them).
    pub range: (f64, f64),
}

/// Most points drawn per walker line.
const TRACE_POINTS: usize = 250;

/// Steps between the points drawn of a trace of `steps` steps.
pub fn trace_stride(steps: usize) -> usize {
    steps.div_ceil(TRACE_POINTS).max(1)
}

/// Trace plots: a few walkers of every ensemble per parameter, ensembles told apart by ink
/// (dark to light), the burn-in marked.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn trace_figure(name: &str, panels: &[TracePanel], burn_in: u64) -> Result<String, DrawError> {
    let cols = 2usize;
    let rows = panels.len().div_ceil(cols).max(1);
    let (w, h) = (480u32, 210u32);
    svg_figure(name, (w * cols as u32, h * rows as u32), |root| {
        let areas = root.split_evenly((rows, cols));
        for (p, (panel, area)) in panels.iter().zip(&areas).enumerate() {
            let steps = panel.steps;
            let (y0, y1) = padded(panel.range, 0.05);
            let mut chart = ChartBuilder::on(area)
                .caption(&panel.title, small_font())
                .margin(6)
                .x_label_area_size(30)
                .y_label_area_size(62)
                .build_cartesian_2d(widen((0.0, steps as f64)).0..steps.max(1) as f64, y0..y1)
                .drawn(name)?;
            let (light, bold) = grid();
            chart
                .configure_mesh()
                .light_line_style(light)
                .bold_line_style(bold)
                .x_labels(5)
                .y_labels(4)
                .x_label_formatter(&|v| tick(*v))
                .y_label_formatter(&|v| tick(*v))
                .label_style(small_font())
                .x_desc(if p + cols >= panels.len() { "step" } else { "" })
                .draw()
                .drawn(name)?;
            for (e, walkers) in panel.points.iter().enumerate() {
                for (w_i, pts) in walkers.iter().enumerate() {
                    let pts = pts.clone();
                    // Solid lines: dashes would multiply the SVG's size by the number of
                    // dashes; ensembles differ in ink, dark to light.
                    let style = ink(e).stroke_width(1);
                    let anno = chart.draw_series(LineSeries::new(pts, style)).drawn(name)?;
                    if p == 0 && w_i == 0 {
                        anno.label(format!("ensemble {}", e + 1))
                            .legend(move |(x, y)| {
                                PathElement::new(vec![(x, y), (x + 24, y)], style.stroke_width(3))
                            });
                    }
                }
            }
            let burn = burn_in as f64;
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(burn, y0), (burn, y1)],
                    RGBColor(150, 0, 0).stroke_width(1),
                )))
                .drawn(name)?;
            if p == 0 {
                legend(&mut chart, name, SeriesLabelPosition::UpperRight)?;
            }
        }
        Ok(())
    })
}

/// Most draws shown as points in a corner plot panel.
pub const CORNER_POINTS: usize = 200;

/// What a corner plot draws of one quantity's draws (in display units): its padded range,
/// its density, and the draws shown as points. Built one quantity at a time
/// ([`CornerColumn::of`]), so that the figure holds a few hundred points per quantity, never
/// the draws.
#[derive(Debug, Clone, PartialEq)]
pub struct CornerColumn {
    /// Axis label.
    pub name: String,
    /// The finite range of the draws, padded by 5 %.
    pub range: (f64, f64),
    /// Kernel density of the draws: (grid, density).
    pub density: (Vec<f64>, Vec<f64>),
    /// Every `draws.div_ceil(CORNER_POINTS)`-th draw, paired by index across quantities.
    pub points: Vec<f64>,
}

impl CornerColumn {
    /// The column of `draws` (display units), labelled `name`.
    pub fn of(name: String, draws: &[f64]) -> Self {
        let stride = draws.len().div_ceil(CORNER_POINTS).max(1);
        Self {
            name,
            range: range_of(draws.iter(), 0.05),
            density: kernel_density(draws, 120),
            points: draws.iter().step_by(stride).copied().collect(),
        }
    }
}

/// A corner plot: densities on the diagonal, pairs of draws below it, one
/// [`CornerColumn`] per quantity.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn corner_figure(name: &str, columns: &[CornerColumn]) -> Result<String, DrawError> {
    let n = columns.len().max(1);
    let cell = 190u32;
    svg_figure(name, (cell * n as u32, cell * n as u32), |root| {
        let areas = root.split_evenly((n, n));
        for i in 0..n {
            for j in 0..=i.min(n - 1) {
                let area = &areas[i * n + j];
                let (grid_x, dens) = &columns[i].density;
                let top = dens.iter().copied().fold(0.0_f64, f64::max);
                let (ci, cj) = (&columns[i], &columns[j]);
                // The diagonal shows a density (no y ticks); below it, column i against j.
                let y = if i == j {
                    (0.0, (top * 1.1).max(f64::MIN_POSITIVE))
                } else {
                    ci.range
                };
                let mut chart = ChartBuilder::on(area)
                    .margin(4)
                    .x_label_area_size(if i == n - 1 { 44 } else { 8 })
                    .y_label_area_size(if j == 0 { 56 } else { 8 })
                    .build_cartesian_2d(cj.range.0..cj.range.1, y.0..y.1)
                    .drawn(name)?;
                chart
                    .configure_mesh()
                    .disable_mesh()
                    .x_labels(if i == n - 1 { 3 } else { 0 })
                    .y_labels(if j == 0 && i != j { 3 } else { 0 })
                    .x_label_formatter(&|v| tick(*v))
                    .y_label_formatter(&|v| tick(*v))
                    .x_desc(if i == n - 1 { cj.name.as_str() } else { "" })
                    .y_desc(if j == 0 { ci.name.as_str() } else { "" })
                    .label_style(small_font())
                    .axis_desc_style(small_font())
                    .draw()
                    .drawn(name)?;
                if i == j {
                    let pts: Vec<(f64, f64)> =
                        grid_x.iter().copied().zip(dens.iter().copied()).collect();
                    line(&mut chart, name, pts, 0, 1, None)?;
                } else {
                    let style = ink(0).mix(0.45).filled();
                    chart
                        .draw_series(
                            cj.points
                                .iter()
                                .zip(&ci.points)
                                .map(|(&x, &y)| Circle::new((x, y), 1, style)),
                        )
                        .drawn(name)?;
                }
            }
        }
        Ok(())
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn velocities_read_as_people_say_them() {
        assert_eq!(velocity_text(1e-9), "1 nm/s");
        assert_eq!(velocity_text(4e-6), "4 µm/s");
        assert_eq!(velocity_text(2.5e-8), "25 nm/s");
    }
}
