#!/usr/bin/env bash
# Scale of `estimate`, `calibrate` and `calibrate validate --time-offset auto`
# on a ~200 MB wheels.csv: wall time,
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
# A real drive has no ground truth (and calibrate would read it).
rm "$work/log/truth.csv"
size=$(stat -c %s "$work/log/wheels.csv")
echo "wheels.csv: $((size / 1000000)) MB, $secs s of drive"
# Wall time, CPU time (user + sys: what the figure is on a busy machine),
# throughput of CSV per CPU second, and peak resident memory.
measure() {
  local name=$1; shift
  /usr/bin/time -f "%e %U %S %M" -o "$work/time" "$@" >/dev/null 2>"$work/err" || {
    cat "$work/err"; exit 1; }
  read -r wall user sys kb < "$work/time"
  awk -v n="$name" -v w="$wall" -v u="$user" -v y="$sys" -v kb="$kb" -v s="$size" \
    'BEGIN { c = u + y; printf "%-10s wall %6.1f s  cpu %6.1f s  %6.1f MB/s  peak %5.0f MB\n", n, w, c, s / 1e6 / c, kb / 1024 }'
}
measure estimate "$bin" estimate "$work/log" --out "$work/est"
measure calibrate "$bin" calibrate "$work/log" --out "$work/params.json"
measure validate "$bin" calibrate validate --params "$work/params.json" --time-offset auto "$work/log"
