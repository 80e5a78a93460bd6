#!/usr/bin/env python3
"""Four hypotheses, tested together on the NanoBench flights: each
fitted on top of the selected model (forced with --with), its estimate (95 %) and the change of
the held-out RMSE of the channel it acts on, per flight.

    for h in base accel_misalignment accel_scale thrust_tilt clock_drift; do
      cargo run --release -- identify data/nanobench/dataset/*.csv --mapping mappings/nanobench.yaml \\
        --with body_offset$( [ $h = base ] || echo ,$h ) --out out/hyp/$h
    done
    python3 scripts/nanobench-hypotheses.py out/hyp
"""
import json, math, os, sys

root = sys.argv[1]
# (effect, the channels whose held-out error it is judged on)
HYPOTHESES = [('accel_misalignment', ['accel_kin', 'force']), ('accel_scale', ['accel_kin']), ('thrust_tilt', ['force']), ('clock_drift', ['accel_kin', 'gyro'])]
names = {'B10_lissajous_fast_rep1': 'B10 lissajous fast', 'B2_circle_fast_rep2': 'B2 circle fast', 'B2_circle_slow_rep2': 'B2 circle slow',
         'B3_figure8_medium_rep2': 'B3 figure-8 medium', 'B5_helix_fast_rep1': 'B5 helix fast', 'B6_linear_ramp_rep1': 'B6 linear ramp 1',
         'B6_linear_ramp_rep2': 'B6 linear ramp 2', 'B7_oval_fast_rep1': 'B7 oval fast', 'B8_star_medium_rep1': 'B8 star medium', 'B9_trefoil_fast_rep1': 'B9 trefoil fast'}
load = lambda d: {i['flight']: i['report'] for i in json.load(open(os.path.join(root, d, 'cross-validation.identify.json')))['reports']}
base = load('base')
runs = {h: load(h) for h, _ in HYPOTHESES}
def rms(report, channel):
    v = [e['rmse_after'] for e in report['errors'] if e['channel'] == channel]
    return math.sqrt(sum(x * x for x in v) / len(v))
neg = lambda t: t.replace('-', '−')
print('| flight | ' + ' | '.join(f'{h} (±95 %): held-out ' + ', '.join(c for c in cs) for h, cs in HYPOTHESES) + ' |')
print('|---|' + '---|' * len(HYPOTHESES))
for flight, b in base.items():
    if not b['effects']:
        continue  # too few usable samples to fit (B6 ramp 1)
    cells = []
    for h, chans in HYPOTHESES:
        f = [e for e in runs[h][flight]['effects'] if e['effect'] == h][0]
        est = ' / '.join(f"{p['value']:.1f}±{p['ci95']:.1f}" if p['identifiable'] else f"{p['value']:.1f} (n.i.)" for p in f['params']) + ' ' + f['params'][0]['unit'].replace('deg', '°')
        change = ', '.join(f'{100 * (rms(runs[h][flight], c) / rms(b, c) - 1):+.1f} %' for c in chans)
        cells.append(neg(f'{est}: {change}'))
    print(f"| {names.get(flight, flight)} | " + ' | '.join(cells) + ' |')
