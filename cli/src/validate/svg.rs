//! Rank histograms as one SVG figure on the crate's plotting layer ([`slipbayes::plot`]): a panel
//! per quantity, bars of binned ranks over the grey band where 99 % of bars fall when ranks
//! are uniform (Talts et al. 2018, Fig. 1), and a dashed line at the expected count.

use super::stats::{binomial_band, Uniformity, BAND_TAIL};
use slipbayes::plot::{
    band_fills, ink, panel_grid, svg_figure, text::Anchor, text::HPos, text::VPos, Axis, Canvas,
    Dash, Fill, Font, LegendAt, Panel, Rect, Rgb, Series, Stroke, CAPTION_PX,
};

/// Size of one panel (pixels).
const PANEL: (u32, u32) = (300, 220);
/// Height of the strip holding the figure's title (pixels).
const TITLE_HEIGHT: u32 = 34;
/// Panels per row.
const COLUMNS: usize = 3;

/// One SVG document with a histogram panel per `(label, uniformity)` of `n` replications,
/// laid out in rows of three under `title`.
pub fn rank_histograms(panels: &[(String, &Uniformity)], n: usize, title: &str) -> String {
    let (rows, _) = panel_grid(panels.len(), COLUMNS);
    let size = (
        PANEL.0 * COLUMNS as u32,
        PANEL.1 * rows as u32 + TITLE_HEIGHT,
    );
    svg_figure(size, |c| {
        let (head, body) = c.bounds().split_top(f64::from(TITLE_HEIGHT));
        c.text(
            title,
            (0.5 * (head.x0 + head.x1), head.y0 + 8.0),
            Font::new(CAPTION_PX, Anchor::new(HPos::Center, VPos::Top)),
        );
        for ((label, u), area) in panels.iter().zip(body.grid(rows, COLUMNS)) {
            histogram(c, area, label, u, n);
        }
    })
}

/// One panel: ranks on x (each bar spans the ranks of its bin), counts on y.
fn histogram(c: &mut Canvas, area: Rect, label: &str, u: &Uniformity, n: usize) {
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
    let mut panel = Panel::new(
        label,
        Axis::linear((0.0, ranks), &format!("rank (χ² p = {:.3})", u.p_value)),
        Axis::linear((0.0, top), "count"),
    );
    panel.legend_at = LegendAt::Nowhere;
    panel.band(
        vec![0.0, ranks],
        vec![band_lo as f64; 2],
        vec![band_hi as f64; 2],
        band_fills().0,
        None,
    );
    let bars_of_bins: Vec<((f64, f64), f64)> = u
        .counts
        .iter()
        .enumerate()
        .map(|(b, &c)| ((b as f64 * per_bin, (b + 1) as f64 * per_bin), c as f64))
        .collect();
    panel.add(
        Series::Bars {
            bars: bars_of_bins,
            base: 0.0,
            fill: Fill::solid(ink(1)),
        },
        None,
    );
    let expected = n as f64 / bins as f64;
    panel.line(
        vec![(0.0, expected), (ranks, expected)],
        Stroke::solid(Rgb::BLACK, 1.0).dashed(Dash::Short),
        None,
    );
    panel.draw(c, area);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Attribute `fill="#RRGGBB"` of a colour as the SVG writer writes it.
    fn fill(c: Rgb) -> String {
        format!("fill=\"{c}\"")
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
        );
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        let bar = fill(ink(1));
        let bars = svg
            .lines()
            .filter(|l| l.starts_with("<rect") && l.contains(&bar))
            .count();
        assert_eq!(bars, 20 + 5);
        let grey = fill(band_fills().0.color);
        let bands = svg
            .lines()
            .filter(|l| l.starts_with("<polygon") && l.contains(&grey))
            .count();
        assert_eq!(bands, 2);
        // The expected count as a dashed line, one per panel.
        assert_eq!(svg.matches("stroke-dasharray").count(), 2);
        // Every axis labelled, no text over the bars.
        let check = slipbayes::plot::check::check_svg(&svg);
        assert!(check.problems.is_empty(), "{:#?}", check.problems);
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
