#!/usr/bin/env python3
"""Campaigns of N contacts fitted by `slipbayes fit` with the default settings, until converged
by the strict standard: where the time goes (the start, the sampling, the summaries, LOO and
the report), peak RSS, the verdict, and the truths counted inside their 95 % intervals.

    python3 benches/campaign_fit.py OUT_DIR N [N ...]

Each campaign is made by `data/make_campaign.py --contacts N` (a 201-point first slide and a
51-point repeat slide per contact, one material) into OUT_DIR/cN, and fitted into
OUT_DIR/cN/run under GNU time. The phases come from the fit's progress lines (every 2 s, each
with its step), timed as they arrive: the sampler's pace is the median of steps per second
between consecutive lines, the sampling is the run's steps at that pace, the start is what
came before the first line's steps, and the rest what is left of the wall time. The rest
is split by the fit's notes: when the summaries find a run that the sampler's rule called
converged not yet converged by the strict standard, the fit says how long they took and samples
on; those summaries are one part, and the last ones with PSIS-LOO, the predictive bands and
the report (and the reading back of the sampler's history before it samples on) the other,
also given per contact and step (a quantity's summary costs in proportion to its draws). The
truths are the simulation's (`truth.json`):
each contact's F_d and k, each first slide's t0, each run's σ, and the material's α and a/F_d.
Writes OUT_DIR/table.md and prints it.
"""
import json
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def coverage(run):
    """Truths inside their 95 % interval, per kind: {kind: [inside, total]}."""
    s = json.loads((run / "summary.json").read_text())
    q = {(p["name"], p["group"]): p for p in s["parameters"] + s["derived"]}
    by = {}

    def check(name, group, value, kind):
        p = q.get((name, group))
        if p is not None:
            counts = by.setdefault(kind, [0, 0])
            counts[0] += p["ci_low"] <= value <= p["ci_high"]
            counts[1] += 1

    seen = set()
    for r in json.loads((run / "truth.json").read_text()):
        sim, name = r["simulation"], r["run"]
        contact = name.rsplit("-", 1)[0]
        if contact not in seen:
            seen.add(contact)
            check("F_d", contact, sim["params"]["f_d_n"], "F_d")
            check("k", contact, sim["stiffness_n_per_m"], "k")
            alpha, ratio = sim["params"]["alpha_per_m"], sim["params"]["a_n"] / sim["params"]["f_d_n"]
        if sim["scene"] == "first":
            check("t0", name, sim["params"]["t0_s"], "t0")
        check("sigma", name, sim["noise_sd_n"], "σ")
    check("alpha", "M", alpha, "α")
    check("a_over_F_d", "M", ratio, "a/F_d")
    return by


def phases(lines, steps, total):
    """(start, sampling, rest) in seconds of a fit of `steps` steps that took `total` seconds,
    from its progress lines [(seconds since launch, step)]: the sampler's pace is the median of
    steps per second between consecutive lines (a pause for the summaries of a run that samples
    on is one interval among many), the sampling is the steps at that pace, the start what came
    before the first line's steps, the rest what is left."""
    rates = sorted((b[1] - a[1]) / (b[0] - a[0]) for a, b in zip(lines, lines[1:]) if b[1] > a[1])
    if not rates:
        raise SystemExit("fewer than two progress lines: run more steps or report more often")
    rate = rates[len(rates) // 2]
    start = lines[0][0] - lines[0][1] / rate
    sampling = steps / rate
    return start, sampling, total - start - sampling


def fit(out, n):
    """Makes and fits the campaign of n contacts; returns the table's row."""
    d = out / f"c{n}"
    if not (d / "campaign.toml").exists():
        subprocess.run([sys.executable, str(ROOT / "data/make_campaign.py"), "--contacts", str(n),
                        "--out", str(d), "--binary", str(ROOT / "target/release/slipbayes")],
                       check=True, stdout=subprocess.DEVNULL)
    run = d / "run"
    cmd = ["/usr/bin/time", "-f", "peak RSS %M kB", str(ROOT / "target/release/slipbayes"), "fit",
           "campaign.toml", "--out", "run", "--overwrite", "--progress-every", "2"]
    began = time.monotonic()
    lines, peak, sent_on = [], 0, []
    # The fit's standard output (a table of every quantity) goes to a file: a pipe read only at
    # the end would fill and stop the fit.
    printed = d / "fit.out"
    with printed.open("w") as out_file:
        proc = subprocess.Popen(cmd, cwd=d, stdout=out_file, stderr=subprocess.PIPE, text=True)
        for line in proc.stderr:
            m = re.match(r"progress: step (\d+)/", line)
            if m:
                lines.append((time.monotonic() - began, int(m.group(1))))
            note = re.match(r"note: the summaries at step (\d+) \(made in ([\d.]+) s\)", line)
            if note:
                sent_on.append(float(note.group(2)))
            rss = re.search(r"peak RSS (\d+) kB", line)
            if rss:
                peak = int(rss.group(1))
        status = proc.wait()
    stdout = printed.read_text()
    if status != 0:
        raise SystemExit(f"the fit of {n} contacts failed: {stdout[-2000:]}")
    total = time.monotonic() - began
    s = re.search(r"sampler: (\d+) ensembles × (\d+) walkers × (\d+) steps \(burn-in (\d+)\), "
                  r"acceptance [\d.]+, τ_max ([\d.]+), (\d+) evaluations, ([\d.]+) s; converged: (\w+)", stdout)
    steps, tau, evaluations, converged = s.group(3), s.group(5), int(s.group(6)), s.group(8)
    summary = json.loads((run / "summary.json").read_text())
    quantities = summary["parameters"] + summary["derived"]
    ess = min(min(q["ess_bulk"], q["ess_tail"]) for q in quantities)
    rhat = max(q["r_hat"] for q in quantities)
    start, sampling, after = phases(lines, int(steps), total)
    cov = coverage(run)
    inside, all_ = sum(c[0] for c in cov.values()), sum(c[1] for c in cov.values())
    kinds = "; ".join(f"{k} {a}/{b}" for k, (a, b) in cov.items())
    final = after - sum(sent_on)
    per = 1000 * final / (n * int(steps))
    return (f"| {n:,} | {converged} | {total:,.0f} | {start:,.0f} | {sampling:,.0f} "
            f"| {len(sent_on)} in {sum(sent_on):,.0f} | {final:,.0f} ({per:.2f}) | {steps} "
            f"| {tau} | {evaluations:,} | {rhat:.4f} | {ess:,.0f} | {peak / 1024:,.0f} "
            f"| {inside}/{all_} ({100 * inside / all_:.1f} %): {kinds} |")


def main():
    out = Path(sys.argv[1])
    sizes = [int(n) for n in sys.argv[2:]] or [200]
    out.mkdir(parents=True, exist_ok=True)
    rows = ["| contacts | converged | wall (s) | start (s) | sampling (s) "
            "| summaries that sent it on: times, in s | last summaries, LOO, report: s (ms per contact and step) "
            "| steps | τ_max (steps) | evaluations | highest R̂ | lowest ESS (bulk or tail) | peak RSS (MB) "
            "| truths inside their 95 % interval |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for n in sizes:
        rows.append(fit(out, n))
        print(rows[-1], file=sys.stderr)
    (out / "table.md").write_text("\n".join(rows) + "\n")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
