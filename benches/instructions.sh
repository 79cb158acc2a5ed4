#!/usr/bin/env bash
# Instructions executed by whole fits of two builds, as a Markdown table on stdout.
#
#   bash benches/instructions.sh OLD_BIN NEW_BIN OUT_DIR
#
# Instruction counts (valgrind's callgrind, one thread) do not depend on the machine's load,
# unlike wall times, so two builds compare on a busy machine too. Each case is one whole fit
# from the repository root (start, sampling, summary, predictive bands, LOO, files), the same
# command for both builds. Needs valgrind.
set -euo pipefail
old=$1 new=$2 out=$3
mkdir -p "$out"
cases=(
  "demo, 100 steps|fit models/demo.toml --steps 100"
  "one contact (quick path), 300 steps|fit --first data/ptfe-c1-first.csv --repeat data/ptfe-c1-repeat.csv --velocity 1e-9 --steps 300"
)
count() { # binary, label, arguments...
  local bin=$1 label=$2
  shift 2
  RAYON_NUM_THREADS=1 valgrind --tool=callgrind --callgrind-out-file="$out/$label.callgrind" \
    "$bin" "$@" --out "$out/$label-run" --overwrite --quiet --seed 7 >/dev/null 2>"$out/$label.log" || true
  grep -m1 '^summary:' "$out/$label.callgrind" | awk '{print $2}'
}
echo "| fit | old (instructions) | new (instructions) | new/old |"
echo "|---|---|---|---|"
i=0
for c in "${cases[@]}"; do
  IFS='|' read -r name args <<< "$c"
  # shellcheck disable=SC2086 # the arguments are words
  a=$(count "$old" "old-$i" $args)
  # shellcheck disable=SC2086
  b=$(count "$new" "new-$i" $args)
  printf '| %s | %s | %s | %s |\n' "$name" "$a" "$b" "$(python3 -c "print(f'{$b / $a:.4f}')")"
  i=$((i + 1))
done
