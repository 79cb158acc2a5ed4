#!/usr/bin/env bash
# reports/campaigns.md: one-material campaigns of N contacts (first + repeat
# slide each, made by data/make_campaign.py through `slipbayes simulate`), each fitted with the
# default settings until converged by the strict standard; contacts, dimensions, τ_max (in
# steps, i.e. sweeps: one step updates every block once), steps, evaluations, wall time and
# peak RSS of the whole command. One fit after the other, nothing else should run meanwhile.
#
#   bash benches/campaign_scaling.sh OUT_DIR [N ...]   # default N: 2 5 10 20
#
# With PREVIOUS=1 each campaign is also fitted, right after, with the previous default (one
# block per material, blocked updates): the rows marked "previous default".
# Needs target/release/slipbayes (cargo build --release), python3 and GNU time
# (/usr/bin/time). Writes OUT_DIR/table.md.
set -euo pipefail
out=${1:?usage: bash benches/campaign_scaling.sh OUT_DIR [N ...]}
shift
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(2 5 10 20)
root=$(pwd)
bin=$root/target/release/slipbayes
mkdir -p "$out"
{
  echo "| contacts | dimensions | walkers | steps | τ_max (sweeps) | min ESS bulk | max R̂ | converged | evaluations | wall (s) | peak RSS (MB) |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
} > "$out/table.md"
fit() { # label, run dir, model, fit arguments...
  local label=$1 dir=$2 model=$3; shift 3
  /usr/bin/time -f "%e %M" -o "$dir.time" \
    "$bin" fit "$model" "$@" --quiet --out "$dir" --overwrite > "$dir.log" 2>&1 || true
  read -r wall rss_kb < "$dir.time"
  python3 benches/run_stats.py "$dir" "| $label | {dimension} | {walkers} | {steps:,} | {tau_max:.1f} \
| {ess_bulk_min:,.0f} | {r_hat_max:.4f} | {converged} | {evals:,} | $wall | $((rss_kb / 1024)) |" \
    >> "$out/table.md"
  tail -1 "$out/table.md"
}
for n in "${sizes[@]}"; do
  c="$out/c$n"
  python3 data/make_campaign.py --contacts "$n" --out "$c" --binary "$bin" > /dev/null
  fit "$n" "$c/run" "$c/campaign.toml"
  if [ "${PREVIOUS:-0}" = 1 ]; then
    { cat "$c/campaign.toml"; printf '\n[sampler]\nblocks = "material"\n'; } > "$c/material.toml"
    fit "$n (previous default)" "$c/run-material" "$c/material.toml" --updates blocked
  fi
done
