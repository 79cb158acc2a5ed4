//! Rank histograms as one small SVG: a panel per quantity, bars of binned ranks over the grey
//! band where 99 % of bars fall when ranks are uniform (Talts et al. 2018, Fig. 1).
//!
//! Written by hand rather than with a plotting crate: a few rectangles and labels need no
//! dependency and no font library.

use std::fmt::Write;

use super::stats::{binomial_band, Uniformity, BAND_TAIL};

const PANEL_W: f64 = 260.0;
const PANEL_H: f64 = 170.0;
const MARGIN: f64 = 28.0;
const COLUMNS: usize = 3;

fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// One SVG document with a histogram panel per `(label, uniformity)` of `n` replications.
pub fn rank_histograms(panels: &[(String, &Uniformity)], n: usize, title: &str) -> String {
    let rows = panels.len().div_ceil(COLUMNS).max(1);
    let (width, height) = (COLUMNS as f64 * PANEL_W, rows as f64 * PANEL_H + MARGIN);
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" viewBox="0 0 {width} {height}" font-family="sans-serif">"#
    );
    let _ = writeln!(
        svg,
        r#"<rect width="{width}" height="{height}" fill="white"/><text x="{}" y="18" font-size="14" text-anchor="middle">{}</text>"#,
        width / 2.0,
        escape(title)
    );
    for (i, (label, u)) in panels.iter().enumerate() {
        let x0 = (i % COLUMNS) as f64 * PANEL_W + MARGIN;
        let y0 = (i / COLUMNS) as f64 * PANEL_H + MARGIN + 18.0;
        let (w, h) = (PANEL_W - 1.5 * MARGIN, PANEL_H - 2.2 * MARGIN);
        let bins = u.counts.len();
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
        let y = |c: f64| y0 + h - h * c / top;
        let _ = writeln!(
            svg,
            r##"<rect x="{x0}" y="{:.1}" width="{w}" height="{:.1}" fill="#dddddd"/>"##,
            y(band_hi as f64),
            y(band_lo as f64) - y(band_hi as f64)
        );
        let bar_w = w / bins as f64;
        for (b, &c) in u.counts.iter().enumerate() {
            let _ = writeln!(
                svg,
                r##"<rect x="{:.1}" y="{:.1}" width="{:.1}" height="{:.1}" fill="#4a78b5" stroke="white" stroke-width="0.5"/>"##,
                x0 + b as f64 * bar_w,
                y(c as f64),
                bar_w,
                y0 + h - y(c as f64)
            );
        }
        let expected = n as f64 / bins as f64;
        let _ = writeln!(
            svg,
            r#"<line x1="{x0}" x2="{:.1}" y1="{:.1}" y2="{:.1}" stroke="black" stroke-dasharray="3,2"/>"#,
            x0 + w,
            y(expected),
            y(expected)
        );
        let _ = writeln!(
            svg,
            r#"<line x1="{x0}" x2="{:.1}" y1="{:.1}" y2="{:.1}" stroke="black"/><text x="{:.1}" y="{:.1}" font-size="12" text-anchor="middle">{}</text><text x="{:.1}" y="{:.1}" font-size="10" text-anchor="middle">rank (χ² p = {:.3})</text>"#,
            x0 + w,
            y0 + h,
            y0 + h,
            x0 + w / 2.0,
            y0 - 6.0,
            escape(label),
            x0 + w / 2.0,
            y0 + h + 14.0,
            u.p_value
        );
    }
    svg.push_str("</svg>\n");
    svg
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_bar_per_bin_and_a_band_per_panel() {
        let u = Uniformity::test(&(0..100).collect::<Vec<_>>(), 99);
        let svg = rank_histograms(&[("a<b".into(), &u), ("t0".into(), &u)], 100, "SBC");
        assert_eq!(svg.matches("fill=\"#4a78b5\"").count(), 2 * u.counts.len());
        assert_eq!(svg.matches("fill=\"#dddddd\"").count(), 2);
        assert!(svg.contains("a&lt;b") && svg.ends_with("</svg>\n"));
    }
}
