//! The peak static friction: its posterior density and its dependence on t0.

use super::*;

/// One panel of the peak density figure: title, the density of the F_peak draws in mN
/// ([`peak_density`]), and (2.5 %, 50 %, 97.5 %) in N.
pub(crate) type PeakDraws = (String, (Vec<f64>, Vec<f64>), [f64; 3]);

/// The density a panel of [`peak_density_figure`] draws, of F_peak draws in N: what a panel
/// keeps of its draws, so that the figure holds no draws.
pub(crate) fn peak_density(draws_n: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let mn: Vec<f64> = draws_n.iter().map(|f| f * MN).collect();
    kernel_density(&mn, 200)
}

/// Posterior density of the peak static friction, one panel per run and per material mean:
/// the density, its 95 % interval shaded under it, and the median as a dashed line. The
/// density leaves the top third of each panel free for the legend.
pub(crate) fn peak_density_figure(panels: &[PeakDraws]) -> String {
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
pub(crate) fn peak_t0_figure(materials: &[(String, Vec<(String, PeakVsT0)>)]) -> String {
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
