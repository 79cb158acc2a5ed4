#!/usr/bin/env python3
"""Loads a slipbayes report.html in headless Chromium, checks that the page loads with every
figure present and visible (an inline SVG of non-zero size inside the page, nothing fetched
from elsewhere) and that its text reads in the browser's own font (every text at least 11 px
at scale 1, inside its figure, not overlapping another text), and saves screenshots of the
whole page in colour and in grey, and of every figure alone at device scale 1 and 2.

Usage: check_report.py REPORT_HTML [--screenshots DIR] [--chromium PATH]
Figure screenshots go to DIR/figures/<figure>@1x.png and @2x.png.
Exit status 0 when every check passes, 1 otherwise (each failure is printed).

The report itself has no scripts; this checker measures a copy of it with one script added
at the end, which writes its measurements into the page so that `--dump-dom` returns them.
"""
import argparse
import html
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile

CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--hide-scrollbars",
    "--virtual-time-budget=5000",
]
WIDTH = 1280
SHOT_HEIGHT = 2400
# No text of a figure may be smaller than this at scale 1 (CSS pixels).
MIN_TEXT_PX = 11.0

MEASURE = """
<script>
(function () {
  var out = {figures: [], resources: [], height: 0};
  var figs = document.querySelectorAll('figure.report-figure');
  for (var i = 0; i < figs.length; i++) {
    var f = figs[i];
    var svg = f.querySelector('svg');
    var r = svg ? svg.getBoundingClientRect() : null;
    var style = svg ? getComputedStyle(svg) : null;
    var textEls = svg ? svg.querySelectorAll('text') : [];
    var texts = textEls.length;
    // The text as the browser set it: its box in the page, its size on screen.
    var boxes = [], small = [], outside = [];
    if (svg) {
      var vb = svg.viewBox && svg.viewBox.baseVal && svg.viewBox.baseVal.width ? svg.viewBox.baseVal.width : r.width;
      var scale = r.width / vb;
      for (var t = 0; t < textEls.length; t++) {
        var el = textEls[t];
        var content = el.textContent.trim();
        if (!content) continue;
        var b = el.getBoundingClientRect();
        var px = parseFloat(getComputedStyle(el).fontSize) * scale;
        if (px < %MIN% - 1e-6) small.push(content + ' (' + px.toFixed(1) + ' px)');
        if (b.left < r.left - 0.5 || b.right > r.right + 0.5 || b.top < r.top - 0.5 || b.bottom > r.bottom + 0.5)
          outside.push(content);
        boxes.push({t: content, l: b.left, r: b.right, y0: b.top, y1: b.bottom});
      }
    }
    var overlaps = [];
    for (var a = 0; a < boxes.length; a++) {
      for (var c = a + 1; c < boxes.length; c++) {
        var p = boxes[a], q = boxes[c];
        // Glyph boxes include the line's leading: compare their middle 60 %.
        var ph = 0.2 * (p.y1 - p.y0), qh = 0.2 * (q.y1 - q.y0);
        if (p.l + 0.5 < q.r && q.l + 0.5 < p.r && p.y0 + ph < q.y1 - qh && q.y0 + qh < p.y1 - ph)
          overlaps.push(p.t + ' / ' + q.t);
      }
    }
    var shapes = svg ? svg.querySelectorAll('polyline,path,polygon,circle,rect,line').length : 0;
    out.figures.push({
      id: f.id,
      svg: !!svg,
      width: r ? r.width : 0,
      height: r ? r.height : 0,
      top: r ? r.top + window.scrollY : 0,
      display: style ? style.display : 'none',
      visibility: style ? style.visibility : 'hidden',
      opacity: style ? parseFloat(style.opacity) : 0,
      texts: texts,
      small: small,
      outside: outside,
      overlaps: overlaps,
      shapes: shapes,
      caption: !!f.querySelector('figcaption')
    });
  }
  var res = performance.getEntriesByType('resource');
  for (var j = 0; j < res.length; j++) { out.resources.push(res[j].name); }
  out.height = document.documentElement.scrollHeight;
  out.ready = document.readyState;
  var pre = document.createElement('pre');
  pre.id = 'slipbayes-check';
  pre.textContent = JSON.stringify(out);
  document.body.appendChild(pre);
})();
</script>
"""


def chromium_run(chromium, args, profile):
    cmd = [chromium] + CHROMIUM_FLAGS + ["--user-data-dir=" + profile] + args
    return subprocess.run(cmd, capture_output=True, text=True, timeout=180)


def with_extra(page, extra):
    """The page with `extra` inserted just before </body>."""
    at = page.rfind("</body>")
    if at < 0:
        raise ValueError("the report has no </body>")
    return page[:at] + extra + page[at:]


FIGURE = re.compile(r'<figure id="fig-([^"]+)" class="report-figure">(<svg width="(\d+)" height="(\d+)".*?</svg>)', re.S)


def figure_shots(chromium, page, report, out_dir, work):
    """Screenshots of every figure alone, at its own size, at device scale 1 and 2: what a
    reader sees on an ordinary and on a high-density screen. Returns the failures."""
    failures = []
    shots = os.path.join(os.path.abspath(out_dir), "figures")
    os.makedirs(shots, exist_ok=True)
    figures = FIGURE.findall(page)
    for name, svg, width, height in figures:
        alone = os.path.join(os.path.dirname(report), ".report-figure.html")
        with open(alone, "w", encoding="utf-8") as f:
            f.write('<!DOCTYPE html><html><head><meta charset="utf-8"><style>'
                    'html,body{margin:0;padding:0;background:#fff}svg{display:block}</style>'
                    f"</head><body>{svg}</body></html>")
        try:
            for scale in (1, 2):
                out = os.path.join(shots, f"{name}@{scale}x.png")
                chromium_run(
                    chromium,
                    [f"--force-device-scale-factor={scale}", f"--screenshot={out}",
                     f"--window-size={width},{height}", "file://" + alone],
                    os.path.join(work, f"f-{name}-{scale}"),
                )
                if not os.path.exists(out) or os.path.getsize(out) < 2_000:
                    failures.append(f"screenshot {out} was not written")
        finally:
            os.remove(alone)
    print(f"screenshots: {len(figures)} figures at scale 1 and 2 in {shots}")
    return failures


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("report")
    ap.add_argument("--screenshots", default=None)
    ap.add_argument("--chromium", default=shutil.which("chromium") or "/usr/bin/chromium")
    args = ap.parse_args()

    report = os.path.abspath(args.report)
    page = open(report, encoding="utf-8").read()
    failures = []

    # Self-contained: no scripts, no external resources referenced.
    if re.search(r"<script", page, re.I):
        failures.append("report.html contains a <script>; it must show everything without one")
    for m in re.finditer(r'(?:src|href)\s*=\s*"([^"#][^"]*)"', page):
        failures.append(f"report.html references {m.group(1)!r}; it must be self-contained")
    for m in re.finditer(r"url\(", page):
        failures.append("report.html uses url(...) in CSS; it must be self-contained")
        break
    expected = len(re.findall(r'<figure id="fig-[^"]+" class="report-figure">', page))
    md_path = os.path.join(os.path.dirname(report), "report.md")
    if os.path.exists(md_path):
        linked = re.findall(r"!\[[^\]]*\]\(figures/([^)]+)\)", open(md_path, encoding="utf-8").read())
        if len(linked) != expected:
            failures.append(f"report.md links {len(linked)} figures, report.html shows {expected}")
        for f in linked:
            if not os.path.exists(os.path.join(os.path.dirname(report), "figures", f)):
                failures.append(f"report.md links figures/{f}, which does not exist")

    measure = MEASURE.replace("%MIN%", repr(MIN_TEXT_PX))
    work = tempfile.mkdtemp(prefix="slipbayes-browser-")
    try:
        # The measuring copy sits beside the report so that relative paths would resolve
        # the same way (there should be none).
        probe = os.path.join(os.path.dirname(report), ".report-check.html")
        with open(probe, "w", encoding="utf-8") as f:
            f.write(with_extra(page, measure))
        try:
            run = chromium_run(args.chromium, ["--dump-dom", "file://" + probe], os.path.join(work, "p1"))
        finally:
            os.remove(probe)
        m = re.search(r'<pre id="slipbayes-check">(.*?)</pre>', run.stdout, re.S)
        if not m:
            print(run.stderr[-3000:], file=sys.stderr)
            failures.append("the page did not load in Chromium (no measurements came back)")
            measured = {"figures": [], "resources": [], "height": 0}
        else:
            measured = json.loads(html.unescape(m.group(1)))
        figs = measured["figures"]
        if len(figs) != expected or expected == 0:
            failures.append(f"Chromium found {len(figs)} figures, the page has {expected}")
        for fig in figs:
            problems = []
            if not fig["svg"]:
                problems.append("no inline SVG")
            if fig["width"] < 100 or fig["height"] < 100:
                problems.append(f"size {fig['width']:.0f}×{fig['height']:.0f} px")
            if fig["display"] == "none" or fig["visibility"] != "visible" or fig["opacity"] < 0.99:
                problems.append("hidden")
            if fig["texts"] < 3:
                problems.append(f"only {fig['texts']} text elements (axis labels missing?)")
            if fig["shapes"] < 5:
                problems.append(f"only {fig['shapes']} shapes (empty plot?)")
            if not fig["caption"]:
                problems.append("no caption")
            if fig["small"]:
                problems.append(f"text under {MIN_TEXT_PX:g} px: {fig['small'][:5]}")
            if fig["outside"]:
                problems.append(f"text cut off at the figure's edge: {fig['outside'][:5]}")
            if fig["overlaps"]:
                problems.append(f"overlapping text: {fig['overlaps'][:5]}")
            if problems:
                failures.append(f"{fig['id']}: " + ", ".join(problems))
        for r in measured["resources"]:
            failures.append(f"the page fetched {r}; it must be self-contained")

        if args.screenshots:
            os.makedirs(args.screenshots, exist_ok=True)
            height = max(int(measured.get("height") or 0), SHOT_HEIGHT)
            shots = (height + SHOT_HEIGHT - 1) // SHOT_HEIGHT
            for mode, css in (("colour", ""), ("grey", "html{filter:grayscale(1)}")):
                for k in range(shots):
                    # Headless screenshots show the top of the page; shift the page up
                    # instead of scrolling (a scroll is not painted before the capture).
                    shift = f"body{{transform:translateY(-{k * SHOT_HEIGHT}px)}}"
                    extra = f"<style>{css}{shift}</style>"
                    shot_page = os.path.join(os.path.dirname(report), ".report-shot.html")
                    with open(shot_page, "w", encoding="utf-8") as f:
                        f.write(with_extra(page, extra))
                    out = os.path.join(os.path.abspath(args.screenshots), f"report-{mode}-{k + 1:02d}.png")
                    try:
                        chromium_run(
                            args.chromium,
                            [f"--screenshot={out}", f"--window-size={WIDTH},{SHOT_HEIGHT}", "file://" + shot_page],
                            os.path.join(work, f"s-{mode}-{k}"),
                        )
                    finally:
                        os.remove(shot_page)
                    if not os.path.exists(out) or os.path.getsize(out) < 10_000:
                        failures.append(f"screenshot {out} was not written")
            print(f"screenshots: {shots} colour and {shots} grey pages in {args.screenshots}")
            failures.extend(figure_shots(args.chromium, page, report, args.screenshots, work))
    finally:
        shutil.rmtree(work, ignore_errors=True)

    print(f"{report}: {len(measured['figures'])} figures measured, page height {measured.get('height')} px")
    if failures:
        for f in failures:
            print("FAIL:", f)
        return 1
    print("OK: every figure is present, visible and of non-zero size; nothing fetched from elsewhere")
    return 0


if __name__ == "__main__":
    sys.exit(main())
