#!/usr/bin/env python3
"""`slipbayes bench --quick` of two builds, interleaved, as Markdown on stdout.

    python3 benches/side_by_side.py OLD_BIN OLD_TREE NEW_BIN NEW_TREE PAIRS OUT_DIR

Runs `BIN bench --quick --no-peer --no-memory` from each build's own source tree (the bench
reads models/ and data/ from the working directory) PAIRS times, old then new then old ...,
so that both see the same load, and compares what the bench measures: the cost per point of
the law and of the one-contact log-density, sampler steps per second on the one-contact and
the demo posteriors (one thread and two), and the wall time of the one-contact reference fit.

For each measure: the median over the pairs of new/old, the range of that ratio, and the
run-to-run spread of each build alone (its largest over its smallest value): a ratio within
the builds' own spread is no measurable change.
"""

import json
import statistics
import subprocess
import sys
from pathlib import Path


def run(binary, tree, out):
    subprocess.run(
        [binary, "bench", "--quick", "--no-peer", "--no-memory", "--out", str(out)],
        cwd=tree,
        check=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    return json.loads((out / "speed-vs-error" / "results.json").read_text())


def measures(results):
    """(name, value, lower is better) of one bench run."""
    out = []
    for row in results["cost"]["rows"]:
        out.append((f"ns per point: {row['what']}", row["ns_per_point"], True))
    for post in results["throughput"]:
        for r in post["runs"]:
            name = f"steps per s: {post['posterior']}, {r['threads']} thread(s)"
            out.append((name, r["steps_per_s"], False))
    out.append(("wall s: one-contact reference fit", results["knobs"]["reference_wall_s"], True))
    return out


def main():
    old_bin, old_tree, new_bin, new_tree, pairs, out = sys.argv[1:7]
    out = Path(out)
    runs = {"old": [], "new": []}
    for i in range(int(pairs)):
        for which, binary, tree in (("old", old_bin, old_tree), ("new", new_bin, new_tree)):
            runs[which].append(measures(run(binary, tree, out / f"{which}-{i}")))
    names = [(n, lower) for n, _, lower in runs["new"][0]]
    print("| measure | old (median) | new (median) | new/old, median of pairs | range of new/old | spread old | spread new |")
    print("|---|---|---|---|---|---|---|")
    for k, (name, lower) in enumerate(names):
        old = [r[k][1] for r in runs["old"]]
        new = [r[k][1] for r in runs["new"]]
        ratios = [n / o for n, o in zip(new, old)]
        spread = lambda v: max(v) / min(v)
        print(
            f"| {name} ({'lower' if lower else 'higher'} is better) | {statistics.median(old):.4g} "
            f"| {statistics.median(new):.4g} | {statistics.median(ratios):.3f} "
            f"| {min(ratios):.3f}–{max(ratios):.3f} | {spread(old):.3f} | {spread(new):.3f} |"
        )


if __name__ == "__main__":
    main()
