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
  heading, the gyro moved onto the wheels' clock (later) by the delay `estimate`
  reports (summary.json gyro.wheels_late_by_s), its bias not removed.

Each is scored by the RMS horizontal distance to the held-out fixes. Prints
one line per window, then the mean over windows, how many windows the
estimate wins against each, and the paired rule against each: the mean of
the per-window differences (estimate - other, and each other track -
odometry) with its 95 % interval by a
block bootstrap over 20 s blocks of window starts (2000 resamples; "tie"
when the interval holds 0), as `terraslip-lab heldout` judges outages.
Pure Python.

With `--swap` two more tracks, from the same start, tell the heading from
the distance: "estimate's heading" (the odometry's speed along the
estimate's own heading changes) and "estimate's distance" (the estimate's
speed along its own heading, turned by the odometry's yaw rate).

With `--split` each error is also split along the track's own direction at
the fix: along-track (+ ahead of the fix: too far; the distance, a speed
factor) and cross-track (the heading); each line then gives both RMS, the
gap's distance by the fixes (chords of about 5 s summed, first to last
held-out fix) and by each track over the same times, and the estimate's
mean speed factor over the gap. The means give RMS over all held-out fixes
of all gaps and the sums of distance.

usage: ros2-gap-check.py TERRASLIP LOG S [LENGTH_S] [T0 ...] [--split] [--swap] [-- ESTIMATE_ARGS ...]
(ESTIMATE_ARGS, e.g. `--init params.json`, are passed to every `estimate`;
T0 defaults to 60 120 180 240 300.)
"""
import bisect
import json
import math
import os
import random
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


def heading_rates(ts, yaw):
    """The yaw rate (rad/s) of each step of a track's heading `yaw` (rad,
    any branch) at times `ts`: the heading changes, unwrapped, over the
    steps (one fewer than the rows)."""
    return [math.atan2(math.sin(yaw[i + 1] - yaw[i]), math.cos(yaw[i + 1] - yaw[i])) / (ts[i + 1] - ts[i])
            for i in range(len(ts) - 1)]


def along_speeds(ts, east, north, yaw):
    """The speed (m/s) of each step of a track along its own heading at the
    step's middle: how far it went, whichever way it turned."""
    out = []
    for i in range(len(ts) - 1):
        dy = math.atan2(math.sin(yaw[i + 1] - yaw[i]), math.cos(yaw[i + 1] - yaw[i]))
        h = yaw[i] + dy / 2
        step = (east[i + 1] - east[i]) * math.cos(h) + (north[i + 1] - north[i]) * math.sin(h)
        out.append(step / (ts[i + 1] - ts[i]))
    return out


BLOCK_S = 20.0


def paired(starts, diffs, block_s=BLOCK_S, resamples=2000, seed=37):
    """The mean of the per-window differences `diffs` (window starts
    `starts`, s) and its 95 % interval by a block bootstrap: the starts in
    each `block_s` s block resampled together. Returns (mean, low, high)."""
    blocks = {}
    for t, d in zip(starts, diffs):
        blocks.setdefault(int((t - starts[0]) // block_s), []).append(d)
    blocks = list(blocks.values())
    rng = random.Random(seed)
    means = []
    for _ in range(resamples):
        pick = [rng.choice(blocks) for _ in blocks]
        means.append(sum(sum(b) for b in pick) / sum(len(b) for b in pick))
    means.sort()
    q = lambda p: means[round((len(means) - 1) * p)]
    return sum(diffs) / len(diffs), q(0.025), q(0.975)


def verdict(low, high):
    return "ahead" if high < 0 else "behind" if low > 0 else "tie"


def on_wheels_clock(gyro, late):
    """The gyro's (t, rate) samples as times on the wheels' clock and rates:
    the wheels are stamped `late` s after the gyro sees the same turn, so a
    gyro sample stamped t belongs with the wheels row stamped t + late."""
    return [t + late for t, _ in gyro], [g for _, g in gyro]


def rms_to_fixes(track, fixes, t0, t1):
    ts = [p[0] for p in track]
    xs = [p[1] for p in track]
    ys = [p[2] for p in track]
    err = [math.hypot(interp(ts, xs, t) - e, interp(ts, ys, t) - n)
           for t, e, n in fixes if t0 <= t < t1 and ts and ts[0] <= t <= ts[-1]]
    return math.sqrt(sum(e * e for e in err) / len(err)), len(err)


def split_errors(track, fixes, t0, t1):
    """Each held-out fix's error split along the track's direction there:
    (along, cross) lists in m, along + when the track is ahead."""
    ts = [p[0] for p in track]
    xs = [p[1] for p in track]
    ys = [p[2] for p in track]
    along, cross = [], []
    for t, e, n in fixes:
        if not (t0 <= t < t1 and ts and ts[0] <= t <= ts[-1]):
            continue
        dx = interp(ts, xs, t + 0.5) - interp(ts, xs, t - 0.5)
        dy = interp(ts, ys, t + 0.5) - interp(ts, ys, t - 0.5)
        norm = math.hypot(dx, dy)
        if norm < 0.05:
            continue  # standing: no direction of travel
        ex, ey = interp(ts, xs, t) - e, interp(ts, ys, t) - n
        along.append((ex * dx + ey * dy) / norm)
        cross.append((ey * dx - ex * dy) / norm)
    return along, cross


def distances(track, fixes, t0, t1, chord_s=5.0):
    """The gap's distance by the fixes and by the track over the same times:
    chords of about `chord_s` between held-out fixes, summed."""
    ts = [p[0] for p in track]
    xs = [p[1] for p in track]
    ys = [p[2] for p in track]
    inside = [f for f in fixes if t0 <= f[0] < t1 and ts and ts[0] <= f[0] <= ts[-1]]
    d_fix = d_track = 0.0
    j = 0
    for i in range(1, len(inside)):
        if inside[i][0] - inside[j][0] < chord_s and i < len(inside) - 1:
            continue
        a, b = inside[j], inside[i]
        d_fix += math.hypot(b[1] - a[1], b[2] - a[2])
        d_track += math.hypot(interp(ts, xs, b[0]) - interp(ts, xs, a[0]),
                              interp(ts, ys, b[0]) - interp(ts, ys, a[0]))
        j = i
    return d_fix, d_track


def rms_of(values):
    return math.sqrt(sum(v * v for v in values) / len(values)) if values else float("nan")


def read_log(log):
    """The log's position fixes `(t, east, north)`, wheels rows (times,
    left and right tread speeds) and gyro samples `(t, rate)` (empty
    without `imu.csv` or its `gyro_z`)."""
    wheels = rows(log, "wheels.csv")
    fixes = [(float(r["t"]), float(r["east"]), float(r["north"]))
             for r in rows(log, "pose.csv") if r["east"]]
    tw = [float(r["t"]) for r in wheels]
    vl = [float(r["v_left"]) for r in wheels]
    vr = [float(r["v_right"]) for r in wheels]
    imu = rows(log, "imu.csv") if os.path.exists(os.path.join(log, "imu.csv")) else []
    gyro = [(float(r["t"]), float(r["gyro_z"])) for r in imu if r.get("gyro_z")]
    return fixes, tw, vl, vr, gyro


def main():
    argv, extra = sys.argv, []
    if "--" in argv:
        k = argv.index("--")
        argv, extra = argv[:k], argv[k + 1:]
    split = "--split" in argv
    swap = "--swap" in argv
    argv = [a for a in argv if a not in ("--split", "--swap")]
    exe, log, sep = argv[1], argv[2], float(argv[3])
    length = float(argv[4]) if len(argv) > 4 else 30.0
    starts = [float(x) for x in argv[5:]] or [60, 120, 180, 240, 300]
    fixes, tw, vl, vr, gyro = read_log(log)
    names = ["estimate", "odometry"] + (["gyro"] if gyro else [])
    names += ["estimate's heading", "estimate's distance"] if swap else []
    tot = {n: [] for n in names}
    parts = {n: ([], []) for n in names}
    dist = {n: 0.0 for n in names + ["fixes"]}
    for t0 in starts:
        t1 = t0 + length
        with tempfile.TemporaryDirectory() as d:
            subprocess.run([exe, "estimate", log, "--out", d, "--outage", f"{t0},{t1}"] + extra,
                           check=True, stderr=subprocess.DEVNULL)
            est = rows(d, "estimate.csv")
            alpha = [0.5 * (float(r["alpha_l"]) + float(r["alpha_r"]))
                     for r in est if t0 <= float(r["t"]) < t1]
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
        if swap:
            te = [float(r["t"]) for r in est]
            ye = [float(r["yaw"]) for r in est]
            rate_e = heading_rates(te, ye)
            speed_e = along_speeds(te, [float(r["east"]) for r in est],
                                   [float(r["north"]) for r in est], ye)
            rate_o = lambda i: (vr[i] - vl[i]) / sep
            at = lambda i: min(max(0, bisect.bisect_right(te, tw[i]) - 1), len(rate_e) - 1)
            tracks["estimate's heading"] = dead_reckon(
                tw, lambda i: (vl[i] + vr[i]) / 2, lambda i: rate_e[at(i)], k, t1, start)
            tracks["estimate's distance"] = dead_reckon(
                tw, lambda i: speed_e[at(i)], rate_o, k, t1, start)
        if gyro:
            tg, gz = on_wheels_clock(gyro, late)
            tracks["gyro"] = dead_reckon(tw, lambda i: (vl[i] + vr[i]) / 2,
                                         lambda i: interp(tg, gz, tw[i]), k, t1, start)
        line, n_fixes = [], 0
        for n in names:
            rms, n_fixes = rms_to_fixes(tracks[n], fixes, t0, t1)
            tot[n].append(rms)
            line.append(f"{n} {rms:.2f} m")
            if split:
                along, cross = split_errors(tracks[n], fixes, t0, t1)
                parts[n][0].extend(along)
                parts[n][1].extend(cross)
                d_fix, d_track = distances(tracks[n], fixes, t0, t1)
                dist["fixes"] += d_fix if n == "estimate" else 0.0
                dist[n] += d_track
                line[-1] += (f" (along {rms_of(along):.2f}, cross {rms_of(cross):.2f},"
                             f" {d_track:.1f} m against the fixes' {d_fix:.1f} m)")
        if split and alpha:
            line.append(f"estimate's speed factor {sum(alpha) / len(alpha):.3f}")
        print(f"gap [{t0:.0f}, {t1:.0f}) s, {n_fixes} held-out fixes, RMS: " + ", ".join(line))
    count = len(starts)
    means = ", ".join(f"{n} {sum(tot[n]) / count:.2f} m" for n in names)
    wins = ", ".join(f"against {n} {sum(e <= b for e, b in zip(tot['estimate'], tot[n]))}/{count}"
                     for n in names[1:])
    print(f"mean over {count} gaps: {means}; the estimate wins {wins}")
    for n in names[1:]:
        m, lo, hi = paired(starts, [e - b for e, b in zip(tot["estimate"], tot[n])])
        print(f"estimate - {n}: mean {m:+.2f} m, 95 % [{lo:+.2f}, {hi:+.2f}] ({verdict(lo, hi)})")
    for n in names[2:]:
        m, lo, hi = paired(starts, [e - b for e, b in zip(tot[n], tot["odometry"])])
        print(f"{n} - odometry: mean {m:+.2f} m, 95 % [{lo:+.2f}, {hi:+.2f}] ({verdict(lo, hi)})")
    if split:
        for n in names:
            along, cross = parts[n]
            print(f"{n}: along-track RMS {rms_of(along):.2f} m (mean {sum(along) / len(along):+.2f} m),"
                  f" cross-track RMS {rms_of(cross):.2f} m (mean {sum(cross) / len(cross):+.2f} m),"
                  f" {dist[n]:.0f} m travelled against the fixes' {dist['fixes']:.0f} m"
                  f" ({dist[n] / dist['fixes']:.3f})")


if __name__ == "__main__":
    main()
