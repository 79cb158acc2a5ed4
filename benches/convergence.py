#!/usr/bin/env python3
"""Time, memory and convergence of the fits a user runs first, against the targets set for
them: the demo (`slipbayes demo`), the one-contact quick path, campaigns of 10 and 50
contacts, and the peak memory of a long run against a short one. Each command runs once, one
after the other, under GNU time (wall time and peak resident memory of the whole command);
steps, τ_max, ESS and R̂ come from each run's summary.json (every reported quantity, every
post-burn-in draw). Writes a Markdown report.

    python3 benches/convergence.py SCRATCH_DIR --out reports/convergence.md

Needs target/release/slipbayes (or --binary), GNU time (/usr/bin/time); standard library only.
Wall times depend on the machine's load: run it with nothing else running.
"""
import argparse
import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
QUICK = ["--first", "data/ptfe-c1-first.csv", "--repeat", "data/ptfe-c1-repeat.csv",
         "--velocity", "1e-9"]


def timed(cmd, log):
    """Runs `cmd` from the repository root under GNU time: (wall s, peak RSS MB, exit code)."""
    stats = log.with_suffix(".time")
    with open(log, "w") as out:
        code = subprocess.call(["/usr/bin/time", "-f", "%e %M", "-o", str(stats), *cmd],
                               cwd=ROOT, stdout=out, stderr=subprocess.STDOUT)
    wall, rss_kb = stats.read_text().split()[-2:]
    return float(wall), int(rss_kb) / 1024, code


def run_stats(run_dir):
    summary = json.loads((Path(run_dir) / "summary.json").read_text())
    quantities = summary["parameters"] + summary["derived"]
    s = summary["sampler"]

    def values(key):
        return [q[key] for q in quantities if q[key] is not None and q[key] == q[key]]

    return {
        "steps": s["steps"],
        "converged": s["converged"],
        "tau_max": s["tau_max"],
        "ess_bulk": min(values("ess_bulk")),
        "ess_tail": min(values("ess_tail")),
        "r_hat": max(values("r_hat")),
        "quantities": len(quantities),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scratch", type=Path)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--binary", default=str(ROOT / "target/release/slipbayes"))
    args = ap.parse_args()
    scratch = args.scratch.resolve()
    scratch.mkdir(parents=True, exist_ok=True)
    binary = args.binary
    rows = []

    def fit(label, command, bars, run_dir, ram_bar=None):
        wall, rss, code = timed(command, scratch / f"{run_dir.name}.log")
        st = run_stats(run_dir)
        met = st["converged"] and wall <= bars and (ram_bar is None or rss <= ram_bar)
        bar = f"converged, ≤ {bars:g} s" + (f", ≤ {ram_bar:g} MB" if ram_bar else "")
        rows.append(
            f"| {label} | {bar} | {wall:.1f} s, {rss:.0f} MB; {st['steps']:,} steps, "
            f"τ_max {st['tau_max']:.1f}, lowest ESS bulk {st['ess_bulk']:,.0f} and tail "
            f"{st['ess_tail']:,.0f}, highest R̂ {st['r_hat']:.4f} over {st['quantities']} "
            f"quantities; converged: {st['converged']} | `{' '.join(command_text(command))}` | "
            f"{'yes' if met else '**no**'} |"
        )
        print(rows[-1], file=sys.stderr)
        return wall, rss, code

    def command_text(command):
        return ["slipbayes" if c == binary else c.replace(str(scratch), "DIR") for c in command]

    demo = scratch / "demo"
    fit("`slipbayes demo`, report included", [binary, "demo", "--out", str(demo),
                                              "--overwrite", "--quiet"], 30, demo)
    quick = scratch / "quick"
    fit("one-contact quick path", [binary, "fit", *QUICK, "--quiet", "--overwrite", "--out",
                                   str(quick)], 5, quick)
    for contacts, seconds, mb in ((10, 60, 300), (50, 300, 1024)):
        camp = scratch / f"campaign-{contacts}"
        subprocess.check_call([sys.executable, "data/make_campaign.py", "--contacts",
                               str(contacts), "--out", str(camp), "--binary", binary],
                              cwd=ROOT, stdout=subprocess.DEVNULL)
        run = scratch / f"campaign-{contacts}-run"
        fit(f"{contacts}-contact campaign (`data/make_campaign.py --contacts {contacts}`)",
            [binary, "fit", str(camp / "campaign.toml"), "--quiet", "--overwrite", "--out",
             str(run)], seconds, run, mb)
    # Memory of a long run against a short one: the summaries and the report read the chains
    # back a row group at a time, so a run 16 times longer should hold about as much.
    peaks = {}
    for steps in (1000, 16000):
        run = scratch / f"memory-{steps}"
        command = [binary, "fit", *QUICK, "--steps", str(steps), "--quiet", "--overwrite",
                   "--out", str(run)]
        wall, rss, _ = timed(command, scratch / f"memory-{steps}.log")
        peaks[steps] = (rss, wall, command)
    ratio = peaks[16000][0] / peaks[1000][0]
    rows.append(
        f"| peak memory at 16,000 steps / at 1,000 steps, one contact | ≤ 1.2× | "
        f"{peaks[16000][0]:.1f} MB / {peaks[1000][0]:.1f} MB = {ratio:.2f}× "
        f"({peaks[16000][1]:.0f} s and {peaks[1000][1]:.1f} s) | "
        f"`{' '.join(command_text(peaks[16000][2])).replace('16000', 'N')}` | "
        f"{'yes' if ratio <= 1.2 else '**no**'} |"
    )
    text = [
        "# Convergence, time and memory of the fits a user runs first",
        "",
        "Each command ran once, one after the other, under GNU time (`/usr/bin/time -f \"%e %M\"`: "
        "wall time and peak resident memory of the whole command, start, sampling, summaries "
        "and report included), written by `python3 benches/convergence.py DIR --out "
        "reports/convergence.md`. \"Converged\" is slipbayes' strict verdict on every "
        "post-burn-in draw: every reported quantity with R̂ < 1.01 between ensembles and ESS "
        "bulk and tail > 400, τ trusted (1,600 post-burn-in walker-steps per τ). Campaigns are one material's contacts, "
        "each a 201-point first slide and a 51-point repeat slide (`data/make_campaign.py`). "
        "The peak beyond the record, the hard case of convergence, is in "
        "[validation/hard/hard_cases.md](validation/hard/hard_cases.md).",
        "",
        "| fit | target | measured | command | met |",
        "|---|---|---|---|---|",
        *rows,
        "",
    ]
    args.out.write_text("\n".join(text))


if __name__ == "__main__":
    main()
