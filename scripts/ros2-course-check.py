#!/usr/bin/env python3
"""Who turns right, the gyro or the odometry? Checked against the fixes'
course over long baselines, on a log imported from a bag whose wheels came
from an odometry twist.

Straight stretches are found where the gyro turns less than 0.06 rad in
10 s and the fixes move more than 7 m; each gives a course (the direction
of the chord between its first and last fix, good to about 0.1 rad with
0.8 m GNSS). For every pair of stretches more than 2.5 rad of turning
apart, the course change is compared with the heading change the gyro
integrates and the one the odometry integrates ((v_r - v_l)/S, S the
controller's separation) between the stretches' midpoints. Least squares
over those pairs gives each sensor's turn as a multiple of the course's;
the odometry's, times the controller's multiplier, is the multiplier the
fixes support (a turn 0.98 x the course's means a separation 0.98 x S).
The pairs share stretches, so the figure's spread is wider than the
number of pairs suggests; long baselines are what make it better than
a per-turn comparison. The gyro's bias is not removed: it adds its rate
times the baseline.

usage: ros2-course-check.py LOG S TRACK [DELAY]
(DELAY: summary.json's gyro.wheels_late_by_s; the wheels' stamps are moved
back by it.)
"""
import bisect
import math
import sys

from logcsv import rows


def integral(ts, vs, a, b):
    """Rectangle-rule integral of the samples inside [a, b]."""
    i = bisect.bisect_left(ts, a)
    s = 0.0
    while i + 1 < len(ts) and ts[i + 1] <= b:
        s += vs[i] * (ts[i + 1] - ts[i])
        i += 1
    return s


def main():
    log, sep, track = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
    delay = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
    imu = rows(log, "imu.csv")
    wheels = rows(log, "wheels.csv")
    fixes = [r for r in rows(log, "pose.csv") if r["east"]]
    tg = [float(r["t"]) for r in imu]
    gz = [float(r["gyro_z"]) for r in imu]
    tw = [float(r["t"]) - delay for r in wheels]
    wz = [(float(r["v_right"]) - float(r["v_left"])) / sep for r in wheels]
    tf = [float(r["t"]) for r in fixes]
    fe = [float(r["east"]) for r in fixes]
    fn = [float(r["north"]) for r in fixes]

    stretches = []
    t = tf[0] + 5.0
    while t + 10.0 < tf[-1]:
        i0, i1 = bisect.bisect_left(tf, t), bisect.bisect_left(tf, t + 10.0) - 1
        chord = math.hypot(fe[i1] - fe[i0], fn[i1] - fn[i0])
        if abs(integral(tg, gz, t, t + 10.0)) < 0.06 and chord > 7.0:
            stretches.append((t + 5.0, math.atan2(fn[i1] - fn[i0], fe[i1] - fe[i0])))
            t += 10.0
        else:
            t += 1.0
    pairs = []
    for i, (m0, c0) in enumerate(stretches):
        for m1, c1 in stretches[i + 1:]:
            g, o = integral(tg, gz, m0, m1), integral(tw, wz, m0, m1)
            if abs(o) < 2.5:
                continue
            course = c1 - c0 - 2 * math.pi * round((c1 - c0 - o) / (2 * math.pi))
            pairs.append((course, g, o))
    print(f"{len(stretches)} straight stretches, {len(pairs)} pairs more than 2.5 rad apart")
    if not pairs:
        sys.exit("too little turning between straight stretches to tell")
    cc = sum(c * c for c, _, _ in pairs)
    k_gyro = sum(g * c for c, g, _ in pairs) / cc
    k_odom = sum(o * c for c, _, o in pairs) / cc
    print(f"gyro turns {k_gyro:.3f} x the course, odometry {k_odom:.3f} x the course")
    print(f"separation the fixes support: {sep * k_odom:.3f} m, a multiplier of "
          f"{sep * k_odom / track:.3f} on the {track} m track (the controller's: {sep / track:.3f})")


if __name__ == "__main__":
    main()
