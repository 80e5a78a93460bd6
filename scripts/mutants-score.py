#!/usr/bin/env python3
"""The mutation score of the shards measured so far (scripts/mutants-shards.tsv), with its sample.

    python3 scripts/mutants-score.py            # every shard
    python3 scripts/mutants-score.py --from 13  # shards 13 on
    python3 scripts/mutants-score.py --coverage # the intervals' coverage, measured by simulation
    python3 scripts/mutants-score.py --from 24 --alpha 0.025  # look 1 of scripts/mutants-plan.md
    python3 scripts/mutants-score.py --census DIR [--survivors]  # scripts/mutants-census.sh's count
    python3 scripts/mutants-score.py --bound-at 0.923 1410 --alpha 0.00078125  # a look projected

A shard is a deterministic round-robin sample (every 90th mutant of the issue-14 list), so the
viable mutants of the shards together are a sample of the population's viable mutants. Printed:
the pooled score at measurement (each shard against the suite of its day, before its survivors
led to tests: the estimate for mutants the suite was not tuned on), its Wilson 95 % interval,
the exact (Clopper-Pearson) one-sided 95 % lower bound, and the score now (biased upwards: the
suite was tuned on these mutants). The suite only gains tests, so a shard measured against an
older suite underestimates what today's suite catches: the at-measurement figures are
conservative for today's suite.
"""
import argparse
import math
import os
import random

Z95 = 1.959963984540054


def wilson(k, n, z=Z95):
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return c - h, c + h


def upper_tail(k, n, p):
    """P(X >= k) for X ~ Binomial(n, p), summed in logs (n of a few hundred)."""
    if p <= 0.0:
        return 0.0 if k > 0 else 1.0
    if p >= 1.0:
        return 1.0
    lp, lq = math.log(p), math.log1p(-p)
    terms = [math.lgamma(n + 1) - math.lgamma(j + 1) - math.lgamma(n - j + 1) + j * lp + (n - j) * lq for j in range(k, n + 1)]
    m = max(terms)
    return math.exp(m) * sum(math.exp(t - m) for t in terms)


def clopper_pearson_lower(k, n, alpha=0.05):
    """The smallest p that a one-sided level-alpha test would not reject given k of n: P(X >= k | p) = alpha."""
    if k == 0:
        return 0.0
    lo, hi = 0.0, k / n
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        if upper_tail(k, n, mid) < alpha:
            lo = mid
        else:
            hi = mid
    return lo


DRAWS = 20000


def coverage(n, p, alpha=0.05, draws=DRAWS, seed=14):
    """How often the two intervals contain the truth p when k ~ Binomial(n, p): the Wilson
    two-sided 95 % interval should contain it about 95 % of the time, the one-sided lower bound
    should lie below it at least 1 - alpha of the time (it is exact, hence conservative)."""
    rng = random.Random(seed)
    cp = {}
    inside = below = 0
    for _ in range(draws):
        k = sum(rng.random() < p for _ in range(n))
        lo, hi = wilson(k, n)
        inside += lo <= p <= hi
        if k not in cp:
            cp[k] = clopper_pearson_lower(k, n, alpha)
        below += cp[k] <= p
    return inside / draws, below / draws


SHARDS = 90


def census(d, survivors=False):
    """The census of scripts/mutants-census.sh in d: per finished shard, stage 1's verdicts
    (caught, missed, unviable, timeout) and stage 2's for each mutant stage 1 missed. Viable is
    every mutant that built; caught is caught by stage 1 or by the whole suite in stage 2; a
    timeout counts as not caught (a conservative reading). Until all 90 shards are done the
    counts are progress, not the score."""
    commit = open(os.path.join(d, "COMMIT"), encoding="utf-8").read().strip()
    done, m, unviable, caught, left = [], 0, 0, 0, []
    for k in range(SHARDS):
        s = os.path.join(d, "shards", str(k))
        if not os.path.exists(os.path.join(s, "DONE")):
            continue
        read = lambda f: [x.strip() for x in open(os.path.join(s, f), encoding="utf-8") if x.strip()] if os.path.exists(os.path.join(s, f)) else []
        c, miss, u, t = read("caught.txt"), read("missed.txt"), read("unviable.txt"), read("timeout.txt")
        verdicts = dict(reversed(x.split("\t", 1)) for x in read("suite.txt"))
        if sorted(verdicts) != sorted(miss):
            raise SystemExit(f"{s}: stage 2 judged {len(verdicts)} mutants, stage 1 missed {len(miss)}")
        done.append(k)
        m += len(c) + len(miss) + len(u) + len(t)
        unviable += len(u)
        caught += len(c) + sum(v == "caught" for v in verdicts.values())
        left += [f"{k}\tstage 1 timeout\t{x}" for x in t] + [f"{k}\t{v}\t{x}" for x, v in verdicts.items() if v != "caught"]
    n = m - unviable
    print(f"census of {commit}: {len(done)} of {SHARDS} shards done, {m} mutants, {n} viable")
    if n:
        state = "the score: every mutant of the list" if len(done) == SHARDS else "progress, not the score: the census decides when all shards are done"
        print(f"caught: {caught} of {n} = {100 * caught / n:.1f} % ({state})")
    if survivors:
        print("\n".join(left))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--census", metavar="DIR", help="count the census of scripts/mutants-census.sh in DIR instead of the shards table")
    ap.add_argument("--survivors", action="store_true", help="with --census: list the viable mutants not caught")
    ap.add_argument("--bound-at", nargs=2, type=float, metavar=("P", "N"), help="the one-sided lower bound (at --alpha) of round(P·N) caught of N: a later look projected at the rate P")
    ap.add_argument("--from", dest="first", type=int, default=None, help="first shard to include")
    ap.add_argument("--to", dest="last", type=int, default=None, help="last shard to include")
    ap.add_argument("--table", default=os.path.join(os.path.dirname(__file__), "mutants-shards.tsv"))
    ap.add_argument("--alpha", type=float, default=0.05, help="one-sided level of the lower bound (scripts/mutants-plan.md spends 0.05 over repeated looks)")
    ap.add_argument("--coverage", action="store_true", help="measure the intervals' coverage at the pooled sample size")
    a = ap.parse_args()
    if a.census:
        return census(a.census, a.survivors)
    if a.bound_at:
        p, n = a.bound_at[0], int(a.bound_at[1])
        k = round(p * n)
        return print(f"{k} of {n} ({100 * p:g} %): one-sided {100 * (1 - a.alpha):g} % lower bound {100 * clopper_pearson_lower(k, n, a.alpha):.2f} %")
    rows = []
    for line in open(a.table, encoding="utf-8"):
        if line.startswith("#") or line.startswith("shard") or not line.strip():
            continue
        shard, session, mutants, unviable, viable, at, now = (int(x) for x in line.split("\t"))
        if viable != mutants - unviable or not 0 <= at <= viable or not 0 <= now <= viable:
            raise SystemExit(f"{a.table}: shard {shard}: inconsistent counts")
        if (a.first is None or shard >= a.first) and (a.last is None or shard <= a.last):
            rows.append((shard, mutants, viable, at, now))
    if not rows:
        raise SystemExit("no shard in that range")
    m = sum(r[1] for r in rows)
    n = sum(r[2] for r in rows)
    k = sum(r[3] for r in rows)
    now = sum(r[4] for r in rows)
    lo, hi = wilson(k, n)
    print(f"shards {rows[0][0]}-{rows[-1][0]} ({len(rows)} shards, {m} mutants, {n} viable)")
    print(f"caught at measurement: {k} of {n} = {100 * k / n:.1f} % (Wilson 95 %: {100 * lo:.1f}-{100 * hi:.1f} %; one-sided {100 * (1 - a.alpha):g} % lower bound, Clopper-Pearson: {100 * clopper_pearson_lower(k, n, a.alpha):.1f} %)")
    print(f"caught now: {now} of {n} = {100 * now / n:.1f} %")
    if a.coverage:
        for p in (0.90, 0.93):
            w, c = coverage(n, p, a.alpha)
            print(f"coverage at n = {n}, p = {p:.2f} ({DRAWS:,} draws): Wilson {100 * w:.1f} %, one-sided {100 * (1 - a.alpha):g} % lower bound {100 * c:.1f} %")


if __name__ == "__main__":
    main()
