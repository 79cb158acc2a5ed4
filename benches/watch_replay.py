#!/usr/bin/env python3
"""How the interval of F_peak narrows while a slide is recorded (reports/watch.md).

    python3 benches/watch_replay.py OUT_DIR [--speed 1000] [--seed 1] \
        [--slide data/ptfe-c1-first.csv] [--velocity 1e-9] [--binary target/release/slipbayes]

Replays the slide's rows into OUT_DIR/export.csv at --speed instrument seconds per wall second,
in bursts of 10 rows, each burst's last row written in two halves, while
`slipbayes watch OUT_DIR/export.csv --out OUT_DIR/watch --idle-s 5 --refit-max-s 3` follows it
to the end of the record. Then fits the whole record once, cold, with the same seed
(`slipbayes fit --first SLIDE`), and tabulates every refit (the fraction of the record seen,
F_peak's median and 95 % interval, the probability that the peak is inside the record, the
refit's time and whether it was warm-started) next to the fit of the whole record, with the
first refit at which each stopping criterion would have been met. Writes OUT_DIR/table.md and
prints it.
"""

import argparse
import csv
import json
import subprocess
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BURST = 10


def replay(source, export, speed, done):
    """Writes the rows of `source` into `export` at `speed`; sets `done` at the end."""
    lines = source.read_text().splitlines()
    header, rows = lines[0], lines[1:]
    times = [float(r.split(",")[0]) for r in rows]
    began = time.monotonic()
    with export.open("w") as f:
        f.write(header + "\n")
        f.flush()
        for i in range(0, len(rows), BURST):
            burst = rows[i:i + BURST]
            # Each burst when the instrument would have written its last row.
            wait = began + (times[i + len(burst) - 1] - times[0]) / speed - time.monotonic()
            if wait > 0:
                time.sleep(wait)
            for r in burst[:-1]:
                f.write(r + "\n")
            last = burst[-1]
            f.write(last[: len(last) // 2])
            f.flush()
            time.sleep(0.01)
            f.write(last[len(last) // 2:] + "\n")
            f.flush()
    done.set()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--speed", type=float, default=1000.0)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--refit-max-s", default="3",
                    help="each refit's wall-time budget (watch --refit-max-s)")
    ap.add_argument("--slide", type=Path, default=ROOT / "data/ptfe-c1-first.csv")
    ap.add_argument("--velocity", default="1e-9")
    ap.add_argument("--record-s", type=float,
                    help="replay the slide only to this instrument time (the record, then)")
    ap.add_argument("--binary", default=str(ROOT / "target/release/slipbayes"))
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    export, watch_dir, full_dir = a.out / "export.csv", a.out / "watch", a.out / "full"
    export.unlink(missing_ok=True)
    slide = a.slide
    if a.record_s is not None:
        # The record as far as it is replayed: what the last refit and the cold fit both see.
        lines = a.slide.read_text().splitlines()
        kept = [lines[0]] + [r for r in lines[1:] if float(r.split(",")[0]) <= a.record_s]
        slide = a.out / "record.csv"
        slide.write_text("\n".join(kept) + "\n")
    done = threading.Event()
    writer = threading.Thread(target=replay, args=(slide, export, a.speed, done))
    watch = subprocess.Popen(
        [a.binary, "watch", str(export), "--out", str(watch_dir), "--overwrite",
         "--velocity", a.velocity, "--idle-s", "5", "--poll-s", "0.2", "--seed", str(a.seed),
         "--refit-max-s", a.refit_max_s],
        stderr=subprocess.PIPE, text=True)
    writer.start()
    log = watch.stderr.read()
    watch.wait()
    writer.join()
    (a.out / "watch.log").write_text(log)
    if watch.returncode != 0:
        raise SystemExit(f"watch exited {watch.returncode}:\n{log[-3000:]}")

    began = time.monotonic()
    subprocess.run([a.binary, "fit", "--first", str(slide), "--velocity", a.velocity,
                    "--seed", str(a.seed), "--out", str(full_dir), "--overwrite", "--quiet"],
                   check=True, stdout=subprocess.DEVNULL)
    full_s = time.monotonic() - began
    full = {q["name"]: q for q in json.loads((full_dir / "summary.json").read_text())["derived"]}
    f_full = full["F_peak"]

    with (watch_dir / "watch.csv").open() as f:
        rows = list(csv.DictReader(f))
    record = float(slide.read_text().splitlines()[-1].split(",")[0])
    truth_path = a.slide.with_suffix(".json")
    truth = json.loads(truth_path.read_text())["peak"] if truth_path.exists() else None

    def mn(v):
        return f"{1e3 * float(v):.3f}"

    table = [
        f"The slide `{a.slide.relative_to(ROOT) if a.slide.is_relative_to(ROOT) else a.slide}`"
        + (f" to t = {record:,.0f} s" if a.record_s is not None else "")
        + f" ({record:,.0f} s of record"
        + (f"; its simulated peak F_peak = {1e3 * truth['f_peak_n']:.3f} mN at t = "
           f"{truth['t_peak_s']:,.0f} s" if truth else "")
        + f") replayed at {a.speed:,.0f}× into an export that `slipbayes watch` followed, each "
        f"refit given at most {a.refit_max_s} s (`--refit-max-s`: before the peak a record is "
        f"slow to fit, and a refit that hits the budget reports what it has, not converged); "
        f"seed {a.seed}. {len(rows)} refits.",
        "",
        "| refit | record seen (s) | fraction of the record | points | F_peak (mN): median "
        "[95 % interval] | width | P(peak inside the record) | converged | refit (s) | warm start |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        end = float(r["record_end_s"])
        width = (float(r["F_peak_high_N"]) - float(r["F_peak_low_N"])) / float(r["F_peak_N"])
        table.append(
            f"| {r['refit']} | {end:,.0f} | {end / record:.3f} | {r['points']} "
            f"| {mn(r['F_peak_N'])} [{mn(r['F_peak_low_N'])}, {mn(r['F_peak_high_N'])}] "
            f"| {100 * width:.2f} % | {float(r['p_peak_in_record']):.2f} | {r['converged']} "
            f"| {float(r['refit_s']):.2f} | {r['warm_start']} |")
    full_width = (f_full["ci_high"] - f_full["ci_low"]) / f_full["median"]
    table.append(
        f"| the record, one cold fit | {record:,.0f} | 1.000 | — | {mn(f_full['median'])} "
        f"[{mn(f_full['ci_low'])}, {mn(f_full['ci_high'])}] | {100 * full_width:.2f} % | — | "
        f"— | {full_s:.2f} (end to end) | no |")

    last = rows[-1]
    sd = (f_full["ci_high"] - f_full["ci_low"]) / 3.92
    diff = (float(last["F_peak_N"]) - f_full["median"]) / sd
    first = {}
    for r in rows:
        width = (float(r["F_peak_high_N"]) - float(r["F_peak_low_N"])) / float(r["F_peak_N"])
        converged = r["converged"] == "true"
        for name, met in (("F_peak's interval narrower than 1 % of its median", width <= 0.01),
                          ("the peak inside the record (P ≥ 0.95)",
                           float(r["p_peak_in_record"]) >= 0.95)):
            if converged and met and name not in first:
                first[name] = r
    table += [
        "",
        f"- The last refit (the whole record replayed, warm-started) against one cold fit of "
        f"that record: F_peak's medians differ by {diff:+.2f} posterior sd; the interval ends by "
        f"{1e3 * (float(last['F_peak_low_N']) - f_full['ci_low']):+.4f} and "
        f"{1e3 * (float(last['F_peak_high_N']) - f_full['ci_high']):+.4f} mN.",
        f"- Refits after the first started from the previous posterior: median refit time "
        f"{sorted(float(r['refit_s']) for r in rows[1:])[len(rows[1:]) // 2]:.2f} s, against "
        f"{full_s:.2f} s for the cold fit of the record (end to end, a process of its own).",
    ]
    for name, r in first.items():
        end = float(r["record_end_s"])
        table.append(f"- Stopping when {name} would have stopped at refit {r['refit']}, "
                     f"{end:,.0f} s into the record ({100 * end / record:.1f} %).")
    text = "\n".join(table) + "\n"
    (a.out / "table.md").write_text(text)
    print(text)


if __name__ == "__main__":
    main()
