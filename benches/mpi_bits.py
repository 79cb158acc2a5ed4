#!/usr/bin/env python3
"""Whether a campaign's chains are the same bits in one process and on MPI ranks, at a size the
test suite cannot afford (`cli/tests/mpi.rs` checks three contacts on 1, 2 and 3 ranks).

    python3 benches/mpi_bits.py CAMPAIGN.toml OUT_DIR [--steps 60] [--ranks 1,2,4] \
        [--binary target/release/slipbayes]

Fits CAMPAIGN.toml for --steps steps with seed 11, once as one process and once under
`mpirun -n R` for each R, each into OUT_DIR/<label>, and compares every run's chains with the
single process's: every row's (step, ensemble, walker) and every value column, as bits. The
binary must be built with `--features mpi`. Reads the chains with pyarrow, from the venv
`benches/stopping.py` makes when this Python lacks it. Needs Open MPI's mpirun; runs as root
with the variables Open MPI asks for. Writes OUT_DIR/table.md and
prints it; exits 1 when any run differs.
"""

import argparse
import glob
import hashlib
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from stopping import ensure_venv  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def fit(cmd, campaign, out, steps):
    """Runs one fit; returns its wall time in seconds."""
    args = cmd + ["fit", str(campaign), "--out", str(out), "--overwrite", "--steps", str(steps),
                  "--seed", "11", "--quiet"]
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    began = time.monotonic()
    # The fit prints a table of every quantity on stdout: to a file, not a pipe.
    with (out.parent / f"{out.name}.out").open("w") as printed:
        subprocess.run(args, cwd=campaign.parent, env=env, stdout=printed, check=True)
    return time.monotonic() - began


def digest(run):
    """(rows, columns, one digest per column) of the chains of run directory `run`, read part
    after part in order: every value's bytes, so equal digests are equal bits."""
    import pyarrow.parquet as pq

    parts = sorted(glob.glob(str(run / "chains" / "part-*.parquet")))
    if not parts:
        sys.exit(f"{run}: no chain parts")
    names, hashes, rows = None, None, 0
    for part in parts:
        table = pq.read_table(part)
        if names is None:
            names = table.column_names
            hashes = [hashlib.sha256() for _ in names]
        elif table.column_names != names:
            sys.exit(f"{part}: columns differ from the first part's")
        rows += table.num_rows
        for h, column in zip(hashes, table.columns):
            h.update(column.to_numpy().tobytes())
    return rows, names, [h.hexdigest() for h in hashes]


def main():
    ensure_venv()
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("campaign", type=Path)
    ap.add_argument("out", type=Path)
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--ranks", default="1,2,4")
    ap.add_argument("--binary", default=str(ROOT / "target/release/slipbayes"))
    a = ap.parse_args()
    campaign, out = a.campaign.resolve(), a.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    mpirun = ["mpirun", "--oversubscribe", "--allow-run-as-root", "-x", "RAYON_NUM_THREADS=1"]
    runs = [("1 process", [a.binary])] + [
        (f"{r} rank{'' if r == '1' else 's'}", mpirun + ["-n", r, a.binary])
        for r in a.ranks.split(",")
    ]
    lines = [
        "| run | wall (s) | rows | value columns | same bits as one process |",
        "|---|---|---|---|---|",
    ]
    reference, differ = None, False
    for label, cmd in runs:
        run = out / label.replace(" ", "-")
        wall = fit(cmd, campaign, run, a.steps)
        rows, names, hashes = digest(run)
        if reference is None:
            reference, same = (rows, names, hashes), "(the reference)"
        else:
            bad = [n for n, h, r in zip(names, hashes, reference[2]) if h != r]
            if rows != reference[0] or names != reference[1] or bad:
                differ = True
                same = f"no: {len(bad)} columns differ (first: {bad[0] if bad else 'rows'})"
            else:
                same = "yes, every column"
        lines.append(f"| {label} | {wall:.0f} | {rows:,} | {len(names) - 3:,} | {same} |")
        print(lines[-1], flush=True)
    (out / "table.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
