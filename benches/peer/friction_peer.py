#!/usr/bin/env python3
"""The Python ensemble peers of `slipbayes bench` on the one-contact posterior: emcee's stretch
move, emcee's differential-evolution moves, and zeus' ensemble slice sampler, over numpy + scipy.

Usage (run by `slipbayes bench`, which writes the problem file):
    python benches/peer/friction_peer.py PROBLEM.json RESULT.json CHAINS.csv [--sampler NAME]

--sampler picks the peer (one per run of the script; the bench runs it once for each):
    stretch     emcee, StretchMove(a=2) (the default);
    de-snooker  emcee, moves=[(DEMove(), 0.8), (DESnookerMove(), 0.2)], as emcee's docs advise;
    zeus        zeus (PyPI zeus-mcmc), ensemble slice sampling with its default moves and tuning.
Every peer runs vectorised (vectorize=True: one numpy call evaluates a batch of points) and
starts each ensemble from the problem's initial walkers. The log-density handed to the sampler
counts the points it is asked for, every call included (the initial walkers; zeus' stepping-out
and shrinking make several calls per step), and the result reports that count.

It fits the IDENTICAL posterior to slipbayes' `Posterior` for one first slide
(src/model/posterior.rs, src/law/):
- coordinates u = ln θ for α, a/F_d, F_d, t0, k; log-uniform priors on θ, so that with the
  Jacobian the log-prior is 0 inside the bounds and −∞ outside (slipbayes drops the same
  constant);
- the law F(τ) = a e^(−x)[Ei(x) − Ei(x0)] + F_d (1 − e^(−x)), x = αvτ, a = (a/F_d)·F_d,
  F = 0 before t0; the elastic correction t = τ + F(τ)/(kv) solved at every data time at
  once by a vectorised safeguarded Newton iteration (bracket [t0, t], bisection whenever the
  Newton step leaves the bracket or fails to halve the previous step); elastic loading
  F = kv (t − t0) until t0 + F(t0)/(kv);
- σ integrated out analytically under its log-uniform prior, as
  `marginal_sigma_log_likelihood` does (regularised incomplete gamma for the truncation).

Stick-slip (dF/dτ ≤ −kv) is checked at the solved τ of every data point (slipbayes checks the
exact minimum of dF/dτ); both reject such points. Ei overflows in double precision beyond
x ≈ 700 (slipbayes uses a scaled form); the peer rejects those points. Neither difference
matters near the posterior, where the log-densities are compared.

The problem file gives the data file, velocity, coordinate names, prior bounds, points at
which to report the log-density (compared with slipbayes'), the initial walkers of every
ensemble, the number of steps and the seed. The result JSON holds the log-density at those
points, the cost of one log-density (one point per call and vectorised), the sampling time and
the log-density evaluations of each ensemble, and the versions; the chains CSV holds every
walker at every step (`ensemble,walker,step,<coordinates>`).
"""
import argparse
import json
import sys
import time

import numpy as np
from scipy.special import expi, gammainc, gammaln

LN_SQRT_2PI = 0.9189385332046728
NEWTON_REL_STEP = 1e-10
MAX_ITERATIONS = 2200


def law(tau, av, a, f_d, ei_x0, xp=np, ei=expi):
    """F(τ) and dF/dτ for τ ≥ t0, broadcasting over (walker, point); `xp` and `ei` are numpy
    and scipy's Ei here, jax.numpy and JAX's Ei in the NUTS peer (friction_nuts.py)."""
    x = av * tau
    e = xp.exp(-x)
    d = e * (ei(x) - ei_x0)
    one_minus_e = xp.where(x < 0.5, -xp.expm1(-x), 1.0 - e)
    aging = a * d
    force = aging + f_d * one_minus_e
    rate = a / tau - av * (aging - f_d * e)
    return force, rate


def newton_pass(tau, g, slope, lo, hi, prev_step, xp=np):
    """One pass of the safeguarded Newton iteration for G(τ) = τ + F(τ)/(kv) − t = 0 on the
    bracket [lo, hi] (G(lo) < 0 <= G(hi)), elementwise, given G and G' at τ. Newton unless
    the step leaves the bracket or does not halve the previous one (rtsafe), else bisection.

    Returns the new bracket, the root (meaningful where done), whether each element is
    done, whether G was not finite there (done, no root), the next τ and the step taken. Converged means a Newton
    step below NEWTON_REL_STEP relative landing in the closed bracket: a step that rounds
    onto the iterate sitting on the bracket's edge counts (the strict safeguard would
    bisect away from the root there, about 30 halvings for nothing).
    """
    hi = xp.where(g > 0, tau, hi)
    lo = xp.where(g < 0, tau, lo)
    newton = tau - g / slope
    step = tau - newton
    ok = (newton > lo) & (newton < hi) & (xp.abs(step) * 2.0 <= xp.abs(prev_step))
    bisect = lo + 0.5 * (hi - lo)
    converged = (
        (newton >= lo) & (newton <= hi) & (xp.abs(step) <= NEWTON_REL_STEP * xp.abs(tau))
    )
    # Adjacent doubles: the bracket is as small as it gets.
    tiny = ~ok & ~converged & ((bisect <= lo) | (bisect >= hi))
    failed = ~xp.isfinite(g)
    done = (g == 0) | converged | tiny | failed
    root = xp.where(converged, newton, xp.where(tiny, bisect, tau))
    next_tau = xp.where(ok, newton, bisect)
    return lo, hi, root, done, failed, next_tau, xp.where(ok, step, hi - lo)


def marginal_sigma_log_likelihood(
    ssr, n, sigma_low, sigma_high, xp=np, incomplete_gamma=gammainc, log_gamma=gammaln
):
    """Gaussian log-likelihood of n residuals with sum of squares `ssr`, σ integrated out
    under its log-uniform prior on [sigma_low, sigma_high]; returns it and the prior mass
    of σ the truncation keeps (both broadcast over `ssr`)."""
    half_n, half_ssr = 0.5 * n, 0.5 * ssr
    mass = incomplete_gamma(half_n, half_ssr / sigma_low**2) - incomplete_gamma(
        half_n, half_ssr / sigma_high**2
    )
    ll = (
        -n * LN_SQRT_2PI
        + log_gamma(half_n)
        - xp.log(2.0)
        - half_n * xp.log(half_ssr)
        - xp.log(xp.log(sigma_high / sigma_low))
        + xp.log(mass)
    )
    return ll, mass


class OneContact:
    def __init__(self, problem):
        data = np.loadtxt(problem["data_csv"], delimiter=",", skiprows=1, ndmin=2)
        self.t = data[:, 0].copy()
        self.f_obs = data[:, 1].copy()
        self.v = float(problem["velocity_m_per_s"])
        names = problem["names"]
        role = {}
        for i, n in enumerate(names):
            for key in ("alpha", "a_over_F_d", "F_d", "t0", "k"):
                if n.startswith(f"ln_{key}["):
                    role[key] = i
        missing = {"alpha", "a_over_F_d", "F_d", "t0", "k"} - set(role)
        if missing or len(names) != 5:
            raise SystemExit(f"peer: unexpected coordinates {names}; missing {sorted(missing)}")
        self.role = role
        self.lo = np.log(np.array([b[0] for b in problem["bounds"]]))
        self.hi = np.log(np.array([b[1] for b in problem["bounds"]]))
        self.bounds = np.array(problem["bounds"], dtype=float)
        self.sigma_low, self.sigma_high = problem["sigma_bounds"]

    def log_density(self, u):
        """Log-posterior of a (walkers, 5) array of coordinates."""
        u = np.atleast_2d(u)
        out = np.full(u.shape[0], -np.inf)
        theta = np.exp(u)
        inside = np.all((theta >= self.bounds[:, 0]) & (theta <= self.bounds[:, 1]), axis=1)
        if not inside.any():
            return out
        th = theta[inside]
        r = self.role
        alpha, ratio, f_d, t0, k = (th[:, r[n]] for n in ("alpha", "a_over_F_d", "F_d", "t0", "k"))
        av = (alpha * self.v)[:, None]
        f_d = f_d[:, None]
        a = ratio[:, None] * f_d
        t0 = t0[:, None]
        kv = (k * self.v)[:, None]
        ei_x0 = expi(av * t0)
        t = self.t[None, :]
        with np.errstate(all="ignore"):
            f_t0, _ = law(t0, av, a, f_d, ei_x0)
            loading_ends = t0 + f_t0 / kv
            sliding = t > loading_ends
            force = np.zeros(sliding.shape)
            rate = np.zeros(sliding.shape)
            # The sliding (walker, point) pairs, flattened; converged pairs leave the arrays,
            # so every iteration evaluates the law only where it is still needed.
            flat = np.flatnonzero(sliding)
            w = flat // sliding.shape[1]
            tt = np.broadcast_to(t, sliding.shape).ravel()[flat]
            p_av, p_a, p_fd, p_kv = av[w, 0], a[w, 0], f_d[w, 0], kv[w, 0]
            p_ei = ei_x0[w, 0]
            # Bracket [t0, t] holds the root: g(t0) < 0 <= g(t).
            lo = t0[w, 0].copy()
            hi = tt.copy()
            # Warm start: the observed force says how much the spring holds.
            tau = tt - self.f_obs[flat % sliding.shape[1]] / p_kv
            tau = np.where((tau > lo) & (tau < hi), tau, lo + 0.5 * (hi - lo))
            prev_step = hi - lo
            for _ in range(MAX_ITERATIONS):
                if flat.size == 0:
                    break
                f, fr = law(tau, p_av, p_a, p_fd, p_ei)
                g = tau + f / p_kv - tt
                lo, hi, root, done, failed, new_tau, prev_step = newton_pass(
                    tau, g, 1.0 + fr / p_kv, lo, hi, prev_step
                )
                # The root is one tiny step from the last evaluation: F follows the tangent,
                # as slipbayes does. A non-finite g leaves NaN, which rejects the point.
                force.flat[flat[done]] = np.where(failed, np.nan, f + fr * (root - tau))[done]
                rate.flat[flat[done]] = fr[done]
                keep = ~done
                prev_step = prev_step[keep]
                tau = new_tau[keep]
                lo, hi, tt, flat = lo[keep], hi[keep], tt[keep], flat[keep]
                p_av, p_a, p_fd, p_kv = p_av[keep], p_a[keep], p_fd[keep], p_kv[keep]
                p_ei = p_ei[keep]
            force.flat[flat] = np.nan  # not converged: reject
            model = np.where(sliding, force, np.where(t <= t0, 0.0, kv * (t - t0)))
            stick_slip = np.any(sliding & (rate <= -kv), axis=1)
            ssr = np.sum((self.f_obs[None, :] - model) ** 2, axis=1)
            ll, mass = marginal_sigma_log_likelihood(
                ssr, self.t.size, self.sigma_low, self.sigma_high
            )
        valid = np.isfinite(ll) & (mass > 0) & (ssr > 0) & ~stick_slip
        out[np.flatnonzero(inside)[valid]] = ll[valid]
        return out


SAMPLERS = ("stretch", "de-snooker", "zeus")


class Counted:
    """The log-density as the samplers see it, counting every point evaluated: a vectorised
    call adds its number of points."""

    def __init__(self, log_density):
        self.log_density = log_density
        self.points = 0

    def __call__(self, u):
        u = np.atleast_2d(u)
        self.points += u.shape[0]
        return self.log_density(u)


def run_ensemble(sampler_name, log_density, walkers, steps):
    """Runs one ensemble from `walkers` for `steps` steps; returns its chain (steps, walkers,
    ndim) and its mean acceptance fraction (None for zeus, whose slice moves always move)."""
    nwalkers, ndim = walkers.shape
    if sampler_name == "zeus":
        import zeus

        sampler = zeus.EnsembleSampler(
            nwalkers, ndim, log_density, vectorize=True, verbose=False
        )
        sampler.run_mcmc(walkers, steps, progress=False)
        return sampler.get_chain(), None
    import emcee

    if sampler_name == "stretch":
        moves = emcee.moves.StretchMove(a=2.0)
    else:
        moves = [(emcee.moves.DEMove(), 0.8), (emcee.moves.DESnookerMove(), 0.2)]
    sampler = emcee.EnsembleSampler(nwalkers, ndim, log_density, moves=moves, vectorize=True)
    sampler.run_mcmc(walkers, steps, progress=False)
    return sampler.get_chain(), float(np.mean(sampler.acceptance_fraction))


def versions(sampler_name):
    import scipy

    out = {"python": sys.version.split()[0], "numpy": np.__version__, "scipy": scipy.__version__}
    if sampler_name == "zeus":
        import zeus

        out["zeus"] = zeus.__version__
    else:
        import emcee

        out["emcee"] = emcee.__version__
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("problem")
    parser.add_argument("result")
    parser.add_argument("chains")
    parser.add_argument("--sampler", choices=SAMPLERS, default="stretch")
    args = parser.parse_args()
    with open(args.problem) as fh:
        problem = json.load(fh)

    post = OneContact(problem)
    points = np.array(problem["points"], dtype=float)
    lp = post.log_density(points)

    # Cost of one log-density: one point per call (the usual log_prob) and in batches of
    # half an ensemble (what vectorize=True does), best of a few repetitions.
    initial = np.array(problem["initial"], dtype=float)
    batch = initial[0][: initial.shape[1] // 2]
    reps = int(problem.get("cost_reps", 5))
    single, vectorised = [], []
    for _ in range(reps):
        t_start = time.perf_counter()
        for x in batch:
            post.log_density(x[None, :])
        single.append((time.perf_counter() - t_start) / len(batch))
        t_start = time.perf_counter()
        post.log_density(batch)
        vectorised.append((time.perf_counter() - t_start) / len(batch))

    steps = int(problem["steps"])
    rows = []
    sampling = []
    evaluations = []
    for e, walkers in enumerate(initial):
        np.random.seed(int(problem["seed"]) + e)
        counted = Counted(post.log_density)
        t_start = time.perf_counter()
        chain, acceptance = run_ensemble(args.sampler, counted, walkers, steps)
        sampling.append(time.perf_counter() - t_start)
        evaluations.append(counted.points)
        rows.append((e, chain, acceptance))

    with open(args.chains, "w") as fh:
        fh.write("ensemble,walker,step," + ",".join(problem["names"]) + "\n")
        for e, chain, _ in rows:
            for w in range(chain.shape[1]):
                for s in range(chain.shape[0]):
                    fh.write(f"{e},{w},{s}," + ",".join(repr(float(v)) for v in chain[s, w]) + "\n")

    result = {
        "sampler": args.sampler,
        "log_density": [float(v) if np.isfinite(v) else None for v in lp],
        "seconds_per_eval_single": float(np.median(single)),
        "seconds_per_eval_vectorised": float(np.median(vectorised)),
        "sampling_s": sampling,
        "evaluations": evaluations,
        "acceptance": [r[2] for r in rows],
        "versions": versions(args.sampler),
    }
    with open(args.result, "w") as fh:
        json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
