#!/usr/bin/env python3
"""The fixes' distance against the odometry's, from the data alone, on a log
with position fixes and wheel speeds (no heading needed).

Two views, each a ratio of GNSS to odometry distance (1 = the odometry's
speed is right; an online speed factor should sit near it):

- straight stretches: the tread speed difference under 0.05 rad/s (over
  the nominal S), mean speed above 0.3 m/s, for at least 8 s; the fixes'
  chord between the stretch's ends over the odometry's path along it;
- consecutive windows of W s (default 20) over the whole drive: the fixes'
  chord over the chord of the odometry dead-reckoned with the heading
  (v_r - v_l) / S_TURN (default 1.04 m, the turn the Husky's course check
  gives for S = 1 m).

With ESTIMATE (an `estimate --out` directory) each window also shows the
filter's mean speed factor over it. Pure Python.

usage: ros2-speed-check.py LOG [W [S_TURN [ESTIMATE]]]
"""
import math
import sys

from logcsv import interp, rows


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    log = sys.argv[1]
    win = float(sys.argv[2]) if len(sys.argv) > 2 else 20.0
    s_turn = float(sys.argv[3]) if len(sys.argv) > 3 else 1.04
    est = sys.argv[4] if len(sys.argv) > 4 else None
    w = rows(log, "wheels.csv")
    p = [r for r in rows(log, "pose.csv") if r["east"] and r["north"]]
    tw = [float(r["t"]) for r in w]
    vl = [float(r["v_left"]) for r in w]
    vr = [float(r["v_right"]) for r in w]
    tp = [float(r["t"]) for r in p]
    e = [float(r["east"]) for r in p]
    n = [float(r["north"]) for r in p]
    # Odometry path length s, dead-reckoned x, y with heading from the treads.
    s, x, y, yaw = [0.0], [0.0], [0.0], 0.0
    for i in range(1, len(tw)):
        dt = tw[i] - tw[i - 1]
        v = 0.5 * (vl[i - 1] + vr[i - 1])
        s.append(s[-1] + abs(v) * dt)
        x.append(x[-1] + v * math.cos(yaw) * dt)
        y.append(y[-1] + v * math.sin(yaw) * dt)
        yaw += (vr[i - 1] - vl[i - 1]) / s_turn * dt

    def fix_chord(a, b):
        return math.hypot(interp(tp, e, b) - interp(tp, e, a), interp(tp, n, b) - interp(tp, n, a))

    # Straight stretches.
    ok = [abs(vr[i] - vl[i]) < 0.05 and vl[i] + vr[i] > 0.6 for i in range(len(tw))]
    stretches, i = [], 0
    while i < len(ok):
        j = i
        while j < len(ok) and ok[j]:
            j += 1
        if j > i and tw[j - 1] - tw[i] >= 8.0 and tw[i] >= tp[0] and tw[j - 1] <= tp[-1]:
            stretches.append((i, j - 1))
        i = max(j, i + 1)
    fix_sum = odo_sum = 0.0
    print("straight stretches (fix chord / odometry path):")
    for i, j in stretches:
        c, o = fix_chord(tw[i], tw[j]), s[j] - s[i]
        fix_sum += c
        odo_sum += o
        print(f"  {tw[i]:6.1f}-{tw[j]:6.1f} s  odometry {o:6.2f} m  fixes {c:6.2f} m  ratio {c / o:.3f}")
    if odo_sum > 0:
        print(f"  {len(stretches)} stretches: {fix_sum:.1f} / {odo_sum:.1f} m = {fix_sum / odo_sum:.4f}")

    alpha = None
    if est:
        er = rows(est, "estimate.csv")
        alpha = ([float(r["t"]) for r in er], [0.5 * (float(r["alpha_l"]) + float(r["alpha_r"])) for r in er])
    print(f"{win:.0f} s windows (fix chord / odometry chord{', filter speed factor' if alpha else ''}):")
    fix_sum = odo_sum = 0.0
    a = tp[0]
    while a + win <= min(tp[-1], tw[-1]):
        b = a + win
        o = math.hypot(interp(tw, x, b) - interp(tw, x, a), interp(tw, y, b) - interp(tw, y, a))
        if o > 3.0:
            c = fix_chord(a, b)
            fix_sum += c
            odo_sum += o
            line = f"  {a:6.1f}-{b:6.1f} s  odometry {o:6.2f} m  fixes {c:6.2f} m  ratio {c / o:.3f}"
            if alpha:
                vals = [v for t, v in zip(*alpha) if a <= t < b]
                line += f"  filter {sum(vals) / len(vals):.3f}"
            print(line)
        a = b
    if odo_sum > 0:
        print(f"  windows: {fix_sum:.1f} / {odo_sum:.1f} m = {fix_sum / odo_sum:.4f}")
    if alpha:
        ts, vs = alpha
        later = [v for t, v in zip(ts, vs) if t >= 30.0]
        print(f"filter speed factor: mean after 30 s {sum(later) / len(later):.3f}, final {vs[-1]:.3f}")


if __name__ == "__main__":
    main()
