#!/usr/bin/env bash
# Fuzzes flyarena's parsers with libFuzzer (cargo-fuzz), SECONDS per target (default 300),
# TARGETs given or all, JOBS targets at a time (default 1; one core each):
#   cargo install cargo-fuzz && fuzz/run.sh 3600 ulog_join mcap_join
#   JOBS=2 fuzz/run.sh 3600
# Targets (fuzz/fuzz_targets/): scenario_parser (scenario YAML), log_reader (flyarena's flight
# log), mapped_log (a CSV through the NanoBench mapping and `identify`), serve_packet (what
# `serve` reads on its command port: commands, offset reports, NatNet requests), ulog_join (a
# PX4 log through px4-ulog and the join), mcap_join (a ROS 2 bag through mcap and the join).
# Corpora (fuzz/corpus/<target>, kept between runs) are seeded with the project's scenarios, a
# flight log, the head of a NanoBench flight, the packets real clients sent
# (fuzz/seeds/serve_packet, fuzz/capture-packets.sh), short PX4 logs written by pyulog 1.2.1 and
# its sample logs, and short ROS 2 bags written by mcap-ros2-support.
# Stable Rust without a sanitizer (`-s none`: libFuzzer's coverage guidance, Rust's own panics,
# with debug assertions and overflow checks on: `-a`); with a nightly toolchain drop `-s none`
# to add AddressSanitizer. Each target's last line and any finding go to fuzz/logs/<target>.log;
# crashes land in fuzz/artifacts/<target>/, and each one is a regression test
# (docs/verification.md).
set -euo pipefail
cd "$(dirname "$0")"
secs=${1:-300}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(scenario_parser log_reader mapped_log serve_packet ulog_join mcap_join)
export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/flyarena-fuzz-target}"
# the real data: $FLYARENA_DATA, else data/ in the checkout (scripts/fetch-data), else ../shared/data
data=${FLYARENA_DATA:-../data}
[ -d "$data/nanobench" ] || data=../../shared/data
flight=$data/nanobench/dataset/B3_figure8_medium_rep2.csv
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p logs
for t in "${targets[@]}"; do
  c=corpus/$t
  [ -d "$c" ] && [ -n "$(ls -A "$c")" ] && continue
  mkdir -p "$c"
  case $t in
    scenario_parser) cp ../scenarios/*.yaml "$c/" ;;
    log_reader)
      ( cd .. && CARGO_TARGET_DIR="$HOME/.cache/flyarena-target" cargo run --release --quiet -- run scenarios/fig7-no-offsets.yaml --no-rrd --quiet --out "$tmp/run" --log "$tmp/run/log.csv" >/dev/null || true )
      head -c 60000 "$tmp/run/log.csv" > "$c/fig7.csv" ;;
    mapped_log) head -n 400 "$flight" > "$c/b3-head.csv" ;;
    serve_packet) cp seeds/serve_packet/* "$c/" ;;
    ulog_join)
      for n in 60 400; do head -n $((n + 1)) "$flight" > "$tmp/b3-$n.csv"; python3 ../scripts/to-ulog.py nanobench "$tmp/b3-$n.csv" "$c/b3-$n.ulg"; done
      # pyulog's own sample logs (its source distribution's test/): heads, and one whole log
      # with appended data sections
      pip download --quiet pyulog==1.2.1 --no-deps --no-binary :all: -d "$tmp" && tar xzf "$tmp"/pyulog-1.2.1.tar.gz -C "$tmp"
      for f in "$tmp"/pyulog-1.2.1/test/*.ulg; do head -c 100000 "$f" > "$c/pyulog-$(basename "$f")"; done
      cp "$tmp"/pyulog-1.2.1/test/sample_appended_multiple.ulg "$c/pyulog-appended-multiple-whole.ulg" ;;
    mcap_join)
      for n in 60 400; do head -n $((n + 1)) "$flight" > "$tmp/b3-$n.csv"; python3 ../scripts/nanobench-to-mcap.py --uncompressed "$tmp/b3-$n.csv" "$c/b3-$n.mcap"; done
      python3 ../scripts/nanobench-to-mcap.py "$tmp/b3-60.csv" "$c/b3-60-zstd.mcap" ;;
  esac
done
cargo fuzz build -s none -O -a
run() {
  local t=$1 len=65536
  case $t in serve_packet) len=2048 ;; ulog_join | mcap_join) len=262144 ;; esac
  cargo fuzz run -s none -O -a "$t" "corpus/$t" -- -max_total_time="$secs" -max_len=$len -rss_limit_mb=4096 \
    -print_final_stats=1 > "logs/$t.log" 2>&1 && r=ok || r="FAILED (fuzz/logs/$t.log)"
  printf '%-16s %s  %s  dependency panics: %s\n' "$t" "$(grep -E '^#[0-9]+.*DONE' "logs/$t.log" | tail -1 | tr -s ' \t' ' ')" "$r" \
    "$(grep -cE '^(px4-ulog|mcap) panicked' "logs/$t.log" || true)"
}
export -f run; export secs
printf '%s\n' "${targets[@]}" | xargs -P "${JOBS:-1}" -I{} bash -c 'run {}'
