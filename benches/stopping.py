#!/usr/bin/env python3
"""reports/stopping.md: how soon fits stop, against a previous build, and whether stopping
there is honest.

    python3 benches/stopping.py OUT_DIR [--before BIN] [--seeds 3] [--only PATTERN]

Needs numpy, pyarrow and arviz (installed into target/stopping-venv when the Python that runs
it lacks them), target/release/slipbayes (or the binary in $SLIPBAYES) and, for the before/after table, a previous build (`--before BIN`).
Every model configuration a model file allows is fitted until converged, with default
settings: the one-contact quick path, the demo (two materials, relative aging), the demo with
`aging = "absolute"`, the demo with t0 pooled, and a 10-contact campaign
(`data/make_campaign.py`). For each:

- **Before/after.** The previous build and this one, seed 1: steps, evaluations, sampling
  time (the summary's `wall_s`), end-to-end wall time, lowest ESS bulk and tail, largest R̂
  between ensembles, converged, and the lowest ESS bulk per 1,000 evaluations.
- **Recomputed by ArviZ.** Each of this build's runs, from its chains on disk: every walker
  a chain, every post-burn-in draw of every reported column, `az.ess` bulk and tail and
  `az.rhat`, and the verdict by ArviZ's thresholds (ESS > 400, R̂ < 1.01 between walkers).
- **Honesty.** This build from `--seeds` seeds, each stopped by its rule, against one long
  reference run of the same model (seed 1000, fixed length: ten times the longest stopped
  run): every parameter's post-burn-in mean within 4 combined MCSE
  (√(MCSE_run² + MCSE_ref²)) of the reference's, and the rule's τ_max against the pooled τ
  of the second half of the reference's chains (the same estimator, on chains five times
  longer).

Runs are sequential, so wall times compare; nothing else should run meanwhile. Writes
OUT_DIR/stopping.md (the tables) and OUT_DIR/results.json.
"""
import argparse
import glob
import json
import os
import re
import subprocess
import sys
import time
import warnings

warnings.filterwarnings("ignore")

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
VENV = os.path.join(ROOT, "target", "stopping-venv")


def ensure_venv():
    """Re-runs this script in a venv that has numpy, pyarrow and arviz, unless this Python
    already has them."""
    try:
        import arviz  # noqa: F401
        import numpy  # noqa: F401
        import pyarrow  # noqa: F401
        return
    except ImportError:
        pass
    py = os.path.join(VENV, "bin", "python")
    if os.path.realpath(sys.prefix) == os.path.realpath(VENV):
        sys.exit("the venv at target/stopping-venv lacks numpy, pyarrow or arviz")
    if not os.path.exists(py):
        subprocess.run([sys.executable, "-m", "venv", VENV], check=True)
        subprocess.run([py, "-m", "pip", "install", "-q", "numpy", "pyarrow", "arviz"],
                       check=True)
    os.execv(py, [py] + sys.argv)
ONE_CONTACT = ["--first", "data/ptfe-c1-first.csv", "--repeat", "data/ptfe-c1-repeat.csv",
               "--velocity", "1e-9"]


def models(out):
    """The model configurations, as (label, fit arguments)."""
    m = os.path.join(out, "models")
    os.makedirs(m, exist_ok=True)
    demo = open(os.path.join(ROOT, "models/demo.toml")).read().replace(
        "../data/", os.path.join(ROOT, "data") + "/")
    variants = {
        "demo": demo,
        "absolute aging": 'aging = "absolute"\n' + demo,
        "t0 pooled": demo + "\n[pooling]\nt0 = true\n",
    }
    configs = [("one contact", ONE_CONTACT)]
    for label, text in variants.items():
        path = os.path.join(m, re.sub(r"\W+", "-", label) + ".toml")
        open(path, "w").write(text)
        configs.append((label, [path]))
    campaign = os.path.join(out, "campaign")
    subprocess.run([sys.executable, os.path.join(ROOT, "data/make_campaign.py"), "--contacts",
                    "10", "--out", campaign], check=True, stdout=subprocess.DEVNULL)
    configs.append(("campaign, 10 contacts", [os.path.join(campaign, "campaign.toml")]))
    return configs


def fit(binary, args, out, extra=()):
    """Runs a fit; returns (summary, end-to-end seconds)."""
    start = time.perf_counter()
    subprocess.run([binary, "fit", *args, "--out", out, "--overwrite", "--quiet", *extra],
                   check=True, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    return json.load(open(os.path.join(out, "summary.json"))), wall


def chains(run, coordinates=False):
    """{column: array (chains, post-burn-in steps)} of a run's parameters and derived
    quantities (or, with `coordinates`, of the sampler's coordinates: the columns before
    `log_density`), every walker a chain; and the run's summary."""
    summary = json.load(open(os.path.join(run, "summary.json")))
    burn = summary["sampler"]["burn_in"]
    table = pa.concat_tables(pq.read_table(p) for p in
                             sorted(glob.glob(os.path.join(run, "chains", "*.parquet"))))
    ens, walker, step = (table[c].to_numpy() for c in ("ensemble", "walker", "step"))
    keep = step >= burn
    chains_n = (ens.max() + 1) * (walker.max() + 1)
    steps = np.unique(step[keep]).size
    order = np.lexsort((step[keep], walker[keep], ens[keep]))
    out = {}
    names = table.column_names
    wanted = (names[3:names.index("log_density")] if coordinates
              else [q["column"] for q in summary["parameters"] + summary["derived"]])
    for col in wanted:
        if col in names:
            x = table[col].to_numpy()[keep][order].reshape(chains_n, steps)
            if np.all(np.isfinite(x)):
                out[col] = x
    return out, summary


def pooled_tau(x, c=5.0):
    """Pooled integrated autocorrelation time of x (chains, steps): the autocovariance of
    every chain about the mean of all, summed, Sokal's window c (as src/diagnostics)."""
    n = x.shape[1]
    m = 2 * (1 << (n - 1).bit_length())
    f = np.fft.rfft(x - x.mean(), n=m, axis=1)
    acov = np.fft.irfft(f * np.conj(f), n=m, axis=1)[:, :n].sum(axis=0)
    rho = acov / acov[0]
    taus = 2 * np.cumsum(rho) - 1
    ok = np.nonzero(np.arange(n) >= c * taus)[0]
    return taus[ok[0] if len(ok) else n - 1]


def arviz_check(run):
    """ArviZ's own ESS (every walker a chain) and R̂ between ensembles (each ensemble's draws
    in step order, walkers interleaved within a step, as the standard defines it), and, for
    information, R̂ with every walker a chain."""
    import arviz as az
    x, summary = chains(run)
    e, w = summary["sampler"]["ensembles"], summary["sampler"]["walkers"]

    def by_ensemble(v):
        return v.reshape(e, w, -1).transpose(0, 2, 1).reshape(e, -1)

    ess_b = min(float(az.ess(v, method="bulk")) for v in x.values())
    ess_t = min(float(az.ess(v, method="tail")) for v in x.values())
    rhat = max(float(az.rhat(by_ensemble(v))) for v in x.values())
    rhat_walkers = max(float(az.rhat(v)) for v in x.values())
    return {"ess_bulk": ess_b, "ess_tail": ess_t, "r_hat": rhat, "r_hat_walkers": rhat_walkers,
            "converged": ess_b > 400 and ess_t > 400 and rhat < 1.01}


def stats(summary, wall):
    s = summary["sampler"]
    q = summary["parameters"] + summary["derived"]
    ess_b = min(v["ess_bulk"] for v in q if v["ess_bulk"] == v["ess_bulk"])
    return {
        "steps": s["steps"], "walkers": s["walkers"], "ensembles": s["ensembles"],
        "evals": s["log_density_evals"], "sampling_s": s["wall_s"], "wall_s": wall,
        "ess_bulk": ess_b,
        "ess_tail": min(v["ess_tail"] for v in q if v["ess_tail"] == v["ess_tail"]),
        "r_hat": max(v["r_hat"] for v in q if v["r_hat"] is not None),
        "tau_max": s["tau_max"], "converged": s["converged"],
        "ess_per_k_evals": 1000 * ess_b / s["log_density_evals"],
    }


def main():
    ensure_venv()
    global np, pa, pq
    import numpy as np
    import pyarrow as pa
    import pyarrow.parquet as pq

    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--before")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--only")
    a = ap.parse_args()
    after = os.environ.get("SLIPBAYES", os.path.join(ROOT, "target/release/slipbayes"))
    os.makedirs(a.out, exist_ok=True)
    runs = os.path.join(a.out, "runs")
    results = []
    for label, args in models(a.out):
        if a.only and not re.search(a.only, label):
            continue
        name = re.sub(r"\W+", "-", label)
        row = {"config": label}
        if a.before:
            row["before"] = stats(*fit(a.before, args, f"{runs}/{name}-before"))
        seeds = []
        for seed in range(1, a.seeds + 1):
            run = f"{runs}/{name}-seed{seed}"
            st = stats(*fit(after, args, run, ["--seed", str(seed)]))
            st["arviz"] = arviz_check(run)
            seeds.append((run, st))
        row["after"] = [st for _, st in seeds]
        longest = max(st["steps"] for _, st in seeds)
        ref_run = f"{runs}/{name}-reference"
        ref_summary, _ = fit(after, args, ref_run, ["--seed", "1000", "--steps", str(10 * longest)])
        ref_coordinates, _ = chains(ref_run, coordinates=True)
        ref = {q["column"]: q for q in ref_summary["parameters"]}
        honest = []
        for run, st in seeds:
            summary = json.load(open(os.path.join(run, "summary.json")))
            z = max(abs(q["mean"] - ref[q["column"]]["mean"])
                    / np.hypot(q["mcse_mean"], ref[q["column"]]["mcse_mean"])
                    for q in summary["parameters"])
            honest.append({"max_z": float(z), "tau_rule": st["tau_max"]})
        # The rule's τ_max is over the sampler's coordinates: so is the reference's.
        # On the second half of the reference: a fixed-length run chooses its burn-in from
        # its own τ, and an ensemble still arriving after it would inflate τ many times.
        half = 10 * longest // 2
        tau_ref = max(pooled_tau(v[:, -half:]) for v in ref_coordinates.values())
        row["reference"] = {"steps": 10 * longest, "tau_max": float(tau_ref),
                            "tau_max_summary": ref_summary["sampler"]["tau_max"]}
        row["honesty"] = honest
        results.append(row)
        print(json.dumps(row), flush=True)
    json.dump(results, open(os.path.join(a.out, "results.json"), "w"), indent=1)
    write_tables(results, os.path.join(a.out, "stopping.md"))


def write_tables(results, path):
    f = open(path, "w")
    f.write("## Before and after (seed 1, until converged, default settings)\n\n")
    f.write("| model | build | walkers | steps | evaluations | sampling (s) | end to end (s) "
            "| τ_max | min ESS bulk / tail | max R̂ | converged | ESS bulk per 1,000 evaluations |\n")
    f.write("|---|---|---|---|---|---|---|---|---|---|---|---|\n")
    for r in results:
        for build, st in (("before", r.get("before")), ("after", r["after"][0])):
            if st is None:
                continue
            f.write(f"| {r['config']} | {build} | {st['ensembles']}×{st['walkers']} | {st['steps']:,} "
                    f"| {st['evals']:,} | {st['sampling_s']:.2f} | {st['wall_s']:.2f} | {st['tau_max']:.1f} "
                    f"| {st['ess_bulk']:,.0f} / {st['ess_tail']:,.0f} | {st['r_hat']:.4f} "
                    f"| {'yes' if st['converged'] else 'no'} | {st['ess_per_k_evals']:.1f} |\n")
        if r.get("before"):
            b, a = r["before"], r["after"][0]
            f.write(f"| {r['config']} | before / after | | {b['steps'] / a['steps']:.2f}× "
                    f"| {b['evals'] / a['evals']:.2f}× | {b['sampling_s'] / a['sampling_s']:.2f}× "
                    f"| {b['wall_s'] / a['wall_s']:.2f}× | | | | | |\n")
    f.write("\n## Every seed of this build, recomputed by ArviZ, against a long reference run\n\n")
    f.write("| model | seed | steps | evaluations | ArviZ min ESS bulk / tail | ArviZ max R̂ "
            "between ensembles | ArviZ verdict | ArviZ max R̂, walkers as chains "
            "| max \\|mean − reference\\| / MCSE | τ_max rule / reference (ratio) |\n")
    f.write("|---|---|---|---|---|---|---|---|---|---|\n")
    for r in results:
        ref = r["reference"]
        for i, (st, h) in enumerate(zip(r["after"], r["honesty"]), 1):
            z = st["arviz"]
            f.write(f"| {r['config']} | {i} | {st['steps']:,} | {st['evals']:,} "
                    f"| {z['ess_bulk']:,.0f} / {z['ess_tail']:,.0f} | {z['r_hat']:.4f} "
                    f"| {'converged' if z['converged'] else 'NOT converged'} "
                    f"| {z['r_hat_walkers']:.3f} | {h['max_z']:.2f} "
                    f"| {h['tau_rule']:.1f} / {ref['tau_max']:.1f} ({h['tau_rule'] / ref['tau_max']:.2f}) |\n")
    f.write("\nReference runs: " + "; ".join(
        f"{r['config']} {r['reference']['steps']:,} steps" for r in results) + ".\n")
    f.close()


if __name__ == "__main__":
    main()
