//! The one palette: series inks, band and grid greys, line dashes and fonts.

use plotters::prelude::*;

/// Width and height of one standard panel, in pixels.
pub const PANEL: (u32, u32) = (560, 380);
/// Font family of every text: plotters' naive metrics assume nothing more specific.
pub const FONT: &str = "sans-serif";
pub(super) const CAPTION_SIZE: u32 = 17;
pub(super) const LABEL_SIZE: u32 = 14;
pub(super) const LEGEND_SIZE: u32 = 13;
const SMALL_SIZE: u32 = 12;

/// Series inks: dark to light, so that they also differ in grey.
const INKS: [RGBColor; 4] = [
    RGBColor(0, 0, 0),
    RGBColor(0, 90, 170),
    RGBColor(205, 110, 0),
    RGBColor(110, 110, 110),
];
/// The 95 % band (light) and the 50 % band (darker).
const BAND_95: RGBColor = RGBColor(215, 215, 215);
const BAND_50: RGBColor = RGBColor(160, 160, 160);
const GRID_LIGHT: RGBColor = RGBColor(246, 246, 246);
const GRID_BOLD: RGBColor = RGBColor(215, 215, 215);

/// Line style of series `k`: solid, dashed, dotted, dash-dot (then again).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Dash {
    /// Solid.
    Solid,
    /// Long dashes.
    Dashed,
    /// Dots.
    Dotted,
    /// Short dashes.
    Short,
}

impl Dash {
    /// The style of series `k`.
    pub fn of(k: usize) -> Self {
        [Self::Solid, Self::Dashed, Self::Dotted, Self::Short][k % 4]
    }

    /// Dash length and gap in pixels; `None` for solid.
    pub fn pattern(self) -> Option<(u32, u32)> {
        match self {
            Self::Solid => None,
            Self::Dashed => Some((9, 5)),
            Self::Dotted => Some((2, 4)),
            Self::Short => Some((5, 3)),
        }
    }
}

/// Ink of series `k` (four inks, then again; marker shapes and dashes repeat with them).
pub fn ink(k: usize) -> RGBColor {
    INKS[k % INKS.len()]
}

/// A translucent fill of series `k`'s ink, for overlapping bands.
pub fn tint(k: usize) -> RGBAColor {
    ink(k).mix(0.16)
}

/// The light (95 %) and darker (50 %) band fills.
pub fn band_fills() -> (RGBAColor, RGBAColor) {
    (BAND_95.to_rgba(), BAND_50.to_rgba())
}

/// Grid line styles (light, bold).
pub fn grid() -> (RGBColor, RGBColor) {
    (GRID_LIGHT, GRID_BOLD)
}

/// Font of small panels (corner plots, traces, rank histograms).
pub fn small_font() -> (&'static str, u32) {
    (FONT, SMALL_SIZE)
}

/// Font of captions.
pub fn caption_font() -> (&'static str, u32) {
    (FONT, CAPTION_SIZE)
}

/// Font of axis labels.
pub fn label_font() -> (&'static str, u32) {
    (FONT, LABEL_SIZE)
}
