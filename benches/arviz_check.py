#!/usr/bin/env python3
"""Recomputes a finished run's diagnostics with ArviZ itself, from its chains on disk.

    python3 benches/arviz_check.py RUN_DIR        # needs: pip install arviz pyarrow

For every reported column stored in the chains (parameters in SI are derived columns, so every
quantity of summary.json that is a column is checked), on every post-burn-in draw (step >=
the summary's burn_in): ArviZ's `ess(method="bulk")`, `ess(method="tail")` and `rhat` with
every walker of every ensemble as a chain (what `az.from_emcee` does), next to slipbayes' own
figures from summary.json (ESS over walkers as chains, which should agree; R-hat between
ensembles, a different grouping, see src/diagnostics/ensemble.rs). Prints the worst of each
and the quantities failing ESS > 400 or R-hat < 1.01 by either count.
"""
import glob
import json
import sys
import warnings

warnings.filterwarnings("ignore")
import arviz as az  # noqa: E402
import numpy as np  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402
import pyarrow as pa  # noqa: E402


def main():
    run = sys.argv[1]
    summary = json.load(open(f"{run}/summary.json"))
    burn = summary["sampler"]["burn_in"]
    table = pa.concat_tables(pq.read_table(p) for p in sorted(glob.glob(f"{run}/chains/*.parquet")))
    ens = table["ensemble"].to_numpy()
    walker = table["walker"].to_numpy()
    step = table["step"].to_numpy()
    keep = step >= burn
    E, W = ens.max() + 1, walker.max() + 1
    steps = np.unique(step[keep]).size
    order = np.lexsort((step[keep], walker[keep], ens[keep]))
    rows = []
    for q in summary["parameters"] + summary["derived"]:
        col = q["column"]
        if col not in table.column_names:
            continue
        x = table[col].to_numpy()[keep][order].reshape(E * W, steps)
        if not np.all(np.isfinite(x)):
            continue
        rows.append((col, az.ess(x, method="bulk"), az.ess(x, method="tail"), az.rhat(x),
                     q["ess_bulk"], q["ess_tail"], q["r_hat"]))
    print(f"{run}: {len(rows)} quantities, {E} ensembles x {W} walkers x {steps} post-burn-in steps")
    def worst(i, f):
        v = [r[i] for r in rows if r[i] is not None]
        return f(v)
    print(f"ArviZ (walkers as chains): min ESS bulk {worst(1, min):.0f}, tail {worst(2, min):.0f}, "
          f"max R-hat {worst(3, max):.4f}")
    print(f"slipbayes summary.json:    min ESS bulk {worst(4, min):.0f}, tail {worst(5, min):.0f}, "
          f"max R-hat {worst(6, max):.4f} (between ensembles)")
    rel = max(abs(r[1] / r[4] - 1) for r in rows)
    print(f"largest relative difference in ESS bulk: {rel:.2e}")
    bad = [r[0] for r in rows if r[1] <= 400 or r[2] <= 400 or r[3] >= 1.01]
    print(f"failing by ArviZ's count: {len(bad)} {bad[:10]}")


if __name__ == "__main__":
    main()
