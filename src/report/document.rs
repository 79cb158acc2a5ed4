//! A report as a list of blocks, rendered twice: as Markdown (figures linked) and as one
//! self-contained HTML page (figures inline, CSS inline, no scripts, no external URLs).

use std::fmt::Write as _;

use crate::plot::escape as escape_html;

/// One block of a report.
#[derive(Debug, Clone, PartialEq)]
pub enum Block {
    /// A heading of level 1 to 3, with an anchor id.
    Heading {
        /// 1, 2 or 3.
        level: u8,
        /// Anchor (letters, digits, dashes).
        id: String,
        /// Text.
        text: String,
    },
    /// A paragraph of plain text.
    Paragraph(String),
    /// A verdict box: `ok` decides its frame; the lines are shown as a list.
    Verdict {
        /// Whether all is well.
        ok: bool,
        /// Headline.
        title: String,
        /// Lines of detail.
        lines: Vec<String>,
    },
    /// A bulleted list.
    List(Vec<String>),
    /// A table; rows flagged `true` are marked as failing.
    Table {
        /// Column names.
        header: Vec<String>,
        /// Cells, row by row.
        rows: Vec<Vec<String>>,
        /// Per row: flagged.
        flagged: Vec<bool>,
    },
    /// A figure: the SVG text, its file name under `figures/`, and its caption.
    Figure {
        /// File name (`fit-ptfe-c1-first.svg`).
        file: String,
        /// Caption.
        caption: String,
        /// SVG text.
        svg: String,
    },
    /// A collapsed list (open by default in Markdown, folded in HTML).
    Details {
        /// The line shown when folded.
        summary: String,
        /// The items.
        items: Vec<String>,
    },
    /// Preformatted text (a command line).
    Code(String),
}

fn escape_cell(s: &str) -> String {
    s.replace('|', "\\|").replace('\n', " ")
}

/// The report as Markdown; figures are linked as `figures/<file>`.
pub(crate) fn render_markdown(title: &str, blocks: &[Block]) -> String {
    let mut md = format!("# {title}\n\n");
    for block in blocks {
        match block {
            Block::Heading { level, text, .. } => {
                let hashes = "#".repeat(usize::from(*level) + 1);
                let _ = writeln!(md, "{hashes} {text}\n");
            }
            Block::Paragraph(text) => {
                let _ = writeln!(md, "{text}\n");
            }
            Block::Verdict { ok, title, lines } => {
                let mark = if *ok { "OK" } else { "WARNING" };
                let _ = writeln!(md, "> **{mark}: {title}**");
                for line in lines {
                    let _ = writeln!(md, "> - {line}");
                }
                md.push('\n');
            }
            Block::List(items) => {
                for item in items {
                    let _ = writeln!(md, "- {item}");
                }
                md.push('\n');
            }
            Block::Table {
                header,
                rows,
                flagged,
            } => {
                let _ = writeln!(
                    md,
                    "| {} |",
                    header
                        .iter()
                        .map(|h| escape_cell(h))
                        .collect::<Vec<_>>()
                        .join(" | ")
                );
                let _ = writeln!(md, "|{}", "---|".repeat(header.len()));
                for (row, &flag) in rows.iter().zip(flagged) {
                    let cells: Vec<String> = row
                        .iter()
                        .enumerate()
                        .map(|(i, c)| {
                            if flag && i == 0 {
                                format!("**{}** ⚠", escape_cell(c))
                            } else {
                                escape_cell(c)
                            }
                        })
                        .collect();
                    let _ = writeln!(md, "| {} |", cells.join(" | "));
                }
                md.push('\n');
            }
            Block::Figure { file, caption, .. } => {
                let _ = writeln!(md, "![{caption}](figures/{file})\n\n*{caption}*\n");
            }
            Block::Details { summary, items } => {
                let _ = writeln!(md, "{summary}\n");
                for item in items {
                    let _ = writeln!(md, "- {item}");
                }
                md.push('\n');
            }
            Block::Code(text) => {
                let _ = writeln!(md, "```\n{text}\n```\n");
            }
        }
    }
    md
}

const STYLE: &str = "\
body{font-family:sans-serif;max-width:1200px;margin:1.5em auto;padding:0 1em;color:#111;line-height:1.45}\
h1{font-size:1.7em;border-bottom:2px solid #333}h2{margin-top:2em;border-bottom:1px solid #999}\
table{border-collapse:collapse;margin:0.8em 0;font-size:0.88em}\
th,td{border:1px solid #bbb;padding:3px 7px;text-align:right}th{background:#eee}\
td:first-child,th:first-child{text-align:left}\
tr.flag td{background:#f2f2f2;font-weight:bold}tr.flag td:first-child::after{content:' \\26A0'}\
.verdict{border:3px solid #333;padding:0.6em 1em;margin:1em 0}\
.verdict.warn{border-style:double;border-width:6px;background:#f4f4f4}\
.verdict.ok{border-style:solid}\
figure{margin:1.2em 0;page-break-inside:avoid;overflow-x:auto}figure svg{height:auto;display:block}\
@media print{figure svg{max-width:100%}}\
figcaption{font-size:0.9em;color:#333;margin-top:0.3em}\
pre{background:#f4f4f4;padding:0.5em;white-space:pre-wrap;word-break:break-all}\
nav a{margin-right:1em}\
";

/// The report as one self-contained HTML page: inline CSS and SVG figures, no scripts, no
/// external URLs. On screen figures keep their own size (their text is sized for it) and
/// scroll sideways in a narrow window; in print they shrink to the page.
pub(crate) fn render_html(title: &str, blocks: &[Block]) -> String {
    let mut html = format!(
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n\
         <title>{}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<h1>{}</h1>\n",
        escape_html(title),
        escape_html(title)
    );
    let top: Vec<(&str, &str)> = blocks
        .iter()
        .filter_map(|b| match b {
            Block::Heading { level: 1, id, text } => Some((id.as_str(), text.as_str())),
            _ => None,
        })
        .collect();
    html.push_str("<nav>");
    for (id, text) in top {
        let _ = write!(html, "<a href=\"#{id}\">{}</a>", escape_html(text));
    }
    html.push_str("</nav>\n");
    for block in blocks {
        match block {
            Block::Heading { level, id, text } => {
                let h = level + 1;
                let _ = writeln!(html, "<h{h} id=\"{id}\">{}</h{h}>", escape_html(text));
            }
            Block::Paragraph(text) => {
                let _ = writeln!(html, "<p>{}</p>", escape_html(text));
            }
            Block::Verdict { ok, title, lines } => {
                let (class, mark) = if *ok {
                    ("ok", "OK")
                } else {
                    ("warn", "WARNING")
                };
                let _ = write!(
                    html,
                    "<div class=\"verdict {class}\"><strong>{mark}: {}</strong><ul>",
                    escape_html(title)
                );
                for line in lines {
                    let _ = write!(html, "<li>{}</li>", escape_html(line));
                }
                html.push_str("</ul></div>\n");
            }
            Block::List(items) => {
                html.push_str("<ul>");
                for item in items {
                    let _ = write!(html, "<li>{}</li>", escape_html(item));
                }
                html.push_str("</ul>\n");
            }
            Block::Table {
                header,
                rows,
                flagged,
            } => {
                html.push_str("<table><thead><tr>");
                for h in header {
                    let _ = write!(html, "<th>{}</th>", escape_html(h));
                }
                html.push_str("</tr></thead><tbody>\n");
                for (row, &flag) in rows.iter().zip(flagged) {
                    html.push_str(if flag { "<tr class=\"flag\">" } else { "<tr>" });
                    for c in row {
                        let _ = write!(html, "<td>{}</td>", escape_html(c));
                    }
                    html.push_str("</tr>\n");
                }
                html.push_str("</tbody></table>\n");
            }
            Block::Figure { file, caption, svg } => {
                let id = file.trim_end_matches(".svg");
                let _ = writeln!(
                    html,
                    "<figure id=\"fig-{id}\" class=\"report-figure\">{svg}<figcaption>{}</figcaption></figure>",
                    escape_html(caption)
                );
            }
            Block::Details { summary, items } => {
                let _ = write!(
                    html,
                    "<details><summary>{}</summary><ul>",
                    escape_html(summary)
                );
                for item in items {
                    let _ = write!(html, "<li>{}</li>", escape_html(item));
                }
                html.push_str("</ul></details>\n");
            }
            Block::Code(text) => {
                let _ = writeln!(html, "<pre>{}</pre>", escape_html(text));
            }
        }
    }
    html.push_str("</body>\n</html>\n");
    html
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Vec<Block> {
        vec![
            Block::Heading {
                level: 1,
                id: "fit".into(),
                text: "Fit <to> data".into(),
            },
            Block::Verdict {
                ok: false,
                title: "not converged".into(),
                lines: vec!["R̂ of alpha[PTFE] is 1.02".into()],
            },
            Block::Table {
                header: vec!["name".into(), "r_hat".into()],
                rows: vec![
                    vec!["alpha|PTFE".into(), "1.02".into()],
                    vec!["k".into(), "1.00".into()],
                ],
                flagged: vec![true, false],
            },
            Block::Figure {
                file: "fit-a.svg".into(),
                caption: "A & B".into(),
                svg: "<svg></svg>".into(),
            },
        ]
    }

    #[test]
    fn html_is_self_contained_and_escaped() {
        let html = render_html("Report", &sample());
        assert!(html.contains("<h2 id=\"fit\">Fit &lt;to&gt; data</h2>"));
        assert!(html.contains("<figure id=\"fig-fit-a\""));
        assert!(html.contains("<svg></svg>"));
        assert!(html.contains("A &amp; B"));
        assert!(html.contains("<tr class=\"flag\">"));
        assert!(html.contains("verdict warn"));
        // Figures are never shrunk on screen: their text stays at its size.
        assert!(
            html.contains("overflow-x:auto")
                && html.contains("@media print{figure svg{max-width:100%}}")
        );
        assert!(!html.contains("<script"));
        assert!(!html.contains("http"));
    }

    #[test]
    fn markdown_links_figures_and_flags_rows() {
        let md = render_markdown("Report", &sample());
        assert!(md.starts_with("# Report\n"));
        assert!(md.contains("## Fit <to> data"));
        assert!(md.contains("![A & B](figures/fit-a.svg)"));
        assert!(md.contains("| **alpha\\|PTFE** ⚠ | 1.02 |"));
        assert!(md.contains("> **WARNING: not converged**"));
    }
}
