#!/usr/bin/env bash
# Wall time of one sweep flown as a Slurm job array of 1, 2 and 4 tasks (one CPU each), from
# submission to the merged output, on the cluster that SLURM_CONF (or /etc/slurm) names; and the
# scheduler's own cost per task, from arrays of tasks that fly one run each. Run from the
# checkout after `cargo build --release`:
#
#     scripts/slurm-timing.sh [RUNS]        # RUNS of sweep-hover-duration (default 2000)
#
# FLYARENA overrides the binary (default: $CARGO_TARGET_DIR/release/flyarena, else
# target/release/flyarena). Prints one line per case; each case writes into a fresh temporary folder.
set -euo pipefail
runs="${1:-2000}"
bin="${FLYARENA:-${CARGO_TARGET_DIR:-target}/release/flyarena}"
scenario="scenarios/sweep-hover-duration.yaml"
now() { date +%s%N; }
secs() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", (b - a) / 1e9 }'; }
start=$(now)
"$bin" sweep "$scenario" --runs "$runs" --quiet --out "$(mktemp -d)" > /dev/null || true
echo "no scheduler, all cores: $runs runs in $(secs "$start" "$(now)") s"
# submits RUNS runs over TASKS one-CPU array tasks and waits for the merge; prints the wall time
timed_array() {
  local runs="$1" tasks="$2" out start
  out=$(mktemp -d)
  "$bin" slurm sweep "$scenario" --runs "$runs" --tasks "$tasks" --cpus-per-task 1 --out "$out" > /dev/null
  start=$(now)
  bash "$out"/*.submit.sh --wait > /dev/null || true
  secs "$start" "$(now)"
}
for tasks in 1 2 4; do
  echo "$tasks array task(s) of 1 CPU: $runs runs in $(timed_array "$runs" "$tasks") s"
done
for tasks in 1 8; do
  echo "$tasks array task(s) of one run each, and the merge: $(timed_array "$tasks" "$tasks") s"
done
