"""The convergence figures of a finished run, formatted for the bench scripts' tables.

    python3 benches/run_stats.py RUN_DIR FORMAT

FORMAT is a Python format string over the fields below, read from RUN_DIR/summary.json: every
reported quantity (parameters and derived), every post-burn-in draw, as ArviZ computes them
(dimension from RUN_DIR/settings.json, None without it).
  dimension, walkers, steps, stopped_by, converged, tau_max, evals, wall_s,
  ess_bulk_min, ess_tail_min, r_hat_max, quantities, low_ess (quantities with ESS bulk <= 400),
  ess_per_k_evals, ess_per_s (the lowest ESS bulk per 1,000 evaluations and per second of
  sampling wall time)
"""
import json
import sys

run_dir, fmt = sys.argv[1:]
summary = json.load(open(run_dir + "/summary.json"))
quantities = summary["parameters"] + summary["derived"]
sampler = summary["sampler"]
try:
    dimension = json.load(open(run_dir + "/settings.json"))["dimension"]
except FileNotFoundError:
    # `validate --hard` keeps only the summaries of its fits.
    dimension = None


def values(key):
    # None (not computed) and NaN are left out.
    return [q[key] for q in quantities if q[key] is not None and q[key] == q[key]]


print(fmt.format(
    dimension=dimension,
    walkers=sampler["walkers"],
    steps=sampler["steps"],
    stopped_by=sampler["stopped_by"],
    converged=sampler["converged"],
    tau_max=sampler["tau_max"],
    evals=sampler["log_density_evals"],
    wall_s=sampler["wall_s"],
    ess_bulk_min=min(values("ess_bulk")),
    ess_tail_min=min(values("ess_tail")),
    r_hat_max=max(values("r_hat")),
    quantities=len(quantities),
    low_ess=sum(1 for v in values("ess_bulk") if v <= 400),
    ess_per_k_evals=1000 * min(values("ess_bulk")) / sampler["log_density_evals"],
    ess_per_s=min(values("ess_bulk")) / sampler["wall_s"],
))
