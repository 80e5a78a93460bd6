#!/usr/bin/env python3
"""The README's NanoBench table, from the JSON that the cross-validation run writes:

    cargo run --release -- identify $FLYARENA_DATA/nanobench/dataset/*.csv --mapping mappings/nanobench.yaml --with body_offset
    python3 scripts/nanobench-table.py out/cross-validation.identify.json

One row per flight: body offset (deg, 95 %), ground tilt (deg), further effects (a pair the
flight cannot tell apart is marked), held-out RMSE of accel_kin and force (RMS over the axes,
nominal -> with the effects).
"""
import re
import json, sys, math

d = json.load(open(sys.argv[1]))
names = {'B10_lissajous_fast_rep1': 'B10 lissajous fast', 'B2_circle_fast_rep2': 'B2 circle fast', 'B2_circle_slow_rep2': 'B2 circle slow',
         'B3_figure8_medium_rep2': 'B3 figure-8 medium', 'B5_helix_fast_rep1': 'B5 helix fast', 'B6_linear_ramp_rep1': 'B6 linear ramp 1',
         'B6_linear_ramp_rep2': 'B6 linear ramp 2', 'B7_oval_fast_rep1': 'B7 oval fast', 'B8_star_medium_rep1': 'B8 star medium', 'B9_trefoil_fast_rep1': 'B9 trefoil fast'}
def rms(errs, ch, key):
    v = [e[key] for e in errs if e['channel'] == ch]
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else None
for item in d['reports']:
    r = item['report']; name = names.get(item['flight'], item['flight'])
    g = r['ground_check']
    gt = f"{g['roll_deg']:.2f} / {g['pitch_deg']:.2f}" if g else '—'
    eff = {e['effect']: e for e in r['effects']}
    if not r['effects']:
        print(re.sub(r'(?<![A-Za-z0-9])-(?=\d)', '−', f"| {name} | — ({r['train_samples']} usable samples, 200 needed) | {gt} | — | — | — |")); continue
    bo = eff['body_offset']['params']
    b = f"{bo[0]['value']:.2f}±{bo[0]['ci95']:.2f} / {bo[1]['value']:.2f}±{bo[1]['ci95']:.2f} / {bo[2]['value']:.1f}±{bo[2]['ci95']:.1f}"
    unid = {a for a, c, _ in r['not_identifiable']}
    further = []
    for e in r['effects']:
        k = e['effect']; p = e['params']; mark = ' (not identifiable from ' + ', '.join(c for a, c, _ in r['not_identifiable'] if a == k) + ')' if k in unid else ''
        if k == 'body_offset': continue
        if k == 'thrust_scale': further.append(f"thrust ×{1 + p[0]['value']:.2f}{mark}")
        elif k == 'rotor_drag': further.append(f"drag {p[0]['value']:.2f}/{p[1]['value']:.2f} 1/s{mark}" if len(p) > 1 else f"drag {p[0]['value']:.2f} 1/s")
        elif k == 'thrust_voltage': further.append(f"{p[0]['value']:.2f}/V{mark}")
        elif k == 'constant_force': further.append("force " + ", ".join(f"{q['name'][0].upper()} {q['value']:.3f}" for q in p if abs(q['value']) >= 0.0015) + f" N{mark}")
        elif k == 'accel_bias': further.append("accel bias (" + ", ".join(f"{q['value']:.2f}" for q in p) + f") m/s²{mark}")
        else: further.append(k + mark)
    ak = (rms(r['errors'], 'accel_kin', 'rmse_before'), rms(r['errors'], 'accel_kin', 'rmse_after'))
    fo = (rms(r['errors'], 'force', 'rmse_before'), rms(r['errors'], 'force', 'rmse_after'))
    row = f"| {name} | {b} | {gt} | {', '.join(further)} | {ak[0]:.3f} → {ak[1]:.3f} | {fo[0]:.2f} → {fo[1]:.3f} |"
    print(re.sub(r'(?<![A-Za-z0-9])-(?=\d)', '−', row))
