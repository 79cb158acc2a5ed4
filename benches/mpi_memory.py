#!/usr/bin/env python3
"""Peak memory of each rank of a campaign fit on MPI ranks, and of one process (reports/mpi.md).

For each campaign and binary: a fit of STEPS steps in one process on one thread (its peak
resident memory from `/usr/bin/time -f %M`), then on 2 ranks of one thread each (each rank
prints its own peak, VmHWM, and how many runs' data it held). Writes OUT_DIR/memory.md and
prints it.

    python3 benches/mpi_memory.py OUT_DIR --campaign NAME=CAMPAIGN.toml ... \
        [--binary NAME=PATH ...] [--steps 10]

Campaigns from `data/make_campaign.py` (`--first-interval 0.2 --repeat-interval 0.2` for long
records). Each binary must be built with `--features mpi` (default: target/release/slipbayes,
named "this"). Needs mpirun (Open MPI) and /usr/bin/time; runs as root with the variables Open
MPI asks for.
"""

import argparse
import os
import re
import subprocess
import sys
from pathlib import Path

ROOT_LINE = re.compile(r"MPI: (\d+) ranks; rank 0 .*?peak memory ([0-9.]+) MB")
RANK_LINE = re.compile(
    r"MPI: rank (\d+) held the data of (\d+) of (\d+) runs.*?peak memory ([0-9.]+) MB"
)
# Binaries from before the ranks held shares print no "held the data" clause.
OLD_RANK_LINE = re.compile(r"MPI: rank (\d+) served .*?peak memory ([0-9.]+) MB")


def named(pairs, what):
    out = []
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep:
            sys.exit(f"--{what} {pair!r}: give NAME=PATH")
        out.append((name, value))
    return out


def fit_args(campaign, out, steps):
    return ["fit", campaign, "--out", str(out), "--steps", str(steps), "--seed", "3",
            "--quiet", "--overwrite"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--campaign", action="append", required=True, help="NAME=CAMPAIGN.toml")
    ap.add_argument("--binary", action="append", help="NAME=PATH (built with --features mpi)")
    ap.add_argument("--steps", type=int, default=10)
    args = ap.parse_args()
    binaries = named(args.binary or ["this=target/release/slipbayes"], "binary")
    campaigns = named(args.campaign, "campaign")
    args.out.mkdir(parents=True, exist_ok=True)
    env = dict(os.environ, RAYON_NUM_THREADS="1", OMPI_ALLOW_RUN_AS_ROOT="1",
               OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    rows = []
    for campaign_name, campaign in campaigns:
        for name, binary in binaries:
            run = args.out / f"{campaign_name}-{name}"
            alone = subprocess.run(
                ["/usr/bin/time", "-f", "%M", binary, *fit_args(campaign, run / "alone",
                                                                 args.steps)],
                env=env, capture_output=True, text=True,
            )
            if alone.returncode != 0:
                sys.exit(f"{name} on {campaign_name}, one process:\n{alone.stderr}")
            one_mb = int(alone.stderr.strip().splitlines()[-1]) / 1e3
            ranks = subprocess.run(
                ["mpirun", "--oversubscribe", "--allow-run-as-root", "-x",
                 "RAYON_NUM_THREADS=1", "-n", "2", binary,
                 *fit_args(campaign, run / "ranks", args.steps)],
                env=env, capture_output=True, text=True,
            )
            if ranks.returncode != 0:
                sys.exit(f"{name} on {campaign_name}, 2 ranks:\n{ranks.stderr}")
            root = ROOT_LINE.search(ranks.stderr)
            other = RANK_LINE.search(ranks.stderr)
            if other:
                held = f"{other.group(2)} of {other.group(3)}"
                rank1_mb = float(other.group(4))
            else:
                old = OLD_RANK_LINE.search(ranks.stderr)
                if not old:
                    sys.exit(f"{name} on {campaign_name}: no rank 1 line:\n{ranks.stderr}")
                held, rank1_mb = "all", float(old.group(2))
            if not root:
                sys.exit(f"{name} on {campaign_name}: no rank 0 line:\n{ranks.stderr}")
            row = (campaign_name, name, f"{one_mb:.1f}", f"{float(root.group(2)):.1f}",
                   f"{rank1_mb:.1f}", held)
            print(" | ".join(row), flush=True)
            rows.append(row)
    table = [
        "| campaign | binary | 1 process | rank 0 of 2 | rank 1 of 2 | runs rank 1 held |",
        "|---|---|---|---|---|---|",
        *("| " + " | ".join(r[:2]) + " | " + " | ".join(f"{v} MB" for v in r[2:5])
          + f" | {r[5]} |" for r in rows),
    ]
    (args.out / "memory.md").write_text("\n".join(table) + "\n")
    print("\n".join(table))


if __name__ == "__main__":
    main()
