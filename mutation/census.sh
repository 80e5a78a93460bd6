#!/usr/bin/env bash
# The mutation census: every mutant of the list, all 90 shards of
# mutation/mutants.sh, against one suite (one commit), so the score has no sampling error.
#
#   mutation/census.sh DIR [COMMIT]      # 31-51 min a shard on 2 cores (~60 h); restartable
#   python3 mutation/score.py --census [--survivors]
#
# The census's results live in the clone, in mutation/census.tsv (committed, one row per
# mutant; its first line names the commit and the cargo-mutants version): a machine's caches
# may not outlive a run, so a finished shard counts only once it is in that table. A shard
# enters the table whole, after both stages finished; run again (on any machine), the census
# skips the shards the table holds and starts the others from their beginning. It refuses a
# COMMIT or a cargo-mutants version other than the table's (one census, one suite, one list).
#
# DIR is scratch and must lie outside the clone: a clone of COMMIT (DIR/tree), its own build
# cache (DIR/target: a census never waits on, nor disturbs, the user's builds) and per shard
# DIR/shards/K (cargo mutants' mutants.out with stage 2's suite.txt and the shard's log). The
# suite runs as CI runs it (CI=true, snapshots never written, the Python clients of .ci/run
# installed, so no test skips for want of one); the real flights are read from FLYARENA_DATA
# (default: the clone's ../shared/data).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
dir="$(realpath -m "${1:?usage: mutation/census.sh DIR [COMMIT]}")"
case "$dir/" in
"$here"/*) echo "mutants-census: $dir is inside the clone ($here); name a folder outside it" >&2; exit 2 ;;
esac
table="$here/mutation/census.tsv"
commit="$(git -C "$here" rev-parse --verify "${2:-HEAD}^{commit}")"
version="$(cargo mutants --version)"
head="# census of $commit ($version)"
if [ -e "$table" ]; then
    if [ "$(head -n 1 "$table")" != "$head" ]; then
        echo "mutants-census: $table holds '$(head -n 1 "$table")', not '$head': one census, one suite, one mutant list" >&2
        exit 2
    fi
else
    printf '%s\n%s\n' "$head" "# shard	verdict	stage	mutant	first failing test (mutation/score.py --census counts it)" > "$table"
fi
mkdir -p "$dir"
if [ "$(cat "$dir/COMMIT" 2> /dev/null)" != "$commit" ]; then
    # scratch of another census (or none): start it afresh
    rm -rf "$dir/tree" "$dir/shards" "$dir/COMMIT"
    git clone -q --no-checkout "$here" "$dir/tree"
    git -C "$dir/tree" checkout -q "$commit"
    echo "$commit" > "$dir/COMMIT"
fi
export CARGO_TARGET_DIR="$dir/target"
# the tree lies elsewhere, so the real flights are found where the clone finds them
export FLYARENA_DATA="${FLYARENA_DATA:-$here/../shared/data}"
export CI=true INSTA_UPDATE=no
eval "$(grep '^PY_CLIENTS=' "$dir/tree/.ci/run")"
# shellcheck disable=SC2086  # the list is words
python3 -m pip install --quiet --disable-pip-version-check $PY_CLIENTS \
  || python3 -m pip install --quiet --disable-pip-version-check --break-system-packages $PY_CLIENTS
mkdir -p "$dir/shards"
# A census killed mid-build can leave this crate's incremental cache
# half written: the next baseline build then fails to link ("undefined hidden symbol")
# and no mutant is tested. Start every run from this crate's clean artefacts
# (the dependencies stay built; about two minutes).
(cd "$dir/tree" && cargo clean --quiet --profile mutants -p flyarena)
rm -rf "$dir/target/mutants/incremental"
for k in $(seq 0 89); do
    # awk reads the whole table: `cut | grep -q` under pipefail failed whenever grep's early exit
    # broke cut's pipe (3 in 200 for a 190 kB table), and a restart began a finished shard again
    if awk -F '\t' -v k="$k" '$1 == k { found = 1 } END { exit !found }' "$table"; then continue; fi
    # Stage 2 first runs the suite without a mutant and gives no verdict if that fails. The
    # commit's suite has tests that can fail on a loaded machine (33c1bbe: a sweep named the bad
    # run a thread met first, fixed on main after it; a real-time network test): such a shard
    # starts again, twice at most, its failed logs kept as DIR/shards/K.baseline-N{,.suite}.log. Any
    # other failure, or a third, stops the census.
    for attempt in 1 2 3; do
        # a shard cut short left the tree mutated and its outcomes partial: restore, start it again
        git -C "$dir/tree" checkout -q -- .
        git -C "$dir/tree" clean -q -fdx
        rm -rf "$dir/shards/$k"
        echo "mutants-census: shard $k of 90: start $(date -u +%FT%TZ)"
        if "$dir/tree/mutation/mutants.sh" "$k" 90 > "$dir/shards/$k.log" 2>&1; then
            break
        fi
        if [ "$attempt" -lt 3 ] && grep -q "the suite fails without a mutant" "$dir/shards/$k.log"; then
            mv "$dir/shards/$k.log" "$dir/shards/$k.baseline-$attempt.log"
            # stage 2 (after d99dfea) keeps the failing suite's output; the restart cleans the tree
            if [ -f "$dir/tree/mutants.out/baseline-suite.log" ]; then
                mv "$dir/tree/mutants.out/baseline-suite.log" "$dir/shards/$k.baseline-$attempt.suite.log"
            fi
            echo "mutants-census: shard $k of 90: stage 2's baseline failed ($(grep -o 'the suite fails without a mutant.*' "$dir/shards/$k.baseline-$attempt.log" | head -n 1)); the shard starts again"
            continue
        fi
        echo "mutants-census: shard $k failed (its log: $dir/shards/$k.log)" >&2
        exit 1
    done
    mv "$dir/tree/mutants.out" "$dir/shards/$k"
    mv "$dir/shards/$k.log" "$dir/shards/$k/shard.log"
    # both stages restore every file they mutate: a tree that differs from COMMIT now is a fault
    if [ -n "$(git -C "$dir/tree" status --porcelain)" ]; then
        echo "mutants-census: shard $k left the tree changed:" >&2
        git -C "$dir/tree" status --porcelain >&2
        exit 1
    fi
    python3 "$here/mutation/score.py" --census-add "$dir/shards/$k" "$k" "$table"
    echo "mutants-census: shard $k of 90: done $(date -u +%FT%TZ)"
done
python3 "$here/mutation/score.py" --census "$table"
