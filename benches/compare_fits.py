#!/usr/bin/env python3
"""Compares two fits of the same data quantity by quantity, in units of posterior sd.

Usage: python3 benches/compare_fits.py REFERENCE_RUN_DIR OTHER_RUN_DIR [LIMIT]

For every row of REFERENCE/summary.csv (parameters and derived quantities), the other fit's
median and 95 % interval ends minus the reference's, divided by the reference's posterior sd.
Prints one row per quantity and the largest shift; exits 1 when a shift exceeds LIMIT
(default 0.05 sd). Standard library only.
"""
import csv
import sys


def rows(run_dir):
    with open(f"{run_dir}/summary.csv", newline="") as f:
        return {(r["kind"], r["name"], r["group"]): r for r in csv.DictReader(f)}


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    reference, other = rows(sys.argv[1]), rows(sys.argv[2])
    limit = float(sys.argv[3]) if len(sys.argv) == 4 else 0.05
    worst = 0.0
    print("| quantity | sd | Δ median / sd | Δ 2.5 % / sd | Δ 97.5 % / sd |")
    print("|---|---|---|---|---|")
    for key, r in reference.items():
        if key not in other:
            sys.exit(f"{key} missing from {sys.argv[2]}")
        sd = float(r["sd"])
        if not sd > 0.0:
            continue
        shifts = [
            (float(other[key][c]) - float(r[c])) / sd for c in ("median", "ci_low", "ci_high")
        ]
        worst = max(worst, *(abs(s) for s in shifts))
        print(f"| {key[1]}[{key[2]}] | {sd:.4g} | " + " | ".join(f"{s:+.4f}" for s in shifts) + " |")
    print(f"\nlargest shift {worst:.4f} posterior sd (limit {limit})")
    sys.exit(0 if worst <= limit else 1)


if __name__ == "__main__":
    main()
