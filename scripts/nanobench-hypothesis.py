#!/usr/bin/env python3
"""A hypothesis tested on the real flights: the held-out error of the selected model against the
same flights with the hypothesis fitted on top (forced), per flight.

    cargo run --release -- identify data/nanobench/dataset/*.csv --mapping mappings/nanobench.yaml --with body_offset --out out/base
    cargo run --release -- identify data/nanobench/dataset/*.csv --mapping mappings/nanobench.yaml --with body_offset,gyro_delay --out out/gyro-delay
    python3 scripts/nanobench-hypothesis.py out/base/cross-validation.identify.json out/gyro-delay/cross-validation.identify.json gyro_delay gyro

One row per flight: the hypothesis' estimate (95 %), and the held-out RMSE of the channel it
acts on (RMS over its axes) without and with it. Then a summary over the flights: per parameter
how many estimates are positive and how many intervals leave out zero, the inverse-variance mean
with its 95 % interval and the χ² of the estimates about it (a property of the vehicle should
agree across flights: χ² near its degrees of freedom); the median change of the held-out RMSE per
axis; and the leads of "what is left" on that channel (signal: flights without → with).
`--skip DIR` leaves out the flights whose logs are in DIR (the shared ones, for the held-out set),
`--no-table` prints the summary alone.
"""
import json, math, os, statistics, sys

args = [a for a in sys.argv[1:] if not a.startswith('--')]
skip = set()
if '--skip' in sys.argv:
    d = sys.argv[sys.argv.index('--skip') + 1]
    args.remove(d)
    skip = {f[:-4] for f in os.listdir(d) if f.endswith('.csv')}
base, with_, effect, channel = json.load(open(args[0])), json.load(open(args[1])), args[2], args[3]
table = '--no-table' not in sys.argv
def rms(errs):
    v = [e['rmse_after'] for e in errs if e['channel'] == channel]
    return math.sqrt(sum(x * x for x in v) / len(v)) if v else None
names = {'B10_lissajous_fast_rep1': 'B10 lissajous fast', 'B2_circle_fast_rep2': 'B2 circle fast', 'B2_circle_slow_rep2': 'B2 circle slow',
         'B3_figure8_medium_rep2': 'B3 figure-8 medium', 'B5_helix_fast_rep1': 'B5 helix fast', 'B6_linear_ramp_rep1': 'B6 linear ramp 1',
         'B6_linear_ramp_rep2': 'B6 linear ramp 2', 'B7_oval_fast_rep1': 'B7 oval fast', 'B8_star_medium_rep1': 'B8 star medium', 'B9_trefoil_fast_rep1': 'B9 trefoil fast'}
b = {i['flight']: i['report'] for i in base['reports']}
neg = lambda t: t.replace('-', '−')
if table:
    print(f"| flight | {effect} (±95 %) | held-out {channel} RMSE without → with | change |")
    print("|---|---|---|---|")
fits, changes, leads = [], {}, {}
for item in with_['reports']:
    r, flight = item['report'], item['flight']
    name = names.get(flight, flight)
    f = [e for e in r['effects'] if e['effect'] == effect]
    if flight in skip or not f or flight not in b:
        continue  # shared (--skip), or too few usable samples to fit (B6 ramp 1)
    fits.append(f[0]['params'])
    for e0 in b[flight]['errors']:
        e1 = [e for e in r['errors'] if e['channel'] == channel and e['axis'] == e0['axis']]
        if e0['channel'] == channel and e1 and e0['rmse_after'] > 0:
            changes.setdefault(e0['axis'], []).append(100 * (e1[0]['rmse_after'] / e0['rmse_after'] - 1))
    for k, rep in enumerate([b[flight], r]):
        for left in rep.get('left', []):
            if left['channel'] == channel:
                for c in left['correlates']:
                    leads.setdefault(f"{channel}.{left['axis']} follows {c['signal']}", [0, 0])[k] += 1
    if table:
        est = ", ".join(f"{p['value']:.1f}±{p['ci95']:.1f} {p['unit']}" if p['identifiable'] else f"{p['value']:.1f} {p['unit']} (not identifiable)" for p in f[0]['params'])
        r0, r1 = rms(b[flight]['errors']), rms(r['errors'])
        print(f"| {name} | {neg(est)} | {r0:.4f} → {r1:.4f} | {neg(f'{100 * (r1 / r0 - 1):+.1f}')} % |")
if fits:
    print(f"\n{effect} over {len(fits)} flights:")
    for k, p0 in enumerate(fits[0]):
        v = [p[k]['value'] for p in fits]
        se = [p[k]['ci95'] / 1.96 for p in fits]
        w = [1 / s ** 2 for s in se]
        mean = sum(x * y for x, y in zip(v, w)) / sum(w)
        chi2 = sum(((x - mean) / s) ** 2 for x, s in zip(v, se))
        print(neg(f"  {p0['name']}: median {statistics.median(v):+.2f} {p0['unit']}, positive in {sum(x > 0 for x in v)} of {len(v)}, interval leaves out zero in "
                  f"{sum(abs(p[k]['value']) > p[k]['ci95'] for p in fits)}; weighted mean (1/σ²) {mean:+.2f} ± {1.96 / math.sqrt(sum(w)):.2f}, χ² {chi2:.0f} on {len(v) - 1} dof"))
    print("  held-out " + channel + " RMSE change, median per axis: " + neg(", ".join(f"{a} {statistics.median(c):+.1f} % (lower in {sum(x < 0 for x in c)} of {len(c)})" for a, c in sorted(changes.items()))))
    print(f"  leads of what is left on {channel} (flights without → with {effect}):")
    for lead, (n0, n1) in sorted(leads.items(), key=lambda x: -max(x[1]))[:6]:
        print(f"    {lead}: {n0} → {n1}")
