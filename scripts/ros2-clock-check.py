#!/usr/bin/env python3
"""The pose stream's clock offset and speed factor against the wheels, from
the data alone, on a log with GNSS fixes, wheel speeds and a gyro.

GNSS velocity (fixes 2 s apart) is compared with the odometry's speed along
the gyro-integrated heading, averaged over the same 2 s and shifted by a
lag; the unknown heading is aligned per 60 s segment. The lag with the least
squared velocity error is the clock offset in the estimator's sign (a fix
stamped t shows the robot at wheel time t - offset: positive = fixes late),
per third of the drive and overall. The speed factor is the least-squares
ratio of GNSS speed to odometry speed at that lag. Pure Python.

usage: ros2-clock-check.py LOG [GYRO_COLUMN]   (default gyro_z)
"""
import bisect
import math
import sys

from logcsv import rows


def at(ts, vs, t):
    i = bisect.bisect_right(ts, t)
    if i == 0 or i >= len(ts):
        return None
    a = (t - ts[i - 1]) / (ts[i] - ts[i - 1])
    return vs[i - 1] + a * (vs[i] - vs[i - 1])


def main():
    log = sys.argv[1]
    gyro = sys.argv[2] if len(sys.argv) > 2 else "gyro_z"
    wheels = rows(log, "wheels.csv")
    tw = [float(r["t"]) for r in wheels]
    vw = [(float(r["v_left"]) + float(r["v_right"])) / 2 for r in wheels]
    fixes = [(float(r["t"]), float(r["east"]), float(r["north"]))
             for r in rows(log, "pose.csv") if r["east"]]
    imu = [(float(r["t"]), float(r[gyro])) for r in rows(log, "imu.csv") if r[gyro]]
    ti = [s[0] for s in imu]
    yaw = [0.0]
    for k in range(1, len(imu)):
        yaw.append(yaw[-1] + imu[k - 1][1] * (imu[k][0] - imu[k - 1][0]))
    gnss = []  # (t, v_east, v_north)
    j = 0
    for i, (t, e, n) in enumerate(fixes):
        j = max(j, i)
        while j < len(fixes) and fixes[j][0] < t + 2.0:
            j += 1
        if j >= len(fixes):
            break
        dt = fixes[j][0] - t
        gnss.append(((t + fixes[j][0]) / 2, (fixes[j][1] - e) / dt, (fixes[j][2] - n) / dt))

    def odo(t):
        """Odometry velocity along the gyro heading and speed, mean over t +- 1 s."""
        ve = vn = sp = 0.0
        m = 0
        for k in range(-10, 11):
            v, y = at(tw, vw, t + k * 0.1), at(ti, yaw, t + k * 0.1)
            if v is None or y is None:
                continue
            ve += v * math.cos(y)
            vn += v * math.sin(y)
            sp += v
            m += 1
        return (ve / m, vn / m, sp / m) if m else None

    def cost(offset, t0, t1):
        segs = {}
        for t, ge, gn in gnss:
            if not t0 <= t < t1:
                continue
            o = odo(t - offset)
            if o:
                segs.setdefault(int(t // 60), []).append((ge, gn, o[0], o[1]))
        err, n = 0.0, 0
        for seg in segs.values():
            s = sum(c * b - d * a for a, b, c, d in seg)
            c_ = sum(c * a + d * b for a, b, c, d in seg)
            th = math.atan2(s, c_)
            cs, sn = math.cos(th), math.sin(th)
            for a, b, c, d in seg:
                err += (a - (cs * c - sn * d)) ** 2 + (b - (sn * c + cs * d)) ** 2
                n += 1
        return err / max(n, 1)

    offsets = [k / 10 for k in range(-15, 16)]
    end = gnss[-1][0] + 1
    for t0, t1 in [(0, end / 3), (end / 3, 2 * end / 3), (2 * end / 3, end), (0, end)]:
        best = min(offsets, key=lambda o: cost(o, t0, t1))
        print(f"[{t0:.0f}, {t1:.0f}) s: clock offset {best:+.1f} s "
              f"(velocity error {cost(best, t0, t1):.4f} m2/s2; at 0 s {cost(0.0, t0, t1):.4f}, "
              f"at -0.5 s {cost(-0.5, t0, t1):.4f})")
    num = den = 0.0
    for t, ge, gn in gnss:
        o = odo(t - best)
        if o and o[2] > 0.3:
            num += math.hypot(ge, gn) * o[2]
            den += o[2] * o[2]
    print(f"speed factor (GNSS speed / odometry speed, moving): {num / den:.3f}")


if __name__ == "__main__":
    main()
