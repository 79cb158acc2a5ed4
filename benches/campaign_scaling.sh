#!/usr/bin/env bash
# The README's campaign scaling table: one-material campaigns of N contacts (first + repeat
# slide each, made by data/make_campaign.py through `slipbayes simulate`), each fitted with the
# default settings until converged by the strict standard; contacts, dimensions, τ_max (in
# steps, i.e. sweeps: one step updates every block once), steps, evaluations, wall time and
# peak RSS of the whole command. One fit after the other, nothing else should run meanwhile.
#
#   bash benches/campaign_scaling.sh OUT_DIR [N ...]   # default N: 2 5 10 20
#
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
for n in "${sizes[@]}"; do
  c="$out/c$n"
  python3 data/make_campaign.py --contacts "$n" --out "$c" --binary "$bin" > /dev/null
  /usr/bin/time -f "%e %M" -o "$c/time.txt" \
    "$bin" fit "$c/campaign.toml" --quiet --out "$c/run" --overwrite > "$c/fit.log" 2>&1 || true
  read -r wall rss_kb < "$c/time.txt"
  python3 benches/run_stats.py "$c/run" "| $n | {dimension} | {walkers} | {steps:,} | {tau_max:.1f} \
| {ess_bulk_min:,.0f} | {r_hat_max:.4f} | {converged} | {evals:,} | $wall | $((rss_kb / 1024)) |" \
    >> "$out/table.md"
  tail -1 "$out/table.md"
done
