//! A run's fit to its data in observed and interface time, fits overlaid, and a contact's
//! slides against sliding distance.

use super::*;

/// Height of the residual strip under a fit.
const RESIDUAL_HEIGHT: u32 = 230;

/// Data in observed time with the posterior median and the 50 %/95 % predictive bands; for a
/// slide with a law, a second panel in interface time with the elastic part removed; under
/// them the residuals.
pub(crate) fn fit_figure(
    run: &RunView,
    predictive: &Band,
    curve: Option<&InterfaceCurve>,
) -> String {
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
pub(crate) fn overlay_figure(run: &str, fits: &[(&str, &Band)]) -> String {
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
pub(crate) fn distance_figure(
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
