#!/usr/bin/env bash
# A deterministic mutation sample of the modules issue 14 names, affordable on 2 cores.
#
#   scripts/mutants.sh 0 30     # shard 0 of 30: every 30th mutant (round-robin), ~1/30 of ~2,800
#
# Each mutant costs an incremental release build of the crate and the test suite (~2 min here),
# so the whole set (~2,800) is a multi-day job on one machine; shards of a round-robin split are
# representative samples that can be run one after another (or on several machines) and their
# outcomes added. The tree is mutated in place (cargo-mutants restores it): do not edit while it
# runs. Results: mutants.out/{caught,missed,unviable,timeout}.txt; survivors go to
# mutants-survivors.txt with a reason each (equivalent, or accepted and why).
set -euo pipefail
cd "$(dirname "$0")/.."
shard="${1:-0}"
of="${2:-30}"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/flyarena-target}"
files=(src/control.rs src/calibrate src/mocap src/radio.rs src/link.rs src/requirements.rs src/vehicle src/identify/select src/identify/stats.rs)
args=()
for f in "${files[@]}"; do
    if [ -d "$f" ]; then
        while IFS= read -r g; do args+=(--file "$g"); done < <(find "$f" -name '*.rs' | sort)
    else
        args+=(--file "$f")
    fi
done
cargo mutants --in-place --profile release --timeout 240 "${args[@]}" --shard "$shard/$of" --sharding round-robin
