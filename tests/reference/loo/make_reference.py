"""Reference values for slipbayes' PSIS-LOO and model comparison (tests/loo.rs), from ArviZ.

Three models of the same 30 observations (standard normal data with two outliers):
  normal_fixed  y ~ N(mu, 1)
  normal        y ~ N(mu, sigma)
  student       y ~ Student-t(3, mu, sigma)
with 800 posterior-like draws of (mu, sigma) each. Draws come from a 64-bit linear
congruential generator and the Box-Muller transform, written identically in tests/loo.rs, so
both sides build the same log-likelihood matrices without storing them. ArviZ's `loo` (with a
given relative efficiency r_eff, as slipbayes takes it) and `compare` (stacking weights) are
then written to reference.json.

Run with a Python that has arviz:
    python3 -m venv /tmp/az && /tmp/az/bin/pip install arviz==0.23.4
    /tmp/az/bin/python tests/reference/loo/make_reference.py
"""

import json
import math
import pathlib
import warnings

import arviz as az
import numpy as np

POINTS = 30
DRAWS = 800
R_EFF = 0.7
MASK = (1 << 64) - 1


class Lcg:
    def __init__(self, seed):
        self.state = seed & MASK

    def uniform(self):
        self.state = (self.state * 6364136223846793005 + 1442695040888963407) & MASK
        return ((self.state >> 11) + 0.5) / 9007199254740992.0

    def normal(self):
        u1 = self.uniform()
        u2 = self.uniform()
        return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)


def data():
    rng = Lcg(1)
    y = [rng.normal() for _ in range(POINTS)]
    y[7] = 6.0
    y[19] = -5.0
    return y


def log_normal(y, mu, sigma):
    z = (y - mu) / sigma
    return -0.5 * z * z - math.log(sigma) - 0.5 * math.log(2.0 * math.pi)


def log_student3(y, mu, sigma):
    # ln Γ(2) − ln Γ(3/2) = −ln(√π / 2); ν = 3.
    z = (y - mu) / sigma
    return (
        -math.log(math.sqrt(math.pi) / 2.0)
        - 0.5 * math.log(3.0 * math.pi)
        - math.log(sigma)
        - 2.0 * math.log1p(z * z / 3.0)
    )


def matrix(model, y, seed):
    """Point-major: row i holds observation i's log-likelihood at every draw."""
    rng = Lcg(seed)
    n = len(y)
    mean = sum(y) / n
    out = np.empty((n, DRAWS))
    for s in range(DRAWS):
        mu = mean + rng.normal() / math.sqrt(n)
        sigma = 1.0 if model == "normal_fixed" else math.exp(0.6 + 0.15 * rng.normal())
        for i, yi in enumerate(y):
            if model == "student":
                out[i, s] = log_student3(yi, mu, sigma)
            else:
                out[i, s] = log_normal(yi, mu, sigma)
    return out


MODELS = {"normal_fixed": 11, "normal": 12, "student": 13}


def main():
    y = data()
    results = {"points": POINTS, "draws": DRAWS, "r_eff": R_EFF, "arviz": az.__version__}
    elpds = {}
    for name, seed in MODELS.items():
        log_lik = matrix(name, y, seed)
        # One chain of DRAWS draws, observations as the data dimension.
        idata = az.from_dict(
            posterior={"mu": np.zeros((1, DRAWS))},
            log_likelihood={"y": log_lik.T[np.newaxis, :, :]},
        )
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            loo = az.loo(idata, pointwise=True, reff=R_EFF)
        elpds[name] = loo
        results[name] = {
            "seed": seed,
            "elpd_loo": float(loo["elpd_loo"]),
            "se": float(loo["se"]),
            "p_loo": float(loo["p_loo"]),
            "good_k": float(loo["good_k"]),
            "warning": bool(loo["warning"]),
            "loo_i": [float(v) for v in loo["loo_i"].values],
            "pareto_k": [float(v) for v in loo["pareto_k"].values],
            "first_row": [float(v) for v in log_lik[0, :4]],
        }
    table = az.compare(elpds, ic="loo", method="stacking")
    results["compare"] = [
        {
            "name": name,
            "rank": int(row["rank"]),
            "elpd_loo": float(row["elpd_loo"]),
            "elpd_diff": float(row["elpd_diff"]),
            "dse": float(row["dse"]),
            "weight": float(row["weight"]),
        }
        for name, row in table.iterrows()
    ]
    path = pathlib.Path(__file__).with_name("reference.json")
    path.write_text(json.dumps(results, indent=1) + "\n")
    print(table)


if __name__ == "__main__":
    main()
