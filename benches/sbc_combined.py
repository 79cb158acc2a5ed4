#!/usr/bin/env python3
"""Pools the replications of several `slipbayes validate` runs of one model (different seeds)
and tests each ranked quantity on all of them together: χ² of the ranks (20 bins), χ² of the
truth's quantile among all post-burn-in draws (20 bins), and the coverage of the central 50 %
and 95 % intervals. Prints the quantities by rank p, smallest first.

    python3 benches/sbc_combined.py reports/validation_pooled reports/validation_pooled_seed2

Needs scipy (for the χ² tail). Used for the combined figures in reports/validation.md.
"""
import glob
import json
import sys

from scipy.stats import chi2

BINS = 20


def chi2_p(counts, n):
    expected = n / len(counts)
    x = sum((k - expected) ** 2 / expected for k in counts)
    return x, chi2.sf(x, len(counts) - 1)


def main(dirs):
    reps = [
        r
        for d in dirs
        for f in sorted(glob.glob(f"{d}/replications/*.json"))
        for r in [json.load(open(f))]
        if r.get("failure") is None
    ]
    n = len(reps)
    rank_draws = json.load(open(f"{dirs[0]}/settings.json"))["rank_draws"]
    per_bin = (rank_draws + 1) // BINS
    rows = []
    for c in sorted(reps[0]["ranks"]):
        ranks = [0] * BINS
        quants = [0] * BINS
        q = []
        for r in reps:
            ranks[r["ranks"][c] // per_bin] += 1
            v = r["quantiles"][c]
            quants[min(int(v * BINS), BINS - 1)] += 1
            q.append(v)
        x, p = chi2_p(ranks, n)
        _, pq = chi2_p(quants, n)
        c50 = sum(0.25 <= v <= 0.75 for v in q) / n
        c95 = sum(0.025 <= v <= 0.975 for v in q) / n
        rows.append((p, c, x, pq, c50, c95))
    print(f"{n} replications from {len(dirs)} runs")
    print(f"{'quantity':<24} {'chi2':>6} {'p':>6} {'p(quant)':>9} {'cover50':>8} {'cover95':>8}")
    for p, c, x, pq, c50, c95 in sorted(rows):
        print(f"{c:<24} {x:6.1f} {p:6.3f} {pq:9.3f} {c50:8.3f} {c95:8.3f}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
