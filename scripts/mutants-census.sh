#!/usr/bin/env bash
# The census of issue 14's mutation score: every mutant of the list, all 90 shards of
# scripts/mutants.sh, against one suite (one commit), so the score has no sampling error.
#
#   scripts/mutants-census.sh DIR [COMMIT]      # ~27 h on 2 cores; restartable
#   python3 scripts/mutants-score.py --census DIR
#
# DIR must lie outside the clone. It receives a clone of COMMIT (default HEAD) in DIR/tree, its
# own build cache in DIR/target (a census never waits on, nor disturbs, the user's builds), and
# per shard DIR/shards/K: stage 1's mutants.out with stage 2's suite.txt, and DONE once both
# stages finished. Run again, it skips the shards marked DONE and reruns from its start a shard
# that was cut short; it refuses a COMMIT other than the one the census began with. The real
# flights are read from FLYARENA_DATA (default: the clone's ../shared/data).
set -euo pipefail
here="$(cd "$(dirname "$0")/.." && pwd)"
dir="$(realpath -m "${1:?usage: scripts/mutants-census.sh DIR [COMMIT]}")"
case "$dir/" in
"$here"/*) echo "mutants-census: $dir is inside the clone ($here); name a folder outside it" >&2; exit 2 ;;
esac
mkdir -p "$dir"
commit="$(git -C "$here" rev-parse --verify "${2:-HEAD}^{commit}")"
if [ -e "$dir/COMMIT" ]; then
    if [ "$(cat "$dir/COMMIT")" != "$commit" ]; then
        echo "mutants-census: $dir holds the census of $(cat "$dir/COMMIT"), not of $commit: one census, one suite" >&2
        exit 2
    fi
else
    rm -rf "$dir/tree"
    git clone -q --no-checkout "$here" "$dir/tree"
    git -C "$dir/tree" checkout -q "$commit"
    echo "$commit" > "$dir/COMMIT"
fi
export CARGO_TARGET_DIR="$dir/target"
# the tree lies elsewhere, so the real flights are found where the clone finds them
export FLYARENA_DATA="${FLYARENA_DATA:-$here/../shared/data}"
mkdir -p "$dir/shards"
for k in $(seq 0 89); do
    [ -e "$dir/shards/$k/DONE" ] && continue
    # a shard cut short left the tree mutated and its outcomes partial: restore, start it again
    git -C "$dir/tree" checkout -q -- .
    rm -rf "$dir/tree/mutants.out" "$dir/shards/$k"
    echo "census shard $k of 90: start $(date -u +%FT%TZ)"
    "$dir/tree/scripts/mutants.sh" "$k" 90 > "$dir/shards/$k.log" 2>&1
    mv "$dir/tree/mutants.out" "$dir/shards/$k"
    mv "$dir/shards/$k.log" "$dir/shards/$k/shard.log"
    touch "$dir/shards/$k/DONE"
    echo "census shard $k of 90: done $(date -u +%FT%TZ)"
done
python3 "$here/scripts/mutants-score.py" --census "$dir"
