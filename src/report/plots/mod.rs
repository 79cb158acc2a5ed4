//! The report's figures: fits in observed time, interface time and sliding distance, the
//! peak's density and its dependence on t0, the material forest plot, traces with rank plots,
//! and corner plots. Values arrive in SI and are shown in mN, µm, µm⁻¹, s. One file per
//! family of figures; what they share (units, a run's name, the figures' width) is here.

mod corner;
mod fit;
mod forest;
mod peak;
mod trace;

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
pub(crate) struct RunView {
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
pub(crate) fn velocity_text(v: f64) -> String {
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

pub(crate) use corner::{corner_figure, CornerColumn, CornerData};
pub(crate) use fit::{distance_figure, fit_figure, overlay_figure};
pub(crate) use forest::{forest_figure, ForestPanel, ForestRow, FOREST_LISTED_ROWS};
pub(crate) use peak::{peak_density, peak_density_figure, peak_t0_figure, PeakDraws};
pub(crate) use trace::{trace_figure, trace_stride, RankCounts, TracePanel};

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
