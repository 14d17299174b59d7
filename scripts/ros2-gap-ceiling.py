#!/usr/bin/env python3
"""What any calibrated dead reckoning reaches through a recording's GNSS gaps:
the ceiling of `ros2-gap-check.py`'s paired rule.

For each window [T0, T0+LENGTH) the fixes inside are withheld (`estimate
--outage`) and, from the estimate's own pose and heading at T0 (as in
`ros2-gap-check.py`), the recorded odometry is dead-reckoned with its yaw
rate times a heading factor H and its speed times a speed factor V, for every
(H, V) on a grid, and the raw gyro's rate divided by a scale G (on the wheels'
clock, its bias not removed) with the odometry's speed times V. Each track
is scored by the RMS distance to the held-out fixes and judged against the
plain odometry (H = V = 1) by the paired rule (the mean of the per-window
differences, 95 % interval by a block bootstrap over 20 s blocks).

Printed: the estimate; the best constant track (the (H, V) or (G, V) with
the lowest mean, chosen on these very windows: no estimator that holds its
calibration through a gap does better); the factors fitted, per window, on
the BEFORE s just before it (the same dead reckoning from the estimate's
pose BEFORE s earlier, scored on the fixes it had: what learning from the
recent past gives); and per window the best of the grid in hindsight (an
upper bound that also picks the fixes' own wander). Pure Python.

With `--held` three more tracks, with the odometry's speed, tell which of
the gyro's states the estimate's heading through a gap owes its error to:
the raw gyro less the bias `estimate` holds at T0 (`ros2-gyro-state.py`:
the log cut at T0), divided by the scale it holds, and both.

usage: ros2-gap-ceiling.py TERRASLIP LOG S LENGTH_S T0 ... [--before S] [--held] [-- ESTIMATE_ARGS ...]
"""
import json
import os
import subprocess
import sys
import tempfile

from logcsv import interp, rows, script

gap_check = script("ros2-gap-check.py")
gyro_state = script("ros2-gyro-state.py")

HEADING = [0.90, 0.92, 0.94, 0.96, 0.98, 1.00, 1.02, 1.04]
SPEED = [0.85, 0.88, 0.91, 0.94, 0.97, 1.00, 1.03]
GYRO = [1.00, 1.03, 1.05, 1.07]


def tracks(tw, vl, vr, sep, gyro_rate, k, t1, start):
    """Every calibrated dead reckoning from row `k` to `t1`, keyed by
    ("odometry", H, V) or ("gyro", G, V). `gyro_rate(i)` is the gyro's rate
    at wheels row i (None: no gyro)."""
    out = {}
    for v in SPEED:
        speed = lambda i, v=v: v * (vl[i] + vr[i]) / 2
        for h in HEADING:
            rate = lambda i, h=h: h * (vr[i] - vl[i]) / sep
            out[("odometry", h, v)] = gap_check.dead_reckon(tw, speed, rate, k, t1, start)
        if gyro_rate is not None:
            for g in GYRO:
                rate = lambda i, g=g: gyro_rate(i) / g
                out[("gyro", g, v)] = gap_check.dead_reckon(tw, speed, rate, k, t1, start)
    return out


def row_at(tw, t):
    """The last wheels row at or before `t` (the first row before the log)."""
    return max([i for i, x in enumerate(tw) if x <= t] or [0])


def name(key):
    kind, f, v = key
    return f"odometry rate x {f:.2f}, speed x {v:.2f}" if kind == "odometry" else \
        f"gyro / {f:.2f}, odometry speed x {v:.2f}"


def main():
    argv, extra = sys.argv, []
    if "--" in argv:
        k = argv.index("--")
        argv, extra = argv[:k], argv[k + 1:]
    before = 30.0
    if "--before" in argv:
        k = argv.index("--before")
        before = float(argv[k + 1])
        argv = argv[:k] + argv[k + 2:]
    with_held = "--held" in argv
    argv = [a for a in argv if a != "--held"]
    exe, log, sep, length = argv[1], argv[2], float(argv[3]), float(argv[4])
    starts = [float(x) for x in argv[5:]]
    fixes, tw, vl, vr, gyro = gap_check.read_log(log)
    score = {}
    estimate, fitted, hindsight = [], [], []
    for t0 in starts:
        t1 = t0 + length
        with tempfile.TemporaryDirectory() as d:
            subprocess.run([exe, "estimate", log, "--out", d, "--outage", f"{t0},{t1}"] + extra,
                           check=True, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL)
            est = rows(d, "estimate.csv")
            with open(os.path.join(d, "summary.json")) as f:
                late = (json.load(f).get("gyro") or {}).get("wheels_late_by_s", 0.0)
        gyro_rate = None
        if gyro:
            tg, gz = gap_check.on_wheels_clock(gyro, late)
            gyro_rate = lambda i: interp(tg, gz, tw[i])

        def pose(k):
            return float(est[k]["east"]), float(est[k]["north"]), float(est[k]["yaw"])

        k0 = row_at(tw, t0)
        here = {key: gap_check.rms_to_fixes(tr, fixes, t0, t1)[0]
                for key, tr in tracks(tw, vl, vr, sep, gyro_rate, k0, t1, pose(k0)).items()}
        tb = max(tw[0], t0 - before)
        kb = row_at(tw, tb)
        past = {key: gap_check.rms_to_fixes(tr, fixes, tb, t0)[0]
                for key, tr in tracks(tw, vl, vr, sep, gyro_rate, kb, t0, pose(kb)).items()}
        if with_held and gyro:
            g = gyro_state.held(exe, log, t0, extra)[0] or {"bias_rad_s": 0.0, "scale": 1.0}
            b, scale = g["bias_rad_s"], g["scale"]
            speed = lambda i: (vl[i] + vr[i]) / 2
            for key, rate in [("gyro - held bias", lambda i: gyro_rate(i) - b),
                              ("gyro / held scale", lambda i: gyro_rate(i) / scale),
                              ("(gyro - held bias) / held scale", lambda i: (gyro_rate(i) - b) / scale)]:
                tr = gap_check.dead_reckon(tw, speed, rate, k0, t1, pose(k0))
                score.setdefault(key, []).append(gap_check.rms_to_fixes(tr, fixes, t0, t1)[0])
        for key, rms in here.items():
            score.setdefault(key, []).append(rms)
        estimate.append(gap_check.rms_to_fixes(
            [(float(r["t"]), float(r["east"]), float(r["north"])) for r in est], fixes, t0, t1)[0])
        fitted.append(here[min(past, key=past.get)])
        hindsight.append(min(here.values()))
    odometry = score[("odometry", 1.0, 1.0)]
    grid = [key for key in score if isinstance(key, tuple)]
    best = min(grid, key=lambda key: sum(score[key]))
    lines = [("estimate", estimate),
             (f"best constant ({name(best)})", score[best]),
             (f"factors fitted on the {before:.0f} s before each window", fitted),
             ("per-window best in hindsight", hindsight)]
    lines += [(name(key), score[key]) for key in
              [("gyro", g, 1.0) for g in GYRO if ("gyro", g, 1.0) in score]
              + [("odometry", 0.98, 0.97), ("odometry", 1.0, 0.97)]]
    lines += [(key, score[key]) for key in score if not isinstance(key, tuple)]
    print(f"{len(starts)} windows of {length:.0f} s; odometry {sum(odometry) / len(odometry):.2f} m")
    for label, values in lines:
        m, lo, hi = gap_check.paired(starts, [a - b for a, b in zip(values, odometry)])
        print(f"{label}: {sum(values) / len(values):.2f} m, - odometry {m:+.2f} m, "
              f"95 % [{lo:+.2f}, {hi:+.2f}] ({gap_check.verdict(lo, hi)})")


if __name__ == "__main__":
    main()
