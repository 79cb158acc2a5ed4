#!/usr/bin/env bash
# How a shared block's followers are carried under hierarchical updates (`[sampler] carry`):
# by a regression fitted to the complementary half at every half-step ("complement", walkers
# max(32, 2f + 4) by default) or tuned on the ensemble's own draws of the first 100 steps and
# then frozen ("tuned", 32 walkers), on every kind of posterior a model file allows: the demo,
# its absolute-aging and t0-pooled forms, one-material campaigns of 3 to 20 contacts, pooled
# campaigns, and the pooled SBC model at the 16 walkers `validate` uses. Each fit runs until
# converged by the strict standard with the default settings but `--carry`; the table gives
# steps, τ_max, the lowest ESS bulk over every reported quantity, evaluations, ESS per 1,000
# evaluations (the efficiency that does not depend on the machine's load) and the wall time.
#
#   bash benches/carry.sh OUT_DIR [PATTERN]   # from the repository root
#
# With PATTERN (an extended regular expression) only the rows whose label matches are run.
# Needs target/release/slipbayes (or $SLIPBAYES) and python3. Writes OUT_DIR/table.md.
set -euo pipefail
out=${1:?usage: bash benches/carry.sh OUT_DIR [PATTERN]}
only=${2:-}
root=$(pwd)
bin=${SLIPBAYES:-$root/target/release/slipbayes}
mkdir -p "$out/models" "$out/runs"
. "$root/benches/demo_forms.sh"
write_demo_forms "$out" "$root"
campaign() { # contacts
  local c="$out/c$1"
  [ -f "$c/campaign.toml" ] || python3 data/make_campaign.py --contacts "$1" --out "$c" --binary "$bin" > /dev/null
  echo "$c"
}
{
  echo "| posterior | carry | dimensions | walkers | steps | τ_max (steps) | min ESS bulk | max R̂ | converged | evaluations | ESS per 1,000 evaluations | wall (s) |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
} > "$out/table.md"
fit() { # label, model, fit arguments...
  local label=$1 model=$2
  shift 2
  if [ -n "$only" ] && ! echo "$label" | grep -Eq "$only"; then return; fi
  for carry in complement tuned; do
    local dir="$out/runs/$(echo "$label $carry" | tr ' ,=/+' '_____')"
    "$bin" fit "$model" --carry "$carry" "$@" --quiet --out "$dir" --overwrite > "$dir.log" 2>&1 || true
    python3 benches/run_stats.py "$dir" "| $label | $carry | {dimension} | {walkers} | {steps:,} \
| {tau_max:.1f} | {ess_bulk_min:,.0f} | {r_hat_max:.4f} | {converged} | {evals:,} \
| {ess_per_k_evals:.2f} | {wall_s:.1f} |" >> "$out/table.md"
    tail -1 "$out/table.md"
  done
}
fit "demo" "$out/models/demo.toml"
fit "demo, absolute" "$out/models/absolute.toml"
fit "demo, t0 pooled" "$out/models/pooled.toml"
fit "demo, absolute, t0 pooled" "$out/models/absolute-pooled.toml"
for n in 3 5 10 20; do
  fit "$n contacts" "$(campaign "$n")/campaign.toml"
done
c=$(campaign 10)
{ cat "$c/campaign.toml"; printf '\n[pooling]\nt0 = true\n'; } > "$c/pooled-t0.toml"
{ cat "$c/campaign.toml"; printf '\n[pooling]\nt0 = true\nF_d = true\n'; } > "$c/pooled-t0-fd.toml"
fit "10 contacts, t0 pooled" "$c/pooled-t0.toml"
fit "10 contacts, t0 and F_d pooled" "$c/pooled-t0-fd.toml"
# The pooled SBC model (t0 and F_d pooled over 3 contacts) on data like its replications', at
# the 16 walkers `validate` fits it with and at the fit's default.
c=$(campaign 3)
{ cat "$c/campaign.toml"; printf '\n[levels]\nsigma = "contact"\n\n[pooling]\nt0 = true\nF_d = true\n'; } > "$c/sbc-pooled.toml"
fit "3 contacts, t0 and F_d pooled, 16 walkers" "$c/sbc-pooled.toml" --walkers 16
fit "3 contacts, t0 and F_d pooled" "$c/sbc-pooled.toml"
