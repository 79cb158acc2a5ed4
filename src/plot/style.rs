//! The one palette: series inks, band and grid greys, line dashes and text sizes.

use std::fmt;

use super::svg::{Fill, Stroke};

/// Font family of every text: the browser's sans-serif ([`text`](super::text) estimates its
/// widths).
pub(crate) const FONT: &str = "sans-serif";
/// Size of tick labels, legends and axis descriptions (CSS pixels at scale 1): readable at 1×.
pub const TEXT_PX: f64 = 12.0;
/// Size of captions.
pub const CAPTION_PX: f64 = 14.0;
/// No text of a figure is smaller than this (CSS pixels at scale 1).
pub(crate) const MIN_TEXT_PX: f64 = 11.0;
/// The widest figure a report shows at its own size (the page's content width, pixels).
pub(crate) const MAX_FIGURE_WIDTH: u32 = 1200;
/// Width and height of one standard panel, in pixels.
pub const PANEL: (u32, u32) = (560, 380);

/// A colour.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Rgb(pub u8, pub u8, pub u8);

impl Rgb {
    /// Black.
    pub const BLACK: Rgb = Rgb(0, 0, 0);
    /// White.
    pub(crate) const WHITE: Rgb = Rgb(255, 255, 255);
}

impl fmt::Display for Rgb {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "#{:02X}{:02X}{:02X}", self.0, self.1, self.2)
    }
}

/// Series inks: dark to light, so that they also differ in grey.
const INKS: [Rgb; 4] = [
    Rgb(0, 0, 0),
    Rgb(0, 90, 170),
    Rgb(205, 110, 0),
    Rgb(110, 110, 110),
];
/// The 95 % band (light) and the 50 % band (darker).
const BAND_95: Rgb = Rgb(215, 215, 215);
const BAND_50: Rgb = Rgb(160, 160, 160);
const GRID_LIGHT: Rgb = Rgb(243, 243, 243);
const GRID_BOLD: Rgb = Rgb(218, 218, 218);
/// Ink of reference lines that are not data (the end of the burn-in, true values).
pub const MARK: Rgb = Rgb(170, 0, 0);

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
    pub fn pattern(self) -> Option<(f64, f64)> {
        match self {
            Self::Solid => None,
            Self::Dashed => Some((9.0, 5.0)),
            Self::Dotted => Some((2.0, 3.0)),
            Self::Short => Some((5.0, 3.0)),
        }
    }
}

/// Ink of series `k` (four inks, then again; marker shapes and dashes repeat with them).
pub fn ink(k: usize) -> Rgb {
    INKS[k % INKS.len()]
}

/// The stroke of series `k`: its ink and its dash, `width` pixels wide.
pub fn series_stroke(k: usize, width: f64) -> Stroke {
    Stroke::solid(ink(k), width).dashed(Dash::of(k))
}

/// A translucent fill of series `k`'s ink, for overlapping bands.
pub fn tint(k: usize) -> Fill {
    Fill::translucent(ink(k), 0.16)
}

/// The light (95 %) and darker (50 %) band fills.
pub fn band_fills() -> (Fill, Fill) {
    (Fill::solid(BAND_95), Fill::solid(BAND_50))
}

/// Grid line strokes (light, bold).
pub fn grid() -> (Stroke, Stroke) {
    (
        Stroke::solid(GRID_LIGHT, 1.0),
        Stroke::solid(GRID_BOLD, 1.0),
    )
}

/// Stroke of axis lines and tick marks.
pub(crate) fn axis_stroke() -> Stroke {
    Stroke::solid(Rgb::BLACK, 1.0)
}
