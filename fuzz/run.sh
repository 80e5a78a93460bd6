#!/usr/bin/env bash
# Runs the cargo-fuzz targets for SECONDS each (default 300), from corpora seeded with the
# project's scenarios, a flight log and the head of a NanoBench flight. Works on stable Rust
# without a sanitizer (`-s none`: libFuzzer's coverage guidance, Rust's own panics and overflow
# checks); with a nightly toolchain drop `-s none` to add AddressSanitizer.
#   cargo install cargo-fuzz && fuzz/run.sh 300
# Crashes land in fuzz/artifacts/<target>/; each one found so far is a regression test in
# tests/acceptance (docs/verification.md).
set -euo pipefail
cd "$(dirname "$0")"
secs=${1:-300}
# the real data: $FLYARENA_DATA, else data/ in the checkout (scripts/fetch-data), else ../shared/data
data=${FLYARENA_DATA:-../data}
[ -d "$data/nanobench" ] || data=../../shared/data
mkdir -p corpus/scenario_parser corpus/log_reader corpus/mapped_log
cp ../scenarios/*.yaml corpus/scenario_parser/
( cd .. && CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/flyarena-target}" cargo run --release --quiet -- run scenarios/fig7-no-offsets.yaml --no-rrd --quiet --out /tmp/flyarena-fuzz --log /tmp/flyarena-fuzz/log.csv >/dev/null || true )
head -c 60000 /tmp/flyarena-fuzz/log.csv > corpus/log_reader/fig7.csv
if [ -d "$data/nanobench/dataset" ]; then
  head -n 400 "$data/nanobench/dataset/B3_figure8_medium_rep2.csv" > corpus/mapped_log/b3-head.csv
fi
for t in scenario_parser log_reader mapped_log; do
  cargo fuzz run -s none -O "$t" "corpus/$t" -- -max_total_time="$secs" -max_len=65536 2>&1 | tail -3
done
