#!/usr/bin/env bash
# The online filter's speed factor and pose clock offset on simulated
# Husky-like drives, where the truth is known: speed factors 0.99 and a
# clock offset of 0 (the fixes are stamped on the wheels' clock).
#
# usage: scripts/husky-like-check.sh [SEEDS [SCENARIO [CONFIG.toml]]]
#   SEEDS     number of seeds, 1..SEEDS (default 10)
#   SCENARIO  scenario file (default scripts/husky-like.toml); edit a copy
#             for other sensors (e.g. `[compass] rate = 2.5` for a heading)
#   CONFIG    an `estimate --config` file (e.g. `[measurement] std_gyro = 0`
#             to leave the gyro out)
# Prints one line per seed and the median / min / max of each figure.
set -euo pipefail
seeds="${1:-10}"
scenario="${2:-scripts/husky-like.toml}"
config="${3:-}"
bin="${TERRASLIP:-target/release/terraslip}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for s in $(seq 1 "$seeds"); do
  "$bin" simulate "$scenario" --seed "$s" --no-camera --out "$work/log$s" >"$work/out" 2>&1 ||
    { cat "$work/out" >&2; exit 1; }
  "$bin" estimate "$work/log$s" --out "$work/est$s" ${config:+--config "$config"} >"$work/out" 2>&1 ||
    { cat "$work/out" >&2; exit 1; }
done
python3 - "$work" "$seeds" <<'PY'
import json, statistics, sys
work, n = sys.argv[1], int(sys.argv[2])
cols = {"alpha": [], "clock_s": [], "clock_std_s": [], "x_c_m": [], "pose_std_xy_m": []}
for s in range(1, n + 1):
    j = json.load(open(f"{work}/est{s}/summary.json"))
    row = {
        "alpha": 0.5 * (j["icr"]["alpha_l"] + j["icr"]["alpha_r"]),
        "clock_s": j["clock_offset_s"]["value"],
        "clock_std_s": j["clock_offset_s"]["std"],
        "x_c_m": j["icr"]["x_c"],
        "pose_std_xy_m": j["pose_noise"]["std_xy_m"],
    }
    print(f"seed {s:3d}  " + "  ".join(f"{k} {v:+.3f}" for k, v in row.items()))
    for k, v in row.items():
        cols[k].append(v)
for k, v in cols.items():
    print(f"{k:14s} median {statistics.median(v):+.3f}  min {min(v):+.3f}  max {max(v):+.3f}")
PY
