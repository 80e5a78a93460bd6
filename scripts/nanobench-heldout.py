#!/usr/bin/env python3
"""What `identify` does on NanoBench flights it was never built on: the published set's further
flights (docs/nanobench.md, Held-out flights).

    git clone --depth 1 https://github.com/syediu/nanobench-iros2026 ../nanobench-full
    cargo run --release -- identify ../nanobench-full/datasets/dataset/B{2,3,5,6,7,8,9,10}_*.csv \\
        --mapping mappings/nanobench.yaml --with body_offset --out out/heldout
    python3 scripts/nanobench-heldout.py out/heldout/cross-validation.identify.json \\
        --skip data/nanobench/dataset

`--by-time` lists the flights in the order they were flown. `--still-above DEG` splits the
still poses at DEG° of roll scatter per sample instead of at identify's own threshold (0.02°). `--skip DIR` leaves out the flights whose names are in DIR (the ten shared flights this project
was built on), so that the figures are over held-out flights only. Reads the JSON that
`identify` writes for several logs; pure Python.
"""
import json, math, os, statistics as st, sys


def median(v):
    return st.median(v) if v else float('nan')


def sign_test_p(n, k):
    """P(X >= k), X ~ B(n, 1/2)."""
    return sum(math.comb(n, i) for i in range(k, n + 1)) / 2 ** n


def mann_whitney_greater(a, b):
    """One-sided P(a tends to be larger than b): normal approximation, ties averaged (as identify)."""
    pooled = sorted([(x, 1) for x in a] + [(x, 0) for x in b])
    n, ra, ties, i = len(pooled), 0.0, 0.0, 0
    while i < n:
        j = i
        while j + 1 < n and pooled[j + 1][0] == pooled[i][0]:
            j += 1
        t = j - i + 1
        ties += t ** 3 - t
        ra += ((i + j) / 2 + 1) * sum(g for _, g in pooled[i:j + 1])
        i = j + 1
    na, nb = len(a), len(b)
    u = ra - na * (na + 1) / 2
    var = na * nb / 12 * ((n + 1) - ties / (n * (n - 1)))
    z = (u - na * nb / 2) / math.sqrt(var)
    return 0.5 * math.erfc(z / math.sqrt(2))


def main():
    args = sys.argv[1:]
    skip = set()
    if '--skip' in args:
        i = args.index('--skip')
        skip = {os.path.splitext(f)[0] for f in os.listdir(args[i + 1]) if f.endswith('.csv')}
        del args[i:i + 2]
    by_time = '--by-time' in args
    if by_time:
        args.remove('--by-time')
    still_above = None
    if '--still-above' in args:
        i = args.index('--still-above')
        still_above = float(args[i + 1])
        del args[i:i + 2]
    d = json.load(open(args[0]))
    skipped = sum(1 for x in d['reports'] + d['excluded'] if x['flight'] in skip)
    reports = [(x['flight'], x['report']) for x in d['reports'] if x['flight'] not in skip]
    excluded = [x for x in d['excluded'] if x['flight'] not in skip]
    copies = [x for x in excluded if 'the same samples as' in x['reason']]
    print(f"flights identified: {len(reports)}; left out: {len(copies)} copies of another log, "
          f"{len(excluded) - len(copies)} rejected by the data-quality gate"
          + (f"; {skipped} flights skipped (--skip)" if skip else ''))
    for x in excluded:
        if x not in copies:
            print(f"  {x['flight']}: {x['reason'].splitlines()[0][:160]}")
    fitted = [(n, r) for n, r in reports if r['train_samples'] >= 200]
    print(f"with enough airborne samples to fit: {len(fitted)}")

    print('\neffects selected (flights):')
    counts = {}
    for _, r in fitted:
        for e in r['effects']:
            counts[e['effect']] = counts.get(e['effect'], 0) + 1
    print('  ' + ', '.join(f"{k} {v}" for k, v in sorted(counts.items(), key=lambda kv: -kv[1])))
    frame = sum(1 for _, r in fitted if any(e['effect'] in ('body_offset', 'world_tilt') for e in r['effects']))
    print(f"  a frame effect (body offset or world tilt): {frame} of {len(fitted)}")
    cf = [(r, {p['name']: p['value'] for e in r['effects'] if e['effect'] == 'constant_force' for p in e['params']})
          for _, r in fitted if any(e['effect'] == 'constant_force' for e in r['effects'])]
    if cf:
        tied = sum(1 for r, _ in cf if any('constant_force' in t[:2] and 'accel_bias' in t[:2] for t in r.get('not_identifiable') or []))
        ne = [v for _, p in cf for k, v in p.items() if k in ('north', 'east')]
        print(f"  constant_force: down median {median([p['down'] for _, p in cf]):+.4f} N, north/east within "
              f"{min(ne):+.4f}..{max(ne):+.4f} N; not identifiable from accel_bias in {tied} of {len(cf)}")

    def rms(r, key, channel):
        v = [e[key] for e in r['errors'] if e['channel'] == channel]
        return math.sqrt(sum(x * x for x in v) / len(v)) if v else None

    print('\nheld-out RMSE, nominal -> with the effects (median over flights):')
    for ch, unit in (('accel_kin', 'm/s²'), ('gyro', 'rad/s'), ('force', 'm/s²')):
        pairs = [(rms(r, 'rmse_before', ch), rms(r, 'rmse_after', ch)) for _, r in fitted]
        pairs = [p for p in pairs if p[0] is not None]
        worse = sum(1 for b, a in pairs if a > b * 1.001)
        print(f"  {ch:<9} {median([p[0] for p in pairs]):.3f} -> {median([p[1] for p in pairs]):.3f} {unit}; "
              f"worse after in {worse} of {len(pairs)}")
    floor = 0
    for _, r in fitted:
        x = [l for l in r['left'] if l['channel'] == 'accel_kin' and l['axis'] == 'x']
        if x and any(c.get('floor') and c['r'] < 0 for c in x[0]['correlates']):
            floor += 1
    print(f"  accel_kin x follows the Vicon attitude's pitch gap (floor, r < 0): {floor} of {len(fitted)}")

    print('\nground check against the flight (deg; |difference|, median over flights; covered: the interval covers zero):')
    ag = [(n, r['ground_agreement']) for n, r in fitted if r.get('ground_agreement')]
    for ax in ('roll', 'pitch'):
        rest = [abs(a[ax]['difference_deg']) for _, a in ag]
        cov = sum(1 for _, a in ag if a[ax]['covers'])
        beyond = [(n, a[ax]) for n, a in ag if abs(a[ax]['difference_deg']) > 1]
        print(f"  {ax:<5} rest before take-off: median {median(rest):.2f} over {len(ag)}, covered {cov}, "
              f"beyond 1°: {len(beyond)} ({sum(1 for _, t in beyond if t['covers'])} covered)")
        sp = [(a[ax], a['spin_up'][ax]) for _, a in ag if a.get('spin_up')]
        toward = sum(1 for t, s in sp if s['change_deg'] * t['difference_deg'] < 0)
        spin = [abs(s['difference_deg']) for _, s in sp]
        sbeyond = [s for _, s in sp if abs(s['difference_deg']) > 1]
        print(f"        spin-up: median {median(spin):.2f} over {len(sp)}, covered {sum(1 for _, s in sp if s['covers'])}, "
              f"beyond 1°: {len(sbeyond)} ({sum(1 for s in sbeyond if s['covers'])} covered); "
              f"moves toward the flight in {toward} of {len(sp)} (sign test p = {sign_test_p(len(sp), toward):.1g})")
        both = [a['after_landing'][ax] for _, a in ag if a.get('after_landing')]
        ref = [abs(b['bracket_difference_deg']) for b in both]
        print(f"        rests before and after: differ by a median {median([abs(b['change_deg']) for b in both]):.2f} "
              f"over {len(both)}; their mean against the flight: median {median(ref):.2f}, covered "
              f"{sum(1 for b in both if b['bracket_covers'])}")
        # split by the still pose's scatter at rest (identify's rest_pose_scatters)
        scatters = (lambda a: a['rest_pose_scatters']) if still_above is None else (lambda a: a['rest_pose_sd_deg'][0] > still_above)
        lo = [a[ax] for _, a in ag if not scatters(a)]
        hi = [a[ax] for _, a in ag if scatters(a)]
        lb = [t for t in lo if abs(t['difference_deg']) > 1]
        print(f"        still pose at rest: median {median([abs(t['difference_deg']) for t in lo]):.2f} over {len(lo)}, "
              f"beyond 1°: {len(lb)} ({sum(1 for t in lb if t['covers'])} covered); scattering (roll above {still_above or 0.02}°): "
              f"median {median([abs(t['difference_deg']) for t in hi]):.2f} over {len(hi)}; "
              f"Mann–Whitney p = {mann_whitney_greater([abs(t['difference_deg']) for t in hi], [abs(t['difference_deg']) for t in lo]):.1g}")

    c = d.get('consistency')
    if c:
        several = [m for m in c['mountings'] if len(m['flights']) > 1]
        axes = [a for m in several for a in m['axes'] if a['axis'] != 'yaw']
        print(f"\nmountings (every flight of the run, --skip or not; ground tilts all within {c['link_deg']}° of each other): "
              f"{len(several)} of several flights, the largest of {max((len(m['flights']) for m in several), default=0)}; "
              f"roll/pitch offsets agree within their intervals on {sum(1 for a in axes if a['agree'])} of {len(axes)} axes")
        pct = lambda x: 'n/a' if x is None else f"{100 * x:.0f} %"
        pts = lambda x: 'n/a' if x is None else f"{100 * x:+.0f} points"
        print(f"  transfer of the accel_kin cut: {pct(c['within_cut'])} inside a mounting ({c['within_pairs']} pairs), "
              f"{pct(c['across_cut'])} across ({c['across_pairs']}); the offset's own share {pts(c['within_offset_gain'])} inside "
              f"(worse in {c['within_offset_worse']}), {pts(c['across_offset_gain'])} across (worse in {c['across_offset_worse']})")
        if 'mounting_pairs' in c:
            print(f"  the mounting's own part (the offset against the other flights' mean offset): {pts(c['within_mounting_gain'])} inside "
                  f"(worse in {c['within_mounting_worse']} of {c['mounting_pairs'][0]}), {pts(c['across_mounting_gain'])} across "
                  f"(worse in {c['across_mounting_worse']} of {c['mounting_pairs'][1]})")

    if by_time:
        # the flights in the order they were flown (the log's first time stamp), with the
        # ground tilt and the body offset: whether a mounting is a run of consecutive flights
        print('\nby time (first time stamp, UTC): ground tilt roll/pitch -> body offset roll/pitch (deg)')
        rows = []
        for n, r in fitted:
            try:
                with open(r['source']) as f:
                    f.readline()
                    t0 = float(f.readline().split(',')[0])
            except (OSError, ValueError):
                continue
            g = r.get('ground_check')
            bo = [e for e in r['effects'] if e['effect'] == 'body_offset']
            rows.append((t0, n, g, bo[0]['params'] if bo else None))
        import datetime
        for t0, n, g, bo in sorted(rows, key=lambda x: x[0]):
            when = datetime.datetime.fromtimestamp(t0, datetime.timezone.utc).strftime('%m-%d %H:%M')
            gt = f"{g['roll_deg']:+.2f} {g['pitch_deg']:+.2f}" if g else '   —'
            ot = f"{bo[0]['value']:+.2f} {bo[1]['value']:+.2f}" if bo else '—'
            print(f"  {when}  {n:<28} {gt} -> {ot}")


if __name__ == '__main__':
    main()
