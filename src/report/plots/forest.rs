//! The forest plot of the materials' and contacts' parameters.

use super::*;

/// One row of a forest panel: a group's median, 50 % and 95 % intervals, in display units.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ForestRow {
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
pub(crate) struct ForestPanel {
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
/// A panel of more contact (or run) rows than this becomes a caterpillar plot: at 26 pixels
/// a row, 200 contacts would make a panel 5,000 pixels tall whose labels nobody reads.
pub(crate) const FOREST_LISTED_ROWS: usize = 40;
/// Height of a caterpillar panel's plot area, whatever the number of contacts.
const CATERPILLAR_PLOT_PX: f64 = 300.0;

/// The forest plot: per quantity, each material and contact (or run) as a thick 50 % bar, a
/// thin 95 % bar and a white dot at the median; materials black, contacts and runs grey; the
/// numbers (median [95 %]) beside each row.
pub(crate) fn forest_figure(panels: &[ForestPanel]) -> String {
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
        .map(|p| match is_caterpillar(p) {
            true => FOREST_FRAME_PX + CATERPILLAR_PLOT_PX,
            false => FOREST_FRAME_PX + FOREST_ROW_PX * p.rows.len() as f64,
        })
        .collect();
    let total = strip + heights.iter().sum::<f64>();
    svg_figure((FOREST_WIDTH, total.ceil() as u32), |c| {
        draw_row(c, &Rect::new(10.0, GAP_PX, width - 10.0, strip), &legend);
        let mut y = strip;
        for (panel, &h) in panels.iter().zip(&heights) {
            let area = Rect::new(0.0, y, width, y + h);
            if is_caterpillar(panel) {
                caterpillar_panel(c, area, panel);
            } else {
                forest_panel(c, area, panel);
            }
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
pub(super) fn error_decimals(error: f64) -> Option<usize> {
    (error > 0.0 && error.is_finite()).then(|| (1 - error.log10().floor() as i32).max(0) as usize)
}

/// `v` with `decimals` decimals and a true minus sign.
pub(super) fn fixed(v: f64, decimals: usize) -> String {
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

/// Whether `panel` has too many contact or run rows to list ([`FOREST_LISTED_ROWS`]).
fn is_caterpillar(panel: &ForestPanel) -> bool {
    panel.rows.iter().filter(|r| !r.material).count() > FOREST_LISTED_ROWS
}

/// A panel of many contacts as a caterpillar plot: the contacts side by side along the
/// horizontal axis, sorted by their median, each a vertical 95 % bar with its 50 % bar over
/// it (and its median's dot while there is room for one); each material as a horizontal line
/// at its median over the band of its 95 % interval, its numbers at the right. A contact far
/// from the others, or an interval far wider, stands out at any number of contacts.
fn caterpillar_panel(c: &mut Canvas, area: Rect, panel: &ForestPanel) {
    let mut contacts: Vec<&ForestRow> = panel.rows.iter().filter(|r| !r.material).collect();
    contacts.sort_by(|a, b| a.median.total_cmp(&b.median));
    let materials: Vec<&ForestRow> = panel.rows.iter().filter(|r| r.material).collect();
    let n = contacts.len();
    let texts: Vec<String> = materials
        .iter()
        .map(|r| format!("{}: {}", r.label, interval_text(r)))
        .collect();
    let values_w = texts
        .iter()
        .map(|t| text_width(t, TEXT_PX))
        .fold(0.0, f64::max);
    let caption = line_height(CAPTION_PX);
    let inner = Rect::new(area.x0 + 10.0, area.y0, area.x1 - values_w - 18.0, area.y1);
    let ys: Vec<f64> = panel.rows.iter().flat_map(|r| [r.low, r.high]).collect();
    let x = Axis::linear(
        (0.5, n as f64 + 0.5),
        &format!("{n} contacts or runs, sorted by their median"),
    );
    let y = Axis::linear(range_of(ys.iter(), 0.08), &panel.axis);
    let keep = crate::plot::Margins {
        top: caption,
        ..Default::default()
    };
    let (plot, xt, yt) = fit_axes(inner, &x, &y, keep);
    draw_grid(c, &plot, &xt, &yt);
    // Bars as wide as the room each contact has, up to the listed rows' widths.
    let room = (plot.rect.x1 - plot.rect.x0) / n as f64;
    let thin = (0.5 * room).clamp(0.5, FOREST_THIN_PX);
    let thick = (0.9 * room).clamp(1.0, FOREST_THICK_PX);
    let (x0, x1) = (0.5, n as f64 + 0.5);
    let mut series: Vec<Series> = materials
        .iter()
        .map(|r| Series::Band {
            xs: vec![x0, x1],
            low: vec![r.low, r.low],
            high: vec![r.high, r.high],
            fill: band_fills().0,
        })
        .collect();
    for (k, row) in contacts.iter().enumerate() {
        let xv = (k + 1) as f64;
        series.push(Series::Line {
            points: vec![(xv, row.low), (xv, row.high)],
            stroke: Stroke::solid(CONTACT_GREY, thin),
        });
        if row.quartiles.0.is_finite() && row.quartiles.1.is_finite() {
            series.push(Series::Line {
                points: vec![(xv, row.quartiles.0), (xv, row.quartiles.1)],
                stroke: Stroke::solid(CONTACT_GREY, thick),
            });
        }
    }
    if room >= 4.0 * FOREST_DOT_PX {
        series.push(Series::Markers {
            points: contacts
                .iter()
                .enumerate()
                .map(|(k, r)| ((k + 1) as f64, r.median))
                .collect(),
            marker: Marker::Dot,
            color: CONTACT_GREY,
            radius: FOREST_DOT_PX,
        });
    }
    for r in &materials {
        series.push(Series::Line {
            points: vec![(x0, r.median), (x1, r.median)],
            stroke: Stroke::solid(Rgb::BLACK, FOREST_THIN_PX),
        });
    }
    draw_series(c, &plot, &series);
    draw_axes(c, &plot, (&x, &xt), (&y, &yt));
    for (r, text) in materials.iter().zip(&texts) {
        if let Some(py) = plot.y_px(r.median) {
            c.text(
                text,
                (plot.rect.x1 + 10.0, py),
                Font::new(TEXT_PX, Anchor::new(HPos::Left, VPos::Center)),
            );
        }
    }
    let centre = 0.5 * (plot.rect.x0 + plot.rect.x1);
    c.text(
        &panel.title,
        (centre, area.y0 + 4.0),
        Font::new(CAPTION_PX, Anchor::new(HPos::Center, VPos::Top)),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

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

    fn row(label: String, median: f64, material: bool) -> ForestRow {
        ForestRow {
            label,
            median,
            low: median - 0.2,
            high: median + 0.3,
            quartiles: (median - 0.05, median + 0.07),
            material,
        }
    }

    /// A panel of 40 contacts is listed, one of 41 or more a caterpillar whose height does not
    /// grow with the contacts: a thousand contacts give the figure of fifty.
    #[test]
    fn many_contacts_make_a_caterpillar_of_fixed_height() {
        let panel = |contacts: usize| ForestPanel {
            title: "F_d".into(),
            axis: "F_d (mN)".into(),
            rows: std::iter::once(row("M".into(), 10.0, true))
                .chain(
                    (0..contacts)
                        .map(|k| row(format!("c{k:04}"), 9.0 + (k % 17) as f64 * 0.1, false)),
                )
                .collect(),
        };
        let height = |svg: &str| -> u32 {
            let at = svg.find("height=\"").unwrap() + 8;
            svg[at..].split('"').next().unwrap().parse().unwrap()
        };
        let listed = forest_figure(&[panel(FOREST_LISTED_ROWS)]);
        assert!(
            listed.contains("c0039"),
            "a listed panel names every contact"
        );
        let fifty = forest_figure(&[panel(50)]);
        let thousand = forest_figure(&[panel(1000)]);
        assert!(!fifty.contains("c0049") && !thousand.contains("c0999"));
        assert_eq!(height(&fifty), height(&thousand));
        assert!(height(&thousand) < height(&listed));
        // The material's numbers are still written out.
        assert!(thousand.contains("M: 10.00"), "{}", &thousand[..400]);
    }
}
