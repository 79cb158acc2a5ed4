//! How much room a text takes, without a font library.
//!
//! SVG text is laid out by the browser in whatever sans-serif font it has. Widths here are the
//! advance widths of Liberation Sans (metric-compatible with Arial and Helvetica), measured in
//! headless Chromium, times [`WIDTH_MARGIN`] so that DejaVu Sans, the widest common sans-serif,
//! also fits. Layout leaves this much room and [`check`](super::check) tests overlaps with the
//! same boxes, so an estimate errs on the side of more room.

use super::geometry::Rect;

/// Estimated widths are this much wider than Liberation Sans: DejaVu Sans, the widest common
/// sans-serif, sets digits and lower case about 12 % wider.
pub const WIDTH_MARGIN: f64 = 1.15;
/// Height above the baseline that glyphs reach (accents included), in em.
pub(crate) const ASCENT_EM: f64 = 0.8;
/// Depth below the baseline (descenders), in em.
pub(crate) const DESCENT_EM: f64 = 0.22;
/// Half the x-height, in em: a `dy` of `0.5ex` moves the baseline this far down.
const HALF_EX_EM: f64 = 0.26;
/// A `dy` of `0.76em` moves the baseline this far down (hanging text).
const HANG_EM: f64 = 0.76;
/// Distance between the baselines of two lines, in em.
pub(crate) const LINE_EM: f64 = 1.25;

/// Horizontal position of the anchor in the text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HPos {
    /// The text starts at the anchor.
    Left,
    /// The text is centred on the anchor.
    Center,
    /// The text ends at the anchor.
    Right,
}

/// Vertical position of the anchor in the text.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VPos {
    /// The text hangs below the anchor.
    Top,
    /// The text is centred on the anchor.
    Center,
    /// The text rests on the anchor.
    Bottom,
}

/// Which point of a text sits at its position.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Anchor {
    /// Horizontal.
    pub h: HPos,
    /// Vertical.
    pub v: VPos,
}

impl Anchor {
    /// The anchor `(h, v)`.
    pub const fn new(h: HPos, v: VPos) -> Self {
        Self { h, v }
    }
}

/// Rotation of a text about its anchor, clockwise as in SVG.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rotation {
    /// Upright.
    None,
    /// A quarter turn clockwise (reads top to bottom).
    Quarter,
    /// Upside down.
    Half,
    /// Three quarters clockwise (reads bottom to top, as y-axis labels).
    ThreeQuarters,
}

impl Rotation {
    /// Degrees as SVG's `rotate()` takes them; `None` when upright.
    pub(crate) fn degrees(self) -> Option<u32> {
        match self {
            Self::None => None,
            Self::Quarter => Some(90),
            Self::Half => Some(180),
            Self::ThreeQuarters => Some(270),
        }
    }

    /// The rotation of SVG's `rotate(degrees)`, if it is a multiple of 90.
    pub(crate) fn of_degrees(degrees: f64) -> Option<Self> {
        let d = degrees.rem_euclid(360.0);
        [
            (0.0, Self::None),
            (90.0, Self::Quarter),
            (180.0, Self::Half),
            (270.0, Self::ThreeQuarters),
        ]
        .into_iter()
        .find(|(q, _)| (d - q).abs() < 1e-6)
        .map(|(_, r)| r)
    }
}

/// Advance width of `c` in em, in Liberation Sans (Arial metrics).
fn char_em(c: char) -> f64 {
    match c {
        '0'..='9' | '#' | '$' | '?' | '_' => 0.556,
        ' ' | '!' | ',' | '.' | '/' | ':' | ';' | '[' | ']' | '\\' | 't' | 'I' | '·' => 0.278,
        '"' => 0.355,
        '%' => 0.889,
        '&' | 'A' | 'B' | 'E' | 'K' | 'P' | 'S' | 'V' | 'X' | 'Y' | 'Δ' => 0.667,
        '\'' => 0.191,
        '(' | ')' | '-' | '`' | 'r' | '²' | '³' | '¹' => 0.333,
        '*' => 0.389,
        '+' | '<' | '=' | '>' | '~' | '−' | '×' => 0.584,
        '@' => 1.015,
        'C' | 'D' | 'H' | 'N' | 'R' | 'U' => 0.722,
        'F' | 'T' | 'Z' => 0.611,
        'G' | 'O' | 'Q' => 0.778,
        'J' | 'c' | 'k' | 's' | 'v' | 'x' | 'y' | 'z' => 0.5,
        'L' | 'a' | 'b' | 'd' | 'e' | 'g' | 'h' | 'n' | 'o' | 'p' | 'q' | 'u' | 'θ' | '–' => {
            0.556
        }
        'M' | 'm' => 0.833,
        'W' => 0.944,
        '^' => 0.469,
        'f' => 0.278,
        'i' | 'j' | 'l' => 0.222,
        'w' => 0.722,
        '{' | '}' => 0.334,
        '|' => 0.26,
        'µ' | 'α' => 0.578,
        'τ' => 0.395,
        'σ' => 0.617,
        '⁰' | '⁴'..='⁹' => 0.401,
        '⁻' | '⁺' => 0.528,
        '±' | '√' | '≈' | '≤' | '≥' => 0.549,
        '°' => 0.4,
        '∞' => 0.713,
        '…' | '—' | '→' | '←' => 1.0,
        // Combining marks (the hat of R̂) take no room of their own.
        '\u{300}'..='\u{36f}' => 0.0,
        c if c.is_alphabetic() && (c as u32) < 0x2000 => 0.7,
        _ => 1.0,
    }
}

/// Estimated width of `text` at `px` pixels, in pixels (with [`WIDTH_MARGIN`]).
pub(crate) fn text_width(text: &str, px: f64) -> f64 {
    text.chars().map(char_em).sum::<f64>() * px * WIDTH_MARGIN
}

/// Height of one line of text at `px` pixels (ascent and descent).
pub(crate) fn text_height(px: f64) -> f64 {
    (ASCENT_EM + DESCENT_EM) * px
}

/// Distance between the baselines of two lines at `px` pixels.
pub(crate) fn line_height(px: f64) -> f64 {
    LINE_EM * px
}

/// The box `text` at `px` pixels covers when placed at `at` with `anchor` and `rotation`, as
/// [`Canvas::text`](super::Canvas::text) writes it.
pub fn text_box(text: &str, px: f64, at: (f64, f64), anchor: Anchor, rotation: Rotation) -> Rect {
    let w = text_width(text, px);
    let (u0, u1) = match anchor.h {
        HPos::Left => (0.0, w),
        HPos::Center => (-w / 2.0, w / 2.0),
        HPos::Right => (-w, 0.0),
    };
    let baseline = px
        * match anchor.v {
            VPos::Top => HANG_EM,
            VPos::Center => HALF_EX_EM,
            VPos::Bottom => -HALF_EX_EM,
        };
    let (v0, v1) = (baseline - ASCENT_EM * px, baseline + DESCENT_EM * px);
    // (u, v) in the text's own frame; SVG's rotate(θ) turns it clockwise about the anchor.
    let (x, y) = at;
    match rotation {
        Rotation::None => Rect::new(x + u0, y + v0, x + u1, y + v1),
        Rotation::Quarter => Rect::new(x - v1, y + u0, x - v0, y + u1),
        Rotation::Half => Rect::new(x - u1, y - v1, x - u0, y - v0),
        Rotation::ThreeQuarters => Rect::new(x + v0, y - u1, x + v1, y - u0),
    }
}

/// `text` broken at spaces (or before `[` and `(`) into lines no wider than `width` pixels at
/// `px` pixels, where it can be: a word wider than the line stays whole.
pub(crate) fn wrap(text: &str, px: f64, width: f64) -> Vec<String> {
    // Words, each marked when it continues the word before (a name cut before its group).
    let mut words: Vec<(String, bool)> = Vec::new();
    for word in text.split(' ') {
        // Long names break before their group: `t0[ptfe-c1-first]`.
        let mut rest = word;
        let mut attached = false;
        while text_width(rest, px) > width {
            let cut = rest
                .char_indices()
                .skip(1)
                .find(|&(_, c)| c == '[' || c == '(')
                .map(|(i, _)| i);
            match cut {
                Some(i) => {
                    words.push((rest[..i].to_owned(), attached));
                    rest = &rest[i..];
                    attached = true;
                }
                None => break,
            }
        }
        words.push((rest.to_owned(), attached));
    }
    let mut lines: Vec<String> = Vec::new();
    for (word, attached) in words {
        let glue = if attached { "" } else { " " };
        match lines.last_mut() {
            Some(line) if text_width(&format!("{line}{glue}{word}"), px) <= width => {
                line.push_str(glue);
                line.push_str(&word);
            }
            _ => lines.push(word),
        }
    }
    lines
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widths_follow_the_glyphs() {
        let px = 10.0;
        assert!(text_width("iii", px) < text_width("mmm", px));
        assert!((text_width("0", px) - 0.556 * px * WIDTH_MARGIN).abs() < 1e-12);
        assert!(text_width("R̂", px) < text_width("RR", px));
        assert!(text_width("漢", px) >= px);
    }

    #[test]
    fn boxes_follow_anchor_and_rotation() {
        let a = Anchor::new(HPos::Center, VPos::Center);
        let upright = text_box("0000", 10.0, (100.0, 50.0), a, Rotation::None);
        assert!((upright.x0 + upright.x1 - 200.0).abs() < 1e-9);
        assert!(upright.contains((100.0, 50.0)));
        let turned = text_box("0000", 10.0, (100.0, 50.0), a, Rotation::ThreeQuarters);
        assert!((turned.width() - upright.height()).abs() < 1e-9);
        assert!((turned.height() - upright.width()).abs() < 1e-9);
        let hanging = text_box(
            "x",
            10.0,
            (0.0, 20.0),
            Anchor::new(HPos::Left, VPos::Top),
            Rotation::None,
        );
        assert!(hanging.y0 >= 19.0 && hanging.x0 >= 0.0);
        let resting = text_box(
            "x",
            10.0,
            (0.0, 20.0),
            Anchor::new(HPos::Right, VPos::Bottom),
            Rotation::None,
        );
        assert!(resting.y1 <= 21.0 && resting.x1 <= 0.0);
        assert_eq!(Rotation::of_degrees(-90.0), Some(Rotation::ThreeQuarters));
    }

    #[test]
    fn long_names_wrap_before_their_group() {
        let lines = wrap("a_over_F_d_pop_log_sd[PTFE] (1)", 12.0, 120.0);
        assert_eq!(lines, vec!["a_over_F_d_pop_log_sd", "[PTFE] (1)"]);
        assert_eq!(wrap("short", 12.0, 200.0), vec!["short"]);
        assert_eq!(wrap("time t (s)", 12.0, 200.0), vec!["time t (s)"]);
        assert_eq!(
            wrap("t0[ptfe-c1-first] (s)", 12.0, 200.0),
            vec!["t0[ptfe-c1-first] (s)"]
        );
    }
}
