#!/usr/bin/env bash
# reports/campaign-scaling.md: what a campaign of N contacts costs, from loading to sampling,
# for two builds of `examples/many_contacts.rs` side by side (a previous one and this one),
# each size run by both in turn, A B A B ..., so that a change of the machine's load touches
# both alike. Each run is one process for one size under GNU time (its peak RSS is the size's).
# Per size and build: the medians over the repeats of each part (posterior built, rough start,
# the fit's mode search where asked, the sampler's start, time per sweep and per sweep per
# contact), the peak RSS and RSS per contact; then the new build's time per sweep over the
# previous one's (median, and the range over the repeats), and time per sweep per contact
# at each size over that at the smallest size.
#
#   bash benches/campaigns.sh OUT_DIR PREVIOUS NEW [N ...]   # default N: 50 200 1000
#
# PREVIOUS and NEW are many_contacts binaries (`cargo build --release --example
# many_contacts`, target/release/examples/many_contacts). REPEATS (default 2) runs of each;
# MODE_UP_TO (default 0) times the mode search for campaigns of at most that many contacts.
#
# Wall times move with the load; instruction counts do not. With `perf` on the PATH (and
# INSTRUCTIONS not 0), each build also runs each size twice on one thread under `perf stat -e
# instructions:u`, with 1 and with 3 sweeps: half the difference is the instructions of one
# sweep, from which the start has cancelled out.
# Writes OUT_DIR/table.md, OUT_DIR/ratios.md, OUT_DIR/instructions.md (with perf) and every
# run's output (OUT_DIR/runs/).
set -euo pipefail
out=${1:?usage: bash benches/campaigns.sh OUT_DIR PREVIOUS NEW [N ...]}
previous=${2:?the previous many_contacts binary}
new=${3:?the new many_contacts binary}
shift 3
sizes=("$@")
[ ${#sizes[@]} -gt 0 ] || sizes=(50 200 1000)
repeats=${REPEATS:-2}
mode_up_to=${MODE_UP_TO:-0}
mkdir -p "$out/runs"
for n in "${sizes[@]}"; do
  for r in $(seq 1 "$repeats"); do
    for build in previous new; do
      bin=$previous
      [ $build = new ] && bin=$new
      log=$out/runs/$build-$n-$r
      /usr/bin/time -f "%M" -o "$log.rss" "$bin" "$n" --mode-up-to "$mode_up_to" > "$log.md"
      echo "$build $n run $r: $(grep "^| $n " "$log.md") peak RSS $(cat "$log.rss") kB" >&2
    done
  done
done
instructions=0
if [ "${INSTRUCTIONS:-1}" != 0 ] && command -v perf > /dev/null; then
  instructions=1
  for n in "${sizes[@]}"; do
    for build in previous new; do
      bin=$previous
      [ $build = new ] && bin=$new
      for k in 1 3; do
        log=$out/runs/$build-$n-sweeps$k
        RAYON_NUM_THREADS=1 perf stat -x, -e instructions:u -o "$log.perf" \
          "$bin" "$n" --sweeps "$k" > "$log.md"
      done
      echo "$build $n: instructions counted" >&2
    done
  done
fi
python3 - "$out" "$repeats" "$instructions" "${sizes[@]}" <<'EOF'
import statistics, sys
from pathlib import Path

out, repeats, counted = Path(sys.argv[1]), int(sys.argv[2]), sys.argv[3] == "1"
sizes = [int(n) for n in sys.argv[4:]]
NAMES = ["posterior built (s)", "rough start (s)", "mode search (s)", "sampler's start (s)",
         "per sweep (s)", "per sweep per contact (ms)"]

def run(build, n, r):
    """The example's row of size n (its cells after contacts, runs, dimensions) and the peak RSS."""
    stem = out / "runs" / f"{build}-{n}-{r}"
    row = next(l for l in stem.with_suffix(".md").read_text().splitlines() if l.startswith(f"| {n} "))
    cells = [c.strip() for c in row.strip("|").split("|")]
    return cells[2], cells[3:], int(stem.with_suffix(".rss").read_text().split()[-1])

def number(cell):
    try:
        return float(cell)
    except ValueError:
        return None

def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else None

def fmt(v, digits=3):
    return "not run" if v is None else f"{v:.{digits}g}" if v < 1 else f"{v:,.2f}"

table = ["| contacts | dimensions | build | " + " | ".join(NAMES) + " | peak RSS (MB) | RSS per contact (kB) |",
         "|---|---|---|" + "---|" * (len(NAMES) + 2)]
per = {}
for n in sizes:
    for build in ["previous", "new"]:
        runs = [run(build, n, r) for r in range(1, repeats + 1)]
        dims = runs[0][0]
        cells = [median([number(c[1][i]) for c in runs]) for i in range(len(NAMES))]
        rss = median([c[2] for c in runs])
        per[build, n] = [number(c[1][4]) for c in runs]
        table.append(f"| {n:,} | {dims} | {build} | " + " | ".join(fmt(v) for v in cells)
                     + f" | {rss / 1024:,.0f} | {rss / n:,.0f} |")
(out / "table.md").write_text("\n".join(table) + "\n")

ratios = ["| contacts | new / previous, per sweep (median; range over the repeats) | per sweep per contact / that at "
          f"{sizes[0]:,} contacts, previous | the same, new |", "|---|---|---|---|"]
for n in sizes:
    pairs = [b / a for a, b in zip(per["previous", n], per["new", n])]
    scale = {b: median(per[b, n]) / n / (median(per[b, sizes[0]]) / sizes[0]) for b in ["previous", "new"]}
    ratios.append(f"| {n:,} | {median(pairs):.3f} ({min(pairs):.3f}–{max(pairs):.3f}) "
                  f"| {scale['previous']:.2f} | {scale['new']:.2f} |")
(out / "ratios.md").write_text("\n".join(ratios) + "\n")
print("\n".join(table + [""] + ratios))
if counted:
    def count(build, n, k):
        for line in (out / "runs" / f"{build}-{n}-sweeps{k}.perf").read_text().splitlines():
            fields = line.split(",")
            if len(fields) > 2 and fields[2].startswith("instructions"):
                return int(fields[0])
        raise SystemExit(f"no instruction count for {build} at {n} contacts")
    sweep = {(b, n): (count(b, n, 3) - count(b, n, 1)) / 2 for b in ["previous", "new"] for n in sizes}
    rows = ["| contacts | previous: instructions per sweep per contact | new | new / previous "
            f"| per contact / that at {sizes[0]:,} contacts, previous | the same, new |",
            "|---|---|---|---|---|---|"]
    for n in sizes:
        p, q = sweep["previous", n] / n, sweep["new", n] / n
        p0, q0 = sweep["previous", sizes[0]] / sizes[0], sweep["new", sizes[0]] / sizes[0]
        rows.append(f"| {n:,} | {p / 1e6:,.2f} M | {q / 1e6:,.2f} M | {q / p:.3f} | {p / p0:.3f} | {q / q0:.3f} |")
    (out / "instructions.md").write_text("\n".join(rows) + "\n")
    print("\n" + "\n".join(rows))
EOF
