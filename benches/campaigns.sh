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
# many_contacts`, target/release/examples/many_contacts). REPEATS (default 2) runs of each.
# The new build times the fit's mode search at every size; the previous one only up to
# MODE_UP_TO contacts (default 0: never), for a build whose dense search takes hours at a
# thousand contacts.
#
# Every run is on one thread (RAYON_NUM_THREADS=1, unless THREADS says otherwise): the
# process's CPU time over the sweeps is then their own work, which other processes on the
# machine lengthen far less than the wall time (the last column of each table).
# Writes OUT_DIR/table.md, OUT_DIR/ratios.md and every run's output (OUT_DIR/runs/).
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
      bin=$previous mode=$mode_up_to
      [ $build = new ] && bin=$new mode=1000000000
      log=$out/runs/$build-$n-$r
      RAYON_NUM_THREADS=${THREADS:-1} /usr/bin/time -f "%M" -o "$log.rss" \
        "$bin" "$n" --mode-up-to "$mode" > "$log.md"
      echo "$build $n run $r: $(grep "^| $n " "$log.md") peak RSS $(cat "$log.rss") kB" >&2
    done
  done
done
python3 - "$out" "$repeats" "${sizes[@]}" <<'EOF'
import statistics, sys
from pathlib import Path

out, repeats = Path(sys.argv[1]), int(sys.argv[2])
sizes = [int(n) for n in sys.argv[3:]]
NAMES = ["posterior built (s)", "rough start (s)", "mode search (s)", "sampler's start (s)",
         "per sweep (s)", "per sweep per contact (ms)", "CPU per sweep per contact (ms)"]

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
per, cpu = {}, {}
for n in sizes:
    for build in ["previous", "new"]:
        runs = [run(build, n, r) for r in range(1, repeats + 1)]
        dims = runs[0][0]
        cells = [median([number(c[1][i]) for c in runs]) for i in range(len(NAMES))]
        rss = median([c[2] for c in runs])
        per[build, n] = [number(c[1][4]) for c in runs]
        cpu[build, n] = [number(c[1][6]) for c in runs]
        table.append(f"| {n:,} | {dims} | {build} | " + " | ".join(fmt(v) for v in cells)
                     + f" | {rss / 1024:,.0f} | {rss / n:,.0f} |")
(out / "table.md").write_text("\n".join(table) + "\n")

ratios = ["| contacts | new / previous: wall per sweep (median; range over the repeats) | CPU per sweep "
          f"| CPU per sweep per contact / that at {sizes[0]:,} contacts, previous | the same, new "
          "| the same in wall time, previous | new | mode search per contact / that at "
          f"{sizes[0]:,} contacts, new |", "|---|---|---|---|---|---|---|---|"]
mode = {n: median([number(run("new", n, r)[1][2]) for r in range(1, repeats + 1)]) for n in sizes}
for n in sizes:
    pairs = [b / a for a, b in zip(per["previous", n], per["new", n])]
    cpairs = [b / a for a, b in zip(cpu["previous", n], cpu["new", n])]
    scale = {b: median(cpu[b, n]) / median(cpu[b, sizes[0]]) for b in ["previous", "new"]}
    wall = {b: median(per[b, n]) / n / (median(per[b, sizes[0]]) / sizes[0]) for b in ["previous", "new"]}
    ratios.append(f"| {n:,} | {median(pairs):.3f} ({min(pairs):.3f}–{max(pairs):.3f}) "
                  f"| {median(cpairs):.3f} ({min(cpairs):.3f}–{max(cpairs):.3f}) "
                  f"| {scale['previous']:.2f} | {scale['new']:.2f} | {wall['previous']:.2f} | {wall['new']:.2f} "
                  f"| {mode[n] / n / (mode[sizes[0]] / sizes[0]):.2f} |")
(out / "ratios.md").write_text("\n".join(ratios) + "\n")
print("\n".join(table + [""] + ratios))
EOF
