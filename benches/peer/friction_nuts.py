#!/usr/bin/env python3
"""The gradient-based peer of `slipbayes bench`: NumPyro's NUTS on JAX (CPU, float64) on the
one-contact posterior.

Usage (run by `slipbayes bench`, which writes the problem file):
    python benches/peer/friction_nuts.py PROBLEM.json RESULT.json

It fits the IDENTICAL posterior to the emcee peer (friction_peer.py, whose data loading,
coordinates, priors, law and σ marginal it imports): coordinates u = ln θ of α, a/F_d, F_d,
t0 and k, flat inside the log-uniform prior bounds and −∞ outside; the law F(τ) with JAX's
Ei; the elastic correction t = τ + F(τ)/(kv) solved at every data time by the same
safeguarded Newton iteration, vectorised over the points inside one `lax.while_loop` that
stops when every point has converged; σ integrated out. NUTS needs the gradient through that
solve. The loop itself is not differentiated: its root τ* is held constant and one more
Newton step τ = τ* − G(τ*; θ) / G'(τ*) (G'(τ*) also held constant) is differentiated instead.
Its value is the root (to rounding) and its derivative is the implicit one,
dτ/dθ = −(∂G/∂θ)/(∂G/∂τ), exactly.

JAX's `jax.scipy.special.expi` in float64 (jax 0.10.2), against mpmath at 40 digits on 4,000
points log-spaced over [1e-8, 700]: within 10.3 ε relative away from Ei's zero x ≈ 0.3725
(within 3.0 ε above x = 1), and within 1.8e-16 absolute in ±0.02 around the zero, where
relative error means nothing; scipy's `expi` is within 121 ε relative (at x = 40) and
2.8e-16 absolute there. Its derivative (e^x/x, JAX's own rule) is within 4e-16 relative.
The log-density below equals the emcee peer's to about 1e-15 relative.

NUTS samples u itself (potential −log density, the same coordinates as emcee and slipbayes),
so the log-densities compared by the bench are those it samples. Each run of the problem's
`nuts.runs` starts its chains from the first walkers of the bench's initial ensembles, runs
NumPyro's warmup (step size and mass matrix adaptation, draws discarded) and then its draws,
timed separately; JAX's compile time inside each phase is measured from JAX's own compile
events and reported apart from the run times (which exclude it). Several chains run in
parallel, one per host device (`numpyro.set_host_device_count`).

The problem file is the emcee peer's plus a `nuts` object: warmup, draws, target_accept,
max_tree_depth, dense_mass and runs = [{chains, out}], `out` being the CSV to write the
chain's draws to (columns ensemble,walker,step,<coordinates>: one "ensemble" per chain,
one walker, so the bench reads them with the emcee peer's reader and one estimator).
"""
import json
import os
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

import numpy as np  # noqa: E402

from friction_peer import (  # noqa: E402
    MAX_ITERATIONS,
    OneContact,
    law,
    marginal_sigma_log_likelihood,
    newton_pass,
)

ROLES = ("alpha", "a_over_F_d", "F_d", "t0", "k")


def jax_modules():
    """JAX in float64, imported after the host device count is set (it cannot change once
    JAX has started)."""
    import jax

    jax.config.update("jax_enable_x64", True)
    return jax


class JaxOneContact:
    """The emcee peer's posterior in JAX, one point u (5,) at a time (vmap for more)."""

    def __init__(self, base):
        jax = jax_modules()
        import jax.numpy as jnp
        from jax.scipy.special import expi, gammainc, gammaln

        self.jax, self.jnp = jax, jnp
        self.expi, self.gammainc, self.gammaln = expi, gammainc, gammaln
        self.t = jnp.asarray(base.t)
        self.f_obs = jnp.asarray(base.f_obs)
        self.v = base.v
        self.order = [base.role[n] for n in ROLES]
        self.bounds = jnp.asarray(base.bounds)
        self.lo, self.hi = jnp.asarray(base.lo), jnp.asarray(base.hi)
        self.sigma_low, self.sigma_high = base.sigma_low, base.sigma_high
        self.n = base.t.size

    def law(self, tau, av, a, f_d, ei_x0):
        return law(tau, av, a, f_d, ei_x0, xp=self.jnp, ei=self.expi)

    def newton_root(self, target, t0, tau_start, av, a, f_d, kv, ei_x0):
        """The root of G(τ) = τ + F(τ)/(kv) − target in [t0, target] at every point: the
        emcee peer's safeguarded Newton iteration, every point in every pass, each frozen
        once converged; NaN where G is not finite or no convergence in MAX_ITERATIONS."""
        jnp, lax = self.jnp, self.jax.lax
        lo = jnp.broadcast_to(t0, target.shape)
        hi = target
        tau = jnp.where((tau_start > lo) & (tau_start < hi), tau_start, lo + 0.5 * (hi - lo))
        done = jnp.zeros(target.shape, dtype=bool)
        # No NaN enters the loop: under jit(vmap) XLA returned NaN roots for points that had
        # converged when the failed points' NaN was selected inside it (jaxlib 0.10.2, CPU).
        state = (tau, lo, hi, hi - lo, tau, done, done, 0)

        def unfinished(state):
            return (state[7] < MAX_ITERATIONS) & ~jnp.all(state[5])

        def step(state):
            tau, lo, hi, prev_step, root, done, bad, it = state
            f, fr = self.law(tau, av, a, f_d, ei_x0)
            g = tau + f / kv - target
            lo, hi, found, now, failed, next_tau, prev_step = newton_pass(
                tau, g, 1.0 + fr / kv, lo, hi, prev_step, xp=jnp
            )
            now = now & ~done
            root = jnp.where(now, found, root)
            bad = bad | (now & failed)
            done = done | now
            tau = jnp.where(done, tau, next_tau)
            return tau, lo, hi, prev_step, root, done, bad, it + 1

        state = lax.while_loop(unfinished, step, state)
        return jnp.where(state[5] & ~state[6], state[4], jnp.nan)

    def log_density(self, u):
        """Log-posterior at u (5,), −∞ where the emcee peer's is; differentiable."""
        jnp, stop = self.jnp, self.jax.lax.stop_gradient
        theta = jnp.exp(u)
        inside = jnp.all((theta >= self.bounds[:, 0]) & (theta <= self.bounds[:, 1]))
        # Outside the bounds the value is discarded; evaluate at the nearest bound instead,
        # so that nothing non-finite reaches the gradient.
        theta = jnp.exp(jnp.clip(u, self.lo, self.hi))
        alpha, ratio, f_d, t0, k = (theta[i] for i in self.order)
        av, a, kv = alpha * self.v, ratio * f_d, k * self.v
        ei_x0 = self.expi(av * t0)
        f_t0, _ = self.law(t0, av, a, f_d, ei_x0)
        loading_ends = t0 + f_t0 / kv
        sliding = self.t > loading_ends
        # Points still loading solve for a stand-in time on the sliding branch instead, so
        # the solve and its gradient stay finite there; their values are discarded.
        target = jnp.where(sliding, self.t, loading_ends + f_t0 / kv)
        params = (av, a, f_d, kv, ei_x0)
        root = stop(
            self.newton_root(
                stop(target), stop(t0), stop(target - self.f_obs / kv), *map(stop, params)
            )
        )
        # One Newton step from the root, differentiated with the slope held: the root's
        # value, the implicit derivative.
        f_root, rate_root = self.law(root, *params[:3], ei_x0)
        g = root + f_root / kv - target
        tau = root - g / stop(1.0 + rate_root / kv)
        force, rate = self.law(tau, av, a, f_d, ei_x0)
        model = jnp.where(sliding, force, jnp.where(self.t <= t0, 0.0, kv * (self.t - t0)))
        stick_slip = jnp.any(sliding & (rate <= -kv))
        ssr = jnp.sum((self.f_obs - model) ** 2)
        ll, mass = marginal_sigma_log_likelihood(
            ssr,
            self.n,
            self.sigma_low,
            self.sigma_high,
            xp=jnp,
            incomplete_gamma=self.gammainc,
            log_gamma=self.gammaln,
        )
        valid = inside & jnp.isfinite(ll) & (mass > 0) & (ssr > 0) & ~stick_slip
        return jnp.where(valid, ll, -jnp.inf)


# Posterior draws (the first points of the problem's list) at which the gradient is checked.
GRADIENT_CHECK_POINTS = 12
# Central-difference step in u. The truncation error is of order h² |∂³ log p| and the
# rounding error of order ε |log p| / h ≈ 4e-6 with |log p| ≈ 2e4, against gradient
# components of 1e2 to 1e5 at posterior draws: both far below the bench's 1e-5 tolerance
# relative to the largest component (3e-8 seen).
GRADIENT_CHECK_STEP = 1e-6


def gradient_check(jax, post, value_and_grad, points):
    """Largest difference between the autodiff gradient and central differences of the
    log-density, relative to the gradient's largest component, over `points`."""
    log_density = jax.jit(post.log_density)
    worst = 0.0
    for x in points:
        _, grad = value_and_grad(jax.numpy.asarray(x))
        grad = np.asarray(grad)
        central = np.empty_like(grad)
        for d in range(x.size):
            step = np.zeros_like(x)
            step[d] = GRADIENT_CHECK_STEP
            up = float(log_density(jax.numpy.asarray(x + step)))
            down = float(log_density(jax.numpy.asarray(x - step)))
            central[d] = (up - down) / (2.0 * GRADIENT_CHECK_STEP)
        worst = max(worst, float(np.max(np.abs(grad - central)) / np.max(np.abs(grad))))
    return worst


class CompileClock:
    """Seconds JAX spends tracing, lowering and compiling, from its monitoring events."""

    EVENTS = (
        "/jax/core/compile/jaxpr_trace_duration",
        "/jax/core/compile/jaxpr_to_mlir_module_duration",
        "/jax/core/compile/backend_compile_duration",
    )

    def __init__(self, jax):
        self.seconds = 0.0
        jax.monitoring.register_event_duration_secs_listener(self._hear)

    def _hear(self, event, duration, **_):
        if event in self.EVENTS:
            self.seconds += duration


def run_nuts(jax, post, settings, run, initial, seed, clock):
    """One NumPyro NUTS run; writes its draws to run["out"] and returns its figures."""
    import numpyro
    from numpyro.infer import MCMC, NUTS

    chains = int(run["chains"])
    kernel = NUTS(
        potential_fn=lambda u: -post.log_density(u),
        target_accept_prob=float(settings["target_accept"]),
        max_tree_depth=int(settings["max_tree_depth"]),
        dense_mass=bool(settings["dense_mass"]),
    )
    mcmc = MCMC(
        kernel,
        num_warmup=int(settings["warmup"]),
        num_samples=int(settings["draws"]),
        num_chains=chains,
        chain_method="parallel" if chains > 1 else "sequential",
        progress_bar=False,
    )
    # The chains start from the first walker of each of the bench's initial ensembles.
    starts = np.array([initial[c % len(initial)][c // len(initial)] for c in range(chains)])
    init = jax.numpy.asarray(starts if chains > 1 else starts[0])
    key = jax.random.PRNGKey(seed)

    compiled = clock.seconds
    t_start = time.perf_counter()
    mcmc.warmup(key, init_params=init, extra_fields=("num_steps",), collect_warmup=False)
    jax.block_until_ready(mcmc.post_warmup_state)
    warmup_wall = time.perf_counter() - t_start
    warmup_compile = clock.seconds - compiled

    compiled = clock.seconds
    t_start = time.perf_counter()
    mcmc.run(
        mcmc.post_warmup_state.rng_key,
        extra_fields=("num_steps", "diverging", "accept_prob"),
    )
    samples = mcmc.get_samples(group_by_chain=True)
    jax.block_until_ready(samples)
    sampling_wall = time.perf_counter() - t_start
    sampling_compile = clock.seconds - compiled

    draws = np.asarray(samples).reshape(chains, int(settings["draws"]), -1)
    extra = mcmc.get_extra_fields(group_by_chain=True)
    with open(run["out"], "w") as fh:
        fh.write("ensemble,walker,step," + ",".join(settings["names"]) + "\n")
        for c in range(chains):
            for s in range(draws.shape[1]):
                fh.write(f"{c},0,{s}," + ",".join(repr(float(v)) for v in draws[c, s]) + "\n")
    state = mcmc.last_state
    return {
        "chains": chains,
        "warmup_s": warmup_wall - warmup_compile,
        "warmup_compile_s": warmup_compile,
        "sampling_s": sampling_wall - sampling_compile,
        "sampling_compile_s": sampling_compile,
        "gradients": int(np.sum(np.asarray(extra["num_steps"]))),
        "divergences": int(np.sum(np.asarray(extra["diverging"]))),
        "accept_prob": float(np.mean(np.asarray(extra["accept_prob"]))),
        "step_size": np.atleast_1d(np.asarray(state.adapt_state.step_size)).tolist(),
        "numpyro": numpyro.__version__,
    }


def main():
    problem_path, result_path = sys.argv[1:3]
    with open(problem_path) as fh:
        problem = json.load(fh)
    settings = dict(problem["nuts"], names=problem["names"])
    import numpyro

    # Must precede JAX's start: one host device per parallel chain.
    numpyro.set_host_device_count(max(int(r["chains"]) for r in settings["runs"]))
    jax = jax_modules()
    clock = CompileClock(jax)
    post = JaxOneContact(OneContact(problem))
    value_and_grad = jax.jit(jax.value_and_grad(post.log_density))

    points = np.array(problem["points"], dtype=float)
    lp = np.asarray(jax.jit(jax.vmap(post.log_density))(jax.numpy.asarray(points)))
    gradient_error = gradient_check(jax, post, value_and_grad, points[:GRADIENT_CHECK_POINTS])

    # Cost of one log-density with its gradient (what a leapfrog step needs), one point per
    # call, best of a few repetitions over the bench's initial walkers.
    initial = np.array(problem["initial"], dtype=float)
    batch = [jax.numpy.asarray(x) for x in initial[0][: initial.shape[1] // 2]]
    jax.block_until_ready(value_and_grad(batch[0]))
    costs = []
    for _ in range(int(problem.get("cost_reps", 5))):
        t_start = time.perf_counter()
        for x in batch:
            jax.block_until_ready(value_and_grad(x))
        costs.append((time.perf_counter() - t_start) / len(batch))

    runs = [
        run_nuts(jax, post, settings, run, initial, int(problem["seed"]) + i, clock)
        for i, run in enumerate(settings["runs"])
    ]
    result = {
        "log_density": [float(v) if np.isfinite(v) else None for v in lp],
        "gradient_check": {
            "points": GRADIENT_CHECK_POINTS,
            "max_error": gradient_error,
        },
        "seconds_per_gradient": float(np.median(costs)),
        "runs": runs,
        "versions": {
            "python": sys.version.split()[0],
            "jax": jax.__version__,
            "jaxlib": __import__("jaxlib").__version__,
            "numpyro": numpyro.__version__,
            "numpy": np.__version__,
        },
    }
    with open(result_path, "w") as fh:
        json.dump(result, fh, indent=1)


if __name__ == "__main__":
    main()
