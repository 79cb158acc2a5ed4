#!/usr/bin/env python3
"""Writes data/rheocompass-ptfe-c1.txt: a realistic synthetic Anton Paar RheoCompass text
export (docs/model.md §9) made from slipbayes' own simulator output, PTFE contact 1
(data/ptfe-c1-first.csv and data/ptfe-c1-repeat.csv, made by data/make_bundle.sh).

What a European-locale export looks like: UTF-16LE with a byte-order mark, CRLF line ends, tab
separated, decimal commas, a header block, three intervals with a units row each, torque in
µN·m (force times the 7 mm moment arm), a deflection angle and a rotational speed nobody fits,
a status column whose text contains commas, and one invalid point with text where numbers
belong.

  interval 1: the first slide at 1 nm/s, logged every 10 s from 0 s to 2990 s (300 points)
  interval 2: the same slide continued, logged every 50 s from 3000 s to 30000 s (541 points)
  interval 3: the repeat slide after a 120 s stop, every 5 s for 2500 s (501 points); its
              `Time` continues, its `Interval Time` restarts at 0 (the repeat slide's clock)

Run from the repository root: python3 data/make_rheocompass.py
"""
import csv
import math
from pathlib import Path

ROOT = Path(__file__).resolve().parent
MOMENT_ARM_M = 7e-3
VELOCITY = 1e-9
STOP_S = 120.0
# Point number whose torque the instrument could not measure (interval 1).
INVALID_POINT = 137


def read(name):
    with open(ROOT / name, newline="") as f:
        rows = list(csv.DictReader(f))
    return [(float(r["time_s"]), float(r["force_N"]), float(r["normal_force_N"])) for r in rows]


def num(x):
    # Python's repr is the shortest round-trip form; the locale writes a decimal comma.
    return repr(float(x)).replace(".", ",")


def main():
    first = read("ptfe-c1-first.csv")
    repeat = read("ptfe-c1-repeat.csv")
    speed_rpm = VELOCITY / (2 * math.pi * MOMENT_ARM_M) * 60
    intervals = [
        [(t, t, f, n) for (t, f, n) in first if t < 3000],
        [(t, t - 3000, f, n) for (t, f, n) in first if t >= 3000 and round(t) % 50 == 0],
        [(30000 + STOP_S + t, t, f, n) for (t, f, n) in repeat if round(t) % 5 == 0],
    ]
    columns = ["Point No.", "Time", "Interval Time", "Torque", "Deflection Angle", "Speed",
               "Normal Force", "Status"]
    units = ["", "[s]", "[s]", "[µN·m]", "[mrad]", "[1/min]", "[N]", ""]
    lines = [
        "Project:\tslipbayes synthetic friction",
        "Test:\tPTFE sphere on glass, contact 1 (synthetic, from slipbayes simulate)",
        "Result:\tPTFE c1 first and repeat slide",
        "Application:\tRheoCompass (synthetic layout)",
        "Device:\tMCR (synthetic)",
        "",
    ]
    point = 0
    for number, rows in enumerate(intervals, start=1):
        lines.append(f"Interval and data points:\t{number}\t{len(rows)}")
        lines.append("Interval data:\t" + "\t".join(columns))
        lines.append("\t" + "\t".join(units))
        for (time, interval_time, force, normal) in rows:
            point += 1
            torque_un_m = force * MOMENT_ARM_M * 1e6
            # Torsional compliance of a synthetic drive: 0.05 mrad per µN·m.
            angle = torque_un_m * 0.05
            status = "Dy_auto, M_Ok" if point % 97 else "Dy_auto, M_Ok, Warning: low torque"
            cells = [str(point), num(time), num(interval_time), num(torque_un_m), num(angle),
                     num(speed_rpm), num(normal), status]
            if point == INVALID_POINT:
                cells[3] = "Invalid"
                cells[4] = "Invalid"
            lines.append("\t" + "\t".join(cells))
    text = "\r\n".join(lines) + "\r\n"
    (ROOT / "rheocompass-ptfe-c1.txt").write_bytes(b"\xff\xfe" + text.encode("utf-16-le"))


if __name__ == "__main__":
    main()
