#!/usr/bin/env python3
"""Per-walker-step figures from `cargo bench --bench sampler` (criterion's median estimates).

Usage (from the repository root):
    python3 benches/peer/report_overhead.py            # table of the last bench run, and
                                                       # append it to target/peer/overhead_runs.jsonl
    python3 benches/peer/report_overhead.py --summary  # medians over all appended runs

Ratios: (run_serial - run_end - density) / floor (a 20,000-step run without its end-of-run
work) and (2 run_serial_long - run_serial - density) / floor (the marginal step of a long run).
"""
import json
import os
import statistics
import sys

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), "..", ".."))
CRIT = os.path.join(ROOT, "target", "criterion")
LOG = os.path.join(ROOT, "target", "peer", "overhead_runs.jsonl")
WALKERS, STEPS, MEDIUM_STEPS = 32, 20_000, 1000
ELEMENTS = {  # walker-steps per iteration
    ("sampler", "floor"): STEPS * WALKERS,
    ("sampler", "density"): 2 * STEPS * WALKERS,
    ("sampler", "run_serial"): STEPS * WALKERS,
    ("sampler", "run_parallel"): STEPS * WALKERS,
    ("sampler", "run_serial_long"): 2 * STEPS * WALKERS,
    ("sampler", "run_serial_4ens"): 4 * STEPS * WALKERS,
    ("sampler", "run_parallel_4ens"): 4 * STEPS * WALKERS,
    ("sampler", "run_end"): STEPS * WALKERS,
    ("sampler_medium", "density"): 512 * WALKERS,
    ("sampler_medium", "run_serial_4ens"): 4 * MEDIUM_STEPS * WALKERS,
    ("sampler_medium", "run_parallel_4ens"): 4 * MEDIUM_STEPS * WALKERS,
}


def snapshot():
    out = {}
    for (group, name), n in ELEMENTS.items():
        path = os.path.join(CRIT, group, name, "new", "estimates.json")
        with open(path) as f:
            out[f"{group}/{name}"] = json.load(f)["median"]["point_estimate"] / n
    return out


def derived(ns):
    d = dict(ns)
    floor, dens = ns["sampler/floor"], ns["sampler/density"]
    d["ratio_run"] = (ns["sampler/run_serial"] - ns["sampler/run_end"] - dens) / floor
    marginal = 2 * ns["sampler/run_serial_long"] - ns["sampler/run_serial"]
    d["marginal"] = marginal
    d["ratio_marginal"] = (marginal - dens) / floor
    d["medium_speedup"] = (ns["sampler_medium/run_serial_4ens"]
                           / ns["sampler_medium/run_parallel_4ens"])
    return d


def table(d):
    rows = [
        ("floor: split, partner, z, proposal, acceptance uniform", "sampler/floor"),
        ("density: one call of the 10-D standard normal", "sampler/density"),
        ("run, serial, 1 ensemble (20,000 steps, everything)", "sampler/run_serial"),
        ("run, parallel allowed, 1 ensemble", "sampler/run_parallel"),
        ("run, serial, 1 ensemble, 40,000 steps", "sampler/run_serial_long"),
        ("end-of-run work (checkpoint, τ report) per step of the 20,000", "sampler/run_end"),
        ("marginal step of a long run: 2·(40,000) − (20,000)", "marginal"),
        ("run, serial, 4 ensembles (incl. end-of-run τ and R̂)", "sampler/run_serial_4ens"),
        ("run, parallel allowed, 4 ensembles", "sampler/run_parallel_4ens"),
        ("medium density (800 logarithms): one call", "sampler_medium/density"),
        ("medium density: run, serial, 4 ensembles", "sampler_medium/run_serial_4ens"),
        ("medium density: run, parallel, 4 ensembles", "sampler_medium/run_parallel_4ens"),
    ]
    print("| benchmark | ns per walker-step |")
    print("|---|---:|")
    for label, key in rows:
        print(f"| {label} | {d[key]:.1f} |")
    print()
    print(f"(run − end − density) / floor = {d['ratio_run']:.2f}; "
          f"(marginal − density) / floor = {d['ratio_marginal']:.2f}; "
          f"medium density parallel speed-up = {d['medium_speedup']:.2f}")


def main():
    if "--summary" in sys.argv:
        with open(LOG) as f:
            runs = [json.loads(line) for line in f if line.strip()]
        ds = [derived(r["ns"]) for r in runs]
        med = {k: statistics.median(d[k] for d in ds) for k in ds[0]}
        print(f"median over {len(ds)} bench runs; load averages at the runs: "
              + "; ".join(r["load"] for r in runs))
        print()
        table(med)
        print()
        print("per run: ratio_run " + ", ".join(f"{d['ratio_run']:.2f}" for d in ds)
              + "; ratio_marginal " + ", ".join(f"{d['ratio_marginal']:.2f}" for d in ds))
        return
    ns = snapshot()
    load = " ".join(f"{x:.2f}" for x in os.getloadavg())
    os.makedirs(os.path.dirname(LOG), exist_ok=True)
    with open(LOG, "a") as f:
        f.write(json.dumps(dict(load=load, ns=ns)) + "\n")
    print(f"load average at the end of the run: {load}")
    # A table must follow a blank line, or Markdown reads it as the paragraph's text.
    print()
    table(derived(ns))


if __name__ == "__main__":
    main()
