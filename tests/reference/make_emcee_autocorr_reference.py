"""Reference integrated autocorrelation times from emcee, for tests/diagnostics_autocorr.rs.

Run with the project venv:  /work/venv/bin/python tests/reference/make_emcee_autocorr_reference.py
Writes tests/reference/emcee_autocorr.json.

Each case is an ensemble of seeded AR(1) walkers x_t = phi x_{t-1} + e_t (e ~ N(0,1), started
from the stationary law), whose integrated autocorrelation time is (1 + phi) / (1 - phi).
To keep the file small the draws are stored as integers `k` meaning x = k / divisor (IEEE
division, done identically in Rust); emcee is run on exactly those decoded values, so the
comparison is exact up to FFT rounding.
"""

import json
import pathlib

import emcee
import numpy as np
from emcee.autocorr import auto_window, function_1d

DIVISOR = 1000.0
C = 5.0
TOL = 50.0

CASES = [
    # name, phi, walkers, steps, seed
    ("white_noise", 0.0, 8, 2000, 11),
    ("ar1_phi0.5", 0.5, 8, 2000, 12),
    ("ar1_phi0.9", 0.9, 8, 2000, 13),
    ("ar1_phi0.9_odd_length", 0.9, 3, 1001, 14),
    ("ar1_phi0.98_short", 0.98, 8, 200, 15),  # too short: unreliable
    ("ar1_phi0.999_tiny", 0.999, 4, 40, 16),  # far too short: tau grossly underestimated
]


def ar1(rng, phi, walkers, steps):
    x = np.empty((steps, walkers))
    x[0] = rng.standard_normal(walkers) / np.sqrt(1.0 - phi * phi)
    for t in range(1, steps):
        x[t] = phi * x[t - 1] + rng.standard_normal(walkers)
    return x


def main():
    out = {
        "generator": "tests/reference/make_emcee_autocorr_reference.py",
        "emcee_version": emcee.__version__,
        "numpy_version": np.__version__,
        "divisor": DIVISOR,
        "c": C,
        "cases": [],
    }
    for name, phi, walkers, steps, seed in CASES:
        rng = np.random.default_rng(seed)
        x = ar1(rng, phi, walkers, steps)
        k = np.rint(x * DIVISOR).astype(np.int64)
        xd = k / DIVISOR  # the values Rust will see
        tau = emcee.autocorr.integrated_time(xd, c=C, tol=TOL, quiet=True)[0]
        # emcee does not return the window; recompute it with emcee's own pieces.
        f = np.zeros(steps)
        for w in range(walkers):
            f += function_1d(xd[:, w])
        f /= walkers
        taus = 2.0 * np.cumsum(f) - 1.0
        window = int(auto_window(taus, C))
        assert taus[window] == tau
        out["cases"].append(
            {
                "name": name,
                "phi": phi,
                "seed": seed,
                "walkers": walkers,
                "steps": steps,
                "tau_analytic": (1.0 + phi) / (1.0 - phi),
                "tau_emcee": float(tau),
                "window_emcee": window,
                "reliable_emcee": bool(not (TOL * tau > steps)),
                # walker-major: draws_int[w][t]
                "draws_int": k.T.tolist(),
            }
        )
    path = pathlib.Path(__file__).with_name("emcee_autocorr.json")
    path.write_text(json.dumps(out, separators=(",", ":")) + "\n")
    for c in out["cases"]:
        print(c["name"], c["tau_emcee"], c["window_emcee"], c["reliable_emcee"], c["tau_analytic"])


if __name__ == "__main__":
    main()
