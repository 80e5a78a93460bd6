#!/usr/bin/env python3
"""Stage 2 of mutation/mutants.sh: every mutant that the unit tests missed (stage 1, cargo
mutants' outcomes.json) is applied to the tree, the whole suite is run against it, and the tree
is restored. Prints and appends to OUT/suite.txt one line per mutant:
caught|missed|timeout <TAB> name <TAB> the first failing test (for a caught mutant; "-" else).

Before the first mutant the suite runs once on the tree as it is (the baseline): if it fails,
every verdict would read "caught" whatever the mutant does (real flights missing, a client not
installed), so stage 2 stops there with exit 1 and writes no verdict.

A failure is confirmed before it counts: the first failing test is run again alone, the mutant
still applied. A test that fails in the suite and passes alone failed for something else than
the mutant (a flaky test, such as a network test on a loaded machine); the suite then runs once more, and a mutant with no confirmed
failure after that is missed, its line saying which test failed unconfirmed.

A stage-1 "unviable" whose build log holds no rustc error (`error[E`) failed at the link, a
fault of incremental compilation (rust-lang/rust#81280): it is built again without incremental
compilation and judged like a missed mutant (its line says "rebuilt without incremental"), and
stays unviable only if that build fails too. Likewise a failure that names no test is
confirmed only by a non-incremental rebuild failing again.

    python3 mutation/stage2.py mutants.out [--every K] [--quick FILTER]

--every K runs a deterministic sample: every K-th missed mutant, from the first (for a large
`--in-diff` run whose stage 1 misses more than there is time to rerun). --quick FILTER first runs
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


# the output of the last command `run` ran (kept for a failing baseline: what failed, and how)
LAST_OUTPUT = ['']


def run(*cmd, incremental=True):
    """(exit code, first failing test or '-', cmd) of cmd under the time limit."""
    env = None if incremental else {**os.environ, 'CARGO_INCREMENTAL': '0'}
    p = subprocess.run(['timeout', str(TIMEOUT_S), *cmd], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, errors='replace', env=env)
    LAST_OUTPUT[0] = p.stdout
    m = FAILED.search(p.stdout)
    return p.returncode, (m.group(1) or m.group(2)) if m else '-', cmd


def suite(*extra, incremental=True):
    """The suite (or the part `extra` selects) against the tree as it is: (0, '-', cmd) when it
    passes, else the exit code, the first failing test and the command that ran it."""
    if not NEXTEST:
        return run('cargo', 'test', '--profile', 'mutants', *extra, incremental=incremental)
    rc = run('cargo', 'nextest', 'run', '--cargo-profile', 'mutants', '--fail-fast', *extra, incremental=incremental)
    return run('cargo', 'test', '--profile', 'mutants', '--doc', incremental=incremental) if rc[0] == 0 and not extra else rc


def fails_alone(failing, cmd, incremental=True):
    """Whether the test `failing` (as `cmd`'s report named it) fails again when run alone, built
    as the suite was (an incremental rebuild could fail at the link, rust-lang/rust#81280, and
    read as a failure); a failure that names no test (the tests did not build) is confirmed by
    the suite failing again when built without incremental compilation, whose link failures
    are no catch."""
    if failing == '-':
        return run(*cmd, incremental=False)[0] not in (0, 124)
    if cmd[:3] == ('cargo', 'nextest', 'run'):
        binary, _, test = failing.partition(' ')
        return run('cargo', 'nextest', 'run', '--cargo-profile', 'mutants', '-E', f'binary_id({binary}) & test(={test})', incremental=incremental)[0] not in (0, 124)
    # libtest: the exact name; a doc test by its name as a filter (rustdoc's merged doc tests
    # do not answer to --exact)
    exact = () if re.search(r' - .*\(line \d+\)$', failing) else ('--exact',)
    return run(*cmd, '--', *exact, failing, incremental=incremental)[0] not in (0, 124)


def judge(quick, incremental=True):
    """The mutant applied now: 'caught', 'missed' or 'timeout', and what the line says of it."""
    unconfirmed = []
    for _ in range(2):
        rc, failing, cmd = suite('--test', 'acceptance', quick, incremental=incremental) if quick else (0, '-', ())
        if rc == 0:
            rc, failing, cmd = suite(incremental=incremental)
        if rc == 124:
            return 'timeout', '-'
        if rc == 0:
            break
        if fails_alone(failing, cmd, incremental):
            return 'caught', failing
        unconfirmed.append(failing)
    return 'missed', f"unconfirmed: {', '.join(unconfirmed)} failed in the suite and passed alone" if unconfirmed else '-'


out = sys.argv[1]
opt = lambda name, default: sys.argv[sys.argv.index(name) + 1] if name in sys.argv else default
every, quick = int(opt('--every', '1')), opt('--quick', None)
kept = open(REGRESSIONS).read() if os.path.exists(REGRESSIONS) else None
d = json.load(open(os.path.join(out, 'outcomes.json')))
missed = [o for o in d['outcomes'] if o.get('summary') == 'MissedMutant']


def link_fault(o):
    """A stage-1 "unviable" whose build failed without a rustc error (no `error[E`): a link
    failure of incremental compilation (rust-lang/rust#81280), not a mutant that cannot build."""
    return o.get('summary') == 'Unviable' and 'error[E' not in open(os.path.join(out, o['log_path']), errors='replace').read()


# judged again, built without incremental compilation: unviable only if that build fails too
rebuilt = [o for o in d['outcomes'] if link_fault(o)]
if missed or rebuilt:
    rc, failing, _ = suite()
    if rc != 0:
        # keep the output: a real-time test can fail on an overloaded machine
        path = os.path.join(out, 'baseline-suite.log')
        with open(path, 'w') as log:
            log.write(LAST_OUTPUT[0])
        sys.exit(f"stage 2: the suite fails without a mutant (exit {rc}, {failing}; its output: {path}): no verdict is written")
    print(f"stage 2: the suite passes without a mutant; {len(missed[::every])} to judge, {len(rebuilt)} unviable by a link failure to rebuild", flush=True)
with open(os.path.join(out, 'suite.txt'), 'w') as log:
    for o in missed[::every] + rebuilt:
        name = o['scenario']['Mutant']['name']
        diff = os.path.join(out, o['diff_path'])
        # cargo-mutants' diffs name the mutant, not the file, on their +++ line
        target = o['scenario']['Mutant']['file']
        subprocess.run(['patch', '-s', target, diff], check=True)
        try:
            # a mutant that makes a loop endless is a timeout (cargo mutants counts those apart)
            if o in rebuilt:
                builds = run('cargo', 'test', '--profile', 'mutants', '--no-run', incremental=False)[0] == 0
                verdict, said = judge(quick, incremental=False) if builds else ('unviable', 'it does not build')
                said = f"rebuilt without incremental; {said}"
            else:
                verdict, said = judge(quick)
        finally:
            subprocess.run(['patch', '-s', '-R', target, diff], check=True)
            if kept is not None:
                open(REGRESSIONS, 'w').write(kept)
        line = f"{verdict}\t{name}\t{said}"
        print(line, flush=True)
        log.write(line + '\n')
        log.flush()
