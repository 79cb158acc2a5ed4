//! Rank histograms as one SVG figure on the crate's plotting layer ([`slipbayes::plot`]): a panel
//! per quantity, bars of binned ranks over the grey band where 99 % of bars fall when ranks
//! are uniform (Talts et al. 2018, Fig. 1), and a dashed line at the expected count.

use plotters::prelude::*;

use super::stats::{binomial_band, Uniformity, BAND_TAIL};
use slipbayes::plot::{
    band, band_fills, bars, caption_font, chart, ink, panel_grid, styled_line, svg_figure, Dash,
    DrawError, Drawn, Frame,
};

/// The figure's name in drawing errors.
pub const FIGURE: &str = "rank_histograms.svg";
/// Size of one panel (pixels).
const PANEL: (u32, u32) = (300, 220);
/// Height of the strip holding the figure's title (pixels).
const TITLE_HEIGHT: u32 = 34;
/// Panels per row.
const COLUMNS: usize = 3;

/// One SVG document with a histogram panel per `(label, uniformity)` of `n` replications,
/// laid out in rows of three under `title`.
///
/// # Errors
/// [`DrawError`] when the backend fails.
pub fn rank_histograms(
    panels: &[(String, &Uniformity)],
    n: usize,
    title: &str,
) -> Result<String, DrawError> {
    let (rows, _) = panel_grid(panels.len(), COLUMNS);
    let size = (
        PANEL.0 * COLUMNS as u32,
        PANEL.1 * rows as u32 + TITLE_HEIGHT,
    );
    svg_figure(FIGURE, size, |root| {
        let (head, body) = root.split_vertically(TITLE_HEIGHT);
        head.titled(title, caption_font()).drawn(FIGURE)?;
        let areas = body.split_evenly((rows, COLUMNS));
        for ((label, u), area) in panels.iter().zip(&areas) {
            histogram(area, label, u, n)?;
        }
        Ok(())
    })
}

/// One panel: ranks on x (each bar spans the ranks of its bin), counts on y.
fn histogram(
    area: &slipbayes::plot::Area,
    label: &str,
    u: &Uniformity,
    n: usize,
) -> Result<(), DrawError> {
    let bins = u.counts.len().max(1);
    let per_bin = u.ranks_per_bin.max(1) as f64;
    let ranks = bins as f64 * per_bin;
    let [band_lo, band_hi] = binomial_band(n, 1.0 / bins as f64, BAND_TAIL);
    let top = u
        .counts
        .iter()
        .copied()
        .max()
        .unwrap_or(0)
        .max(band_hi)
        .max(1) as f64
        * 1.1;
    let mut chart = chart(
        area,
        FIGURE,
        &Frame::SMALL,
        label,
        (0.0..ranks, &format!("rank (χ² p = {:.3})", u.p_value)),
        (0.0..top, "count"),
    )?;
    band(
        &mut chart,
        FIGURE,
        &[0.0, ranks],
        &[band_lo as f64; 2],
        &[band_hi as f64; 2],
        band_fills().0,
        None,
    )?;
    let bars_of_bins: Vec<((f64, f64), f64)> = u
        .counts
        .iter()
        .enumerate()
        .map(|(b, &c)| ((b as f64 * per_bin, (b + 1) as f64 * per_bin), c as f64))
        .collect();
    bars(&mut chart, FIGURE, &bars_of_bins, ink(1), None)?;
    let expected = n as f64 / bins as f64;
    styled_line(
        &mut chart,
        FIGURE,
        vec![(0.0, expected), (ranks, expected)],
        BLACK.stroke_width(1),
        Dash::Short,
        None,
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Attribute `fill="#RRGGBB"` of a colour as plotters' SVG backend writes it.
    fn fill(c: RGBColor) -> String {
        format!("fill=\"#{:02X}{:02X}{:02X}\"", c.0, c.1, c.2)
    }

    #[test]
    fn one_bar_per_bin_and_a_band_per_panel() {
        let wide = Uniformity::test(&(0..100).collect::<Vec<_>>(), 99);
        let narrow = Uniformity::test(&(0..30).map(|r| 3 * r).collect::<Vec<_>>(), 99);
        assert_eq!((wide.counts.len(), narrow.counts.len()), (20, 5));
        let svg = rank_histograms(
            &[("a<b & c".into(), &wide), ("t0".into(), &narrow)],
            100,
            "SBC <ranks>",
        )
        .unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        let bar = fill(ink(1));
        let bars = svg
            .lines()
            .filter(|l| l.starts_with("<rect") && l.contains(&bar))
            .count();
        assert_eq!(bars, 20 + 5);
        let grey = band_fills().0;
        let grey = fill(RGBColor(grey.0, grey.1, grey.2));
        let bands = svg
            .lines()
            .filter(|l| l.starts_with("<polygon") && l.contains(&grey))
            .count();
        assert_eq!(bands, 2);
        // The expected count as a dashed line: many short segments per panel.
        assert!(svg.matches("<polyline").count() > 2 * 10);
        for text in [
            "a&lt;b &amp; c",
            "SBC &lt;ranks&gt;",
            "t0",
            "rank (χ² p = 1.000)",
        ] {
            assert!(svg.contains(text), "{text} missing");
        }
        assert!(!svg.contains("a<b"));
    }
}
