#!/usr/bin/env bash
# Scale of `estimate` and `calibrate` on a ~200 MB wheels.csv: wall time,
# throughput and peak memory (GNU time's maximum resident set size).
# Targets (docs/benchmarks.md): estimate >= 20 MB/s of CSV with a peak
# under 100 MB; calibrate of that file in under 20 s.
#   scripts/scale-bench.sh [TERRASLIP_BINARY] [MB]
# Builds the release binary and the synth_log example when not given one.
set -euo pipefail
cd "$(dirname "$0")/.."
mb=${2:-200}
cargo build -q --release -p terraslip --example synth_log
if [ -n "${1:-}" ]; then
  bin=$1
else
  cargo build -q --release -p terraslip --bin terraslip
  bin=target/release/terraslip
fi
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# An exact-model drive at 50 Hz wheels and 1 Hz pose, long enough for the
# wheels file to reach the size asked for.
target/release/examples/synth_log "$work/probe" 600
probe=$(stat -c %s "$work/probe/wheels.csv")
secs=$(( 600 * mb * 1000000 / probe ))
target/release/examples/synth_log "$work/log" "$secs"
size=$(stat -c %s "$work/log/wheels.csv")
echo "wheels.csv: $((size / 1000000)) MB, $secs s of drive"
measure() {
  local name=$1; shift
  /usr/bin/time -f "%e %M" -o "$work/time" "$@" >/dev/null 2>"$work/err" || {
    cat "$work/err"; exit 1; }
  read -r wall kb < "$work/time"
  awk -v n="$name" -v w="$wall" -v kb="$kb" -v s="$size" \
    'BEGIN { printf "%-10s %7.1f s  %6.1f MB/s  peak %5.0f MB\n", n, w, s / 1e6 / w, kb / 1024 }'
}
measure estimate "$bin" estimate "$work/log" --out "$work/est"
measure calibrate "$bin" calibrate "$work/log" --out "$work/params.json"
