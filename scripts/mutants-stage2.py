#!/usr/bin/env python3
"""Stage 2 of scripts/mutants.sh: every mutant that the unit tests missed (stage 1, cargo
mutants' outcomes.json) is applied to the tree, the whole suite is run against it, and the tree
is restored. Prints and appends to OUT/suite.txt one line per mutant:
caught|missed|timeout <TAB> name <TAB> the first failing test (for a caught mutant; "-" else).

Before the first mutant the suite runs once on the tree as it is (the baseline): if it fails,
every verdict would read "caught" whatever the mutant does (real flights missing, a client not
installed, a flaky test), so stage 2 stops there with exit 1 and writes no verdict.

    python3 scripts/mutants-stage2.py mutants.out [--every K] [--quick FILTER]

--every K runs a deterministic sample: every K-th missed mutant, from the first (for a large
`--in-diff` run whose stage 1 misses more than a session can rerun). --quick FILTER first runs
only the acceptance tests whose names match FILTER (e.g. `identify::`): a mutant they catch is
caught, and only a mutant they miss is run against the whole suite, so a "missed" verdict is
always the whole suite's.
"""
import json, os, re, shutil, subprocess, sys

TIMEOUT_S = 600  # the whole suite takes ~80 s with the mutants profile
# a property test that fails under a mutant writes its seed here: it belongs to the mutant, not
# to the suite, so the file is put back after every mutant
REGRESSIONS = 'tests/proptest-regressions/props.txt'
# cargo-nextest stops at the first failing test (libtest runs the whole binary, ~80 s, even
# when its first test fails); the verdict is the same, a caught mutant costs less. Without it,
# or for the doc tests (nextest does not run them), cargo test.
NEXTEST = shutil.which('cargo-nextest') is not None


# the name of a failing test in nextest's ("FAIL [   0.123s] flyarena::acceptance a::b") or
# libtest's ("test a::b ... FAILED") report
FAILED = re.compile(r'^\s*FAIL \[[^]]*\] (?:\([^)]*\) )?(\S+(?: \S+)?)\s*$|^test (\S.*?) \.\.\. FAILED\s*$', re.M)


def run(*cmd):
    """(exit code, first failing test or '-') of cmd under the time limit."""
    p = subprocess.run(['timeout', str(TIMEOUT_S), *cmd], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors='replace')
    m = FAILED.search(p.stdout)
    return p.returncode, (m.group(1) or m.group(2)) if m else '-'


def suite(*extra):
    """The suite (or the part `extra` selects) against the tree as it is: (0, '-') when it passes."""
    if not NEXTEST:
        return run('cargo', 'test', '--profile', 'mutants', *extra)
    rc = run('cargo', 'nextest', 'run', '--cargo-profile', 'mutants', '--fail-fast', *extra)
    return run('cargo', 'test', '--profile', 'mutants', '--doc') if rc[0] == 0 and not extra else rc


out = sys.argv[1]
opt = lambda name, default: sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default
every, quick = int(opt('--every', '1')), opt('--quick', None)
kept = open(REGRESSIONS).read() if os.path.exists(REGRESSIONS) else None
d = json.load(open(os.path.join(out, 'outcomes.json')))
missed = [o for o in d['outcomes'] if o.get('summary') == 'MissedMutant']
if missed:
    rc, failing = suite()
    if rc != 0:
        sys.exit(f"stage 2: the suite fails without a mutant (exit {rc}, {failing}): no verdict is written")
    print(f"stage 2: the suite passes without a mutant; {len(missed[::every])} to judge", flush=True)
with open(os.path.join(out, 'suite.txt'), 'w') as log:
    for o in missed[::every]:
        name = o['scenario']['Mutant']['name']
        diff = os.path.join(out, o['diff_path'])
        # cargo-mutants' diffs name the mutant, not the file, on their +++ line
        target = o['scenario']['Mutant']['file']
        subprocess.run(['patch', '-s', target, diff], check=True)
        try:
            # a mutant that makes a loop endless is a timeout (cargo mutants counts those apart)
            rc, failing = suite('--test', 'acceptance', quick) if quick else (0, '-')
            if rc == 0:
                rc, failing = suite()
        finally:
            subprocess.run(['patch', '-s', '-R', target, diff], check=True)
            if kept is not None:
                open(REGRESSIONS, 'w').write(kept)
        verdict = 'timeout' if rc == 124 else 'missed' if rc == 0 else 'caught'
        line = f"{verdict}\t{name}\t{failing if verdict == 'caught' else '-'}"
        print(line, flush=True)
        log.write(line + '\n')
        log.flush()
