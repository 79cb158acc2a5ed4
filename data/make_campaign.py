#!/usr/bin/env python3
"""A simulated one-material campaign: N contacts of a PTFE-like material on glass, each a
1 nm/s first slide and a repeat slide, with contact-to-contact spread in F_d, k and t0 (the
paper's point: static friction varies between contacts). Writes the data (by
`slipbayes simulate`: a 201-point first slide and a 51-point repeat slide per contact) and a
model file `campaign.toml` into OUT; the "campaign" rows of reports/moves.md were measured on it.

    python3 data/make_campaign.py --contacts 10 --out /tmp/campaign-10

--first-interval and --repeat-interval (s between points; 100 and 40 by default) make long
records instead: `--first-interval 0.2` gives first slides of 100,001 points, which a fit
reduces to sufficient statistics (reports/mpi.md measured memory per MPI rank on those).

Deterministic: the same --contacts and --seed give the same files. α = 0.92 /µm and
a/F_d = 0.62 as in the demo's PTFE; F_d ~ 10 mN × e^(0.15 N(0,1)), k ~ 1.2e4 N/m ×
e^(0.2 N(0,1)), t0 ~ 15 s × e^(0.5 N(0,1)); σ = 0.1 mN.
"""
import argparse
import math
import random
import subprocess
from pathlib import Path

ALPHA = 0.92e6
RATIO = 0.62


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--contacts", type=int, required=True)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--seed", type=int, default=7)
    # The repository's release build when there is one, else `slipbayes` on the PATH.
    built = Path("target/release/slipbayes")
    ap.add_argument("--binary", default=str(built) if built.exists() else "slipbayes")
    ap.add_argument("--first-interval", default="100", help="s between a first slide's points")
    ap.add_argument("--repeat-interval", default="40", help="s between a repeat slide's points")
    args = ap.parse_args()
    rng = random.Random(args.seed)
    out = args.out
    (out / "data").mkdir(parents=True, exist_ok=True)
    model = [
        f"# A simulated campaign of {args.contacts} PTFE-like contacts (data/make_campaign.py,",
        f"# --contacts {args.contacts} --seed {args.seed} --first-interval {args.first_interval}"
        f" --repeat-interval {args.repeat_interval}).",
        "",
        "[[material]]",
        'name = "M"',
    ]
    runs = []
    for c in range(1, args.contacts + 1):
        f_d = 10e-3 * math.exp(0.15 * rng.gauss(0, 1))
        k = 1.2e4 * math.exp(0.2 * rng.gauss(0, 1))
        t0 = 15.0 * math.exp(0.5 * rng.gauss(0, 1))
        common = [
            "--alpha", repr(ALPHA), "--a", repr(RATIO * f_d), "--f-d", repr(f_d),
            "--t0", repr(t0), "--k", repr(k), "--velocity", "1e-9", "--sigma", "1e-4",
        ]
        name = f"c{c:03}"
        model += ["", "[[contact]]", f'name = "{name}"', 'material = "M"']
        for scene, extra in [
            ("first", ["--duration", "20000", "--interval", args.first_interval]),
            ("repeat", ["--after-first", "20000", "--duration", "2000",
                        "--interval", args.repeat_interval]),
        ]:
            csv = out / "data" / f"{name}-{scene}.csv"
            seed = str(args.seed * 100_000 + 10 * c + (scene == "repeat"))
            subprocess.run(
                [args.binary, "simulate", "--scene", scene, *common, *extra,
                 "--seed", seed, "--out", str(csv)],
                check=True, stdout=subprocess.DEVNULL,
            )
            runs += ["", "[[run]]", f'name = "{name}-{scene}"', f'contact = "{name}"',
                     f'data = "data/{csv.name}"', "velocity_m_per_s = 1e-9", f'scene = "{scene}"']
    (out / "campaign.toml").write_text("\n".join(model + runs) + "\n")
    print(f"wrote {out / 'campaign.toml'} and {2 * args.contacts} data files")


if __name__ == "__main__":
    main()
