#!/usr/bin/env python3
"""How τ estimated on short chains compares with τ on the whole of a long run.

    python3 benches/tau_windows.py RUN_DIR [BURN_IN]     # needs numpy and pyarrow

RUN_DIR is a fixed-length fit's run directory (e.g. `slipbayes fit --first
data/ptfe-c1-first.csv --repeat data/ptfe-c1-repeat.csv --velocity 1e-9 --steps 4000 --out
RUN_DIR`). For every sampler coordinate and the log-density, τ over steps BURN_IN (default 50)
to the end is the reference (emcee's estimator: each walker's ACF about its own mean,
averaged over all walkers). Then on windows of 5 to 50 reference τ_max, eight windows each
spread over the run, τ by two estimators, as a ratio to the reference:
- emcee's (each walker about its own mean);
- pooled (each walker about its ensemble's mean, autocovariances summed over every walker of
  every ensemble), what slipbayes' sampler and summary use (src/diagnostics/autocorr.rs).
Prints the smallest, median and largest ratio over windows × coordinates.
"""
import glob
import sys

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq


def sokal(rho, c=5.0):
    taus = 2 * np.cumsum(rho) - 1
    ok = np.nonzero(np.arange(len(rho)) >= c * taus)[0]
    return taus[ok[0] if len(ok) else len(rho) - 1]


def acov(y):
    """Autocovariance sums of the columns of y (steps, chains), by FFT."""
    n = y.shape[0]
    m = 2 * (1 << (n - 1).bit_length())
    f = np.fft.rfft(y, n=m, axis=0)
    return np.fft.irfft(f * np.conj(f), n=m, axis=0)[:n]


def tau_emcee(x, ensembles):
    a = acov(x - x.mean(axis=0))
    return sokal((a / a[0]).mean(axis=1))


def tau_pooled(x, ensembles):
    steps, chains = x.shape
    groups = x.reshape(steps, ensembles, chains // ensembles)
    centred = (groups - groups.mean(axis=(0, 2), keepdims=True)).reshape(steps, chains)
    a = acov(centred).sum(axis=1)
    return sokal(a / a[0])


def main():
    run = sys.argv[1]
    burn = int(sys.argv[2]) if len(sys.argv) > 2 else 50
    t = pa.concat_tables(pq.read_table(f) for f in sorted(glob.glob(run + "/chains/*.parquet")))
    t = t.to_pandas().sort_values(["step", "ensemble", "walker"])
    names = list(t.columns)
    cols = names[3:names.index("log_density") + 1]
    e, w, s = t.ensemble.max() + 1, t.walker.max() + 1, t.step.max() + 1
    series = {c: t[c].to_numpy().reshape(s, e * w) for c in cols}
    ref = {c: tau_emcee(series[c][burn:], e) for c in cols}
    tref = max(ref.values())
    print(f"{run}: {e} ensembles × {w} walkers × {s} steps; reference τ (steps {burn}–{s}): "
          + ", ".join(f"{c} {v:.2f}" for c, v in ref.items()))
    for name, f in (("emcee (each walker about its own mean)", tau_emcee),
                    ("pooled (about each ensemble's mean)", tau_pooled)):
        print(name)
        for mult in (5, 10, 12.5, 15, 20, 30, 50):
            length = int(mult * tref)
            r = np.array([[f(series[c][a:a + length], e) / ref[c] for c in cols]
                          for a in range(burn, s - length, max(length, (s - burn) // 8))])
            print(f"  {mult:5.1f} τ ({length:4d} steps), {r.shape[0]} windows × {r.shape[1]}: "
                  f"min {r.min():.2f}, median {np.median(r):.2f}, max {r.max():.2f}")


if __name__ == "__main__":
    main()
