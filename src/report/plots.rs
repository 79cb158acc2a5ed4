//! The report's figures: fits in observed time, interface time and sliding distance, the
//! peak's density and its dependence on t0, the material forest plot, traces with rank plots,
//! and corner plots. Values arrive in SI and are shown in mN, µm, µm⁻¹, s.

use super::contours::{Histogram2d, BINS};
use super::density::kernel_density;
use crate::fit::run_dir::{InterfaceCurve, PeakVsT0};
use crate::law::Scene;
use crate::model::Band;
use crate::plot::{
    axis_margins, band_fills, box_size, choose_ticks, draw_axes, draw_box, draw_grid, draw_row,
    draw_series, fit_axes, ink, panel_grid, range_of, row_height, series_stroke, significant,
    svg_figure, text::line_height, text::text_width, text::wrap, text::Anchor, text::HPos,
    text::VPos, tick, tint, Axis, Canvas, DrawError, Fill, Font, LegendAt, LegendEntry, Marker,
    Panel, Plot, Rect, Rgb, Scale, Series, Show, Stroke, Swatch, Ticks, CAPTION_PX, GAP_PX, MARK,
    PANEL, TEXT_PX,
};

/// N to mN.
const MN: f64 = 1e3;
/// m to µm.
const UM: f64 = 1e6;
/// The widest a figure is drawn, so that the report shows it at its own size.
const FIGURE_WIDTH: f64 = 1160.0;

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

/// Points (x, force in mN) from forces in N.
fn in_mn(xs: &[f64], forces_n: &[f64]) -> Vec<(f64, f64)> {
    xs.iter()
        .zip(forces_n)
        .map(|(&x, &f)| (x, f * MN))
        .collect()
}

fn scaled(v: &[f64], factor: f64) -> Vec<f64> {
    v.iter().map(|f| f * factor).collect()
}

/// Height of the residual strip under a fit.
const RESIDUAL_HEIGHT: u32 = 230;

/// Data in observed time with the posterior median and the 50 %/95 % predictive bands; for a
/// slide with a law, a second panel in interface time with the elastic part removed; under
/// them the residuals.
pub fn fit_figure(run: &RunView, predictive: &Band, curve: Option<&InterfaceCurve>) -> String {
    let panels = if curve.is_some() { 2 } else { 1 };
    svg_figure((PANEL.0 * panels, PANEL.1 + RESIDUAL_HEIGHT), |c| {
        let (top, bottom) = c.bounds().split_top(f64::from(PANEL.1));
        let areas = top.grid(1, panels as usize);
        let p = predictive;
        let y_all = p
            .observed_n
            .iter()
            .chain(&p.predictive_n[0])
            .chain(&p.predictive_n[3])
            .chain(std::iter::once(&0.0));
        let (y0, y1) = range_of(y_all, 0.04);
        let y = (y0 * MN, y1 * MN);
        let mut observed = Panel::new(
            &format!(
                "{}: observed time ({})",
                run.name,
                velocity_text(run.velocity_m_per_s)
            ),
            Axis::linear(range_of(p.time_s.iter(), 0.0), "instrument time t (s)"),
            Axis::linear(y, "friction force F (mN)"),
        );
        let (light, dark) = band_fills();
        let q = |k: usize| scaled(&p.predictive_n[k], MN);
        observed.band(p.time_s.clone(), q(0), q(3), light, Some("95 % predictive"));
        observed.band(p.time_s.clone(), q(1), q(2), dark, Some("50 % predictive"));
        observed.markers(
            in_mn(&p.time_s, &p.observed_n),
            Marker::Circle,
            ink(0),
            Some("data"),
        );
        let median = in_mn(&p.time_s, &p.model_n[1]);
        observed.line(
            median.clone(),
            series_stroke(1, 2.0),
            Some("posterior median"),
        );
        observed.draw(c, areas[0]);

        if let Some(curve) = curve {
            let tau_data: Vec<(f64, f64)> = p
                .time_s
                .iter()
                .zip(&p.observed_n)
                .map(|(&t, &f)| (curve.interface_time(t, f), f * MN))
                .collect();
            let mut interface = Panel::new(
                &format!("{}: interface time, elastic part removed", run.name),
                Axis::linear(
                    range_of(curve.tau_s.iter(), 0.0),
                    "interface time τ = t − F/(kv) (s)",
                ),
                Axis::linear(y, "friction force F (mN)"),
            );
            interface.band(
                curve.tau_s.clone(),
                scaled(&curve.force_n[0], MN),
                scaled(&curve.force_n[2], MN),
                light,
                Some("95 % posterior of F(τ)"),
            );
            interface.markers(
                tau_data,
                Marker::Circle,
                ink(0),
                Some("data at τ (median k)"),
            );
            interface.line(
                in_mn(&curve.tau_s, &curve.force_n[1]),
                series_stroke(1, 2.0),
                Some("law F(τ), median"),
            );
            if curve.kv_n_per_s.is_some() {
                interface.line(median, series_stroke(3, 1.0), Some("median in observed t"));
            }
            interface.draw(c, areas[1]);
        }
        residual_panel(c, bottom.split_left(f64::from(PANEL.0)).0, p);
    })
}

/// Data minus the posterior median in observed time, with the 50 % and 95 % predictive bands
/// around it: where the bands are too thin to see on the force scale, misfit shows here.
fn residual_panel(c: &mut Canvas, area: Rect, p: &Band) {
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
    let mut panel = Panel::new(
        "residual: data − posterior median",
        Axis::linear(range_of(p.time_s.iter(), 0.0), "instrument time t (s)"),
        Axis::linear(y, "residual (mN)"),
    );
    panel.legend_at = LegendAt::Nowhere;
    let (light, dark) = band_fills();
    panel.band(p.time_s.clone(), lo95, hi95, light, None);
    panel.band(p.time_s.clone(), lo50, hi50, dark, None);
    let (t0, t1) = range_of(p.time_s.iter(), 0.0);
    panel.line(
        vec![(t0, 0.0), (t1, 0.0)],
        Stroke::solid(Rgb(90, 90, 90), 1.0),
        None,
    );
    let points: Vec<(f64, f64)> = p.time_s.iter().copied().zip(residual).collect();
    panel.markers(points, Marker::Circle, ink(0), None);
    panel.draw(c, area);
}

/// Several fits of the same run overlaid on its data: each fit's posterior median in
/// observed time (one line style per fit, legend by name); under them, on the noise's scale,
/// the data and every other fit's median less the first fit's median, so that where one law
/// follows the data and another does not shows even when the curves coincide at full scale.
/// `fits` pairs each fit's name with its band of this run (the same data), the reference
/// (best-ranked) first.
pub fn overlay_figure(run: &str, fits: &[(&str, &Band)]) -> String {
    svg_figure((PANEL.0, PANEL.1 + RESIDUAL_HEIGHT), |c| {
        let (top, bottom) = c.bounds().split_top(f64::from(PANEL.1));
        let Some((reference_name, reference)) = fits.first() else {
            return;
        };
        let y_all = reference
            .observed_n
            .iter()
            .chain(fits.iter().flat_map(|(_, b)| &b.model_n[1]))
            .chain(std::iter::once(&0.0));
        let (y0, y1) = range_of(y_all, 0.04);
        let t = range_of(reference.time_s.iter(), 0.0);
        let mut observed = Panel::new(
            &format!("{run}: the fits overlaid on the data"),
            Axis::linear(t, "instrument time t (s)"),
            Axis::linear((y0 * MN, y1 * MN), "friction force F (mN)"),
        );
        observed.markers(
            in_mn(&reference.time_s, &reference.observed_n),
            Marker::Circle,
            ink(0),
            Some("data"),
        );
        let less_reference = |v: &[f64]| -> Vec<(f64, f64)> {
            reference
                .time_s
                .iter()
                .zip(v.iter().zip(&reference.model_n[1]))
                .map(|(&t, (f, m))| (t, (f - m) * MN))
                .collect()
        };
        let data = less_reference(&reference.observed_n);
        let others: Vec<Vec<(f64, f64)>> = fits
            .iter()
            .map(|(_, b)| less_reference(&b.model_n[1]))
            .collect();
        let mut residual = Panel::new(
            &format!("less {reference_name}'s posterior median"),
            Axis::linear(t, "instrument time t (s)"),
            Axis::linear(
                range_of(
                    data.iter().chain(others.iter().flatten()).map(|p| &p.1),
                    0.05,
                ),
                "difference (mN)",
            ),
        );
        // The styles are the upper panel's, whose legend names them.
        residual.legend_at = LegendAt::Nowhere;
        residual.markers(data, Marker::Circle, Rgb(150, 150, 150), None);
        for (i, ((name, band), other)) in fits.iter().zip(others).enumerate() {
            observed.line(
                in_mn(&band.time_s, &band.model_n[1]),
                series_stroke(i + 1, 2.0),
                Some(name),
            );
            residual.line(other, series_stroke(i + 1, 2.0), None);
        }
        observed.draw(c, top);
        residual.draw(c, bottom);
    })
}

/// The slides of one contact against sliding distance x = vτ on a logarithmic axis (the
/// paper's Fig. 2): the rise, the peak and the relaxation to F_d each get their decades, and
/// slides at different velocities fall on one curve when the law holds. `None` when no data
/// point has a positive sliding distance (data that never slide have nothing to show on a
/// logarithmic axis).
pub fn distance_figure(
    contact: &str,
    slides: &[(&RunView, &Band, &InterfaceCurve)],
) -> Option<String> {
    let data: Vec<Vec<(f64, f64)>> = slides
        .iter()
        .map(|(run, p, c)| {
            let v = run.velocity_m_per_s;
            p.time_s
                .iter()
                .zip(&p.observed_n)
                .map(|(&t, &f)| (c.interface_time(t, f) * v * UM, f * MN))
                .collect()
        })
        .collect();
    let end = slides
        .iter()
        .filter_map(|(r, _, c)| c.tau_s.last().map(|t| t * r.velocity_m_per_s * UM))
        .fold(0.0_f64, f64::max);
    // From the first positive distance of the data (a lone point very close to zero would
    // spend decades on nothing: at most six decades below the end).
    let first = data
        .iter()
        .flatten()
        .map(|&(x, _)| x)
        .filter(|&x| x > 0.0)
        .fold(f64::INFINITY, f64::min)
        .max(end * 1e-6);
    if !(first.is_finite() && end > first) {
        return None;
    }
    let ys: Vec<f64> = data
        .iter()
        .flatten()
        .map(|&(_, f)| f)
        .chain(std::iter::once(0.0))
        .collect();
    Some(svg_figure((PANEL.0 + 140, PANEL.1 + 20), |c| {
        let mut panel = Panel::new(
            &format!("contact {contact}: against sliding distance (log scale)"),
            Axis::log((first, end), "sliding distance x = vτ (µm, log scale)"),
            Axis::linear(range_of(ys.iter(), 0.04), "friction force F (mN)"),
        );
        for (k, ((run, _, curve), points)) in slides.iter().zip(data).enumerate() {
            let v = run.velocity_m_per_s;
            panel.markers(
                points,
                Marker::of(k),
                ink(k),
                Some(&format!("{} ({}): data", run.name, velocity_text(v))),
            );
            let law: Vec<(f64, f64)> = curve
                .tau_s
                .iter()
                .zip(&curve.force_n[1])
                .map(|(&t, &f)| (t * v * UM, f * MN))
                .collect();
            panel.line(
                law,
                series_stroke(k, 2.0),
                Some(&format!("{}: law median", run.name)),
            );
        }
        let whole = c.bounds();
        panel.draw(c, whole);
    }))
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
/// the density, its 95 % interval shaded under it, and the median as a dashed line. The
/// density leaves the top third of each panel free for the legend.
pub fn peak_density_figure(panels: &[PeakDraws]) -> String {
    let (rows, cols) = panel_grid(panels.len(), 3);
    let (w, h) = (390u32, 300u32);
    svg_figure((w * cols as u32, h * rows as u32), |c| {
        let areas = c.bounds().grid(rows, cols);
        for ((title, (grid_x, dens), q), &area) in panels.iter().zip(&areas) {
            let top = dens.iter().copied().fold(0.0_f64, f64::max);
            let mut panel = Panel::new(
                title,
                Axis::linear(range_of(grid_x.iter(), 0.0), "F_peak (mN)"),
                Axis::linear((0.0, (top * 1.5).max(f64::MIN_POSITIVE)), "density (1/mN)"),
            );
            let (lo, med, hi) = (q[0] * MN, q[1] * MN, q[2] * MN);
            let inside: Vec<usize> = (0..grid_x.len())
                .filter(|&j| grid_x[j] >= lo && grid_x[j] <= hi)
                .collect();
            let xs: Vec<f64> = inside.iter().map(|&j| grid_x[j]).collect();
            let ds: Vec<f64> = inside.iter().map(|&j| dens[j]).collect();
            panel.band(
                xs.clone(),
                vec![0.0; xs.len()],
                ds,
                band_fills().0,
                Some("95 % interval"),
            );
            let pts: Vec<(f64, f64)> = grid_x.iter().copied().zip(dens.iter().copied()).collect();
            panel.line(pts, series_stroke(0, 2.0), Some("posterior density"));
            panel.line(
                vec![(med, 0.0), (med, top * 1.05)],
                series_stroke(1, 2.0),
                Some(&format!("median {} mN", significant(med, 4))),
            );
            panel.draw(c, area);
        }
    })
}

/// The peak against t0 (the paper's Fig. 4) per material: for each slide, the median and
/// 95 % band of F_peak when t0 is varied with the other parameters drawn from the posterior,
/// and the posterior draws of (t0, F_peak) themselves.
pub fn peak_t0_figure(materials: &[(String, Vec<(String, PeakVsT0)>)]) -> String {
    let (rows, cols) = panel_grid(materials.len(), 2);
    svg_figure((PANEL.0 * cols as u32, (PANEL.1 + 40) * rows as u32), |c| {
        let areas = c.bounds().grid(rows, cols);
        for ((material, runs), &area) in materials.iter().zip(&areas) {
            let t0s = runs.iter().flat_map(|(_, c)| c.t0_s.iter());
            let (lo, hi) = t0s.fold((f64::INFINITY, 0.0_f64), |(lo, hi), &t| {
                (lo.min(t), hi.max(t))
            });
            let ys: Vec<f64> = runs
                .iter()
                .flat_map(|(_, c)| c.peak_n[0].iter().chain(&c.peak_n[2]).map(|f| f * MN))
                .collect();
            let mut panel = Panel::new(
                &format!("{material}: F_peak against t0"),
                Axis::log((lo, hi), "t0, short-time cut-off (s, log scale)"),
                Axis::linear(
                    range_of(ys.iter(), 0.05),
                    "peak static friction F_peak (mN)",
                ),
            );
            for (k, (run, curve)) in runs.iter().enumerate() {
                let fill = tint(k);
                panel.band(
                    curve.t0_s.clone(),
                    scaled(&curve.peak_n[0], MN),
                    scaled(&curve.peak_n[2], MN),
                    fill,
                    None,
                );
                let median: Vec<(f64, f64)> = curve
                    .t0_s
                    .iter()
                    .copied()
                    .zip(scaled(&curve.peak_n[1], MN))
                    .collect();
                let stroke = series_stroke(k, 2.0);
                panel.add(
                    Series::Line {
                        points: median,
                        stroke,
                    },
                    Some(LegendEntry::new(
                        format!("{run}: t0 varied (95 % band)"),
                        Swatch::LineOnFill(stroke, fill),
                    )),
                );
                let own: Vec<(f64, f64)> = curve.draws.iter().map(|&(t, f)| (t, f * MN)).collect();
                panel.markers(
                    own,
                    Marker::of(k),
                    ink(k),
                    Some(&format!("{run}: posterior draws")),
                );
            }
            panel.draw(c, area);
        }
    })
}

/// One row of a forest panel: a group's median, 50 % and 95 % intervals, in display units.
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
    /// 25 % and 75 % quantiles (NaN when the draws could not be read).
    pub quartiles: (f64, f64),
    /// Whether the group is a material (drawn black; contacts and runs grey).
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

const FOREST_ROW_PX: f64 = 26.0;
const FOREST_FRAME_PX: f64 = 96.0;
const FOREST_WIDTH: u32 = 980;
/// The 50 % bar is this thick and the 95 % bar thin: the median's dot fits inside the thick
/// bar, so that the intervals read before the dots.
const FOREST_THICK_PX: f64 = 7.0;
const FOREST_THIN_PX: f64 = 2.0;
const FOREST_DOT_PX: f64 = 2.0;
const CONTACT_GREY: Rgb = Rgb(125, 125, 125);

/// The forest plot: per quantity, each material and contact (or run) as a thick 50 % bar, a
/// thin 95 % bar and a white dot at the median; materials black, contacts and runs grey; the
/// numbers (median [95 %]) beside each row.
pub fn forest_figure(panels: &[ForestPanel]) -> String {
    let legend = vec![
        LegendEntry::new(
            "median",
            Swatch::Marker(Marker::Dot, Rgb::BLACK, FOREST_DOT_PX),
        ),
        LegendEntry::new(
            "50 % interval",
            Swatch::Line(Stroke::solid(Rgb::BLACK, FOREST_THICK_PX)),
        ),
        LegendEntry::new(
            "95 % interval",
            Swatch::Line(Stroke::solid(Rgb::BLACK, FOREST_THIN_PX)),
        ),
        LegendEntry::new("material", Swatch::Fill(Fill::solid(Rgb::BLACK))),
        LegendEntry::new("contact or run", Swatch::Fill(Fill::solid(CONTACT_GREY))),
    ];
    let width = f64::from(FOREST_WIDTH);
    let strip = row_height(&legend, width - 20.0) + 2.0 * GAP_PX;
    let heights: Vec<f64> = panels
        .iter()
        .map(|p| FOREST_FRAME_PX + FOREST_ROW_PX * p.rows.len() as f64)
        .collect();
    let total = strip + heights.iter().sum::<f64>();
    svg_figure((FOREST_WIDTH, total.ceil() as u32), |c| {
        draw_row(c, &Rect::new(10.0, GAP_PX, width - 10.0, strip), &legend);
        let mut y = strip;
        for (panel, &h) in panels.iter().zip(&heights) {
            forest_panel(c, Rect::new(0.0, y, width, y + h), panel);
            y += h;
        }
    })
}

/// `median [low, high]`, all to the decimal place of two significant digits of the nearer
/// bound's distance from the median.
fn interval_text(r: &ForestRow) -> String {
    match error_decimals((r.median - r.low).min(r.high - r.median)) {
        Some(d) => format!(
            "{} [{}, {}]",
            fixed(r.median, d),
            fixed(r.low, d),
            fixed(r.high, d)
        ),
        None => significant(r.median, 4),
    }
}

/// Decimals that show two significant digits of `error` (an uncertainty); `None` when it is
/// not positive.
fn error_decimals(error: f64) -> Option<usize> {
    (error > 0.0 && error.is_finite()).then(|| (1 - error.log10().floor() as i32).max(0) as usize)
}

/// `v` with `decimals` decimals and a true minus sign.
fn fixed(v: f64, decimals: usize) -> String {
    format!("{v:.decimals$}").replace('-', "−")
}

fn forest_panel(c: &mut Canvas, area: Rect, panel: &ForestPanel) {
    let n = panel.rows.len();
    let labels_w = panel
        .rows
        .iter()
        .map(|r| text_width(&r.label, TEXT_PX))
        .fold(0.0, f64::max);
    let values_w = panel
        .rows
        .iter()
        .map(|r| text_width(&interval_text(r), TEXT_PX))
        .fold(0.0, f64::max);
    let caption = line_height(CAPTION_PX);
    let inner = Rect::new(
        area.x0 + labels_w + 14.0,
        area.y0,
        area.x1 - values_w - 18.0,
        area.y1,
    );
    let xs: Vec<f64> = panel.rows.iter().flat_map(|r| [r.low, r.high]).collect();
    let x = Axis::linear(range_of(xs.iter(), 0.08), &panel.axis);
    let y = Axis::linear((-0.6, n as f64 - 0.4), "").showing(Show::Off);
    let keep = crate::plot::Margins {
        top: caption,
        ..Default::default()
    };
    let (plot, xt, yt) = fit_axes(inner, &x, &y, keep);
    draw_grid(
        c,
        &plot,
        &xt,
        &Ticks {
            minor: Vec::new(),
            values: Vec::new(),
            ..yt.clone()
        },
    );
    let mut series = Vec::new();
    for (i, row) in panel.rows.iter().enumerate() {
        let yv = (n - 1 - i) as f64;
        if let Some(py) = plot.y_px(yv) {
            c.grid_line(
                (plot.rect.x0, py),
                (plot.rect.x1, py),
                crate::plot::grid().0,
            );
            c.text(
                &row.label,
                (plot.rect.x0 - 8.0, py),
                Font::new(TEXT_PX, Anchor::new(HPos::Right, VPos::Center)),
            );
            c.text(
                &interval_text(row),
                (plot.rect.x1 + 10.0, py),
                Font::new(TEXT_PX, Anchor::new(HPos::Left, VPos::Center)),
            );
        }
        let color = if row.material {
            Rgb::BLACK
        } else {
            CONTACT_GREY
        };
        series.push(Series::Line {
            points: vec![(row.low, yv), (row.high, yv)],
            stroke: Stroke::solid(color, FOREST_THIN_PX),
        });
        series.push(Series::Line {
            points: vec![(row.quartiles.0, yv), (row.quartiles.1, yv)],
            stroke: Stroke::solid(color, FOREST_THICK_PX),
        });
        series.push(Series::Markers {
            points: vec![(row.median, yv)],
            marker: Marker::Dot,
            color,
            radius: FOREST_DOT_PX,
        });
    }
    draw_series(c, &plot, &series);
    draw_axes(c, &plot, (&x, &xt), (&y, &yt));
    let centre = 0.5 * (plot.rect.x0 + plot.rect.x1);
    c.text(
        &panel.title,
        (centre, area.y0 + 4.0),
        Font::new(CAPTION_PX, Anchor::new(HPos::Center, VPos::Top)),
    );
}

/// Rank counts of one parameter (ArviZ's `plot_rank`): its kept draws ranked among all
/// ensembles' kept draws, and per ensemble the count of its draws in each of equal bins of
/// rank.
#[derive(Debug, Clone, PartialEq)]
pub struct RankCounts {
    /// Number of ranks (kept draws of all ensembles).
    pub ranks: usize,
    /// `counts[ensemble][bin]`.
    pub counts: Vec<Vec<f64>>,
}

/// One row of the trace figure: a parameter's walkers per ensemble as drawn (every
/// [`trace_stride`]-th step) with the range of every step, and its rank counts.
#[derive(Debug, Clone, PartialEq)]
pub struct TracePanel {
    /// Title (parameter and unit).
    pub title: String,
    /// Steps of the run (the x axis spans them).
    pub steps: usize,
    /// `points[ensemble][walker]`: (step, value in display units) at every
    /// [`trace_stride`]`(steps)`-th step from step 0, for the walkers shown.
    pub points: Vec<Vec<Vec<(f64, f64)>>>,
    /// The finite range of the values of these walkers at every step, in display units
    /// (before padding; [`extend_bounds`](crate::plot::extend_bounds) folded over them).
    pub range: (f64, f64),
    /// Rank counts of the kept draws; `None` with one ensemble.
    pub ranks: Option<RankCounts>,
}

/// Most points drawn per walker line.
const TRACE_POINTS: usize = 150;

/// Steps between the points drawn of a trace of `steps` steps.
pub fn trace_stride(steps: usize) -> usize {
    steps.div_ceil(TRACE_POINTS).max(1)
}

const TRACE_ROW_PX: f64 = 170.0;
const TRACE_SPLIT: f64 = 0.62;

/// Trace plots beside rank plots, one parameter per row: on the left the walkers shown of
/// every ensemble (ensembles told apart by ink), the burn-in marked; on the right each
/// ensemble's histogram of ranks among all ensembles' kept draws, a dashed line at what
/// uniform ranks give. All rows share the step axis and the rank axis, labelled at the bottom.
pub fn trace_figure(panels: &[TracePanel], burn_in: u64, ensembles: usize) -> String {
    let mut legend: Vec<LegendEntry> = (0..ensembles)
        .map(|e| {
            LegendEntry::new(
                format!("ensemble {}", e + 1),
                Swatch::Line(Stroke::solid(ink(e), 2.0)),
            )
        })
        .collect();
    legend.push(LegendEntry::new(
        "end of burn-in",
        Swatch::Line(Stroke::solid(MARK, 1.5)),
    ));
    legend.push(LegendEntry::new(
        "uniform ranks (expected count)",
        Swatch::Line(Stroke::solid(Rgb::BLACK, 1.0).dashed(crate::plot::Dash::Short)),
    ));
    let strip = row_height(&legend, FIGURE_WIDTH - 20.0) + 2.0 * GAP_PX;
    let steps = panels.first().map_or(1, |p| p.steps).max(1);
    let step_axis = Axis::linear((0.0, steps as f64), "step");
    let ranks = panels
        .iter()
        .find_map(|p| p.ranks.as_ref())
        .map_or(1, |r| r.ranks);
    let rank_axis = Axis::linear((0.0, ranks as f64), "rank among all ensembles' kept draws");
    let line = line_height(TEXT_PX);
    // Room under the last row for the shared axes' labels and descriptions.
    let foot = TICK_FOOT + 3.0 * line;
    let height = strip + panels.len() as f64 * TRACE_ROW_PX + foot;
    svg_figure((FIGURE_WIDTH as u32, height.ceil() as u32), |c| {
        draw_row(
            c,
            &Rect::new(10.0, GAP_PX, FIGURE_WIDTH - 10.0, strip),
            &legend,
        );
        let trace_right = (FIGURE_WIDTH * TRACE_SPLIT).round();
        // Every row's value axis is labelled; the widest labels set a left edge for all, so
        // that the step axes line up.
        let plot_h = TRACE_ROW_PX - 2.0 * line - 2.0 * GAP_PX;
        let value_axes: Vec<(Axis, Ticks)> = panels
            .iter()
            .map(|p| {
                let axis = Axis::linear(crate::plot::padded(p.range, 0.05), "");
                let ticks = choose_ticks(&axis.scale, plot_h, false);
                (axis, ticks)
            })
            .collect();
        let step_ticks = choose_ticks(&step_axis.scale, trace_right - 140.0, true);
        let left = value_axes
            .iter()
            .map(|(a, t)| axis_margins((&step_axis, &step_ticks), (a, t), 500.0).left)
            .fold(0.0, f64::max)
            + 10.0;
        let trace_x = (left, trace_right - 16.0);
        let rank_ticks = choose_ticks(&rank_axis.scale, FIGURE_WIDTH - trace_right - 100.0, true);
        let rank_label_w = text_width(&ensembles.to_string(), TEXT_PX);
        let rank_x = (
            trace_right + 16.0 + line + 2.0 * GAP_PX + crate::plot::TICK_PX + rank_label_w,
            FIGURE_WIDTH
                - 10.0
                - 0.5
                    * rank_ticks
                        .labels
                        .last()
                        .map_or(0.0, |l| text_width(l, TEXT_PX)),
        );
        let ensemble_axis = Axis::linear((0.0, ensembles as f64), "ensemble");
        let ensemble_ticks = Ticks {
            values: (0..ensembles).map(|e| e as f64 + 0.275).collect(),
            labels: (0..ensembles).map(|e| (e + 1).to_string()).collect(),
            minor: Vec::new(),
            note: String::new(),
        };
        let last = panels.len().saturating_sub(1);
        for (i, (panel, (value_axis, value_ticks))) in panels.iter().zip(&value_axes).enumerate() {
            let top = strip + i as f64 * TRACE_ROW_PX + GAP_PX;
            let shared = if i == last { Show::Labels } else { Show::Ticks };
            let trace = Plot {
                rect: Rect::new(trace_x.0, top + line, trace_x.1, top + line + plot_h),
                x: step_axis.scale,
                y: value_axis.scale,
            };
            // The title over the trace, centred; a scale or offset note sits at its left.
            c.text(
                &panel.title,
                (0.5 * (trace.rect.x0 + trace.rect.x1), top),
                Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Top)).bold(),
            );
            draw_grid(c, &trace, &step_ticks, value_ticks);
            let mut series = Vec::new();
            for (e, walkers) in panel.points.iter().enumerate() {
                for pts in walkers {
                    series.push(Series::Line {
                        points: pts.clone(),
                        stroke: Stroke::solid(ink(e), 0.8).faded(0.6),
                    });
                }
            }
            let (v0, v1) = value_axis.scale.range();
            series.push(Series::Line {
                points: vec![(burn_in as f64, v0), (burn_in as f64, v1)],
                stroke: Stroke::solid(MARK, 1.5),
            });
            draw_series(c, &trace, &series);
            let step = Axis {
                show: shared,
                ..step_axis.clone()
            };
            draw_axes(c, &trace, (&step, &step_ticks), (value_axis, value_ticks));

            if let Some(r) = &panel.ranks {
                let rank = Plot {
                    rect: Rect::new(rank_x.0, trace.rect.y0, rank_x.1, trace.rect.y1),
                    x: rank_axis.scale,
                    y: ensemble_axis.scale,
                };
                c.text(
                    &format!("ranks of {}", panel.title),
                    (0.5 * (rank.rect.x0 + rank.rect.x1), top),
                    Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Top)),
                );
                draw_series(c, &rank, &rank_series(r));
                let rank_show = Axis {
                    show: shared,
                    ..rank_axis.clone()
                };
                draw_axes(
                    c,
                    &rank,
                    (&rank_show, &rank_ticks),
                    (&ensemble_axis, &ensemble_ticks),
                );
            }
        }
    })
}

/// Room under a plot area for tick marks and their labels (pixels).
const TICK_FOOT: f64 = 2.0 * GAP_PX + 5.0;

/// Bars of each ensemble's rank histogram on its own row (row e spans e to e + 1; a bar of
/// the expected count is half a row high) and the dashed expected count.
fn rank_series(r: &RankCounts) -> Vec<Series> {
    let mut out = Vec::new();
    let bins = r.counts.first().map_or(1, Vec::len).max(1);
    let width = r.ranks as f64 / bins as f64;
    for (e, counts) in r.counts.iter().enumerate() {
        let expected = counts.iter().sum::<f64>() / bins as f64;
        let base = e as f64 + 0.05;
        let scale = if expected > 0.0 { 0.45 / expected } else { 0.0 };
        let bars: Vec<((f64, f64), f64)> = counts
            .iter()
            .enumerate()
            .map(|(b, &n)| {
                (
                    (b as f64 * width, (b + 1) as f64 * width),
                    (base + n * scale).min(e as f64 + 0.97),
                )
            })
            .collect();
        out.push(Series::Bars {
            bars,
            base,
            fill: Fill::translucent(ink(e), 0.75),
        });
        out.push(Series::Line {
            points: vec![(0.0, base + 0.45), (r.ranks as f64, base + 0.45)],
            stroke: Stroke::solid(Rgb::BLACK, 1.0).dashed(crate::plot::Dash::Short),
        });
    }
    out
}

/// What a corner plot draws of one quantity's kept draws (display units): its range, its
/// histogram, its 16, 50 and 84 % quantiles and, for synthetic data, its true value. Built
/// one quantity at a time, so that the figure holds a few numbers per quantity, never the
/// draws.
#[derive(Debug, Clone, PartialEq)]
pub struct CornerColumn {
    /// Axis label with unit.
    pub name: String,
    /// Range shown: the draws between their 0.05 and 99.95 % quantiles and the true value,
    /// padded.
    pub range: (f64, f64),
    /// Counts of the draws in [`BINS`] equal bins over the range.
    pub hist: Vec<f64>,
    /// 16, 50 and 84 % quantiles.
    pub quantiles: [f64; 3],
    /// The simulation's true value, when known.
    pub truth: Option<f64>,
}

/// A corner plot's numbers: its columns, and the 2-D histogram of every pair.
#[derive(Debug, Clone, PartialEq)]
pub struct CornerData {
    /// One per quantity.
    pub columns: Vec<CornerColumn>,
    /// For rows i > j, in the order (1, 0), (2, 0), (2, 1), (3, 0), …: the histogram of
    /// (quantity j, quantity i).
    pub pairs: Vec<Histogram2d>,
}

impl CornerData {
    /// The histogram of (quantity `j`, quantity `i`), `i > j`.
    pub fn pair(&self, i: usize, j: usize) -> &Histogram2d {
        &self.pairs[i * (i - 1) / 2 + j]
    }
}

/// `median +up −down` with two significant digits of the smaller error, the median to the
/// same decimal place.
pub fn median_with_errors([q16, q50, q84]: [f64; 3]) -> String {
    let (down, up) = (q50 - q16, q84 - q50);
    match error_decimals(down.min(up)) {
        Some(d) => format!("{} +{} −{}", fixed(q50, d), fixed(up, d), fixed(down, d)),
        None => significant(q50, 4),
    }
}

/// Fills of the 2-D contours, outermost (2 σ) first.
const CONTOUR_FILLS: [Rgb; 4] = [
    Rgb(228, 228, 228),
    Rgb(198, 198, 198),
    Rgb(160, 160, 160),
    Rgb(115, 115, 115),
];
const TRUTH: Rgb = Rgb(0, 100, 200);
const CORNER_GAP: f64 = 24.0;
/// Room for a diagonal panel's two-line title between rows (pixels).
const CORNER_ROW_GAP: f64 = 40.0;

/// A corner plot (corner.py's layout): on the diagonal each quantity's histogram with dashed
/// lines at its 16, 50 and 84 % quantiles and `median +up −down` above it; below the diagonal
/// each pair's smoothed 2-D histogram as filled contours at 0.5, 1, 1.5 and 2 σ; the true
/// values as lines when every one of them is known; equal square panels, the axes labelled
/// on the bottom row and the left column.
///
/// # Errors
/// [`DrawError`] when there are fewer than two quantities.
pub fn corner_figure(name: &str, data: &CornerData) -> Result<String, DrawError> {
    let cols = &data.columns;
    let n = cols.len();
    if n < 2 {
        return Err(DrawError::new(name, "a corner plot needs two quantities"));
    }
    let truths = cols.iter().all(|c| c.truth.is_some());
    let line = line_height(TEXT_PX);
    let mut legend = vec![
        LegendEntry::new(
            "posterior: 0.5, 1, 1.5, 2σ contours",
            Swatch::Fill(Fill::solid(CONTOUR_FILLS[1])),
        ),
        LegendEntry::new(
            "16, 50, 84 % quantiles",
            Swatch::Line(Stroke::solid(Rgb::BLACK, 1.0).dashed(crate::plot::Dash::Dashed)),
        ),
    ];
    if truths {
        legend.push(LegendEntry::new(
            "simulation's true value",
            Swatch::Line(Stroke::solid(TRUTH, 1.5)),
        ));
    }
    // Equal square panels in the width left by the left column's labels.
    let cell = ((FIGURE_WIDTH - 130.0 - (n - 1) as f64 * CORNER_GAP) / n as f64).min(210.0);
    let x_ticks: Vec<Ticks> = cols
        .iter()
        .map(|c| choose_ticks(&Scale::linear(c.range), cell, true))
        .collect();
    let y_ticks: Vec<Ticks> = cols
        .iter()
        .map(|c| choose_ticks(&Scale::linear(c.range), cell, false))
        .collect();
    // Each quantity's name, wrapped to a cell: under its column and beside its row.
    let descs: Vec<Vec<String>> = cols.iter().map(|c| wrap(&c.name, TEXT_PX, cell)).collect();
    let y_label_w = y_ticks[1..]
        .iter()
        .flat_map(|t| t.labels.iter())
        .map(|l| text_width(l, TEXT_PX))
        .fold(0.0, f64::max);
    let y_desc_lines = descs[1..].iter().map(Vec::len).max().unwrap_or(1) as f64;
    let left = 10.0 + y_desc_lines * line + 2.0 * GAP_PX + y_label_w + crate::plot::TICK_PX;
    let has_x_note = x_ticks.iter().any(|t| !t.note.is_empty());
    let x_desc_lines = descs.iter().map(Vec::len).max().unwrap_or(1) as f64;
    let bottom = crate::plot::TICK_PX
        + GAP_PX
        + line
        + if has_x_note { GAP_PX + line } else { 0.0 }
        + GAP_PX
        + x_desc_lines * line
        + 10.0;
    let top = CORNER_ROW_GAP;
    let size = (
        left + n as f64 * cell + (n - 1) as f64 * CORNER_GAP + 0.5 * cell.min(90.0),
        top + n as f64 * cell + (n - 1) as f64 * CORNER_ROW_GAP + bottom,
    );
    let (legend_w, legend_h) = box_size(&legend);
    // The legend goes into the empty upper triangle when it fits there, else under the plot.
    let triangle = Rect::new(
        left + cell + CORNER_GAP,
        top,
        size.0 - 10.0,
        top + (n - 1) as f64 * (cell + CORNER_ROW_GAP) - CORNER_ROW_GAP,
    );
    let legend_inside = legend_w <= triangle.width() && legend_h <= triangle.height();
    let size = if legend_inside {
        size
    } else {
        (size.0, size.1 + legend_h + 10.0)
    };
    Ok(svg_figure(
        (size.0.ceil() as u32, size.1.ceil() as u32),
        |c| {
            let rect_of = |i: usize, j: usize| {
                let x0 = left + j as f64 * (cell + CORNER_GAP);
                let y0 = top + i as f64 * (cell + CORNER_ROW_GAP);
                Rect::new(x0, y0, x0 + cell, y0 + cell)
            };
            for i in 0..n {
                for j in 0..=i {
                    let rect = rect_of(i, j);
                    let (cx, cy) = (&cols[j], &cols[i]);
                    let x_show = if i == n - 1 {
                        Show::Labels
                    } else {
                        Show::Ticks
                    };
                    let x_axis = Axis {
                        scale: Scale::linear(cx.range),
                        desc: String::new(),
                        show: x_show,
                    };
                    if i == j {
                        let top_count = cx.hist.iter().copied().fold(0.0, f64::max).max(1.0);
                        let plot = Plot {
                            rect,
                            x: Scale::linear(cx.range),
                            y: Scale::linear((0.0, 1.1 * top_count)),
                        };
                        let off = Axis::linear((0.0, 1.0), "").showing(Show::Off);
                        draw_series(c, &plot, &diagonal_series(cx, truths));
                        draw_axes(c, &plot, (&x_axis, &x_ticks[j]), (&off, &y_ticks[i]));
                        let title = [cx.name.clone(), median_with_errors(cx.quantiles)];
                        for (k, t) in title.iter().enumerate() {
                            c.text(
                                t,
                                (
                                    0.5 * (rect.x0 + rect.x1),
                                    rect.y0 - GAP_PX - (1 - k) as f64 * line,
                                ),
                                Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Bottom)),
                            );
                        }
                    } else {
                        let plot = Plot {
                            rect,
                            x: Scale::linear(cx.range),
                            y: Scale::linear(cy.range),
                        };
                        let y_axis = Axis {
                            scale: Scale::linear(cy.range),
                            desc: String::new(),
                            show: if j == 0 { Show::Labels } else { Show::Ticks },
                        };
                        draw_series(c, &plot, &pair_series(data.pair(i, j), cx, cy, truths));
                        draw_axes(c, &plot, (&x_axis, &x_ticks[j]), (&y_axis, &y_ticks[i]));
                    }
                    // Descriptions: under the bottom row, left of the left column.
                    if i == n - 1 {
                        let mut below = rect.y1 + crate::plot::TICK_PX + GAP_PX + line;
                        if has_x_note {
                            below += GAP_PX + line;
                        }
                        for (k, l) in descs[j].iter().enumerate() {
                            c.text(
                                l,
                                (0.5 * (rect.x0 + rect.x1), below + GAP_PX + k as f64 * line),
                                Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Top)),
                            );
                        }
                    }
                    if j == 0 && i > 0 {
                        let lines = &descs[i];
                        for (k, l) in lines.iter().enumerate() {
                            let x = 10.0 + (k as f64 + 0.5) * line;
                            c.text(
                                l,
                                (x, 0.5 * (rect.y0 + rect.y1)),
                                Font::new(TEXT_PX, Anchor::new(HPos::Center, VPos::Center))
                                    .rotated(crate::plot::text::Rotation::ThreeQuarters),
                            );
                        }
                    }
                }
            }
            if legend_inside {
                draw_box(c, (triangle.x1 - legend_w, triangle.y0), &legend);
            } else {
                draw_box(c, (left, size.1 - legend_h - 6.0), &legend);
            }
        },
    ))
}

/// The diagonal: histogram as steps, quantile lines, the true value.
fn diagonal_series(col: &CornerColumn, truth: bool) -> Vec<Series> {
    let (lo, hi) = col.range;
    let w = (hi - lo) / BINS as f64;
    let mut steps = Vec::with_capacity(2 * col.hist.len() + 2);
    steps.push((lo, 0.0));
    for (b, &count) in col.hist.iter().enumerate() {
        steps.push((lo + b as f64 * w, count));
        steps.push((lo + (b + 1) as f64 * w, count));
    }
    steps.push((hi, 0.0));
    let top = col.hist.iter().copied().fold(0.0, f64::max) * 1.05;
    let mut out = vec![
        Series::Area {
            points: steps.clone(),
            fill: Some(Fill::solid(Rgb(232, 232, 232))),
            stroke: None,
        },
        Series::Line {
            points: steps,
            stroke: Stroke::solid(Rgb::BLACK, 1.2),
        },
    ];
    for q in col.quantiles {
        out.push(Series::Line {
            points: vec![(q, 0.0), (q, top)],
            stroke: Stroke::solid(Rgb::BLACK, 1.0).dashed(crate::plot::Dash::Dashed),
        });
    }
    if let (true, Some(t)) = (truth, col.truth) {
        out.push(Series::Line {
            points: vec![(t, 0.0), (t, top * 2.0)],
            stroke: Stroke::solid(TRUTH, 1.5),
        });
    }
    out
}

/// Below the diagonal: filled contours, their outlines, the true values.
fn pair_series(h: &Histogram2d, cx: &CornerColumn, cy: &CornerColumn, truth: bool) -> Vec<Series> {
    let mut out = Vec::new();
    for (k, (_, loops)) in h.contours().into_iter().enumerate() {
        for l in loops {
            out.push(Series::Area {
                points: l,
                fill: Some(Fill::solid(CONTOUR_FILLS[k.min(3)])),
                stroke: Some(Stroke::solid(Rgb(60, 60, 60), 0.8)),
            });
        }
    }
    if let (true, Some(tx), Some(ty)) = (truth, cx.truth, cy.truth) {
        let stroke = Stroke::solid(TRUTH, 1.5);
        out.push(Series::Line {
            points: vec![(tx, cy.range.0), (tx, cy.range.1)],
            stroke,
        });
        out.push(Series::Line {
            points: vec![(cx.range.0, ty), (cx.range.1, ty)],
            stroke,
        });
        out.push(Series::Markers {
            points: vec![(tx, ty)],
            marker: Marker::Square,
            color: TRUTH,
            radius: 4.0,
        });
    }
    out
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

    #[test]
    fn forest_numbers_share_their_decimals() {
        let row = ForestRow {
            label: "c1".into(),
            median: 10.0,
            low: 9.9977,
            high: 10.0023,
            quartiles: (9.999, 10.001),
            material: false,
        };
        assert_eq!(interval_text(&row), "10.0000 [9.9977, 10.0023]");
    }

    #[test]
    fn medians_carry_their_errors() {
        assert_eq!(
            median_with_errors([0.9205, 0.9216, 0.9228]),
            "0.9216 +0.0012 −0.0011"
        );
        assert_eq!(
            median_with_errors([11998.1, 12003.4, 12008.9]),
            "12003.4 +5.5 −5.3"
        );
        assert_eq!(median_with_errors([1.0, 1.0, 1.0]), "1.000");
    }
}
