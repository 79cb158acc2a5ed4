"""Reference ArviZ diagnostics, for tests/diagnostics_arviz.rs and tests/diagnostics_ensemble.rs.

Run with the project venv:  /work/venv/bin/python tests/reference/make_arviz_reference.py
Writes tests/reference/arviz_diagnostics.json.

Seeded chains (numpy default_rng) of shapes typical of MCMC output: well mixed, autocorrelated,
heavy tailed, one chain shifted (high R-hat), skewed, tied values, odd length, single chain.
Draws are stored as integers k meaning x = k / divisor (IEEE division, done identically in
Rust) and ArviZ is run on exactly those decoded values.
"""

import json
import pathlib

import arviz as az
import numpy as np
import scipy

DIVISOR = 10000.0
HDI_PROB = 0.94
QUANTILE_PROBS = [0.05, 0.5, 0.95]
PLAIN_QUANTILES = [0.0, 0.025, 0.1, 0.25, 0.5, 0.75, 0.9, 0.975, 1.0]


def ar1(rng, phi, chains, draws):
    x = np.empty((chains, draws))
    x[:, 0] = rng.standard_normal(chains) / np.sqrt(1.0 - phi * phi)
    for t in range(1, draws):
        x[:, t] = phi * x[:, t - 1] + rng.standard_normal(chains)
    return x


def make_cases():
    cases = []
    rng = np.random.default_rng(20240601)
    cases.append(("normal_iid", rng.standard_normal((4, 500)) * 2.0 + 3.0))
    cases.append(("ar1_phi0.9", ar1(rng, 0.9, 4, 500)))
    cases.append(("student_t3", rng.standard_t(3, (4, 500))))
    shifted = rng.standard_normal((4, 500))
    shifted[3] += 1.5
    cases.append(("one_chain_shifted", shifted))
    cases.append(("lognormal_skewed", np.exp(rng.standard_normal((4, 500)))))
    cases.append(("poisson_ties", rng.poisson(3.0, (4, 500)).astype(float)))
    cases.append(("ar1_phi0.5_odd_length", ar1(rng, 0.5, 3, 301)))
    cases.append(("single_chain_ar1", ar1(rng, 0.7, 1, 400)))
    cases.append(("many_short_chains", rng.standard_normal((16, 8))))
    return cases


def f(v):
    v = float(v)
    return None if np.isnan(v) else v


def main():
    out = {
        "generator": "tests/reference/make_arviz_reference.py",
        "arviz_version": az.__version__,
        "numpy_version": np.__version__,
        "scipy_version": scipy.__version__,
        "divisor": DIVISOR,
        "hdi_prob": HDI_PROB,
        "quantile_probs": QUANTILE_PROBS,
        "plain_quantiles": PLAIN_QUANTILES,
        "cases": [],
    }
    for name, x in make_cases():
        k = np.rint(x * DIVISOR).astype(np.int64)
        x = k / DIVISOR
        flat = x.ravel()
        case = {
            "name": name,
            "chains": x.shape[0],
            "draws": x.shape[1],
            "draws_int": k.tolist(),
            "r_hat": f(az.rhat(x, method="rank")),
            "ess_bulk": f(az.ess(x, method="bulk")),
            "ess_tail": f(az.ess(x, method="tail")),
            "ess_mean": f(az.ess(x, method="mean")),
            "mcse_mean": f(az.mcse(x, method="mean")),
            "mcse_sd": f(az.mcse(x, method="sd")),
            "mcse_quantile": [f(az.mcse(x, method="quantile", prob=p)) for p in QUANTILE_PROBS],
            "hdi": [float(v) for v in az.hdi(flat, hdi_prob=HDI_PROB)],
            "eti": [float(v) for v in np.quantile(flat, [(1 - HDI_PROB) / 2, (1 + HDI_PROB) / 2])],
            "quantiles": [float(v) for v in np.quantile(flat, PLAIN_QUANTILES)],
            "mean": float(np.mean(flat)),
            "sd": float(np.std(flat, ddof=1)),
            "median": float(np.median(flat)),
        }
        # az.summary as users see it (unrounded); its R-hat folds before splitting, which
        # differs from az.rhat only for odd draw counts.
        if x.shape[0] > 1:
            s = az.summary({"x": x}, hdi_prob=HDI_PROB, round_to="none")
            case["summary"] = {c: float(s.loc["x", c]) for c in s.columns}
        out["cases"].append(case)
    path = pathlib.Path(__file__).with_name("arviz_diagnostics.json")
    path.write_text(json.dumps(out, separators=(",", ":")) + "\n")
    for c in out["cases"]:
        print(c["name"], c["r_hat"], c["ess_bulk"], c["ess_tail"], c["ess_mean"], c["mcse_quantile"])


if __name__ == "__main__":
    main()
