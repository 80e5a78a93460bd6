#!/usr/bin/env python3
"""The unsynchronised-clock table of docs/findings.md from two sweeps of scenarios/gyro-clock.yaml:

    cargo run --release -- sweep scenarios/gyro-clock.yaml --out out/fitted
    sed 's/estimate: true/estimate: false/' scenarios/gyro-clock.yaml > /tmp/gyro-clock-naive.yaml
    cargo run --release -- sweep /tmp/gyro-clock-naive.yaml --out out/naive
    python3 scripts/gyro-clock-table.py out/fitted/gyro-clock.sweep.csv out/naive/gyro-clock.sweep.csv

Per grid offset: median and max |yaw error| with the clock fitted and taken for the Vicon's.
"""
import csv
import statistics
import sys


def by_offset(path):
    out = {}
    for row in csv.DictReader(open(path)):
        out.setdefault(float(row['telemetry.clock.offset_ms']), []).append(abs(float(row['yaw_gyro_err_deg'])))
    return out


fitted, naive = by_offset(sys.argv[1]), by_offset(sys.argv[2])
print("| telemetry clock offset | yaw error, clock fitted: median / max | taken for the Vicon's clock: median / max |")
print("|---|---|---|")
for k in sorted(fitted):
    f, n = fitted[k], naive[k]
    print(f"| {k:.0f} ms | {statistics.median(f):.3f}° / {max(f):.3f}° | {statistics.median(n):.2f}° / {max(n):.2f}° |")
