#!/usr/bin/env python3
"""GNSS gaps on a log imported from a bag: the estimate against dead reckoning,
scored on the held-out fixes.

For each window [T0, T0+L) the fixes inside are dropped (`estimate --outage`).
Two dead reckonings start from the estimate's own pose at T0, so that all
three share the error they start with and differ only in how they carry the
pose through the gap:

* odometry: the recorded odometry twist, v = (v_l+v_r)/2, w = (v_r-v_l)/S, S
  the controller's separation the log was imported with;
* gyro (when imu.csv has gyro_z): the odometry's v along the raw gyro's
  heading, the gyro moved onto the wheels' clock by the delay `estimate`
  reports (summary.json gyro.wheels_late_by_s), its bias not removed.

Each is scored by the RMS horizontal distance to the held-out fixes. Prints
one line per window, then the mean over windows and how many windows the
estimate wins against each. Pure Python.

usage: ros2-gap-check.py TERRASLIP LOG S [LENGTH_S] [T0 ...] [-- ESTIMATE_ARGS ...]
(ESTIMATE_ARGS, e.g. `--init params.json`, are passed to every `estimate`;
T0 defaults to 60 120 180 240 300.)
"""
import json
import math
import os
import subprocess
import sys
import tempfile

from logcsv import interp, rows


def dead_reckon(tw, speed, rate, k, t1, pose):
    """Integrate speed(i) along the heading turned by rate(i) from row k to t1."""
    x, y, yaw = pose
    track = []
    for i in range(k, len(tw) - 1):
        if tw[i] >= t1:
            break
        v, w, dt = speed(i), rate(i), tw[i + 1] - tw[i]
        x += v * math.cos(yaw + w * dt / 2) * dt
        y += v * math.sin(yaw + w * dt / 2) * dt
        yaw += w * dt
        track.append((tw[i + 1], x, y))
    return track


def rms_to_fixes(track, fixes, t0, t1):
    ts = [p[0] for p in track]
    xs = [p[1] for p in track]
    ys = [p[2] for p in track]
    err = [math.hypot(interp(ts, xs, t) - e, interp(ts, ys, t) - n)
           for t, e, n in fixes if t0 <= t < t1 and ts and ts[0] <= t <= ts[-1]]
    return math.sqrt(sum(e * e for e in err) / len(err)), len(err)


def main():
    argv, extra = sys.argv, []
    if "--" in argv:
        k = argv.index("--")
        argv, extra = argv[:k], argv[k + 1:]
    exe, log, sep = argv[1], argv[2], float(argv[3])
    length = float(argv[4]) if len(argv) > 4 else 30.0
    starts = [float(x) for x in argv[5:]] or [60, 120, 180, 240, 300]
    wheels = rows(log, "wheels.csv")
    fixes = [(float(r["t"]), float(r["east"]), float(r["north"]))
             for r in rows(log, "pose.csv") if r["east"]]
    tw = [float(r["t"]) for r in wheels]
    vl = [float(r["v_left"]) for r in wheels]
    vr = [float(r["v_right"]) for r in wheels]
    imu_path = os.path.join(log, "imu.csv")
    imu = rows(log, "imu.csv") if os.path.exists(imu_path) else []
    gyro = [(float(r["t"]), float(r["gyro_z"])) for r in imu if r.get("gyro_z")]
    names = ["estimate", "odometry"] + (["gyro"] if gyro else [])
    tot = {n: [] for n in names}
    for t0 in starts:
        t1 = t0 + length
        with tempfile.TemporaryDirectory() as d:
            subprocess.run([exe, "estimate", log, "--out", d, "--outage", f"{t0},{t1}"] + extra,
                           check=True, stderr=subprocess.DEVNULL)
            est = rows(d, "estimate.csv")
            with open(os.path.join(d, "summary.json")) as f:
                late = (json.load(f).get("gyro") or {}).get("wheels_late_by_s", 0.0)
        k = max(i for i, t in enumerate(tw) if t <= t0)
        yaw = float(est[k]["yaw"])
        start = (float(est[k]["east"]), float(est[k]["north"]), math.atan2(math.sin(yaw), math.cos(yaw)))
        tracks = {
            "estimate": [(float(r["t"]), float(r["east"]), float(r["north"])) for r in est],
            "odometry": dead_reckon(tw, lambda i: (vl[i] + vr[i]) / 2,
                                    lambda i: (vr[i] - vl[i]) / sep, k, t1, start),
        }
        if gyro:
            tg = [t - late for t, _ in gyro]
            gz = [g for _, g in gyro]
            tracks["gyro"] = dead_reckon(tw, lambda i: (vl[i] + vr[i]) / 2,
                                         lambda i: interp(tg, gz, tw[i]), k, t1, start)
        line, n_fixes = [], 0
        for n in names:
            rms, n_fixes = rms_to_fixes(tracks[n], fixes, t0, t1)
            tot[n].append(rms)
            line.append(f"{n} {rms:.2f} m")
        print(f"gap [{t0:.0f}, {t1:.0f}) s, {n_fixes} held-out fixes, RMS: " + ", ".join(line))
    count = len(starts)
    means = ", ".join(f"{n} {sum(tot[n]) / count:.2f} m" for n in names)
    wins = ", ".join(f"against {n} {sum(e <= b for e, b in zip(tot['estimate'], tot[n]))}/{count}"
                     for n in names[1:])
    print(f"mean over {count} gaps: {means}; the estimate wins {wins}")


if __name__ == "__main__":
    main()
