#!/usr/bin/env python3
"""slipbayes' ensemble sampler against emcee 3 on the same target, in the same run.

Usage (from the repository root):
    python3 benches/peer/compare_emcee.py [--walkers 32] [--steps 20000] [--reps 3]

Creates a venv under target/peer-venv (pip install emcee numpy) and re-runs itself there.
Target: a 10-D Gaussian with condition number 1e4 and strong correlations, covariance
Q diag(logspace(0, 4, 10)) Q^T with Q orthogonal from a seeded QR; its precision matrix and
the initial walkers (exact draws from the target, so no burn-in is needed) are written to
target/peer/ and read by both samplers.

- emcee: EnsembleSampler with StretchMove(a=2), one process, the usual per-walker Python
  log-probability (and, as a second row, vectorize=True with one numpy call per half).
- ours: `cargo run --release --no-default-features --example sampler_peer -- run ...`
  (stretch a = 2, rayon default threads), with 1 ensemble and with 4 ensembles.

Both chains go through ONE estimator: emcee.autocorr.integrated_time (per ensemble for
ours). ESS = steps * walkers / tau_max per ensemble, summed over ensembles. Timings are the
median of --reps runs of the sampling call alone (process start and chain I/O excluded);
tau comes from the first repetition (all repetitions use the same seed).

With --posterior-steps N (default 3000; 0 skips it) our sampler also runs the 6-D
one-contact friction posterior (benches/peer/one_contact.toml) once with parallel and once
with serial evaluation; emcee is not run there (the posterior exists only in Rust).
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
VENV = os.path.join(ROOT, "target", "peer-venv")
OUT = os.path.join(ROOT, "target", "peer")
NDIM = 10
SEED = 20240517


def ensure_venv():
    py = os.path.join(VENV, "bin", "python")
    if os.path.realpath(sys.prefix) == os.path.realpath(VENV):
        return
    if not os.path.exists(py):
        subprocess.run([sys.executable, "-m", "venv", VENV], check=True)
        subprocess.run([py, "-m", "pip", "install", "-q", "emcee", "numpy"], check=True)
    os.execv(py, [py] + sys.argv)


def write_target(walkers, ensembles):
    import numpy as np

    rng = np.random.default_rng(SEED)
    q, r = np.linalg.qr(rng.standard_normal((NDIM, NDIM)))
    q = q * np.sign(np.diag(r))  # a unique Q
    eig = np.logspace(0.0, 4.0, NDIM)
    cov = (q * eig) @ q.T
    cov = 0.5 * (cov + cov.T)
    prec = np.linalg.inv(cov)
    prec = 0.5 * (prec + prec.T)
    init = rng.multivariate_normal(np.zeros(NDIM), cov, size=walkers * ensembles)
    os.makedirs(OUT, exist_ok=True)
    paths = {
        "cov": os.path.join(OUT, "cov.txt"),
        "precision": os.path.join(OUT, "precision.txt"),
        "init": os.path.join(OUT, "init.txt"),
    }
    np.savetxt(paths["cov"], cov, fmt="%.17e")
    np.savetxt(paths["precision"], prec, fmt="%.17e")
    np.savetxt(paths["init"], init, fmt="%.17e")
    # Read back what was written so that both sides use bit-identical numbers.
    prec = np.loadtxt(paths["precision"])
    init = np.loadtxt(paths["init"])
    sd = np.sqrt(np.diag(cov))
    corr = cov / np.outer(sd, sd)
    info = {
        "condition_number": float(np.linalg.cond(cov)),
        "max_abs_correlation": float(np.max(np.abs(corr - np.eye(NDIM)))),
    }
    return paths, prec, init, info


def tau_and_ess(chains, walkers):
    """chains: list of (steps, walkers, ndim) arrays, one per ensemble."""
    import emcee

    taus = [emcee.autocorr.integrated_time(c, quiet=True) for c in chains]
    ess = sum(c.shape[0] * walkers / float(max(t)) for c, t in zip(chains, taus))
    return taus, ess


def run_emcee(prec, init, walkers, steps, vectorize):
    import emcee
    import numpy as np

    if vectorize:
        def log_prob(x):
            return -0.5 * np.einsum("ij,jk,ik->i", x, prec, x)
    else:
        def log_prob(x):
            return -0.5 * x @ prec @ x

    np.random.seed(SEED)
    sampler = emcee.EnsembleSampler(
        walkers, NDIM, log_prob, moves=emcee.moves.StretchMove(a=2.0), vectorize=vectorize
    )
    t = time.perf_counter()
    sampler.run_mcmc(init[:walkers].copy(), steps, progress=False)
    wall = time.perf_counter() - t
    return wall, sampler.get_chain(), float(np.mean(sampler.acceptance_fraction))


def run_ours(paths, walkers, steps, ensembles):
    import numpy as np

    chain_path = os.path.join(OUT, f"ours_{ensembles}.f64")
    cmd = [
        "cargo", "run", "--quiet", "--release", "--no-default-features", "--example",
        "sampler_peer", "--", "run", "--precision", paths["precision"], "--init",
        paths["init"], "--walkers", str(walkers), "--steps", str(steps), "--ensembles",
        str(ensembles), "--seed", "1", "--out", chain_path,
    ]
    res = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
    info = json.loads(res.stdout.strip().splitlines()[-1])
    chains = np.fromfile(chain_path, dtype="<f8").reshape(ensembles, steps, walkers, NDIM)
    return info, [chains[e] for e in range(ensembles)]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--walkers", type=int, default=32)
    ap.add_argument("--steps", type=int, default=20000)
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--skip-vectorized", action="store_true")
    ap.add_argument("--posterior-steps", type=int, default=3000,
                    help="steps on the 6-D one-contact friction posterior (0: skip)")
    args = ap.parse_args()
    ensure_venv()
    import emcee
    import numpy as np

    walkers, steps, reps = args.walkers, args.steps, args.reps
    paths, prec, init, target = write_target(walkers, 4)
    subprocess.run(
        ["cargo", "build", "--quiet", "--release", "--no-default-features", "--example",
         "sampler_peer"], cwd=ROOT, check=True)
    load = os.getloadavg()
    rows = []

    variants = [("emcee (per-walker log_prob)", False)]
    if not args.skip_vectorized:
        variants.append(("emcee (vectorize=True)", True))
    for label, vec in variants:
        walls, first = [], None
        for _ in range(reps):
            wall, chain, acc = run_emcee(prec, init, walkers, steps, vec)
            walls.append(wall)
            if first is None:
                first = (chain, acc)
        taus, ess = tau_and_ess([first[0]], walkers)
        rows.append(dict(name=label, ensembles=1, wall=statistics.median(walls),
                         walls=walls, report=0.0, tau=[t.tolist() for t in taus],
                         tau_max=max(max(t) for t in taus), ess=ess, acceptance=first[1],
                         evals=walkers * steps, threads="1 (one Python process)"))

    for ens in (1, 4):
        walls, reports, first = [], [], None
        for _ in range(reps):
            info, chains = run_ours(paths, walkers, steps, ens)
            walls.append(info["wall_s"])
            reports.append(info["report_s"])
            if first is None:
                first = (info, chains)
        taus, ess = tau_and_ess(first[1], walkers)
        rows.append(dict(name=f"slipbayes, {ens} ensemble{'s' if ens > 1 else ''}",
                         ensembles=ens, wall=statistics.median(walls), walls=walls,
                         report=statistics.median(reports),
                         tau=[t.tolist() for t in taus],
                         tau_max=max(max(t) for t in taus), ess=ess,
                         acceptance=first[0]["acceptance"], evals=first[0]["evaluations"],
                         threads=f"{first[0]['threads']} (rayon default)"))

    base = rows[0]
    print(f"load average at start: {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}; "
          f"emcee {emcee.__version__}, numpy {np.__version__}; target: 10-D Gaussian, "
          f"condition number {target['condition_number']:.3g}, max |correlation| "
          f"{target['max_abs_correlation']:.3f}; {walkers} walkers, {steps} steps, "
          f"median of {reps} runs")
    print()
    print("| sampler | threads | wall time (s) | of which end-of-run report (s) | steps/s | "
          "log-density evals/s | acceptance | τ_max (steps) | ESS = N/τ_max | ESS/s | "
          "ESS/s ours/emcee |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        ess_s = r["ess"] / r["wall"]
        print(f"| {r['name']} | {r['threads']} | {r['wall']:.3f} | {r['report']:.3f} | "
              f"{steps / r['wall']:.4g} | {r['evals'] / r['wall']:.4g} | "
              f"{r['acceptance']:.3f} | {r['tau_max']:.1f} | {r['ess']:.0f} | {ess_s:.4g} | "
              f"{ess_s / (base['ess'] / base['wall']):.3g} |")
    post_rows = []
    if args.posterior_steps > 0:
        ps = args.posterior_steps
        for parallel in ("true", "false"):
            chain_path = os.path.join(OUT, f"posterior_{parallel}.f64")
            cmd = ["cargo", "run", "--quiet", "--release", "--no-default-features",
                   "--example", "sampler_peer", "--", "posterior", "--walkers", str(walkers),
                   "--steps", str(ps), "--parallel", parallel, "--out", chain_path]
            res = subprocess.run(cmd, cwd=ROOT, check=True, capture_output=True, text=True)
            info = json.loads(res.stdout.strip().splitlines()[-1])
            chain = np.fromfile(chain_path, dtype="<f8").reshape(ps, walkers, info["ndim"])
            taus, ess = tau_and_ess([chain], walkers)
            info.update(tau=taus[0].tolist(), tau_max=float(max(taus[0])), ess=ess)
            post_rows.append(info)
        print()
        print(f"6-D one-contact friction posterior (benches/peer/one_contact.toml), ours only, "
              f"{walkers} walkers, {ps} steps, stretch a = 2, one run each:")
        print()
        print("| evaluation | threads | wall time (s) | steps/s | log-density evals/s | "
              "acceptance | τ_max (steps) | steps / τ_max | ESS = N/τ_max | ESS/s |")
        print("|---|---|---:|---:|---:|---:|---:|---:|---:|---:|")
        for r in post_rows:
            print(f"| {'parallel' if r['parallel'] else 'serial'} | {r['threads']} | "
                  f"{r['wall_s']:.2f} | {ps / r['wall_s']:.4g} | "
                  f"{r['evaluations'] / r['wall_s']:.4g} | {r['acceptance']:.3f} | "
                  f"{r['tau_max']:.1f} | {ps / r['tau_max']:.0f} | {r['ess']:.0f} | "
                  f"{r['ess'] / r['wall_s']:.4g} |")
    with open(os.path.join(OUT, "results.json"), "w") as f:
        json.dump(dict(load=load, target=target, walkers=walkers, steps=steps, reps=reps,
                       rows=rows, posterior=post_rows), f, indent=1)


if __name__ == "__main__":
    main()
