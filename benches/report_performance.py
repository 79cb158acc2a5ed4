#!/usr/bin/env python3
"""Turn criterion's estimates for `cargo bench --bench law` into a markdown table.

Usage: python3 benches/report_performance.py [target/criterion]
Prints nanoseconds per point (median of criterion's estimate) and the ratio to the exp floor
measured in the same run.
"""
import json
import os
import sys

root = sys.argv[1] if len(sys.argv) > 1 else os.path.join("target", "criterion")
POINTS = 5000
rows = [
    ("exp_floor", "one f64::exp per point (floor)", None),
    ("scaled_ei", "S(x) = e^-x Ei(x) per call", 10.0),
    ("law_force", "F(tau) per point (scalar)", None),
    ("observed_model", "observed-time model per point (5,000-point slow first slide)", 2.0),
    ("observed_model_serial", "observed-time model, serial reference solve", None),
    ("rate_state_aging", "rate-and-state spring-slider, aging law (Radau5, tol 1e-13)", None),
    ("rate_state_slip", "rate-and-state spring-slider, slip law (Radau5, tol 1e-13)", None),
    ("rate_state_aging_fit", "rate-and-state as a fit's likelihood solves it, aging law (tol 1e-7)", None),
    ("rate_state_slip_fit", "rate-and-state as a fit's likelihood solves it, slip law (tol 1e-7)", None),
]
# Per instruction set the machine has (criterion leaves the others out).
for simd in ("avx512", "avx2", "baseline"):
    rows.append((f"observed_model_{simd}", f"observed-time model in lanes, {simd}", 2.0))
    rows.append((f"law_lanes_{simd}", f"F(t) in lanes (no elastic correction), {simd}", 1.5))


def median_ns(name):
    path = os.path.join(root, "per_point", name, "new", "estimates.json")
    with open(path) as f:
        est = json.load(f)
    return est["median"]["point_estimate"] / POINTS


floor = median_ns("exp_floor")
print("| benchmark | ns per point | ratio to exp floor | target |")
print("|---|---:|---:|---:|")
for name, label, target in rows:
    try:
        ns = median_ns(name)
    except FileNotFoundError:
        continue
    t = f"<= {target:g}x" if target else ""
    print(f"| {label} | {ns:.2f} | {ns / floor:.2f} | {t} |")
