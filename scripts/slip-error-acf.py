#!/usr/bin/env python3
"""How long the slip model's error stays correlated on a drive: the body
velocity the pose shows against the online filter's twist, and the
autocorrelation of the residual at lags of 0.2-5 s.

- the pose (its stamps are irregular, 0.05-0.65 s apart) interpolated on
  a 0.05 s grid, away from gaps over 0.5 s;
- body-frame forward speed and yaw rate from it by a central
  difference over +-0.1 s, the pose read CLOCK s late (a pose stamped `t`
  describes the robot at wheel time `t - CLOCK`);
- the model's forward speed and yaw rate from the tread speeds with the
  ICRs and speed factors `estimate.csv` gives at that time (ESTIMATE, an
  `estimate --out` directory of the same drive; the constant-ICR twist,
  without the turn laws and centripetal terms);
- residuals where the robot drives (|v| > 0.3 m/s) or turns
  (|omega| > 0.2 rad/s), after the first 30 % of the drive (the filter
  still learning); their rms and their correlation at each lag.

Usage: slip-error-acf.py LOG ESTIMATE CLOCK
"""

import sys

import numpy as np

from logcsv import columns, model_twist

LAGS = [0.2, 0.3, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0]
HALF_WIDTH = 0.1
GRID = 0.05
MAX_GAP = 0.5


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    log, est, clock = sys.argv[1], sys.argv[2], float(sys.argv[3])
    p, w, e = columns(f"{log}/pose.csv"), columns(f"{log}/wheels.csv"), columns(f"{est}/estimate.csv")
    ts = p["t"]
    t = np.arange(ts[0], ts[-1], GRID)
    # Grid points inside a gap between stamps are not used.
    i = np.clip(np.searchsorted(ts, t, side="right"), 1, len(ts) - 1)
    gap = ts[i] - ts[i - 1] > MAX_GAP
    east, north = np.interp(t, ts, p["east"]), np.interp(t, ts, p["north"])
    yaw = np.interp(t, ts, np.unwrap(p["yaw"]))
    east[gap] = north[gap] = yaw[gap] = np.nan
    dt = GRID
    k = int(round(HALF_WIDTH / dt))
    span = t[2 * k:] - t[:-2 * k]
    tc, yc = t[k:-k], yaw[k:-k]
    ve = (east[2 * k:] - east[:-2 * k]) / span
    vn = (north[2 * k:] - north[:-2 * k]) / span
    omega = (yaw[2 * k:] - yaw[:-2 * k]) / span
    vx = ve * np.cos(yc) + vn * np.sin(yc)
    tw = tc - clock
    model_vx, model_omega = model_twist(w, e, tw)
    v = 0.5 * (np.interp(tw, w["t"], w["v_left"]) + np.interp(tw, w["t"], w["v_right"]))
    late = tc > tc[0] + 0.3 * (tc[-1] - tc[0])
    name = log.rstrip("/").split("/")[-1]
    for what, r, moving in [
        ("v_x", vx - model_vx, np.abs(v) > 0.3),
        ("omega", omega - model_omega, np.abs(model_omega) > 0.2),
    ]:
        r = np.where(moving & late, r, np.nan)
        rho = []
        for lag in LAGS:
            n = int(round(lag / dt))
            a, b = r[:-n], r[n:]
            ok = ~np.isnan(a) & ~np.isnan(b)
            rho.append(np.corrcoef(a[ok], b[ok])[0, 1])
        print(
            f"{name} {what}: rms {np.nanstd(r):.3f}, correlation "
            + ", ".join(f"{lag:g} s {c:+.2f}" for lag, c in zip(LAGS, rho))
        )


if __name__ == "__main__":
    main()
