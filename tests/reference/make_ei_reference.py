#!/usr/bin/env python3
"""Reference values for slipbayes::special (the exponential integral).

Run with the project venv (mpmath 1.x):

    /work/venv/bin/python tests/reference/make_ei_reference.py          # writes the CSVs
    /work/venv/bin/python tests/reference/make_ei_reference.py --tables # prints Rust tables

Writes, next to this script:

* ``ei_grid.csv``  columns ``x,ei,s``: Ei(x) and S(x) = exp(-x) Ei(x).
* ``ei_diff.csv``  columns ``x0,x,d``: D(x, x0) = exp(-x) [Ei(x) - Ei(x0)].

Every ``x`` is written as ``repr`` of an IEEE double, so the Rust side reads back exactly the
input that was evaluated here. Values are 50 significant digits, computed with far more working
precision than printed (Ei at 90 digits; D at 130 digits and cross-checked at 170 digits, since
Ei(x) - Ei(x0) cancels for close pairs). Ei beyond the double range is written as a decimal
with a large exponent; the Rust tests parse it as +inf.

The grid is log-spaced over [1e-300, 1e12], dense around the root of Ei (including the doubles
nearest to it), dense on both sides of every branch boundary of the Rust implementation, plus
seeded random points. The pairs cover both-tiny, both-huge, far-apart and a-few-ulps-apart
pairs, the branch boundaries of the difference, and pairs shaped like the friction law's
(x0 = alpha*v*t0, x = alpha*v*tau) for alpha*v down to 1e-12.

``--tables`` prints the Gauss-Legendre nodes/weights and the 1/(k k!) coefficients that are
pasted into src/special/ (computed here at 40 digits and rounded to double by Python).
"""

import csv
import math
import os
import random
import sys

import numpy as np
from mpmath import mp, mpf

HERE = os.path.dirname(os.path.abspath(__file__))
SEED = 20240611
DIGITS = 50

# Branch boundaries of src/special/mod.rs (keep in sync).
ROOT = mpf("0.37250741078136663446199186658011913353568949777165")
S_BOUNDARIES = [6.0, 10.0, 20.0, 40.0, 60.0, 700.0, 709.78, 716.0, 716.35, 1e-300,
                float(ROOT) - 0.1, float(ROOT) + 0.1]
# Difference: series for h < 1 and x <= 2 (polynomials of degree 8/12/17/22 for x up to
# 1/32, 1/4, 1, 2 when x >= 2 x0; a recurrence when x < 2 x0); quadrature for h < 2 and x0 >= h, with tiers
# (4 nodes: h <= 1/64 and x0 >= 64h; 8 nodes: h <= 1.5 and x0 >= 3h); subtraction otherwise.
H_SPLIT = 1.0
X_SERIES_MAX = 2.0
H_QUAD_MAX = 2.0


def s(v):
    return mp.nstr(v, DIGITS, strip_zeros=False, min_fixed=1, max_fixed=0)


def ulps_around(x, n):
    out = [x]
    up = down = x
    for _ in range(n):
        up = float(np.nextafter(up, math.inf))
        down = float(np.nextafter(down, 0.0))
        out += [up, down]
    return out


def rel_around(x, exps=range(1, 16)):
    out = []
    for k in exps:
        out += [x * (1 + 10.0 ** -k), x * (1 - 10.0 ** -k)]
    return out


def grid_points(rng):
    pts = list(np.logspace(-300, 12, 3000))
    # Subnormal and extreme inputs.
    pts += [5e-324, 1e-320, 1e-310, 2.2250738585072014e-308, 1e-305]
    # Around the root: nearest doubles, relative offsets, a dense uniform band.
    r = float(ROOT)
    pts += ulps_around(r, 40)
    pts += rel_around(r)
    pts += [r + rng.uniform(-1e-3, 1e-3) for _ in range(300)]
    pts += [r + rng.uniform(-1e-8, 1e-8) for _ in range(100)]
    # Branch boundaries, both sides.
    for b in S_BOUNDARIES:
        pts += ulps_around(b, 4)
        pts += rel_around(b, range(1, 13))
    # Seeded random points.
    pts += [10.0 ** rng.uniform(-300, 12) for _ in range(600)]
    pts += [rng.uniform(0.0, 50.0) for _ in range(600)]
    pts += [rng.uniform(0.0, 1.0) for _ in range(200)]
    pts += [rng.uniform(50.0, 800.0) for _ in range(200)]
    pts = sorted({float(p) for p in pts if p > 0.0})
    return pts


def ei_row(x):
    with mp.workdps(90):
        xm = mpf(x)
        e = mp.ei(xm)
        sv = mp.exp(-xm) * e
    return [repr(x), s(e), s(sv)]


def d_value(x0, x, dps):
    with mp.workdps(dps):
        a, b = mpf(x0), mpf(x)
        return mp.exp(-b) * (mp.ei(b) - mp.ei(a))


def diff_pairs(rng):
    pairs = []

    def add(x0, x):
        x0, x = float(x0), float(x)
        if 0.0 < x0 <= x:
            pairs.append((x0, x))

    def add_h(x0, h):
        add(x0, x0 + h)

    # Both tiny.
    for x0 in [5e-324, 1e-310, 1e-300, 1e-200, 1e-100, 1e-50, 1e-20, 1e-15, 1e-9]:
        for x in ulps_around(x0, 3)[1::2]:
            add(x0, x)
        for f in [1 + 1e-15, 1 + 1e-10, 1 + 1e-5, 1.5, 1.999, 2.0, 2.001, 10.0, 1e8, 1e100]:
            add(x0, x0 * f)
        for h in [1e-3, 0.5, 0.999, 1.0, 1.001, 1.999, 2.0, 2.5, 5.0, 50.0, 1e3]:
            add_h(x0, h)
    # Both huge.
    for x0 in [64.0, 1e3, 1e6, 1e9, 1e12]:
        for x in ulps_around(x0, 5)[1::2]:
            add(x0, x)
        for h in [1e-9, 1e-3, 1.0 / 64, 0.02, 0.5, 0.99999, 1.0, 1.00001, 10.0, 1e3]:
            add_h(x0, h)
        for f in [2.0, 10.0]:
            add(x0, x0 * f)
    # Far apart.
    for x0 in [1e-300, 1e-30, 1e-8, 1e-3, 0.3, 1.0, 3.0]:
        for x in [0.5, 1.0, 2.0, 6.0, 10.0, 40.0, 100.0, 700.0, 800.0, 1e6, 1e12, 1e300]:
            add(x0, x)
    # Friction-law shaped pairs: x0 = av*t0, x = av*tau.
    for av in [1e-12, 1e-9, 1e-6, 7e-3, 1.0, 1e3]:
        for t0 in [1e-9, 1e-3, 0.3, 14.8, 1e3]:
            for tau in [1e-9, 1e-6, 1e-3, 0.1, 1.0, 10.0, 1e3, 1e5, 1e8]:
                if tau >= t0:
                    add(av * t0, av * tau)
    # Branch boundaries of the difference, both sides.
    for x0 in [1e-3, 0.1, float(ROOT), 0.5, 0.999, 1.0, 1.001, 1.5, 3.0, 10.0, 100.0]:
        for h in ulps_around(H_SPLIT, 2) + [1 - 1e-12, 1 + 1e-12, 1 - 1e-6, 1 + 1e-6]:
            add_h(x0, h)
    for h in [1e-12, 1e-3, 0.5, 0.999, 1.0 - 2.0 ** -52]:
        for x in ulps_around(X_SERIES_MAX, 2) + [2 - 1e-9, 2 + 1e-9]:
            add(x - h, x)
    for x0 in [1.0, 1.5, 2.0, 3.0, 10.0, 1e3]:
        for h in ulps_around(H_QUAD_MAX, 2) + [2 - 1e-9, 2 + 1e-9]:
            add_h(x0, h)
    for h in [1.0, 1.2, 1.5, 1.9, 1.999]:
        for x0 in ulps_around(h, 2) + [h * (1 - 1e-9), h * (1 + 1e-9)]:
            add_h(x0, h)
    for h in [1.0 / 64, 1.0 / 64 * (1 + 1e-12), 1.0 / 64 * (1 - 1e-12), 0.01, 0.1, 0.5, 0.9,
              1.0, 1.2, 1.5 * (1 - 1e-12), 1.5, 1.5 * (1 + 1e-12), 1.9]:
        for f in [1.0, 3.0, 64.0]:
            for x0 in [f * h * (1 - 1e-12), f * h, f * h * (1 + 1e-12)]:
                add_h(x0, h)
    # Series: degree switches of the polynomial form (x = 1/32, 1/4, 1, 2) and the switch
    # to the recurrence at x = 2 x0.
    for xb in [1.0 / 32, 0.25, 1.0, 2.0]:
        for x in ulps_around(xb, 2) + [xb * (1 - 1e-9), xb * (1 + 1e-9)]:
            for x0 in [1e-300, x * 1e-12, x * 1e-3, x * 0.3] + ulps_around(x / 2, 2):
                if x - x0 < 1.0:
                    add(x0, x)
    for x in [1e-200, 1e-5, 0.01, 0.3, 0.9, 1.5, 1.99]:
        for x0 in ulps_around(x / 2, 3) + [x / 2 * (1 - 1e-9), x / 2 * (1 + 1e-9)]:
            add(x0, x)
    # Across the root of Ei.
    r = float(ROOT)
    for x0 in [r - 1e-3, r - 1e-9, float(np.nextafter(r, 0.0)), r]:
        for x in [float(np.nextafter(r, 1.0)), r + 1e-9, r + 1e-3, 0.5, 1.2, 1.4]:
            add(x0, x)
    # Seeded random pairs.
    for _ in range(800):
        x0 = 10.0 ** rng.uniform(-300, 12)
        add(x0, x0 * (1 + 10.0 ** rng.uniform(-16, 3)))
    for _ in range(800):
        x0 = 10.0 ** rng.uniform(-20, 3)
        add_h(x0, 10.0 ** rng.uniform(-6, 1.5))
    for _ in range(400):
        x0 = rng.uniform(0.0, 8.0)
        add_h(x0, rng.uniform(0.0, 3.0))
    # Where the subtraction cancels most (h just above 1 or 2, x0 of order 1 to 20).
    for _ in range(1500):
        x0 = 10.0 ** rng.uniform(-1, 1.3)
        add_h(x0, rng.uniform(1.0, 4.0))
    return sorted(set(pairs))


def diff_row(x0, x):
    d1 = d_value(x0, x, 130)
    d2 = d_value(x0, x, 170)
    if d1 != 0 or d2 != 0:
        with mp.workdps(170):
            if abs(d1 - d2) > abs(d2) * mpf(10) ** -(DIGITS + 2):
                raise RuntimeError("D not converged at x0=%r x=%r" % (x0, x))
    return [repr(x0), repr(x), s(d2)]


def gauss_legendre(n):
    """Nodes (descending) and weights of the n-point rule on [-1, 1], by Newton at 40 digits."""
    with mp.workdps(40):
        xs, ws = [], []
        for i in range(1, n + 1):
            x = mp.cos(mp.pi * (i - mpf(1) / 4) / (n + mpf(1) / 2))
            for _ in range(100):
                p0, p1 = mpf(1), x
                for k in range(2, n + 1):
                    p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
                dp = n * (x * p1 - p0) / (x * x - 1)
                dx = p1 / dp
                x -= dx
                if abs(dx) < mpf(10) ** -38:
                    break
            p0, p1 = mpf(1), x
            for k in range(2, n + 1):
                p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
            dp = n * (x * p1 - p0) / (x * x - 1)
            xs.append(x)
            ws.append(2 / ((1 - x * x) * dp * dp))
        return xs, ws


def print_tables():
    for n in (4, 8, 12):
        xs, ws = gauss_legendre(n)
        half = n // 2
        print("// %d-point Gauss-Legendre on [-1, 1]: positive nodes, weights." % n)
        print("const GL%d_X: [f64; %d] = [%s];" % (n, half, ", ".join(repr(float(v)) for v in xs[:half])))
        print("const GL%d_W: [f64; %d] = [%s];" % (n, half, ", ".join(repr(float(v)) for v in ws[:half])))
    with mp.workdps(40):
        vals = [repr(float(1 / (k * mp.factorial(k)))) for k in range(1, 33)]
    print("// 1 / (k k!) for k = 1..=32.")
    print("const INV_K_KFACT: [f64; 32] = [%s];" % ", ".join(vals))


def main():
    if "--tables" in sys.argv:
        print_tables()
        return
    rng = random.Random(SEED)
    pts = grid_points(rng)
    with open(os.path.join(HERE, "ei_grid.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["x", "ei", "s"])
        for x in pts:
            w.writerow(ei_row(x))
    pairs = diff_pairs(rng)
    with open(os.path.join(HERE, "ei_diff.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["x0", "x", "d"])
        for x0, x in pairs:
            w.writerow(diff_row(x0, x))
    print("wrote %d grid points and %d pairs" % (len(pts), len(pairs)))


if __name__ == "__main__":
    main()
