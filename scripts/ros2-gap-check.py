#!/usr/bin/env python3
"""GNSS gaps on a log imported from a bag: the estimate against dead reckoning
on the recorded wheel odometry, scored on the held-out fixes.

For each window [T0, T0+L) the fixes inside are dropped (`estimate --outage`);
dead reckoning starts from the estimate's own pose at T0 and integrates the
recorded odometry twist (v = (v_l+v_r)/2, w = (v_r-v_l)/S, S the controller's
separation the log was imported with). Both are scored by the horizontal
distance to each held-out fix. Pure Python; prints one line per window and the
mean over windows.

usage: ros2-gap-check.py TERRASLIP LOG S [LENGTH_S] [T0 ...] [-- ESTIMATE_ARGS ...]
(ESTIMATE_ARGS, e.g. `--init params.json`, are passed to every `estimate`.)
"""
import csv
import math
import os
import subprocess
import sys
import tempfile


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def interp(ts, vs, t):
    lo, hi = 0, len(ts) - 1
    if t <= ts[0]:
        return vs[0]
    if t >= ts[-1]:
        return vs[-1]
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ts[mid] <= t:
            lo = mid
        else:
            hi = mid
    a = (t - ts[lo]) / (ts[hi] - ts[lo])
    return vs[lo] + a * (vs[hi] - vs[lo])


def main():
    argv, extra = sys.argv, []
    if "--" in argv:
        k = argv.index("--")
        argv, extra = argv[:k], argv[k + 1:]
    exe, log, sep = argv[1], argv[2], float(argv[3])
    length = float(argv[4]) if len(argv) > 4 else 30.0
    starts = [float(x) for x in argv[5:]] or [60, 120, 180, 240, 300]
    wheels = rows(os.path.join(log, "wheels.csv"))
    fixes = [r for r in rows(os.path.join(log, "pose.csv")) if r["east"]]
    tw = [float(r["t"]) for r in wheels]
    tot = {"est": [], "dr": []}
    for t0 in starts:
        t1 = t0 + length
        with tempfile.TemporaryDirectory() as d:
            subprocess.run([exe, "estimate", log, "--out", d, "--outage", f"{t0},{t1}"] + extra,
                           check=True, stderr=subprocess.DEVNULL)
            est = rows(os.path.join(d, "estimate.csv"))
        te = [float(r["t"]) for r in est]
        e_e = [float(r["east"]) for r in est]
        e_n = [float(r["north"]) for r in est]
        e_y = [math.atan2(math.sin(float(r["yaw"])), math.cos(float(r["yaw"]))) for r in est]
        # dead reckoning from the estimate's pose at the last row before t0
        k = max(i for i, t in enumerate(tw) if t <= t0)
        x, y, yaw = e_e[k], e_n[k], e_y[k]
        dr = []
        for i in range(k, len(wheels) - 1):
            if tw[i] >= t1:
                break
            vl, vr = float(wheels[i]["v_left"]), float(wheels[i]["v_right"])
            v, w = (vl + vr) / 2, (vr - vl) / sep
            dt = tw[i + 1] - tw[i]
            x += v * math.cos(yaw + w * dt / 2) * dt
            y += v * math.sin(yaw + w * dt / 2) * dt
            yaw += w * dt
            dr.append((tw[i + 1], x, y))
        dts = [p[0] for p in dr]
        err = {"est": [], "dr": []}
        for f in fixes:
            t = float(f["t"])
            if t0 <= t < t1 and dts and dts[0] <= t <= dts[-1]:
                fe, fn = float(f["east"]), float(f["north"])
                err["est"].append(math.hypot(interp(te, e_e, t) - fe, interp(te, e_n, t) - fn))
                err["dr"].append(math.hypot(interp(dts, [p[1] for p in dr], t) - fe,
                                            interp(dts, [p[2] for p in dr], t) - fn))
        rms = {k: math.sqrt(sum(e * e for e in v) / len(v)) for k, v in err.items()}
        end = {k: v[-1] for k, v in err.items()}
        for k in tot:
            tot[k].append((rms[k], end[k]))
        print(f"gap [{t0:.0f}, {t1:.0f}) s, {len(err['est'])} held-out fixes: "
              f"estimate RMS {rms['est']:.2f} m (end {end['est']:.2f} m), "
              f"odometry dead reckoning RMS {rms['dr']:.2f} m (end {end['dr']:.2f} m)")
    n = len(starts)
    print(f"mean over {n} gaps: estimate RMS {sum(r for r, _ in tot['est']) / n:.2f} m, "
          f"end {sum(e for _, e in tot['est']) / n:.2f} m; dead reckoning RMS "
          f"{sum(r for r, _ in tot['dr']) / n:.2f} m, end {sum(e for _, e in tot['dr']) / n:.2f} m")


if __name__ == "__main__":
    main()
