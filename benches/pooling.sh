#!/usr/bin/env bash
# Issue 20's pooling targets, side by side in one sequential run on this machine: each fit with
# the default settings until converged by the strict standard (τ trusted and settled, R̂), its wall
# time and peak RSS (nothing else should run meanwhile):
# - the demo (models/demo.toml) without pooling, with `[pooling] t0 = true`, and under
#   `aging = "absolute"` without and with t0 pooled;
# - a 10-contact one-material campaign (data/make_campaign.py) without pooling, with t0
#   pooled, and with t0 and F_d pooled;
# - the pooled demo with both population updates in every step (`[sampler] populations =
#   "interwoven"`, the default being "auto") and with each alone (`"exact"`, `"carried"`; the
#   latter capped at 2,000 steps).
#
#   bash benches/pooling.sh OUT_DIR [PATTERN]   # from the repository root, ~22 min on 2 cores
#
# With PATTERN (an extended regular expression) only the rows whose label matches are run.
#
# Needs target/release/slipbayes (or the binary in $SLIPBAYES), python3 and GNU time
# (/usr/bin/time). Writes OUT_DIR/table.md; ESS and R̂ from each fit's summary.json by
# benches/run_stats.py (every post-burn-in draw, every reported quantity).
set -euo pipefail
out=${1:?usage: bash benches/pooling.sh OUT_DIR [PATTERN]}
only=${2:-}
root=$(pwd)
bin=${SLIPBAYES:-$root/target/release/slipbayes}
mkdir -p "$out/models" "$out/runs"
. "$root/benches/demo_forms.sh"
write_demo_forms "$out" "$root"
for how in exact carried interwoven; do
  sed "s/^\[sampler\]$/[sampler]\npopulations = \"$how\"/" "$out/models/pooled.toml" > "$out/models/pooled-$how.toml"
done
python3 data/make_campaign.py --contacts 10 --out "$out/campaign" --binary "$bin" > /dev/null
c="$out/campaign"
{ cat "$c/campaign.toml"; printf '\n[pooling]\nt0 = true\n'; } > "$c/pooled-t0.toml"
{ cat "$c/campaign.toml"; printf '\n[pooling]\nt0 = true\nF_d = true\n'; } > "$c/pooled-t0-fd.toml"
{
  echo "| posterior | dimensions | walkers | steps | τ_max (steps) | min ESS bulk | max R̂ | converged | evaluations | wall (s) | peak RSS (MB) |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
} > "$out/table.md"
fit() { # label, model, fit arguments...
  local label=$1 model=$2
  shift 2
  if [ -n "$only" ] && ! echo "$label" | grep -Eq "$only"; then return; fi
  local dir="$out/runs/$(echo "$label" | tr ' ,=/+' '_____')"
  /usr/bin/time -f "%e %M" -o "$dir.time" \
    "$bin" fit "$model" "$@" --quiet --out "$dir" --overwrite > "$dir.log" 2>&1 || true
  read -r wall rss_kb < "$dir.time"
  python3 benches/run_stats.py "$dir" "| $label | {dimension} | {walkers} | {steps:,} | {tau_max:.1f} \
| {ess_bulk_min:,.0f} | {r_hat_max:.4f} | {converged} | {evals:,} | $wall | $((rss_kb / 1024)) |" \
    >> "$out/table.md"
  tail -1 "$out/table.md"
}
fit "demo" "$out/models/demo.toml"
fit "demo, t0 pooled" "$out/models/pooled.toml"
fit "demo, absolute" "$out/models/absolute.toml"
fit "demo, absolute, t0 pooled" "$out/models/absolute-pooled.toml"
fit "10 contacts" "$c/campaign.toml"
fit "10 contacts, t0 pooled" "$c/pooled-t0.toml"
fit "10 contacts, t0 and F_d pooled" "$c/pooled-t0-fd.toml"
fit "demo, t0 pooled, interwoven every step" "$out/models/pooled-interwoven.toml"
fit "demo, t0 pooled, exact draws alone" "$out/models/pooled-exact.toml"
fit "demo, t0 pooled, carried moves alone" "$out/models/pooled-carried.toml" --max-steps 2000
