#!/usr/bin/env python3
"""Pools the replications of several `slipbayes validate` runs of one model (different seeds)
and tests each ranked quantity on all of them together: χ² of the ranks (20 bins), χ² of the
truth's quantile among all post-burn-in draws (20 bins), and the coverage of the central 50 %
and 95 % intervals. Prints a Markdown report, the quantities by rank p, smallest first.

    python3 benches/sbc_combined.py reports/validation_pooled reports/validation_pooled_seed2

Reads each run's `replications.csv` and `settings.json`; standard library only.
"""
import csv
import json
import math
import sys

BINS = 20


def upper_gamma_regularized(s, x):
    """Q(s, x) = Γ(s, x) / Γ(s): the series of P below s + 1, Lentz's continued fraction
    above (Numerical Recipes §6.2), to about 1e-15."""
    if x <= 0:
        return 1.0
    log_front = s * math.log(x) - x - math.lgamma(s)
    if x < s + 1:
        term = total = 1.0 / s
        a = s
        while abs(term) > abs(total) * 1e-16:
            a += 1
            term *= x / a
            total += term
        return 1.0 - total * math.exp(log_front)
    tiny = 1e-300
    b = x + 1 - s
    c = 1 / tiny
    d = 1 / b
    h = d
    for i in range(1, 10_000):
        an = -i * (i - s)
        b += 2
        d = an * d + b
        d = tiny if abs(d) < tiny else d
        c = b + an / c
        c = tiny if abs(c) < tiny else c
        d = 1 / d
        delta = d * c
        h *= delta
        if abs(delta - 1) < 1e-16:
            break
    return math.exp(log_front) * h


def chi2_p(counts, n):
    expected = n / len(counts)
    x = sum((k - expected) ** 2 / expected for k in counts)
    return x, upper_gamma_regularized((len(counts) - 1) / 2, x / 2)


def replications(run):
    """The successful replications of a run: {quantity: (rank, quantile)} each."""
    with open(f"{run}/replications.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    quantities = [c[len("rank:"):] for c in rows[0] if c.startswith("rank:")] if rows else []
    return [
        {q: (int(r[f"rank:{q}"]), float(r[f"quantile:{q}"])) for q in quantities}
        for r in rows
        if not r["failure"]
    ]


def main(runs):
    reps = [r for run in runs for r in replications(run)]
    n = len(reps)
    rank_draws = json.load(open(f"{runs[0]}/settings.json"))["rank_draws"]
    per_bin = (rank_draws + 1) // BINS
    rows = []
    for c in sorted(reps[0]):
        ranks = [0] * BINS
        quants = [0] * BINS
        q = []
        for r in reps:
            rank, v = r[c]
            ranks[rank // per_bin] += 1
            quants[min(int(v * BINS), BINS - 1)] += 1
            q.append(v)
        x, p = chi2_p(ranks, n)
        _, pq = chi2_p(quants, n)
        c50 = sum(0.25 <= v <= 0.75 for v in q) / n
        c95 = sum(0.025 <= v <= 0.975 for v in q) / n
        rows.append((p, c, x, pq, c50, c95))
    print("# Simulation-based calibration, runs pooled")
    print()
    print(
        f"{n} successful replications of {len(runs)} runs ({', '.join(f'`{r}`' for r in runs)}), "
        f"pooled by `python3 benches/sbc_combined.py {' '.join(runs)}`: χ² of the ranks in "
        f"{BINS} bins ({BINS - 1} degrees of freedom), χ² of the truth's quantile among all "
        "post-burn-in draws, and the coverage of the central 50 % and 95 % intervals. With "
        f"{len(rows)} quantities tested, about one p below 0.05 is expected by chance; "
        f"Bonferroni's bound at 0.05 is {0.05 / len(rows):.4f}."
    )
    print()
    print("| quantity | χ² | p (ranks) | p (quantiles) | 50 % coverage | 95 % coverage |")
    print("|---|---|---|---|---|---|")
    for p, c, x, pq, c50, c95 in sorted(rows):
        print(f"| `{c}` | {x:.1f} | {p:.3f} | {pq:.3f} | {c50:.3f} | {c95:.3f} |")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
