#!/usr/bin/env python3
"""The NanoBench table of docs/nanobench.md, from the JSON that the cross-validation run writes:

    cargo run --release -- identify data/nanobench/dataset/*.csv --mapping mappings/nanobench.yaml --with body_offset
    python3 scripts/nanobench-table.py out/cross-validation.identify.json

One row per flight: body offset (deg, 95 %), ground tilt (deg), further effects (a pair the
flight cannot tell apart is marked), held-out RMSE of accel_kin and force (RMS over the axes,
nominal -> with the effects).

Then the ground agreement: per flight the ground tilt, the tilt of the fitted accelerometer bias,
the flight's body offset and the difference (ground - bias tilt - offset) with its 95 % interval;
and the median |difference| per axis.

Then what is left: per flight, the channel axes whose final residual follows a measured signal.
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

print()
print("| flight | ground roll / pitch | bias tilt roll / pitch | flight offset roll / pitch | difference roll | difference pitch |")
print("|---|---|---|---|---|---|")
diffs = {'roll': [], 'pitch': []}
for item in d['reports']:
    r = item['report']; name = names.get(item['flight'], item['flight'])
    a = r.get('ground_agreement')
    if not a:
        continue
    cell = lambda t: f"{t['difference_deg']:+.2f} ± {t['ci95_deg']:.2f}" + ('' if t['covers'] else ' ✗')
    for k in diffs:
        diffs[k].append(abs(a[k]['difference_deg']))
    row = (f"| {name} | {a['roll']['ground_deg']:.2f} / {a['pitch']['ground_deg']:.2f} | {a['roll']['bias_tilt_deg']:.2f} / {a['pitch']['bias_tilt_deg']:.2f} | "
           f"{a['roll']['flight_deg']:.2f} / {a['pitch']['flight_deg']:.2f} | {cell(a['roll'])} | {cell(a['pitch'])} |")
    print(re.sub(r'(?<![A-Za-z0-9])-(?=\d)', '−', row))
med = lambda v: sorted(v)[len(v) // 2] if len(v) % 2 else 0.5 * (sorted(v)[len(v) // 2 - 1] + sorted(v)[len(v) // 2])
print(f"\nmedian |difference|: roll {med(diffs['roll']):.2f}°, pitch {med(diffs['pitch']):.2f}° over {len(diffs['roll'])} flights; "
      f"beyond 1°: {sum(x > 1 for x in diffs['roll'])} roll, {sum(x > 1 for x in diffs['pitch'])} pitch")
print()
print("| flight | spin-up thrust / s | spin-up − rest roll | spin-up − rest pitch | spin-up − flight roll | spin-up − flight pitch |")
print("|---|---|---|---|---|---|")
for item in d['reports']:
    r = item['report']; name = names.get(item['flight'], item['flight'])
    a = (r.get('ground_agreement') or {}).get('spin_up')
    if not a:
        continue
    ch = lambda t: f"{t['change_deg']:+.2f} ± {t['change_ci95_deg']:.2f}"
    cell = lambda t: f"{t['difference_deg']:+.2f} ± {t['ci95_deg']:.2f}" + ('' if t['covers'] else ' ✗')
    row = (f"| {name} | {100 * a['thrust_fraction']:.0f} % / {a['duration_s']:.2f} | {ch(a['roll'])} | {ch(a['pitch'])} | {cell(a['roll'])} | {cell(a['pitch'])} |")
    print(re.sub(r'(?<![A-Za-z0-9])-(?=\d)', '−', row))
sp = d.get('spin_up')
if sp:
    print()
    for k in ('roll', 'pitch'):
        a = sp[k]
        print(f"{k}: median |difference| rest {a['median_rest_deg']:.2f}°, spin-up {a['median_spin_up_deg']:.2f}°; "
              f"toward the flight in {a['toward_flight']} of {sp['flights']} (sign test p = {a['sign_test_p']:.3f})")

print()
print("| flight | after − before roll | after − before pitch | mean of the rests − flight roll | mean of the rests − flight pitch | mocap scatter at rest roll / pitch |")
print("|---|---|---|---|---|---|")
for item in d['reports']:
    r = item['report']; name = names.get(item['flight'], item['flight'])
    g = r.get('ground_agreement')
    if not g:
        continue
    a = g.get('after_landing')
    if not a:
        sd = r['ground_check']['mocap_sd_deg']
        print(f"| {name} | — (no rest after landing) | — | — | — | {sd[0]:.3f} / {sd[1]:.3f} |")
        continue
    ch = lambda t: f"{t['change_deg']:+.2f} ± {t['change_ci95_deg']:.2f}"
    cell = lambda t: f"{t['bracket_difference_deg']:+.2f} ± {t['bracket_ci95_deg']:.2f}" + ('' if t['bracket_covers'] else ' ✗')
    sd = r['ground_check']['mocap_sd_deg']
    row = f"| {name} | {ch(a['roll'])} | {ch(a['pitch'])} | {cell(a['roll'])} | {cell(a['pitch'])} | {sd[0]:.3f} / {sd[1]:.3f} |"
    print(re.sub(r'(?<![A-Za-z0-9])-(?=\d)', '−', row))

print()
print("what is left (final residual per channel axis; the measured signals it follows):")
for item in d['reports']:
    r = item['report']; name = names.get(item['flight'], item['flight'])
    for l in r.get('left', []):
        if l['correlates']:
            leads = ', '.join(f"{c['signal']} {c['r']:+.2f}" + (' (floor)' if c.get('floor') else '') for c in l['correlates'])
            print(f"  {name}: {l['channel']}.{l['axis']} {l['rmse']:.3f} {l['unit']}: {leads}")

print()
print("hypothesis: a lever arm between the mocap origin and the IMU (held-out accel_kin cut when it is tried)")
print("| flight | selected | r x / y / z (mm, ±95 %) | held-out cut of its channel |")
print("|---|---|---|---|")
for item in d['reports']:
    r = item['report']; name = names.get(item['flight'], item['flight'])
    if not r['effects']:
        continue
    eff = {e['effect']: e for e in r['effects']}
    step = next((s for s in r['steps'] if s['added'] == 'lever_arm' or s.get('together_with') == 'lever_arm'), None)
    if step:
        p = eff['lever_arm']['params']
        rr = ' / '.join(f"{q['value']:.1f}±{q['ci95']:.1f}" for q in p)
        print(re.sub(r'(?<![A-Za-z0-9])-(?=\d)', '−', f"| {name} | yes | {rr} | {100 * step['heldout_gain']:.0f} % |"))
    else:
        c = next(c for c in r['final_candidates'] if c['effect'] == 'lever_arm')
        why = 'fails ' + ', '.join(k for k, bad in [('F-test', c['p_value'] >= 0.01 / 11), ('ΔBIC', c['delta_bic'] >= 0), ('held-out (< 10 %)', c['heldout_gain'] < 0.1)] if bad)
        print(re.sub(r'(?<![A-Za-z0-9])-(?=\d)', '−', f"| {name} | no ({why}) | — | {100 * c['heldout_gain']:.0f} % |"))
