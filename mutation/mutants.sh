#!/usr/bin/env bash
# A deterministic mutation sample of the modules in `files` below, affordable on 2 cores.
#
#   mutation/mutants.sh 12 90             # shard 12 of 90: every 90th mutant (round-robin), ~47 of ~4,200
#   mutation/mutants.sh 3 100 outside     # the same over the modules the census leaves out
#                                         # (serve, engine, estimate, guidance and identify's
#                                         # ros2, design, ground, consistency, series, mapping:
#                                         # 2,466 mutants, ~25 a shard of 100)
#
# Two stages, so that a mutant costs seconds rather than minutes:
#  1. `cargo mutants` with the `mutants` profile (Cargo.toml: this crate at opt-level 1,
#     incremental, no debug info; the dependencies optimised) against the library's unit tests;
#  2. every mutant they miss is applied by hand and the whole suite (`cargo test`, the acceptance
#     tests with the real flights included) is run against it: a mutant the suite catches is
#     caught, one it misses is a survivor.
# The tree is mutated in place (cargo-mutants and stage 2 restore it): do not edit while it
# runs. Results: mutants.out/{caught,missed,unviable,timeout}.txt for stage 1,
# mutants.out/suite.txt for stage 2 (verdict, mutant and the first failing test, confirmed alone, after a baseline
# run of the unmutated suite: `mutation/stage2.py`).
set -euo pipefail
cd "$(dirname "$0")/.."
shard="${1:-0}"
of="${2:-30}"
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/flyarena-target}"
case "${3:-core}" in
    core) files=(src/control.rs src/calibrate src/mocap src/radio.rs src/link.rs src/requirements.rs src/vehicle src/identify/select src/identify/stats.rs) ;;
    outside) files=(src/serve src/engine src/estimate.rs src/guidance.rs src/identify/ros2.rs src/identify/design.rs src/identify/ground.rs src/identify/consistency.rs src/identify/series.rs src/identify/mapping.rs) ;;
    *) echo "mutants.sh: the set is core or outside, not $3" >&2; exit 2 ;;
esac
args=()
for f in "${files[@]}"; do
    if [ -d "$f" ]; then
        while IFS= read -r g; do args+=(--file "$g"); done < <(find "$f" -name '*.rs' | sort)
    else
        args+=(--file "$f")
    fi
done
# stage 1. Exit 2 means "some mutants were missed", which stage 2 decides; 3, "some timed out",
# takes precedence over 2 (a shard with a timeout and misses exits 3); anything else is a harness fault.
cargo mutants --in-place --profile mutants --timeout 300 "${args[@]}" --shard "$shard/$of" --sharding round-robin -- --lib || {
    rc=$?
    [ "$rc" -eq 2 ] || [ "$rc" -eq 3 ]
}
# stage 2: the whole suite against each mutant stage 1 missed
python3 mutation/stage2.py mutants.out
