#!/usr/bin/env bash
# Does `estimate --init` help? For every drive under DRIVES (default
# ../shared/data/drive): calibrate on the first 300 s, then compare the 2 s
# prediction error of `estimate` without and with `--init` (summary.json).
set -euo pipefail
drives="${1:-../shared/data/drive}"
bin="${TERRASLIP:-target/release/terraslip}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for d in "$drives"/*/; do
  n="$(basename "$d")"
  "$bin" calibrate "$d" --t-max 300 --out "$work/$n.json" >/dev/null 2>&1
  "$bin" estimate "$d" --out "$work/$n-plain" >/dev/null 2>&1
  "$bin" estimate "$d" --out "$work/$n-init" --init "$work/$n.json" >/dev/null 2>&1
  python3 - "$work/$n-plain/summary.json" "$work/$n-init/summary.json" "$n" <<'PY'
import json, sys
a = json.load(open(sys.argv[1]))["prediction"]["mean_m"]
b = json.load(open(sys.argv[2]))["prediction"]["mean_m"]
print("%-22s without --init %.3f m   with --init %.3f m   %s" % (sys.argv[3], a, b, "better" if b <= a else "worse"))
PY
done
