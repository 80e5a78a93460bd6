#!/usr/bin/env python3
"""A hypothesis tested on the real flights: the held-out error of the selected model against the
same flights with the hypothesis fitted on top (forced), per flight.

    cargo run --release -- identify $FLYARENA_DATA/nanobench/dataset/*.csv --mapping mappings/nanobench.yaml --with body_offset --out out/base
    cargo run --release -- identify $FLYARENA_DATA/nanobench/dataset/*.csv --mapping mappings/nanobench.yaml --with body_offset,gyro_delay --out out/gyro-delay
    python3 scripts/nanobench-hypothesis.py out/base/cross-validation.identify.json out/gyro-delay/cross-validation.identify.json gyro_delay gyro

One row per flight: the hypothesis' estimate (95 %), and the held-out RMSE of the channel it
acts on (RMS over its axes) without and with it.
"""
import json, math, sys

base, with_, effect, channel = json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), sys.argv[3], sys.argv[4]
def rms(errs):
    v = [e['rmse_after'] for e in errs if e['channel'] == channel]
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else None
names = {'B10_lissajous_fast_rep1': 'B10 lissajous fast', 'B2_circle_fast_rep2': 'B2 circle fast', 'B2_circle_slow_rep2': 'B2 circle slow',
         'B3_figure8_medium_rep2': 'B3 figure-8 medium', 'B5_helix_fast_rep1': 'B5 helix fast', 'B6_linear_ramp_rep1': 'B6 linear ramp 1',
         'B6_linear_ramp_rep2': 'B6 linear ramp 2', 'B7_oval_fast_rep1': 'B7 oval fast', 'B8_star_medium_rep1': 'B8 star medium', 'B9_trefoil_fast_rep1': 'B9 trefoil fast'}
b = {i['flight']: i['report'] for i in base['reports']}
print(f"| flight | {effect} (±95 %) | held-out {channel} RMSE without → with | change |")
print("|---|---|---|---|")
for item in with_['reports']:
    r, flight = item['report'], item['flight']
    name = names.get(flight, flight)
    f = [e for e in r['effects'] if e['effect'] == effect]
    if not f:
        continue  # too few usable samples to fit (B6 ramp 1)
    est = ", ".join(f"{p['value']:.1f}±{p['ci95']:.1f} {p['unit']}" if p['identifiable'] else f"{p['value']:.1f} {p['unit']} (not identifiable)" for p in f[0]['params'])
    r0, r1 = rms(b[flight]['errors']), rms(r['errors'])
    neg = lambda t: t.replace('-', '−')
    print(f"| {name} | {neg(est)} | {r0:.4f} → {r1:.4f} | {neg(f'{100 * (r1 / r0 - 1):+.1f}')} % |")
