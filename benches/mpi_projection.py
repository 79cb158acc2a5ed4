#!/usr/bin/env python3
"""Where the time and memory of campaign fits on MPI ranks go, per contact, and what they project
for campaigns larger than this machine can fit (reports/mpi.md).

    python3 benches/mpi_projection.py OUT_DIR --campaign CAMPAIGN.toml [--campaign ...] \
        [--steps 60] [--project 2000,10000] [--ranks 64] [--binary target/release/slipbayes]

Each campaign (from `data/make_campaign.py --contacts N`) is fitted for --steps steps with seed 3
on 1 rank and on 2 ranks of one thread each (`mpirun -n R`, RAYON_NUM_THREADS=1), reporting its
progress every half second. The phases (the start, the sampling, and the summaries, LOO and
report) come from the progress lines as in `benches/campaign_fit.py`; rank 0's bytes and MPI
seconds and each rank's peak memory from the lines the ranks print at the end.

The projection. A sweep's cost per contact is the largest campaign's; the start's, the
summaries' and the memory's are the slopes between the two largest campaigns (each has a part
that does not grow with the contacts). A sweep on R ranks costs T(R) = s + p / R: p is the
work the ranks share (each contact's update and its share of the shared block's, split by
contact), s what none shares (rank 0's moves, merge and chains, and the traffic through it, on
loopback here); from one and two ranks on two cores, s = 2 T(2) - T(1) and p = 2 (T(1) - T(2)).
The start and the summaries are projected from one rank's (they run on rank 0, which may hand
evaluations to the ranks, and are taken as not sped up by them); the summaries also linearly in
the steps. Rank 0's peak memory and another rank's (per contact it holds) from the two ranks'.
The assumptions are printed with the table: costs linear in the contacts beyond those measured
(reports/campaign-scaling.md measures a sweep and the start to 1,000 contacts), a rank per core
as fast as this machine's, and a network that moves rank 0's bytes as fast as loopback here.

Writes OUT_DIR/projection.md and prints it. The binary must be built with `--features mpi`;
needs Open MPI's mpirun and GNU time; runs as root with the variables Open MPI asks for.
"""

import argparse
import os
import re
import subprocess
import sys
import time
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from campaign_fit import phases  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
RANK0 = re.compile(
    r"MPI: (\d+) ranks; rank 0 spent ([0-9.]+) s of its ([0-9.]+) s in MPI calls.*?"
    r", ([0-9.]+) MB, peak memory ([0-9.]+) MB"
)
OTHER = re.compile(r"MPI: rank (\d+) held the data of (\d+) of (\d+) runs.*?peak memory ([0-9.]+) MB")
TIME = re.compile(r"peak RSS (\d+) kB")


def contacts(campaign):
    """The number of contacts of a model file."""
    return len(tomllib.loads(campaign.read_text()).get("contact", []))


def fit(binary, campaign, out, ranks, steps):
    """One fit on `ranks` ranks: its phases, rank 0's MB and MPI seconds, each rank's peak MB."""
    cmd = ["mpirun", "--oversubscribe", "--allow-run-as-root", "-x", "RAYON_NUM_THREADS=1",
           "-n", str(ranks), "/usr/bin/time", "-f", "peak RSS %M kB", binary, "fit",
           str(campaign), "--out", str(out), "--overwrite", "--steps", str(steps), "--seed", "3",
           "--progress-every", "0.5"]
    env = dict(os.environ, OMPI_ALLOW_RUN_AS_ROOT="1", OMPI_ALLOW_RUN_AS_ROOT_CONFIRM="1")
    began = time.monotonic()
    lines, said = [], []
    # The fit prints a table of every quantity on stdout: to a file, not a pipe read at the end.
    with (out.parent / f"{out.name}.out").open("w") as printed:
        proc = subprocess.Popen(cmd, cwd=campaign.parent, env=env, stdout=printed,
                                stderr=subprocess.PIPE, text=True)
        for line in proc.stderr:
            said.append(line)
            m = re.match(r"progress: step (\d+)/", line)
            if m:
                lines.append((time.monotonic() - began, int(m.group(1))))
        status = proc.wait()
    (out.parent / f"{out.name}.err").write_text("".join(said))
    if status != 0:
        sys.exit(f"{' '.join(cmd)} failed:\n{''.join(said[-20:])}")
    start, sampling, rest = phases(lines, steps, time.monotonic() - began)
    text = "".join(said)
    result = {"start": start, "sweep": sampling / steps, "rest": rest}
    found = RANK0.search(text)
    if found:
        result["mb"] = float(found[4])
        result["mpi_share"] = float(found[2]) / float(found[3])
        result["peak"] = {0: float(found[5])}
        for m in OTHER.finditer(text):
            result["peak"][int(m[1])] = float(m[4])
    else:
        # One rank prints no MPI line: its peak is GNU time's.
        result["peak"] = {0: int(TIME.search(text)[1]) / 1e3}
    return result


def seconds(s):
    return f"{s / 3600:.1f} h" if s >= 3600 else f"{s / 60:.1f} min" if s >= 120 else f"{s:.2f} s"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--campaign", type=Path, action="append", required=True)
    ap.add_argument("--steps", type=int, default=60)
    ap.add_argument("--project", default="2000,10000")
    ap.add_argument("--ranks", type=int, default=64)
    ap.add_argument("--binary", default=str(ROOT / "target/release/slipbayes"))
    a = ap.parse_args()
    a.out.mkdir(parents=True, exist_ok=True)
    measured = []
    for campaign in a.campaign:
        campaign = campaign.resolve()
        n = contacts(campaign)
        one = fit(a.binary, campaign, a.out / f"c{n}-1", 1, a.steps)
        two = fit(a.binary, campaign, a.out / f"c{n}-2", 2, a.steps)
        print(f"{n} contacts: {one} / {two}", file=sys.stderr, flush=True)
        measured.append((n, one, two))

    rows = [
        f"Measured: {a.steps}-step fits, seed 3, ranks of one thread.",
        "",
        "| contacts | ranks | start (s) | per sweep (s) | per sweep per contact (ms) "
        "| summaries, LOO, report (s) | the same per contact (ms) | rank 0: MB through it, "
        "share of its time in MPI calls | peak memory per rank (MB) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for n, one, two in measured:
        for ranks, r in ((1, one), (2, two)):
            traffic = (f"{r['mb']:.0f} MB, {100 * r['mpi_share']:.0f} %" if "mb" in r else "—")
            peaks = ", ".join(f"{r['peak'][k]:.0f}" for k in sorted(r["peak"]))
            rows.append(
                f"| {n:,} | {ranks} | {r['start']:.1f} | {r['sweep']:.3f} "
                f"| {1e3 * r['sweep'] / n:.2f} | {r['rest']:.1f} | {1e3 * r['rest'] / n:.1f} "
                f"| {traffic} | {peaks} |")

    # Each cost as a line in the contacts through the two largest campaigns: the slope is the
    # cost per contact, the intercept what a fit costs whatever its contacts.
    (n0, one0, two0), (n1, one1, two1) = measured[-2], measured[-1]

    def line(x0, x1):
        slope = (x1 - x0) / (n1 - n0)
        return lambda c: x1 + slope * (c - n1), slope

    # A sweep has no fixed part to speak of (reports/campaign-scaling.md: its cost per contact
    # is the same from 50 to 1,000 contacts), and the largest campaign's is the least noisy.
    t1_slope, t2_slope = one1["sweep"] / n1, two1["sweep"] / n1

    def t1(c):
        return c * t1_slope

    def t2(c):
        return c * t2_slope

    start, start_slope = line(one0["start"], one1["start"])
    rest, rest_slope = line(one0["rest"] / a.steps, one1["rest"] / a.steps)
    root, root_slope = line(two0["peak"][0], two1["peak"][0])
    other_mb = [max(v for k, v in t["peak"].items() if k > 0) for t in (two0, two1)]
    other, other_slope = line(*other_mb)
    rows += [
        "",
        f"Per contact: a sweep of the {n1:,}-contact fits {1e3 * t1_slope:.3f} ms on one rank "
        f"and {1e3 * t2_slope:.3f} ms on two, "
        f"so the work the ranks share p = 2 (T(1) − T(2)) = {2e3 * (t1_slope - t2_slope):.3f} ms "
        f"and what none shares s = 2 T(2) − T(1) = {1e3 * (2 * t2_slope - t1_slope):.3f} ms; the "
        f"start {1e3 * start_slope:.1f} ms and the summaries, LOO and report "
        f"{1e6 * rest_slope:.0f} µs per step of the fit (the slopes between the {n0:,}- and "
        f"{n1:,}-contact fits), both on rank 0 alone; rank 0's peak memory "
        f"{1e3 * root_slope:.0f} kB, another rank's {2e3 * other_slope:.0f} kB per contact it "
        "holds (the same slopes).",
    ]
    if 2 * t2_slope < t1_slope:
        rows += [
            "",
            "Two ranks measured more than twice as fast as one (the machine's load moved between "
            "the fits): what none shares is not resolved, and is taken as 0, so the rows on many "
            "ranks are a lower bound.",
        ]
    rows += [
        "",
        "| contacts | ranks | per sweep: shared / R | unshared | per sweep | 500 sweeps "
        "| start (rank 0) | summaries, LOO and report of 500 steps (rank 0) "
        "| rank 0's peak memory | another rank's |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for c in [int(v) for v in a.project.split(",")]:
        # What the ranks share is what one rank does apart from what none shares, so that
        # the two add up to one rank's sweep also when the unshared part is taken as 0.
        unshared = max(0.0, 2 * t2(c) - t1(c))
        shared = t1(c) - unshared
        for ranks in (1, a.ranks):
            per_sweep = t1(c) if ranks == 1 else unshared + shared / ranks
            held = other(2 * c / ranks) if ranks > 1 else None
            rows.append(
                f"| {c:,} | {ranks} | {seconds(shared / ranks)} | {seconds(unshared)} "
                f"| {seconds(per_sweep)} | {seconds(500 * per_sweep)} | {seconds(start(c))} "
                f"| {seconds(500 * rest(c))} | {root(c) / 1e3:.1f} GB "
                f"| {'—' if held is None else f'{held:.0f} MB'} |")
    rows += [
        "",
        "Assumed: each cost linear in the contacts beyond the largest campaign measured, and the "
        "summaries linear in the steps; a rank per core as fast as this machine's; rank 0's "
        "traffic as fast over the network as over loopback here. 500 sweeps is what the "
        "1,000-contact campaign took to converge (reports/campaign-fit.md); at 64 ranks "
        "another rank holds C / 64 contacts (2 C / 64 runs).",
    ]
    table = "\n".join(rows) + "\n"
    (a.out / "projection.md").write_text(table)
    print(table)


if __name__ == "__main__":
    main()
