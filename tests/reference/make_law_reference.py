#!/usr/bin/env python3
"""50-digit reference values for the friction law, its elastic correction and its peak.

Run from the repository root with mpmath installed:

    python3 tests/reference/make_law_reference.py

Writes tests/reference/law_mpmath.csv, law_lanes_mpmath.csv (dense runs of tau within each
regime of the vectorised law), observed_mpmath.csv and peak_mpmath.csv. Every input
is an exact binary64 value (written with repr, so Rust parses the same double); every output is
a 50-significant-digit decimal string. The law is Farain and Bonn's Eq. 3 with x = alpha_v*tau,
x0 = alpha_v*t0 (alpha_v = alpha*v in 1/s, given directly so that the product is exact):

    F(tau) = a e^-x [Ei(x) - Ei(x0)] + F_d (1 - e^-x)   for tau >= t0, 0 before.
"""
import csv
import os
from mpmath import mp, mpf, ei, exp, expm1, log10, findroot, quad, inf

mp.dps = 50
HERE = os.path.dirname(os.path.abspath(__file__))


def ei_diff_scaled(x, x0):
    """e^-x [Ei(x) - Ei(x0)] with enough working digits for x close to x0."""
    h = x - x0
    if h == 0:
        return mpf(0)
    extra = int(max(0, float(log10(abs(x) / h)))) + 20
    with mp.workdps(mp.dps + extra):
        if x > 1000:
            # Ei(x) is astronomically large; integrate e^-(x-t)/t from x0 to x instead.
            u = mp.mpf(h)
            val = quad(lambda s: exp(-s) / (x - s), [0, min(u, 50), u] if u > 50 else [0, u])
        else:
            val = exp(-x) * (ei(x) - ei(x0))
        return +val


def force(alpha_v, a, f_d, t0, tau):
    alpha_v, a, f_d, t0, tau = map(mpf, (alpha_v, a, f_d, t0, tau))
    if tau < t0:
        return mpf(0)
    x = alpha_v * tau
    x0 = alpha_v * t0
    return a * ei_diff_scaled(x, x0) - f_d * expm1(-x)


def rate(alpha_v, a, f_d, t0, tau):
    """dF/dtau = a/tau - alpha_v (F - F_d), paper Eq. 2."""
    return mpf(a) / mpf(tau) - mpf(alpha_v) * (force(alpha_v, a, f_d, t0, tau) - mpf(f_d))


def s(v):
    return mp.nstr(v, 50, strip_zeros=False, min_fixed=-1, max_fixed=-1) if v != 0 else "0"


# Parameter sets spanning docs/model.md §8: t0 1e-9..1e3 s, alpha_v 1e-12..1e3 1/s,
# tau up to 1e8 s, a -> 0 and a >> F_d. Forces are in newtons.
CASES = [
    # name, alpha_v, a, f_d, t0
    ("ptfe_fig2", 0.92e6 * 1e-9, 6.2e-3, 10e-3, 14.8),
    ("fig4_t0_1e-3", 0.007, 0.3, 1.0, 1e-3),
    ("fig4_t0_0.3", 0.007, 0.3, 1.0, 0.3),
    ("fast_4um", 0.92e6 * 4e-6, 6.2e-3, 10e-3, 4e-3),
    ("tiny_alpha_v", 1e-12, 6.2e-3, 10e-3, 14.8),
    ("tiny_alpha_v_t0", 1e-12, 1.0, 1.0, 1e-9),
    ("huge_alpha_v", 1e3, 0.3, 1.0, 1e-9),
    ("huge_alpha_v_big_t0", 1e3, 0.3, 1.0, 1e3),
    ("tiny_t0", 0.007, 0.3, 1.0, 1e-9),
    ("big_t0", 1e-4, 0.3, 1.0, 1e3),
    ("a_zero", 0.007, 0.0, 1.0, 0.1),
    ("a_tiny", 0.007, 1e-12, 1.0, 0.1),
    ("a_huge", 0.007, 100.0, 1.0, 0.1),
    ("pp_like", 1.5e6 * 1e-9, 3.2e-3, 8e-3, 30.0),
]


def tau_grid(t0):
    taus = [t0, t0 * (1 + 2**-40), t0 * (1 + 1e-9), t0 * (1 + 1e-6), t0 * 1.001, t0 * 1.1]
    lo = float(log10(t0))
    hi = 8.0
    n = 40
    taus += [10 ** (lo + (hi - lo) * i / n) for i in range(1, n + 1)]
    return sorted(set(float(t) for t in taus if t >= t0))


def write_law():
    path = os.path.join(HERE, "law_mpmath.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "alpha_v", "a", "f_d", "t0", "tau", "force", "rate"])
        for name, av, a, fd, t0 in CASES:
            for tau in tau_grid(t0) + [t0 * 0.5]:
                w.writerow([name, repr(av), repr(a), repr(fd), repr(t0), repr(tau),
                            s(force(av, a, fd, t0, tau)),
                            s(rate(av, a, fd, t0, tau)) if tau >= t0 else "0"])


# Observed-time model: t = tau + F(tau)/(k v); the recorded force at instrument time t is
# F(tau(t)). Cases: the steep rise of a slow first slide, a stiff-ish machine, k just above the
# stick-slip limit.
OBS_CASES = [
    # name, alpha_v, a, f_d, t0, kv (N/s), t_max
    ("slow_first", 0.92e6 * 1e-9, 6.2e-3, 10e-3, 14.8, 1.2e4 * 1e-9, 30000.0),
    # k just above the stick-slip limit (3.1e3 N/m for these parameters).
    ("near_stick_slip", 0.92e6 * 1e-9, 6.2e-3, 10e-3, 14.8, 3.2e3 * 1e-9, 30000.0),
    ("pp_like", 1.5e6 * 1e-9, 3.2e-3, 8e-3, 30.0, 1.0e4 * 1e-9, 30000.0),
    ("fig4", 0.007, 0.3, 1.0, 1e-3, 0.05, 2000.0),
]


def observed_force(av, a, fd, t0, kv, t):
    av, a, fd, t0, kv, t = map(mpf, (av, a, fd, t0, kv, t))
    if t <= t0:
        return mpf(0), t
    f_t0 = force(av, a, fd, t0, t0)
    if t <= t0 + f_t0 / kv:
        # Elastic loading while the interface waits at t0 (the law jumps to F(t0) > 0).
        return kv * (t - t0), t0
    g = lambda tau: tau + force(av, a, fd, t0, tau) / kv - t
    # Bisection bracket then polish: g is increasing when the path is stable.
    lo, hi = t0, t
    for _ in range(200):
        mid = (lo + hi) / 2
        if g(mid) > 0:
            hi = mid
        else:
            lo = mid
        if hi - lo < t * mpf(10) ** -30:
            break
    tau = findroot(g, (lo + hi) / 2)
    return force(av, a, fd, t0, tau), tau


def write_observed():
    path = os.path.join(HERE, "observed_mpmath.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "alpha_v", "a", "f_d", "t0", "kv", "t", "tau", "force"])
        for name, av, a, fd, t0, kv, tmax in OBS_CASES:
            ts = [t0 * 0.5, t0 * (1 + 1e-12)] + [tmax * i / 60 for i in range(1, 61)]
            for t in sorted(ts):
                F, tau = observed_force(av, a, fd, t0, kv, t)
                w.writerow([name, repr(av), repr(a), repr(fd), repr(t0), repr(kv), repr(t),
                            s(tau), s(F)])


def peak(av, a, fd, t0):
    av, a, fd, t0 = map(mpf, (av, a, fd, t0))
    r = lambda tau: rate(av, a, fd, t0, tau)
    lo = t0
    hi = t0 * 2
    while r(hi) > 0:
        lo, hi = hi, hi * 2
    for _ in range(400):
        mid = (lo + hi) / 2
        if r(mid) > 0:
            lo = mid
        else:
            hi = mid
        if hi - lo < hi * mpf(10) ** -45:
            break
    tau = (lo + hi) / 2
    return tau, force(av, a, fd, t0, tau)


def write_peak():
    path = os.path.join(HERE, "peak_mpmath.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "alpha_v", "a", "f_d", "t0", "tau_peak", "force_peak"])
        # Fig. 4: alpha_v = 0.007 1/s, a/F_d = 0.3, t0 from 0.3 down to 0.001 s.
        for t0 in [0.3, 0.1, 0.03, 0.01, 0.003, 0.001]:
            tau, F = peak(0.007, 0.3, 1.0, t0)
            w.writerow(["fig4", "0.007", "0.3", "1.0", repr(t0), s(tau), s(F)])
        for name, av, a, fd, t0 in CASES:
            if a == 0 or name in ("tiny_alpha_v", "tiny_alpha_v_t0"):
                continue
            tau, F = peak(av, a, fd, t0)
            w.writerow([name, repr(av), repr(a), repr(fd), repr(t0), s(tau), s(F)])


def lanes_tau_grid(alpha_v, t0):
    """Sorted tau values in runs dense enough that every batch of the law's vector kernel lies
    in one regime of e^-x [Ei(x) - Ei(x0)]: the series with x >= 2 x0 (x up to x0 + 1 and 2),
    and the subtraction regime (x from x0 + 2 to 700) across all its rational pieces."""
    x0 = alpha_v * t0
    xs = []
    lo, hi = 2 * x0, min(x0 + 1, 2.0)
    if lo < hi:
        xs += [lo * (hi / lo) ** (i / 63) for i in range(64)]
    lo, hi = x0 + 2, 700.0
    if lo < hi:
        xs += [lo * (hi / lo) ** (i / 255) for i in range(256)]
    return sorted(set(float(x / alpha_v) for x in xs if x / alpha_v >= t0))


def write_law_lanes():
    path = os.path.join(HERE, "law_lanes_mpmath.csv")
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["case", "alpha_v", "a", "f_d", "t0", "tau", "force"])
        for name, av, a, fd, t0 in CASES:
            for tau in lanes_tau_grid(av, t0):
                w.writerow([name, repr(av), repr(a), repr(fd), repr(t0), repr(tau),
                            s(force(av, a, fd, t0, tau))])


if __name__ == "__main__":
    write_law_lanes()
    write_law()
    write_observed()
    write_peak()
