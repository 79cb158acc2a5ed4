#!/usr/bin/env python3
"""Time per sweep of a campaign fit in one process and on MPI ranks (reports/mpi.md).

Each configuration fits the campaign twice, for SHORT and LONG steps (--steps), with the same seed; the
time per sweep is the difference of the fits' sampling wall times (`summary.json`,
sampler.wall_s) over the difference of steps, which removes the start and the summaries. On
ranks, rank 0 prints the seconds it spent in MPI calls; the communication share is their
difference over the difference of wall times. The configurations run interleaved, ROUNDS times,
so that a change of the machine's load touches all of them alike.

    python3 benches/mpi_sweep.py CAMPAIGN.toml OUT_DIR [--binary NAME=PATH ...] [--rounds 2] \
        [--steps 20,80]

CAMPAIGN.toml from `python3 data/make_campaign.py --contacts 50 --out DIR`. Each binary must
be built with `--features mpi` (default: target/release/slipbayes, named "this"). Writes
OUT_DIR/table.md and prints it. Needs mpirun (Open MPI); runs as root with the variables Open
MPI asks for.
"""

import argparse
import json
import os
import re
import subprocess
import sys
from pathlib import Path

# Steps of the short and the long fit (--steps): the start's time varies from fit to fit, so a
# campaign whose start is long next to 60 sweeps (one with pooling) needs a longer long fit.
STEPS = "20,80"
MPI_LINE = re.compile(
    r"rank 0 spent ([0-9.]+) s of its ([0-9.]+) s in MPI calls .*?, ([0-9]+) requests"
    r".*?, ([0-9.]+) MB"
)


def configurations(binary):
    """(label, command prefix, environment) of every configuration for one binary."""
    mpirun = ["mpirun", "--oversubscribe", "--allow-run-as-root", "-x", "RAYON_NUM_THREADS=1"]
    return [
        ("1 process, 1 thread", [binary], {"RAYON_NUM_THREADS": "1"}),
        ("1 process, 2 threads", [binary], {"RAYON_NUM_THREADS": "2"}),
        ("2 ranks × 1 thread, busy polling", mpirun + ["-n", "2", binary], {}),
        (
            "2 ranks × 1 thread, yielding",
            mpirun[:1] + ["--mca", "mpi_yield_when_idle", "1"] + mpirun[1:] + ["-n", "2", binary],
            {},
        ),
    ]


def fit(prefix, env, model, out, steps):
    """Sampling wall time (s), rank 0's MPI seconds, requests and MB (None in one process)."""
    args = prefix + ["fit", str(model), "--out", str(out), "--overwrite", "--quiet"]
    args += ["--steps", str(steps), "--seed", "3"]
    full_env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    full_env.update(env)
    done = subprocess.run(args, env=full_env, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"{' '.join(args)} failed:\n{done.stderr}")
    (out / "stderr.txt").write_text(done.stderr)
    wall = json.loads((out / "summary.json").read_text())["sampler"]["wall_s"]
    found = MPI_LINE.search(done.stderr)
    mpi = None
    if found:
        mpi = (float(found[1]), float(found[2]), int(found[3]), float(found[4]))
    return wall, mpi, (out / "summary.csv").read_bytes()


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("model", type=Path)
    parser.add_argument("out", type=Path)
    parser.add_argument("--binary", action="append", default=[], help="NAME=PATH")
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--steps", default=STEPS, help="SHORT,LONG steps of the two fits")
    args = parser.parse_args()
    short, long = (int(v) for v in args.steps.split(","))
    binaries = [b.split("=", 1) for b in args.binary] or [["this", "target/release/slipbayes"]]
    args.out.mkdir(parents=True, exist_ok=True)
    rows = {}
    summaries = set()
    for round_no in range(1, args.rounds + 1):
        for name, path in binaries:
            for label, prefix, env in configurations(str(Path(path).resolve())):
                run = {}
                for steps in (short, long):
                    out = args.out / f"run-{len(rows)}-{steps}"
                    run[steps] = fit(prefix, env, args.model, out, steps)
                (w0, m0, _), (w1, m1, summary) = run[short], run[long]
                summaries.add((name, summary))
                per_sweep = (w1 - w0) / (long - short)
                share = None
                if m0 and m1:
                    # MPI seconds over rank 0's whole wall time (its start included), both
                    # differenced between the long and the short fit.
                    share = (m1[0] - m0[0]) / (m1[1] - m0[1])
                mb_per_sweep = (m1[3] - m0[3]) / (long - short) if m0 and m1 else None
                rows.setdefault((name, label), []).append((per_sweep, share, mb_per_sweep))
                print(
                    f"round {round_no}, {name}, {label}: {per_sweep:.4f} s per sweep"
                    + (f", {100 * share:.0f} % in MPI, {mb_per_sweep:.1f} MB" if share else ""),
                    flush=True,
                )
    lines = [
        "| binary | configuration | time per sweep, each round | in MPI calls (rank 0) | "
        "MB per sweep (rank 0) |",
        "|---|---|---|---|---|",
    ]
    for (name, label), results in rows.items():
        times = ", ".join(f"{r[0]:.3f} s" for r in results)
        shares = ", ".join(f"{100 * r[1]:.0f} %" for r in results if r[1] is not None) or "—"
        mb = ", ".join(f"{r[2]:.1f}" for r in results if r[2] is not None) or "—"
        lines.append(f"| {name} | {label} | {times} | {shares} | {mb} |")
    same = {name: len({s for n, s in summaries if n == name}) == 1 for name, _ in binaries}
    lines.append("")
    for name, one in same.items():
        lines.append(
            f"- {name}: the {long}-step fits' summary.csv are "
            + ("byte-identical across configurations." if one else "NOT identical.")
        )
    table = "\n".join(lines) + "\n"
    (args.out / "table.md").write_text(table)
    print(table)


if __name__ == "__main__":
    main()
