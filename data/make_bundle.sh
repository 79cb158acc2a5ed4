#!/usr/bin/env bash
# Regenerates the bundled synthetic data set with `slipbayes simulate`.
# Run from the repository root: bash data/make_bundle.sh
# Every CSV gets a JSON of its true values beside it. All values SI (N, s, m/s, 1/m, N/m).
set -euo pipefail
cargo build --release --quiet
sim() { ./target/release/slipbayes simulate "$@"; }

# PTFE on glass: alpha and a/F_d near the paper's Fig. 2 fit (0.92 1/um, 0.62); F_d, k, sigma,
# F_N are not given by the paper and are plausible choices (docs/model.md §7).
# Contact 1: first slide at 1 nm/s (t0 = 14.8 s as in Fig. 2), repeat slide, and a fast 4 um/s
# slide declared stiff after re-aging the contact (t0 = 4 ms).
sim --scene first  --alpha 0.92e6 --a 6.2e-3 --f-d 10e-3 --t0 14.8 --k 1.2e4 --velocity 1e-9 \
    --duration 30000 --interval 10 --sigma 1e-4 --normal-force 0.05 --normal-sigma 2e-4 \
    --seed 101 --out data/ptfe-c1-first.csv
sim --scene repeat --alpha 0.92e6 --a 6.2e-3 --f-d 10e-3 --t0 14.8 --k 1.2e4 --velocity 1e-9 \
    --after-first 30000 --duration 2500 --interval 1 --sigma 1e-4 --normal-force 0.05 \
    --normal-sigma 2e-4 --seed 102 --out data/ptfe-c1-repeat.csv
sim --scene stiff-fast --alpha 0.92e6 --a 6.2e-3 --f-d 10e-3 --t0 4e-3 --velocity 4e-6 \
    --duration 10 --interval 0.002 --sigma 1e-4 --normal-force 0.05 --normal-sigma 2e-4 \
    --seed 103 --out data/ptfe-c1-fast.csv
# Contact 2: another placement of the same sphere: different F_d, k and t0.
sim --scene first  --alpha 0.92e6 --a 7.13e-3 --f-d 11.5e-3 --t0 9.0 --k 0.9e4 --velocity 1e-9 \
    --duration 30000 --interval 10 --sigma 1e-4 --normal-force 0.055 --normal-sigma 2e-4 \
    --seed 201 --out data/ptfe-c2-first.csv
sim --scene repeat --alpha 0.92e6 --a 7.13e-3 --f-d 11.5e-3 --t0 9.0 --k 0.9e4 --velocity 1e-9 \
    --after-first 30000 --duration 2500 --interval 1 --sigma 1e-4 --normal-force 0.055 \
    --normal-sigma 2e-4 --seed 202 --out data/ptfe-c2-repeat.csv

# Polypropylene on glass: the paper gives no PP parameters; these are synthetic and chosen
# plausibly different from PTFE (faster rejuvenation, weaker aging, lower F_d). No normal force.
sim --scene first  --alpha 1.5e6 --a 3.2e-3 --f-d 8e-3 --t0 30 --k 1.0e4 --velocity 1e-9 \
    --duration 30000 --interval 10 --sigma 1e-4 --seed 301 --out data/pp-c1-first.csv
sim --scene repeat --alpha 1.5e6 --a 3.2e-3 --f-d 8e-3 --t0 30 --k 1.0e4 --velocity 1e-9 \
    --after-first 30000 --duration 2500 --interval 1 --sigma 1e-4 --seed 302 \
    --out data/pp-c1-repeat.csv
sim --scene first  --alpha 1.5e6 --a 2.88e-3 --f-d 7.2e-3 --t0 20 --k 1.1e4 --velocity 1e-9 \
    --duration 30000 --interval 10 --sigma 1e-4 --seed 401 --out data/pp-c2-first.csv
sim --scene repeat --alpha 1.5e6 --a 2.88e-3 --f-d 7.2e-3 --t0 20 --k 1.1e4 --velocity 1e-9 \
    --after-first 30000 --duration 2500 --interval 1 --sigma 1e-4 --seed 402 \
    --out data/pp-c2-repeat.csv
