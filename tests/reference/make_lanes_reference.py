#!/usr/bin/env python3
"""Reference values for the branch-free lane functions of slipbayes::special::lanes.

Run (mpmath 1.x):

    python3 tests/reference/make_lanes_reference.py

Writes ``lanes_mpmath.csv`` next to this script, columns ``function,x,value``:

* ``exp_neg``: e^(-x) for 0 <= x <= 700 (uniform, log-spaced from 1e-300, and the doubles
  around every boundary (k + 1/2) ln 2 of the range reduction).
* ``ln``: ln x for normal x, log-spaced over [1e-300, 1e300], dense around 1 and sqrt(2) and at
  the powers of two with their neighbouring doubles.
* ``one_minus_exp_neg``: 1 - e^(-x) for 0 < x <= 2 (log-spaced from 1e-300, dense around 1/2
  where the lane function switches from its series).
* ``ln_1p``: ln(1 + u) for 0 <= u <= 1 (log-spaced from 1e-300, uniform).

Every ``x`` is written as ``repr`` of an IEEE double, so the Rust side reads back exactly the
input evaluated here; values are 40 significant digits at 60 digits of working precision.
"""

import csv
import math
import os
import random

import mpmath as mp

mp.mp.dps = 60


def nextafter_n(x, n):
    """The n doubles on each side of x."""
    out = [x]
    lo = hi = x
    for _ in range(n):
        lo = math.nextafter(lo, -math.inf)
        hi = math.nextafter(hi, math.inf)
        out += [lo, hi]
    return out


def logspace(lo, hi, n):
    return [10 ** (lo + (hi - lo) * i / (n - 1)) for i in range(n)]


def main():
    rng = random.Random(20261125)
    rows = []

    xs = [0.0] + [700.0 * i / 1999 for i in range(2000)] + logspace(-300, math.log10(700), 400)
    for k in range(0, 1011):
        xs += [x for x in nextafter_n((k + 0.5) * math.log(2), 2) if 0 <= x <= 700]
    xs += [rng.uniform(0, 700) for _ in range(1000)]
    for x in sorted(set(xs)):
        rows.append(("exp_neg", x, mp.exp(-mp.mpf(x))))

    xs = logspace(-300, 300, 3000)
    xs += [1 + rng.uniform(-0.5, 0.5) for _ in range(1000)]
    xs += nextafter_n(1.0, 4) + nextafter_n(math.sqrt(2), 4) + nextafter_n(math.sqrt(0.5), 4)
    for e in range(-1000, 1001, 7):
        xs += nextafter_n(2.0 ** e, 1)
    xs += [rng.uniform(1, 6) for _ in range(1000)]
    for x in sorted(set(xs)):
        if x >= 2.2250738585072014e-308 and math.isfinite(x):
            rows.append(("ln", x, mp.log(mp.mpf(x))))

    xs = logspace(-300, math.log10(2), 1000) + nextafter_n(0.5, 4)
    xs += [rng.uniform(0, 2) for _ in range(1000)]
    for x in sorted(set(xs)):
        if 0 < x <= 2:
            rows.append(("one_minus_exp_neg", x, -mp.expm1(-mp.mpf(x))))

    xs = logspace(-300, 0, 1000) + [rng.uniform(0, 1) for _ in range(1000)] + nextafter_n(1.0, 2)
    for x in sorted(set(xs)):
        if 0 <= x <= 1:
            rows.append(("ln_1p", x, mp.log1p(mp.mpf(x))))

    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), "lanes_mpmath.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["function", "x", "value"])
        for name, x, v in rows:
            w.writerow([name, repr(x), mp.nstr(v, 40, min_fixed=1, max_fixed=0)])
    print(f"wrote {len(rows)} rows to {path}")


if __name__ == "__main__":
    main()
