#!/usr/bin/env python3
"""Reference values for the incomplete gamma and beta functions and the normal quantile of
slipbayes::special (src/special/gamma.rs, beta.rs, normal.rs).

Run from the repository root with mpmath installed (pip install mpmath):

    python3 tests/reference/make_special_reference.py

Writes tests/reference/special_gamma_beta.csv with columns ``function,arg1,arg2,arg3,value``,
one row per evaluation, the arguments in the order of the Rust call:

* ``gamma_p``, ``gamma_q``, ``ln_gamma_p``, ``ln_gamma_q``: s, x (arg3 empty). P(s, x) and
  Q(s, x) are the regularised lower and upper incomplete gamma functions.
* ``ln_gamma_p_diff``: s, x_lo, x_hi; ln[P(s, x_hi) - P(s, x_lo)].
* ``beta_reg``: a, b, x; the regularised incomplete beta function I_x(a, b).
* ``beta_ppf``: q, a, b; the x with I_x(a, b) = q.
* ``norm_ppf``: p (arg2, arg3 empty); the standard normal quantile.

Every argument is written as ``repr`` of an IEEE double, so the Rust side reads back exactly
the input that was evaluated here. Values are 50 significant digits, computed at 60 digits and
cross-checked at 80 (the script stops if the two disagree beyond 1e-50 relative). Values far
below the double range (P deep in its lower tail) are written with their true exponent; Rust
parses them as 0, and the test then checks only the logarithm.

The incomplete beta function comes from the series I_x(a, b) = x^a (1-x)^b / (a B(a, b)) *
2F1(a + b, 1; a + 1; x), whose terms are all positive, on the side of the mean where it is
the smaller tail (mpmath's own betainc cancels catastrophically for a, b ~ 1e4); where
mpmath's betainc does converge the two are checked against each other.
"""
import csv
import math
import os
import random

from mpmath import mp, mpf, inf, log, log1p, exp, beta, hyp2f1, gammainc, betainc, ncdf, npdf

HERE = os.path.dirname(os.path.abspath(__file__))
DIGITS = 50
SEED = 20261123


def s(v):
    return mp.nstr(v, DIGITS, strip_zeros=False, min_fixed=1, max_fixed=0) if v != 0 else "0"


def checked(f, *args):
    """f(*args) at 60 digits, cross-checked at 80."""
    with mp.workdps(60):
        lo = f(*args)
    with mp.workdps(80):
        hi = f(*args)
    if hi != 0 or lo != 0:
        err = abs(lo - hi) / max(abs(hi), mpf(10) ** -100000000)
        assert err < mpf(10) ** -50, (f.__name__, args, lo, hi)
    return hi


# --- incomplete gamma ---------------------------------------------------------------------

def lower(sv, x):
    return gammainc(mpf(sv), 0, mpf(x), regularized=True)


def upper(sv, x):
    return gammainc(mpf(sv), mpf(x), inf, regularized=True)


# Logarithms of values close to 1 from the complement, which mpmath forms directly: log(P)
# of P = 1 - 1e-18 would keep only 42 of the 60 digits.
def ln_lower(sv, x):
    p = lower(sv, x)
    return log(p) if p < 0.5 else log1p(-upper(sv, x))


def ln_upper(sv, x):
    q = upper(sv, x)
    return log(q) if q < 0.5 else log1p(-lower(sv, x))


def ln_mass(sv, x_lo, x_hi):
    outside = lower(sv, x_lo) + upper(sv, x_hi)
    if outside < 0.5:
        return log1p(-outside)
    return log(gammainc(mpf(sv), mpf(x_lo), mpf(x_hi), regularized=True))


# Shapes: every branch boundary of src/special/gamma.rs (s = 1 for the small-shape formulas,
# s = 10 for Stirling's prefix), the noise model's s = n/2, and seeded log-uniform ones.
S_FIXED = [1e-3, 2.5e-3, 0.01, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.999, 1.0, 1.5, 2.0, 3.0,
           4.5, 7.0, 9.5, 9.999, 10.0, 10.5, 15.0, 20.0, 35.0, 50.0, 100.0, 250.0, 500.0,
           1000.0, 1500.5, 3000.0, 5000.0, 1e4]
# Absolute x: tails down to 1e-300 and up to 1e8, the small-shape switch at 1.1, the
# product-form limit at 700.
X_ABS = [1e-300, 1e-100, 1e-20, 1e-8, 1e-3, 0.1, 0.5, 1.0, 1.0999999999999999, 1.1,
         1.1000000000000003, 2.0, 5.0, 30.0, 100.0, 699.0, 701.0, 1e3, 1e4, 1e5, 1e6, 1e8]
# x relative to s, and in standard deviations around the bulk.
X_REL = [1e-6, 1e-3, 0.01, 0.1, 0.3, 0.5, 0.6, 0.8, 0.9, 0.95, 0.99, 1.0, 1.01, 1.05, 1.1,
         1.25, 1.5, 2.0, 3.0, 5.0, 10.0, 30.0, 100.0, 1000.0]
X_SD = [-8, -5, -3, -2, -1, -0.5, 0, 0.5, 1, 2, 3, 5, 8, 12, 20]


def gamma_shapes():
    rng = random.Random(SEED)
    return S_FIXED + [10 ** rng.uniform(-3, 4) for _ in range(12)]


def gamma_xs(sv):
    xs = set(X_ABS)
    xs.update(sv * f for f in X_REL)
    xs.update(sv + t * math.sqrt(sv) for t in X_SD)
    # The series/fraction switch at x = s + 1, and the doubles either side of it.
    b = sv + 1.0
    xs.update([b, math.nextafter(b, 0), math.nextafter(b, math.inf)])
    return sorted(x for x in xs if x > 0 and math.isfinite(x))


def write_gamma(w):
    for sv in gamma_shapes():
        for x in gamma_xs(sv):
            with mp.workdps(80):
                assert abs(lower(sv, x) + upper(sv, x) - 1) < mpf(10) ** -70, (sv, x)
            for name, f in [("gamma_p", lower), ("gamma_q", upper), ("ln_gamma_p", ln_lower),
                            ("ln_gamma_q", ln_upper)]:
                w.writerow([name, repr(sv), repr(x), "", s(checked(f, sv, x))])


# The truncation mass of the noise model (src/model/posterior/sigma.rs): s = n/2,
# x = SSR/(2 sigma^2) at the prior's bounds; both ends in one tail, straddling the bulk,
# close together and far apart.
def diff_cases():
    cases = []
    for ssr, n, low, high in [(1e6, 100, 1e-8, 1.0), (1.0, 201, 3e-5, 3e-4),
                              (0.01, 51, 3e-5, 3e-4), (1e-9, 201, 3e-5, 3e-4),
                              (50.0, 8, 0.01, 1.5), (2.0, 10, 0.1, 10.0),
                              (3.0e-5, 3000, 1e-8, 1.0), (1e-3, 1, 1e-4, 1.0)]:
        half = 0.5 * ssr
        cases.append((0.5 * n, half / (high * high), half / (low * low)))
    for sv in [0.5, 3.0, 12.5, 150.0, 1500.0]:
        sd = math.sqrt(sv)
        for lo_t, hi_t in [(-30, -20), (-6, -5.5), (-3, -1), (-1, 1), (-0.1, 0.1), (1, 3),
                           (5, 6), (20, 40), (-2, 50)]:
            x_lo, x_hi = sv + lo_t * sd, sv + hi_t * sd
            if 0 < x_lo < x_hi:
                cases.append((sv, x_lo, x_hi))
        cases.append((sv, 1e-300, 1e-299))
        cases.append((sv, 1e-3 * sv, 2e-3 * sv))
        cases.append((sv, 50 * sv + 100, 60 * sv + 200))
    return cases


def write_gamma_diff(w):
    for sv, x_lo, x_hi in diff_cases():
        w.writerow(["ln_gamma_p_diff", repr(sv), repr(x_lo), repr(x_hi),
                    s(checked(ln_mass, sv, x_lo, x_hi))])


# --- incomplete beta ----------------------------------------------------------------------

def ibeta(a, b, x):
    a, b, x = mpf(a), mpf(b), mpf(x)
    if x > a / (a + b):
        return 1 - ibeta(b, a, 1 - x)
    front = exp(a * log(x) + b * log1p(-x) - log(beta(a, b)))
    return front * hyp2f1(a + b, 1, a + 1, x, maxterms=10**7) / a


AB = [0.5, 1.0, 2.5, 5.0, 9.5, 10.0, 15.0, 20.0, 50.0, 200.0, 1000.0, 1e4]
X_BETA_ABS = [1e-10, 1e-3, 0.1, 0.5, 0.9, 0.999, 1 - 1e-10]
X_BETA_SD = [-6, -3, -1, 0, 1, 3, 6]


def beta_xs(a, b):
    mean = a / (a + b)
    sd = math.sqrt(a * b / ((a + b) ** 2 * (a + b + 1)))
    xs = set(X_BETA_ABS)
    xs.update(mean + t * sd for t in X_BETA_SD)
    return sorted(x for x in xs if 0 < x < 1)


def write_beta(w):
    for a in AB:
        for b in AB:
            for x in beta_xs(a, b):
                v = checked(ibeta, a, b, x)
                if max(a, b) <= 50:
                    with mp.workdps(60):
                        ref = betainc(mpf(a), mpf(b), 0, mpf(x), regularized=True)
                    assert abs(ref - v) <= abs(v) * mpf(10) ** -50, (a, b, x, v, ref)
                w.writerow(["beta_reg", repr(a), repr(b), repr(x), s(v)])


def ibeta_inv(q, a, b):
    """Newton on I_x(a, b) = q from the normal approximation, bracketed."""
    q, a, b = mpf(q), mpf(a), mpf(b)
    mean = a / (a + b)
    sd = mp.sqrt(a * b / ((a + b) ** 2 * (a + b + 1)))
    lo, hi = mpf(0), mpf(1)
    x = min(max(mean + sd * mp.sqrt(2) * mp.erfinv(2 * q - 1), mpf(10) ** -30), 1 - mpf(10) ** -30)
    for _ in range(200):
        f = ibeta(a, b, x) - q
        if f < 0:
            lo = x
        else:
            hi = x
        pdf = exp((a - 1) * log(x) + (b - 1) * log1p(-x) - log(beta(a, b)))
        step = f / pdf
        nx = x - step
        if not (lo < nx < hi):
            nx = (lo + hi) / 2
        if abs(nx - x) < abs(x) * mpf(10) ** -(mp.dps - 5):
            return nx
        x = nx
    raise RuntimeError("beta quantile did not converge")


def beta_ppf_cases():
    cases = []
    # ArviZ's quantile MCSE: a = ess p + 1, b = ess (1 - p) + 1 at its +-1 sigma probabilities.
    for ess in [10.0, 403.7, 5000.0, 5e4]:
        for p in [0.5, 0.05, 0.95]:
            for q in [0.1586553, 0.8413447]:
                cases.append((q, ess * p + 1.0, ess * (1.0 - p) + 1.0))
    for q, a, b in [(0.3, 1.0, 1.0), (0.25, 2.0, 1.0), (0.6, 1.0, 3.0), (0.5, 2.5, 7.0),
                    (1e-6, 2.5, 7.0), (0.999, 0.5, 0.5), (0.5, 2e3, 2e3), (0.01, 15.0, 800.0)]:
        cases.append((q, a, b))
    return cases


def write_beta_ppf(w):
    for q, a, b in beta_ppf_cases():
        w.writerow(["beta_ppf", repr(q), repr(a), repr(b), s(checked(ibeta_inv, q, a, b))])


# --- normal quantile ----------------------------------------------------------------------

def norm_quantile(p):
    p = mpf(p)
    if p == mpf(1) / 2:
        return mpf(0)
    if p > mpf(1) / 2:
        return -norm_quantile(1 - p)
    # Newton on ln Phi(z) = ln p, which is well scaled however small p is.
    z = -mp.sqrt(-2 * log(p))
    for _ in range(200):
        f = log(ncdf(z)) - log(p)
        step = f * ncdf(z) / npdf(z)
        z -= step
        if abs(step) < abs(z) * mpf(10) ** -(mp.dps - 5):
            return z
    raise RuntimeError("normal quantile did not converge")


def norm_ps():
    ps = [1e-300, 1e-200, 1e-100, 1e-50, 1e-20, 1e-10, 1e-5, 1e-3, 0.01, 0.025, 0.05, 0.1,
          0.2, 0.3, 0.4, 0.45, 0.49, 0.499, 0.5, 0.501, 0.51, 0.6, 0.7, 0.8, 0.9, 0.95,
          0.975, 0.99, 0.999, 1 - 1e-5, 1 - 1e-10, 1 - 1e-16, 0.1586553, 0.8413447]
    rng = random.Random(SEED + 1)
    ps += [10 ** rng.uniform(-300, -0.3) for _ in range(40)]
    ps += [1 - 10 ** rng.uniform(-16, -0.3) for _ in range(40)]
    return sorted(set(p for p in ps if 0 < p < 1))


def write_norm(w):
    for p in norm_ps():
        w.writerow(["norm_ppf", repr(p), "", "", s(checked(norm_quantile, p))])


if __name__ == "__main__":
    with open(os.path.join(HERE, "special_gamma_beta.csv"), "w", newline="") as f:
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["function", "arg1", "arg2", "arg3", "value"])
        write_norm(w)
        write_gamma(w)
        write_gamma_diff(w)
        write_beta(w)
        write_beta_ppf(w)
