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
  gives for S = 1 m);
- a least-squares speed factor from chords of 5 s and 10 s over the whole
  drive (consecutive, the odometry's chord over 2 m): fixes' chord = k x
  odometry's chord, each fix chord's squared length less the fixes' white
  noise (4 sigma^2, sigma from their second differences), with a 90 %
  interval from resampling 30 s blocks (the fixes' error wanders over tens
  of seconds, so chords are not independent).

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
    chord_fit(tw, x, y, tp, e, n)
    if alpha:
        ts, vs = alpha
        later = [v for t, v in zip(ts, vs) if t >= 30.0]
        print(f"filter speed factor: mean after 30 s {sum(later) / len(later):.3f}, final {vs[-1]:.3f}")


def chord_fit(tw, x, y, tp, e, n, chords=(5.0, 10.0), block_s=30.0, resamples=2000):
    """Print the least-squares factor fixes' chord / odometry chord and its
    90 % block-bootstrap interval, for each chord length in `chords`."""
    import random

    d2 = [(e[i + 1] - 2 * e[i] + e[i - 1]) ** 2 + (n[i + 1] - 2 * n[i] + n[i - 1]) ** 2
          for i in range(1, len(tp) - 1)]
    sigma = math.sqrt(sum(d2) / len(d2) / 12.0)  # per axis: a second difference has 6 sigma^2 per axis
    for length in chords:
        pairs = []
        a = max(tp[0], tw[0])
        while a + length <= min(tp[-1], tw[-1]):
            b = a + length
            o = math.hypot(interp(tw, x, b) - interp(tw, x, a), interp(tw, y, b) - interp(tw, y, a))
            if o > 2.0:
                c2 = (interp(tp, e, b) - interp(tp, e, a)) ** 2 + (interp(tp, n, b) - interp(tp, n, a)) ** 2
                pairs.append((a, math.sqrt(max(c2 - 4 * sigma * sigma, 0.0)), o))
            a = b

        def fit(sample):
            return sum(c * o for _, c, o in sample) / sum(o * o for _, _, o in sample)

        blocks = {}
        for p in pairs:
            blocks.setdefault(int(p[0] // block_s), []).append(p)
        keys = sorted(blocks)
        rng = random.Random(1)
        boot = sorted(fit([p for k in (rng.choice(keys) for _ in keys) for p in blocks[k]])
                      for _ in range(resamples))
        print(f"{length:.0f} s chords, least squares: fixes = {fit(pairs):.3f} x odometry, 90 % "
              f"{boot[int(0.05 * resamples)]:.3f}-{boot[int(0.95 * resamples)]:.3f} "
              f"({len(pairs)} chords in {len(keys)} blocks of {block_s:.0f} s; white noise {sigma:.2f} m per axis)")


if __name__ == "__main__":
    main()
