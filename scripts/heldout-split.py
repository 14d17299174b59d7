#!/usr/bin/env python3
"""Where one model of `terraslip-lab heldout` beats another on a drive:
the per-segment 2 s errors (`heldout --diagnose DIR` writes DIR/DRIVE.csv)
split by what the robot did over each segment, and the lateral slip the
pose shows against the centripetal acceleration.

- splits in thirds by the segment's mean |v| (mean tread speed, m/s),
  |dv| (tread speed difference, m/s), |v omega| (omega = dv / track width),
  the change of command against the 3 s before, the time in the drive;
  and by the direction driven (mean v < 0), and, with ESTIMATE (an
  `estimate --out` directory of the same drive), by the time since the
  slip-change detector last fired;
- with ESTIMATE: DRIVE's model refitted on the first half's steady rows
  and the filter's twist (the ICRs in effect) against the body velocity
  the pose shows on the second half (a central difference over +-0.25 s,
  the pose read CLOCK s late): each one's rms residual, and the share of
  the filter's that each candidate regressor (v, v omega, omega, ...)
  explains;
- the pose's body-frame lateral speed against v omega: its least-squares
  slope overall and per |v omega| band, with v omega as it is and
  low-passed (the ground taking a turn up); with ESTIMATE, the filter's
  own slope and its x_c against v per 50 s (its k_x_speed as it went).

Needs numpy.

usage: heldout-split.py LOG DIAGNOSE.csv [A B [CLOCK [ESTIMATE]]]
  CLOCK: how late the pose is stamped, s (default 0.35).
  A, B: the two columns compared (default "DRIVE's model" and
  "online default"; the gap is B - A, m).
"""
import csv
import sys

import numpy as np


def table(path):
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    def num(x):
        try:
            return float(x)
        except ValueError:
            return np.nan

    head = rows[0]
    body = np.array([[num(x) for x in r] for r in rows[1:]])
    return {h: body[:, k] for k, h in enumerate(head)}


def track_width(log):
    for line in open(f"{log}/meta.toml"):
        key, _, val = line.partition("=")
        if key.strip() == "track_width":
            return float(val.split("#")[0])
    return 0.5


def body_velocity(p, tq, h=0.25):
    """The pose's body-frame velocity (v_x, v_y, omega) at pose times `tq`:
    a central difference over +-h s, the chord taken along the mean heading."""
    yaw = np.unwrap(p["yaw"])
    ea, eb = np.interp(tq - h, p["t"], p["east"]), np.interp(tq + h, p["t"], p["east"])
    na, nb = np.interp(tq - h, p["t"], p["north"]), np.interp(tq + h, p["t"], p["north"])
    ya, yb = np.interp(tq - h, p["t"], yaw), np.interp(tq + h, p["t"], yaw)
    mid, half = 0.5 * (ya + yb), 0.5 * (yb - ya)
    safe = np.where(half == 0, 1.0, half)
    sinc = np.where(abs(half) > 1e-6, np.sin(half) / safe, 1.0)
    de, dn = eb - ea, nb - na
    vx = (de * np.cos(mid) + dn * np.sin(mid)) / (2 * h * sinc)
    vy = (-de * np.sin(mid) + dn * np.cos(mid)) / (2 * h * sinc)
    return np.stack([vx, vy, (yb - ya) / (2 * h)], axis=1)


def filter_twist(est, vl, vr, i):
    """The filter's body twist at wheels rows `i`: the ICRs in effect
    (`estimate.csv`, one row per wheels row) in the plain ICR model."""
    s = table(f"{est}/estimate.csv")
    k = np.minimum(i, len(s["t"]) - 1)
    yl, yr, xc = s["y_l"][k], s["y_r"][k], s["x_c"][k]
    ul, ur = s["alpha_l"][k] * vl[i], s["alpha_r"][k] * vr[i]
    d = yl - yr
    return np.stack([(ur * yl - ul * yr) / d, xc * (ul - ur) / d, (ur - ul) / d], axis=1)


def steady_rows(wt, vl, vr, tol=0.1, hold=1.0, h=0.25):
    """Rows whose tread speeds were held within `tol` for `hold` s before
    and through +-h s (DRIVE's steady part of a command, as blr.rs reads it)."""
    n = len(wt)
    out = np.zeros(n, bool)
    since = 0
    for k in range(n):
        while since < k and (
            np.any(abs(vl[since:k] - vl[k]) > tol) or np.any(abs(vr[since:k] - vr[k]) > tol)
        ):
            since += 1
        j = np.searchsorted(wt, wt[k] + h, side="right")
        ahead = np.all(abs(vl[k:j] - vl[k]) <= tol) and np.all(abs(vr[k:j] - vr[k]) <= tol)
        out[k] = ahead and wt[k] - wt[since] >= hold and abs(vl[k]) + abs(vr[k]) >= 0.2
    return out


def regressors(w, p, b, clock, est):
    """DRIVE's model (least squares on the first half's steady rows) and the
    filter's twist (the ICRs in effect, `estimate.csv`) against the pose's
    body velocity on the second half: each one's rms residual, and how much
    of it each candidate regressor explains."""
    wt, vl, vr = w["t"], w["v_left"], w["v_right"]
    v, om = 0.5 * (vl + vr), (vr - vl) / b
    half = 0.5 * wt[-1]
    train = steady_rows(wt, vl, vr) & (wt < half - 1.0) & (wt > 1.0)
    m = body_velocity(p, wt[train] + clock)
    vt, ot = v[train], om[train]
    wx = (vt @ (vt - m[:, 0])) / (vt @ vt)
    wy = ((vt * ot) @ (-m[:, 1])) / ((vt * ot) @ (vt * ot))
    wyaw = np.linalg.lstsq(np.c_[vt * ot, vt, ot], ot - m[:, 2], rcond=None)[0]
    moving = (abs(vl) + abs(vr) >= 0.2) & (wt > half) & (wt < wt[-1] - 1.0)
    i = np.where(moving)[0][::2]
    online = filter_twist(est, vl, vr, i)
    vi, oi = v[i], om[i]
    drive = np.stack(
        [vi * (1 - wx), -wy * vi * oi, oi - (wyaw[0] * vi * oi + wyaw[1] * vi + wyaw[2] * oi)],
        axis=1,
    )
    meas = body_velocity(p, wt[i] + clock)
    print(
        f"DRIVE's model on the first half's steady rows: w_x {wx:+.3f}, w_y {wy:+.3f} s, "
        f"w_yaw [v omega, v, omega] {np.round(wyaw, 3)}"
    )
    cands = {
        "v": vi, "v omega": vi * oi, "omega": oi, "|v|": abs(vi), "|v| omega": abs(vi) * oi,
        "v |omega|": vi * abs(oi), "omega |omega|": oi * abs(oi), "v |v|": vi * abs(vi),
    }
    print(f"residual against the pose (second half, {len(i)} rows), rms; share of it each regressor explains:")
    for c, name in enumerate(["v_x", "v_y", "omega"]):
        ro, rd = meas[:, c] - online[:, c], meas[:, c] - drive[:, c]
        print(f"  {name}: filter {np.sqrt(np.mean(ro**2)):.3f}, DRIVE's model {np.sqrt(np.mean(rd**2)):.3f}")
        for rn, x in cands.items():
            co = (x @ ro) / (x @ x)
            share = 1 - np.mean((ro - co * x) ** 2) / np.mean(ro**2)
            print(f"    filter's ~ {rn:<14} slope {co:+.4f}, {100 * share:4.1f} %")


def main(argv):
    if len(argv) < 3:
        sys.exit(__doc__)
    log, diag = argv[1], argv[2]
    a_col = argv[3] if len(argv) > 3 else "DRIVE's model"
    b_col = argv[4] if len(argv) > 4 else "online default"
    clock = float(argv[5]) if len(argv) > 5 else 0.35
    est = argv[6] if len(argv) > 6 else None
    w, p, e = table(f"{log}/wheels.csv"), table(f"{log}/pose.csv"), table(diag)
    b = track_width(log)
    t, a, m = e["t"], e[a_col], e[b_col]
    gap = m - a
    wt, vl, vr = w["t"], w["v_left"], w["v_right"]
    v, dv = 0.5 * (vl + vr), vr - vl
    feats = {k: [] for k in ["|v|", "|dv|", "|v omega|", "command change", "time"]}
    reverse = []
    for s in t:
        i = (wt >= s) & (wt <= s + 2.0)
        j = (wt >= s - 3.0) & (wt < s)
        feats["|v|"].append(np.mean(abs(v[i])))
        feats["|dv|"].append(np.mean(abs(dv[i])))
        feats["|v omega|"].append(np.mean(abs(v[i] * dv[i] / b)))
        chg = abs(np.mean(v[i]) - np.mean(v[j])) + abs(np.mean(dv[i]) - np.mean(dv[j]))
        feats["command change"].append(chg)
        feats["time"].append(s)
        reverse.append(np.mean(v[i]) < 0)
    print(f"{len(t)} segments: {a_col} {a.mean():.3f} m, {b_col} {m.mean():.3f} m, gap {gap.mean():+.4f} m")

    def show(name, groups):
        cells = [
            f"[{g.sum()}: {a[g].mean():.3f} / {m[g].mean():.3f}, gap {gap[g].mean():+.3f}]"
            for g in groups
            if g.sum()
        ]
        print(f"  {name:<16} " + " ".join(cells))

    print(f"split (segments: {a_col} / {b_col}, gap):")
    for name, x in feats.items():
        x = np.array(x)
        q = np.quantile(x, [1 / 3, 2 / 3])
        show(name, [x <= q[0], (x > q[0]) & (x <= q[1]), x > q[1]])
    r = np.array(reverse)
    show("forward/reverse", [~r, r])
    if est:
        s = table(f"{est}/estimate.csv")
        fired = s["t"][s["change"] > 0]
        print(f"  the detector fired {len(fired)} times")
        since = np.array([x - fired[fired <= x].max() if (fired <= x).any() else 1e9 for x in t])
        groups = [(since >= lo) & (since < hi) for lo, hi in [(0, 3), (3, 10), (10, 20), (20, 1e10)]]
        show("since detection 0-3/3-10/10-20/20+ s", groups)
        regressors(w, p, b, clock, est)
    top = np.sort(gap)[::-1][:20].sum()
    print(f"  the 20 largest gaps add up to {top:+.2f} m, all {len(t)} to {gap.sum():+.2f} m")

    # The lateral slip the pose shows against v omega, second half.
    moving = (abs(vl) + abs(vr) >= 0.2) & (wt > 0.5 * wt[-1]) & (wt < wt[-1] - 1.0)
    idx = np.where(moving)[0][::2]
    vy = body_velocity(p, wt[idx] + clock)[:, 1]
    dt = np.median(np.diff(wt))
    print(f"lateral speed (pose {clock:+.2f} s late, second half) against v omega:")
    for tau in [0.0, 0.25, 0.5]:
        x = v * dv / b
        if tau > 0:
            y, k = np.zeros_like(x), dt / (tau + dt)
            for n in range(1, len(x)):
                y[n] = y[n - 1] + k * (x[n] - y[n - 1])
            x = y
        x = x[idx]
        slope = (x @ vy) / (x @ x)
        r2 = 1 - np.mean((vy - slope * x) ** 2) / np.mean(vy**2)
        print(f"  low-passed {tau:.2f} s: slope {slope:+.4f} s, R^2 {r2:.3f}")
    x = (v * dv / b)[idx]
    if est:
        model = filter_twist(est, vl, vr, idx)[:, 1]
        print(f"  the filter's own lateral speed (ICRs in effect): slope {(x @ model) / (x @ x):+.4f} s")
        s = table(f"{est}/estimate.csv")
        n = min(len(s["t"]), len(v))
        cells = []
        for t0 in np.arange(0.0, wt[-1], 50.0):
            g = (s["t"][:n] >= t0) & (s["t"][:n] < t0 + 50.0) & (abs(v[:n]) > 0.3)
            if g.sum() > 10:
                fit = np.linalg.lstsq(np.c_[np.ones(g.sum()), v[:n][g]], s["x_c"][:n][g], rcond=None)
                cells.append(f"{t0:.0f}: {fit[0][1]:+.3f}")
        print("  the filter's x_c against v per 50 s (its k_x_speed as it went, s): " + ", ".join(cells))
    # The same slope over the drive so far (every other moving row from
    # the start), to set beside the filter's k_x_speed as it went.
    run = (abs(vl) + abs(vr) >= 0.2) & (wt > 1.0) & (wt < wt[-1] - 1.0)
    ridx = np.where(run)[0][::2]
    rvy = body_velocity(p, wt[ridx] + clock)[:, 1]
    rx = (v * dv / b)[ridx]
    cum = []
    for t1 in np.arange(100.0, wt[-1] + 100.0, 100.0):
        g = wt[ridx] < t1
        if g.sum() > 10:
            cum.append(f"{min(t1, wt[-1]):.0f}: {(rx[g] @ rvy[g]) / (rx[g] @ rx[g]):+.3f}")
    print("  the pose's slope over the drive up to t (s): " + ", ".join(cum))
    for lo, hi in [(0, 1), (1, 2), (2, 3), (3, 4), (4, 1e9)]:
        g = (abs(x) >= lo) & (abs(x) < hi)
        if g.sum():
            print(f"  |v omega| {lo}-{hi if hi < 1e9 else 'up'} m/s^2: slope {(x[g] @ vy[g]) / (x[g] @ x[g]):+.4f} s ({g.sum()} rows)")


if __name__ == "__main__":
    main(sys.argv)
