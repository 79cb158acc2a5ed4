#!/usr/bin/env bash
# Before/after timings of the demo, alternated in one run so that the machine's state is
# shared: the demo with its default settings (hierarchical updates, student-t=0.5,de=0.5, run
# until converged), with the previous default (one block per material, blocked updates, run
# until converged) against the settings the demo had before issue 13 (joint updates, stretch move,
# 38 walkers, 1,000 fixed steps); and the one-contact quick path run until converged with the
# default moves against the stretch move.
#
#   bash benches/demo_side_by_side.sh OUT_DIR    # from the repository root, ~20 min on 2 cores
set -euo pipefail
out=${1:?usage: bash benches/demo_side_by_side.sh OUT_DIR}
bin=$(pwd)/target/release/slipbayes
mkdir -p "$out"
# The demo with one block per material (data paths made absolute: the model lives in OUT_DIR).
sed "s#\.\./data/#$(pwd)/data/#; s/^\[sampler\]$/[sampler]\nblocks = \"material\"/" \
  models/demo.toml > "$out/demo-material.toml"
one_contact=(--first data/ptfe-c1-first.csv --repeat data/ptfe-c1-repeat.csv --velocity 1e-9)
report() { # label, run dir, total seconds
  python3 benches/run_stats.py "$2" "$1: {steps} steps ({stopped_by}), converged {converged}, \
τ_max {tau_max:.1f}, min ESS bulk {ess_bulk_min:.0f}, tail {ess_tail_min:.0f}, \
max R̂ {r_hat_max:.4f}, {low_ess} of {quantities} with ESS bulk ≤ 400, fit {wall_s:.1f} s, \
command $(printf %.1f "$3") s"
}
timed() { # label, run dir, command...
  local label=$1 dir=$2; shift 2
  local t0=$(date +%s.%N)
  "$@" > "$dir.log" 2>&1 || true
  local t1=$(date +%s.%N)
  report "$label" "$dir" "$(echo "$t1 - $t0" | bc)"
}
for round in 1 2; do
  timed "demo, defaults (round $round)" "$out/demo-new-$round" \
    "$bin" demo --quiet --out "$out/demo-new-$round"
  timed "demo, previous default: material blocks (round $round)" "$out/demo-material-$round" \
    "$bin" fit "$out/demo-material.toml" --updates blocked --quiet \
    --out "$out/demo-material-$round" --overwrite
  timed "demo, settings before issue 13 (round $round)" "$out/demo-old-$round" \
    "$bin" fit models/demo.toml --updates joint --moves stretch=1 --walkers 38 --steps 1000 \
    --quiet --out "$out/demo-old-$round" --overwrite
  timed "one contact until converged, defaults (round $round)" "$out/one-new-$round" \
    "$bin" fit "${one_contact[@]}" --quiet --out "$out/one-new-$round" --overwrite
  timed "one contact until converged, stretch (round $round)" "$out/one-old-$round" \
    "$bin" fit "${one_contact[@]}" --moves stretch=1 --quiet --out "$out/one-old-$round" --overwrite
done
