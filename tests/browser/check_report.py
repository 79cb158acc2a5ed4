#!/usr/bin/env python3
"""Loads a slipbayes report.html in headless Chromium, checks that the page loads with every
figure present and visible (an inline SVG of non-zero size inside the page, nothing fetched
from elsewhere), and saves screenshots of the whole page, in colour and in grey.

Usage: check_report.py REPORT_HTML [--screenshots DIR] [--chromium PATH]
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
    var texts = svg ? svg.querySelectorAll('text').length : 0;
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

    work = tempfile.mkdtemp(prefix="slipbayes-browser-")
    try:
        # The measuring copy sits beside the report so that relative paths would resolve
        # the same way (there should be none).
        probe = os.path.join(os.path.dirname(report), ".report-check.html")
        with open(probe, "w", encoding="utf-8") as f:
            f.write(with_extra(page, MEASURE))
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
