#!/usr/bin/env python3
"""The mutation score of the shards measured so far (mutation/shards.tsv), with its sample.

    python3 mutation/score.py            # every shard
    python3 mutation/score.py --from 13  # shards 13 on
    python3 mutation/score.py --coverage # the intervals' coverage, measured by simulation
    python3 mutation/score.py --from 24 --alpha 0.025  # shards 24 on, a one-sided 97.5 % bound
    python3 mutation/score.py --census [--survivors]  # mutation/census.tsv's count
    python3 mutation/score.py --bound-at 0.923 1410 --alpha 0.00078125  # a look projected

A shard is a deterministic round-robin sample (every 90th mutant of the list of mutation/mutants.sh), so the
viable mutants of the shards together are a sample of the population's viable mutants. Printed:
the pooled score at measurement (each shard against the suite of its day, before its survivors
led to tests: the estimate for mutants the suite was not tuned on), its Wilson 95 % interval,
the exact (Clopper-Pearson) one-sided 95 % lower bound, and the score now (biased upwards: the
suite was tuned on these mutants). The suite only gains tests, so a shard measured against an
older suite underestimates what today's suite catches: the at-measurement figures are
conservative for today's suite.
"""
import argparse
import json
import math
import os
import random
import re

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
CENSUS = os.path.join(os.path.dirname(os.path.abspath(__file__)), "census.tsv")
SHARDS_TABLE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "shards.tsv")
STAGE1 = {"CaughtMutant": "caught", "MissedMutant": "missed", "Unviable": "unviable", "Timeout": "timeout"}


def census_rows(shard_dir, k):
    """One finished shard of mutation/census.sh as rows of mutation/census.tsv:
    shard, verdict (caught, missed, timeout, unviable), the stage that gave it (1: the unit
    tests in cargo mutants; 2: the whole suite, mutation/stage2.py, for each mutant stage
    1 missed), the mutant, and for a caught mutant the first failing test (confirmed alone),
    for a missed one the tests that failed in the suite but passed alone (or "-")."""
    d = json.load(open(os.path.join(shard_dir, "outcomes.json"), encoding="utf-8"))
    stage2 = {}
    path = os.path.join(shard_dir, "suite.txt")
    for line in open(path, encoding="utf-8") if os.path.exists(path) else []:
        if line.strip():
            verdict, name, failing = line.rstrip("\n").split("\t")
            stage2[name] = (verdict, failing)
    rows = []
    for o in d["outcomes"]:
        if o["scenario"] == "Baseline":
            if o["summary"] != "Success":
                raise SystemExit(f"{shard_dir}: stage 1's baseline did not pass ({o['summary']})")
            continue
        name = o["scenario"]["Mutant"]["name"]
        if o["summary"] not in STAGE1 or "\t" in name:
            raise SystemExit(f"{shard_dir}: {name}: unexpected outcome {o['summary']}")
        verdict, stage, failing = STAGE1[o["summary"]], 1, "-"
        if verdict == "missed":
            if name not in stage2:
                raise SystemExit(f"{shard_dir}: {name}: stage 1 missed it and stage 2 has no verdict")
            (verdict, failing), stage = stage2.pop(name), 2
        elif verdict == "unviable" and name in stage2:
            # stage 1's build failed at the link (rust-lang/rust#81280): stage 2 built it again
            (verdict, failing), stage = stage2.pop(name), 2
        rows.append(f"{k}\t{verdict}\t{stage}\t{name}\t{failing}")
    if stage2:
        raise SystemExit(f"{shard_dir}: stage 2 judged mutants stage 1 did not miss: {sorted(stage2)}")
    if not rows:
        raise SystemExit(f"{shard_dir}: no mutant")
    return rows


def census_add(shard_dir, k, table):
    """Append a finished shard's rows to the census table in one replace (a shard is in the
    table whole or not at all); a shard already there is refused."""
    lines = open(table, encoding="utf-8").read().splitlines()
    if any(x.split("\t", 1)[0] == str(k) for x in lines if not x.startswith("#")):
        raise SystemExit(f"{table}: shard {k} is there already")
    tmp = table + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write("\n".join(lines + census_rows(shard_dir, k)) + "\n")
    os.replace(tmp, table)


def census(table, survivors=False):
    """The census table's count: viable is every mutant that built; caught is caught by stage
    1 or by the whole suite in stage 2; a timeout counts as not caught (a conservative reading).
    Until all 90 shards are in, the counts are progress, not the score."""
    head = [x for x in open(table, encoding="utf-8").read().splitlines() if x.startswith("# census of ")]
    rows = [x.split("\t") for x in open(table, encoding="utf-8").read().splitlines() if x and not x.startswith("#")]
    if len(head) != 1 or any(len(r) != 5 or r[1] not in STAGE1.values() or r[2] not in ("1", "2") for r in rows):
        raise SystemExit(f"{table}: not a census table (one '# census of' line, rows of five columns)")
    done = sorted({int(r[0]) for r in rows})
    # a table of another round-robin (the modules outside the census) names its shard count
    of = re.search(r"(\d+) shards", head[0])
    shards = int(of.group(1)) if of else SHARDS
    m, unviable = len(rows), sum(r[1] == "unviable" for r in rows)
    caught = sum(r[1] == "caught" for r in rows)
    n = m - unviable
    print(f"{head[0][2:]}: {len(done)} of {shards} shards done, {m} mutants, {n} viable")
    if n:
        state = "the score: every mutant of the list" if done == list(range(shards)) else "progress, not the score: the census decides when all shards are done"
        print(f"caught: {caught} of {n} = {100 * caught / n:.1f} % ({state})")
        print(f"by stage: {sum(r[1] == 'caught' and r[2] == '1' for r in rows)} by the unit tests, {sum(r[1] == 'caught' and r[2] == '2' for r in rows)} by the whole suite; not caught: {sum(r[1] == 'missed' for r in rows)} missed ({sum(r[4].startswith('unconfirmed') for r in rows)} of them failed a test that then passed alone), {sum(r[1] == 'timeout' for r in rows)} timeouts")
        # the shards no earlier sample measured: mutants the suite was never tuned on
        # (the earlier sample's shards are the census's; no test was tuned on another set)
        sampled = {int(x.split("\t")[0]) for x in open(SHARDS_TABLE, encoding="utf-8") if x[:1].isdigit()} if not of else set()
        fresh = [r for r in rows if int(r[0]) not in sampled and r[1] != "unviable"]
        if fresh:
            kf = sum(r[1] == "caught" for r in fresh)
            lo, hi = wilson(kf, len(fresh))
            print(f"on the {len(set(r[0] for r in fresh))} shards never sampled before the census (mutants the suite was not tuned on): {kf} of {len(fresh)} = {100 * kf / len(fresh):.1f} % (Wilson 95 %: {100 * lo:.1f}-{100 * hi:.1f} %)")
    if survivors:
        print("\n".join(f"{r[0]}\t{r[1]}\t{r[3]}" for r in rows if r[1] in ("missed", "timeout")))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--census", nargs="?", const=CENSUS, metavar="TABLE", help="count the census (mutation/census.tsv unless TABLE) instead of the shards table")
    ap.add_argument("--survivors", action="store_true", help="with --census: list the viable mutants not caught")
    ap.add_argument("--census-add", nargs=3, metavar=("SHARD_DIR", "K", "TABLE"), help="append finished shard K (mutation/census.sh) to the census TABLE")
    ap.add_argument("--bound-at", nargs=2, type=float, metavar=("P", "N"), help="the one-sided lower bound (at --alpha) of round(P·N) caught of N: a later look projected at the rate P")
    ap.add_argument("--from", dest="first", type=int, default=None, help="first shard to include")
    ap.add_argument("--to", dest="last", type=int, default=None, help="last shard to include")
    ap.add_argument("--table", default=SHARDS_TABLE)
    ap.add_argument("--alpha", type=float, default=0.05, help="one-sided level of the lower bound")
    ap.add_argument("--coverage", action="store_true", help="measure the intervals' coverage at the pooled sample size")
    a = ap.parse_args()
    if a.census_add:
        return census_add(a.census_add[0], int(a.census_add[1]), a.census_add[2])
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
        shard, mutants, unviable, viable, at, now = (int(x) for x in line.split("\t"))
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
