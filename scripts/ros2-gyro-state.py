#!/usr/bin/env python3
"""What the estimator knows of its gyro at given times: `estimate` run on
the log cut at each time T (every CSV's rows stamped after T left out), and
summary.json's gyro scale, bias (rad/s) and delay (s) printed with the
speed factors and ICRs of the last row. The delay is decided from the cut
log, so it can differ from the whole log's by a few hundredths of a second
in the first minute.

usage: ros2-gyro-state.py TERRASLIP LOG T ... [-- ESTIMATE_ARGS ...]
"""
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile


def cut(src, dst, t_end):
    """Copies the log directory `src` to `dst`, its CSV files' rows stamped
    after `t_end` (s) left out."""
    for name in os.listdir(src):
        path = os.path.join(src, name)
        if not name.endswith(".csv"):
            if os.path.isfile(path):
                shutil.copy(path, dst)
            continue
        with open(path, newline="") as f, open(os.path.join(dst, name), "w", newline="") as g:
            rows = csv.reader(f)
            out = csv.writer(g)
            out.writerow(next(rows))
            out.writerows(r for r in rows if r and float(r[0]) <= t_end)


def held(exe, log, t_end, extra=()):
    """What `estimate` (with `extra` arguments) holds at `t_end` (s): its
    summary.json `gyro` (None before the first gyro window) and the last
    row of its estimate.csv, on the log cut there."""
    with tempfile.TemporaryDirectory() as d, tempfile.TemporaryDirectory() as out:
        cut(log, d, t_end)
        subprocess.run([exe, "estimate", d, "--out", out] + list(extra), check=True,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        with open(os.path.join(out, "summary.json")) as f:
            g = json.load(f).get("gyro")
        with open(os.path.join(out, "estimate.csv"), newline="") as f:
            last = list(csv.DictReader(f))[-1]
    return g, last


def main():
    argv, extra = sys.argv, []
    if "--" in argv:
        k = argv.index("--")
        argv, extra = argv[:k], argv[k + 1:]
    exe, log, times = argv[1], argv[2], [float(t) for t in argv[3:]]
    print("t_s scale scale_std bias_rad_s bias_std late_s alpha_l alpha_r y_l y_r x_c")
    for t_end in times:
        g, last = held(exe, log, t_end, extra)
        if not g:
            print(f"{t_end:.0f} no gyro window fused yet")
            continue
        print(f"{t_end:.0f} {g['scale']:.4f} {g['scale_std']:.4f} {g['bias_rad_s']:+.5f} "
              f"{g['bias_std_rad_s']:.5f} {g['wheels_late_by_s']:.3f} "
              + " ".join(last[k] for k in ("alpha_l", "alpha_r", "y_l", "y_r", "x_c")))


if __name__ == "__main__":
    main()
