#!/usr/bin/env bash
# reports/moves.md: τ, ESS, R̂ and wall time of fixed-length fits of
# five posteriors under several moves and updates, all on this machine in one sequential run
# (so the wall times are comparable; nothing else should run meanwhile).
#
#   bash benches/moves_and_blocks.sh OUT_DIR [PATTERN]   # from the repository root, ~17 min idle
#
# With PATTERN (an extended regular expression) only the rows whose "posterior | updates,
# moves" label matches are run, e.g. `hierarchical`. The hard case of `slipbayes validate
# --hard` (peak beyond the record) runs only when PATTERN matches its label "hard case | …".
# Needs target/release/slipbayes (cargo build --release; or the binary in $SLIPBAYES) and python3. Writes OUT_DIR/table.md.
# ESS and R̂ are read from each fit's summary.json by benches/run_stats.py: every post-burn-in
# draw, every reported quantity (parameters and derived), as ArviZ computes them.
set -euo pipefail
out=${1:?usage: bash benches/moves_and_blocks.sh OUT_DIR [PATTERN]}
only=${2:-}
root=$(pwd)
bin=${SLIPBAYES:-$root/target/release/slipbayes}
mkdir -p "$out/models" "$out/runs"
# The demo and its variants, with absolute data paths.
demo() { sed "s#\.\./data/#$root/data/#" models/demo.toml; }
# Each model also with one block per material (the default before hierarchical updates).
blocks() { sed "s/^\[sampler\]$/[sampler]\nblocks = \"$1\"/"; }
demo > "$out/models/demo.toml"
demo | blocks material > "$out/models/demo-material.toml"
demo | blocks contact > "$out/models/demo-contact.toml"
{ echo 'aging = "absolute"'; demo; } > "$out/models/absolute.toml"
{ echo 'aging = "absolute"'; demo | blocks material; } > "$out/models/absolute-material.toml"
{ demo; printf '\n[pooling]\nt0 = true\n'; } > "$out/models/pooled.toml"
{ demo | blocks material; printf '\n[pooling]\nt0 = true\n'; } > "$out/models/pooled-material.toml"
python3 data/make_campaign.py --contacts 10 --out "$out/campaign" > /dev/null
cp "$out/campaign/campaign.toml" "$out/campaign/campaign-contact.toml"
printf '\n[sampler]\nblocks = "contact"\n' >> "$out/campaign/campaign-contact.toml"
one_contact=(--first data/ptfe-c1-first.csv --repeat data/ptfe-c1-repeat.csv --velocity 1e-9)

echo "| posterior | updates, moves | walkers | steps | τ_max | min ESS bulk | min ESS tail | max R̂ | evaluations | wall (s) | ESS per 1,000 evaluations | ESS per s |" > "$out/table.md"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|" >> "$out/table.md"
row() { # label, description, steps, then fit arguments
  local label=$1 what=$2 steps=$3; shift 3
  if [ -n "$only" ] && ! echo "$label | $what" | grep -Eq "$only"; then return; fi
  local dir="$out/runs/$label-$(echo "$what" | tr ' ,=/' '____')"
  "$bin" fit "$@" --steps "$steps" --quiet --out "$dir" --overwrite > "$dir.log" 2>&1 || true
  python3 benches/run_stats.py "$dir" "| $label | $what | {walkers} | {steps} | {tau_max:.1f} \
| {ess_bulk_min:,.0f} | {ess_tail_min:,.0f} | {r_hat_max:.4f} | {evals:,} | {wall_s:.1f} \
| {ess_per_k_evals:.2f} | {ess_per_s:.1f} |" \
    >> "$out/table.md"
  tail -1 "$out/table.md"
}
m="$out/models"
c="$out/campaign"
# The moves of `slipbayes fit`'s defaults (slipbayes::fit::default_moves), which a row without
# --moves runs: its label must name them.
dm="student-t=0.9,de=0.1"
row "one contact" "joint, stretch" 2000 "${one_contact[@]}" --updates joint --moves stretch=1
row "one contact" "joint, student-t=0.9,stretch=0.1" 2000 "${one_contact[@]}" --updates joint --moves student-t=0.9,stretch=0.1
row "one contact" "joint, de" 2000 "${one_contact[@]}" --updates joint --moves de=1
row "one contact" "joint, $dm (default)" 2000 "${one_contact[@]}"
row demo "joint, stretch" 1000 "$m/demo.toml" --updates joint --moves stretch=1 --walkers 38
row demo "contact blocks, student-t=0.9,stretch=0.1" 1000 "$m/demo-contact.toml" --updates blocked --moves student-t=0.9,stretch=0.1 --walkers 40
row demo "material blocks, stretch" 1000 "$m/demo-material.toml" --updates blocked --moves stretch=1 --walkers 40
row demo "material blocks, student-t=0.9,stretch=0.1" 1000 "$m/demo-material.toml" --updates blocked --moves student-t=0.9,stretch=0.1 --walkers 40
row demo "material blocks (previous default), $dm" 1000 "$m/demo-material.toml" --updates blocked
row demo "hierarchical, $dm (default)" 1000 "$m/demo.toml"
row absolute "joint, stretch" 1000 "$m/absolute.toml" --updates joint --moves stretch=1 --walkers 38
row absolute "material blocks (previous default), $dm" 1000 "$m/absolute-material.toml" --updates blocked
row absolute "hierarchical, $dm (default)" 1000 "$m/absolute.toml"
row pooled "joint, stretch" 1000 "$m/pooled.toml" --updates joint --moves stretch=1 --walkers 46
row pooled "material blocks (previous default), $dm" 1000 "$m/pooled-material.toml" --updates blocked
row pooled "hierarchical, $dm (default)" 1000 "$m/pooled.toml"
row campaign "joint, stretch" 1000 "$c/campaign.toml" --updates joint --moves stretch=1 --walkers 68
row campaign "joint, student-t=0.9,stretch=0.1" 1000 "$c/campaign.toml" --updates joint --moves student-t=0.9,stretch=0.1 --walkers 68
row campaign "contact blocks, $dm" 1000 "$c/campaign-contact.toml" --updates blocked --walkers 68
row campaign "joint, de" 1000 "$c/campaign.toml" --updates joint --moves de=1 --walkers 68
row campaign "joint, $dm" 1000 "$c/campaign.toml" --updates joint --walkers 68
row campaign "joint (previous default, 132 walkers), $dm" 1000 "$c/campaign.toml" --updates joint --walkers 132
row campaign "hierarchical, $dm (default)" 1000 "$c/campaign.toml"
row campaign "hierarchical, $dm, 64 walkers" 1000 "$c/campaign.toml" --walkers 64
# The KDE and DE-snooker moves against the default on every posterior (run alone with
# PATTERN "kde|snooker|\(default\)").
row "one contact" "joint, kde" 2000 "${one_contact[@]}" --moves kde=1
row "one contact" "joint, snooker" 2000 "${one_contact[@]}" --moves snooker=1
row demo "hierarchical, kde=0.5,de=0.5" 1000 "$m/demo.toml" --moves kde=0.5,de=0.5
row demo "hierarchical, student-t=0.5,snooker=0.5" 1000 "$m/demo.toml" --moves student-t=0.5,snooker=0.5
row absolute "hierarchical, kde=0.5,de=0.5" 1000 "$m/absolute.toml" --moves kde=0.5,de=0.5
row pooled "hierarchical, kde=0.5,de=0.5" 1000 "$m/pooled.toml" --moves kde=0.5,de=0.5
row pooled "hierarchical, student-t=0.5,snooker=0.5" 1000 "$m/pooled.toml" --moves student-t=0.5,snooker=0.5
row campaign "hierarchical, kde=0.5,de=0.5" 1000 "$c/campaign.toml" --moves kde=0.5,de=0.5
row campaign "hierarchical, student-t=0.5,snooker=0.5" 1000 "$c/campaign.toml" --moves student-t=0.5,snooker=0.5
# Ensemble slice sampling (zeus) alone and mixed into the default, against the default, on
# every posterior and the hard case (run alone with PATTERN "slice": 87 min on 2026-11-25 on
# this machine while it was shared, load 2-9). Shorter than the rows above: the slice move
# alone costs about five evaluations
# per walker and block update, so 200 of its steps cost about what 1,000 of the default do;
# every row is longer than the 50 steps of the slice move's tuning plus 15 τ.
d="$dm (default, slice comparison)"
mix="student-t=0.4,de=0.4,slice=0.2"
row "one contact" "joint, $d" 1000 "${one_contact[@]}"
row "one contact" "joint, slice" 500 "${one_contact[@]}" --moves slice=1
row "one contact" "joint, $mix" 1000 "${one_contact[@]}" --moves $mix
for p in demo absolute pooled; do
  row $p "hierarchical, $d" 400 "$m/$p.toml"
  row $p "hierarchical, slice" 200 "$m/$p.toml" --moves slice=1
  row $p "hierarchical, $mix" 400 "$m/$p.toml" --moves $mix
done
row campaign "hierarchical, $d" 400 "$c/campaign.toml"
row campaign "hierarchical, slice" 200 "$c/campaign.toml" --moves slice=1
row campaign "hierarchical, $mix" 400 "$c/campaign.toml" --moves $mix
# The hard case where the default mixes slowest: `validate --hard` fits it
# until converged, here capped at 5,000 steps, 4
# ensembles × 32 walkers; its figures come from the fit's summary.json like the rows above.
hard() { # description, then validate arguments
  local what=$1; shift
  if [ -z "$only" ] || ! echo "hard case | $what" | grep -Eq "$only"; then return; fi
  local dir="$out/runs/hard-$(echo "$what" | tr ' ,=/()' '______')"
  "$bin" validate --hard --case peak-beyond-record --max-steps 5000 --out "$dir" --quiet "$@" \
    > "$dir.log" 2>&1 || true
  python3 benches/run_stats.py "$dir/hard/peak-beyond-record/fit" "| hard case | $what | {walkers} \
| {steps} | {tau_max:.1f} | {ess_bulk_min:,.0f} | {ess_tail_min:,.0f} | {r_hat_max:.4f} | {evals:,} \
| {wall_s:.1f} | {ess_per_k_evals:.2f} | {ess_per_s:.1f} |" >> "$out/table.md"
  tail -1 "$out/table.md"
}
hard "joint, $d"
hard "joint, slice" --moves slice=1
hard "joint, $mix" --moves $mix
