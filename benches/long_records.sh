#!/usr/bin/env bash
# Long records on sufficient statistics, measured (reports/long-records.md, docs/model.md §5):
#
# 1. The PTFE contact of docs/model.md §7 sampled every 0.02 s, as a rheometer logs: a first
#    slide of 1,000,001 points (20,000 s) and a repeat slide of 100,001 (2,000 s), simulated
#    with `slipbayes simulate`, fitted until converged with --strict (the default fit: the
#    strict convergence standard, exit code 3 otherwise) and timed; then its likelihood on
#    sufficient statistics checked against the exact one at 200 of its own posterior draws
#    (examples/long_record_check.rs).
# 2. A subsample of the same records, every 10th point (100,001 + 10,001 points), where the
#    exact fit is feasible: fitted exactly (--likelihood-tolerance 0) and on sufficient
#    statistics (the default) with the same seed, every posterior median and 95 % interval end
#    compared in posterior sd (benches/compare_fits.py, limit 0.05 sd). 4,000 steps each:
#    the σ reported is drawn from its conditional posterior with random numbers seeded by the
#    sum of squared residuals, which the two likelihoods give to different bits, so its draws
#    differ between the fits by Monte Carlo error: at the default length (400 steps here) its
#    sd is about 0.04 posterior sd at an interval end, at 4,000 steps about 0.012.
# 3. The start against the record's length (examples/start_cost.rs).
#
#   bash benches/long_records.sh OUT_DIR [PARTS]   # from the repository root
#
# PARTS is any of `million`, `subsample` and `start`, comma-separated (default all three: about
# 30 min on 2 idle cores, most of it the exact subsample fit); STEPS (environment, default 4000)
# sets the subsample fits' length. The data are simulated once per OUT_DIR.
#
# Writes OUT_DIR/results-HHMMSS.md (reports/long-records.md is assembled from it) and the run
# directories; the data (about 35 MB) and a copy of the binaries stay in OUT_DIR (so a build
# during the run does not change what is measured), nothing is written to the repository.
set -euo pipefail
out=$(realpath -m "${1:?usage: bash benches/long_records.sh OUT_DIR [million,subsample,start]}")
parts=,${2:-million,subsample,start},
steps=${STEPS:-4000}
repo=$(pwd)
cargo build --release --quiet --bin slipbayes --example long_record_check --example start_cost
mkdir -p "$out"
cp "$repo/target/release/slipbayes" "$repo/target/release/examples/long_record_check" \
  "$repo/target/release/examples/start_cost" "$out/"
bin=$out/slipbayes
cd "$out"
results=$out/results-$(date -u +%H%M%S).md
{
  echo "# Long records: results of benches/long_records.sh"
  echo
  echo "- date: $(date -u '+%Y-%m-%d %H:%M UTC'); commit $(git -C "$repo" rev-parse --short HEAD)"
  echo "- machine: $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | xargs)"
  echo "- parts: ${parts:1:-1}"
  echo "- load average at the start: $(cut -d' ' -f1-3 /proc/loadavg)"
  echo
} > "$results"

truth=(--alpha 0.92e6 --a 6.2e-3 --f-d 10e-3 --t0 14.8 --k 1.2e4 --velocity 1e-9 --sigma 1e-4)
if [[ ! -f repeat-sub.csv ]]; then
  "$bin" simulate --scene first "${truth[@]}" --duration 20000 --interval 0.02 --seed 1 \
    --out first.csv --overwrite > /dev/null
  "$bin" simulate --scene repeat "${truth[@]}" --after-first 20000 --duration 2000 \
    --interval 0.02 --seed 2 --out repeat.csv --overwrite > /dev/null
  # Every 10th point (the header kept).
  awk 'NR == 1 || (NR - 2) % 10 == 0' first.csv > first-sub.csv
  awk 'NR == 1 || (NR - 2) % 10 == 0' repeat.csv > repeat-sub.csv
fi

# Runs a command, appending its wall time and peak memory to the results.
timed() { # label, log, command...
  local label=$1 log=$2; shift 2
  local code=0
  /usr/bin/time -f "%e %M" -o time.txt "$@" > "$log" 2>&1 || code=$?
  read -r wall rss < <(tail -n 1 time.txt)
  echo "- $label: $wall s wall, $((rss / 1024)) MB peak resident, exit code $code" >> "$results"
}
# The sampler's own account of a fit, from its summary.json.
account() { # run dir
  python3 - "$1" >> "$results" <<'EOF'
import json, sys
s = json.load(open(f"{sys.argv[1]}/summary.json"))
m = s["sampler"]
qs = s["parameters"] + s["derived"]
print(f"  - {m['ensembles']} ensembles × {m['walkers']} walkers × {m['steps']} steps, "
      f"converged: {m['converged']}, τ_max {m['tau_max']:.1f}, {m['log_density_evals']} "
      f"evaluations, fit {m['wall_s']:.1f} s; lowest ESS bulk "
      f"{min(q['ess_bulk'] for q in qs):.0f}, tail "
      f"{min(q['ess_tail'] for q in qs):.0f}, highest R̂ "
      f"{max(q['r_hat'] or 0 for q in qs):.4f}")
for d in s["data"]:
    b = d["binning"]
    if b:
        print(f"  - run `{d['run']}`: {d['points_used']} points, {b['bins']} bins of degree "
              f"{b['degree']}, {b['exact_points']} points exact, {b['evaluations']} model times "
              f"per evaluation; bound {b['bound']:.3g} (tolerance {b['tolerance']:.3g})")
    else:
        print(f"  - run `{d['run']}`: {d['points_used']} points, exact")
EOF
}

status=0
if [[ $parts == *,million,* ]]; then
echo "## 10^6 points: first slide 1,000,001 + repeat slide 100,001" >> "$results"
echo >> "$results"
timed "\`slipbayes fit --first first.csv --repeat repeat.csv --velocity 1e-9 --strict\`" \
  million.log "$bin" fit --first first.csv --repeat repeat.csv --velocity 1e-9 --strict \
  --quiet --out million --overwrite
account million
echo >> "$results"
echo "Checked against the exact likelihood at its posterior draws:" >> "$results"
echo >> "$results"
"$out/long_record_check" million 200 | sed 's/^/    /' >> "$results"
echo >> "$results"
fi

if [[ $parts == *,subsample,* ]]; then
echo "## Subsample, every 10th point: 100,001 + 10,001 points" >> "$results"
echo >> "$results"
sub=(--first first-sub.csv --repeat repeat-sub.csv --velocity 1e-9 --steps "$steps" --quiet --overwrite)
timed "exact (\`--likelihood-tolerance 0 --steps $steps\`)" exact.log \
  "$bin" fit "${sub[@]}" --likelihood-tolerance 0 --out sub-exact
account sub-exact
timed "on sufficient statistics (the default, \`--steps $steps\`)" reduced.log "$bin" fit "${sub[@]}" --out sub-reduced
account sub-reduced
echo >> "$results"
python3 "$repo/benches/compare_fits.py" sub-exact sub-reduced 0.05 >> "$results" || status=$?
echo >> "$results"
fi

if [[ $parts == *,start,* ]]; then
echo "## The start against the record's length (examples/start_cost.rs)" >> "$results"
echo >> "$results"
"$out/start_cost" >> "$results"
echo >> "$results"
fi
echo "- load average at the end: $(cut -d' ' -f1-3 /proc/loadavg)" >> "$results"
cat "$results"
exit $status
