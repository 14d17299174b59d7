#!/usr/bin/env python3
"""Is a drive's pose stamped with a random time error (jitter)? The motion
between consecutive pose fixes against the online filter's model, and a
regression of the squared residual on what each kind of error predicts.

- the stamps: how many lie on the wheels' sample grid, the intervals;
- for each pair of consecutive fixes (stamps `t0 < t1`, at most 0.7 s
  apart, the pose read CLOCK s late: a pose stamped `t` describes the
  robot at wheel time `t - CLOCK`), the model's motion from the first fix
  integrated over the wheels between them (the tread speeds with the ICRs
  and speed factors `estimate.csv` gives at that time; ESTIMATE is an
  `estimate --out` directory of the same drive);
- the second fix against it: the position residual along the model's
  track at `t1` and across it, and the heading residual;
- after the first 30 % of the drive, moving pairs (model speed over
  0.3 m/s or yaw rate over 0.2 rad/s at both ends);
- least squares of the squared residual on `[1, sum(v^2 dt), v0^2 +
  v1^2]` (sensor noise, white model error, stamp jitter at both fixes;
  `v` the model's speed, resp. `omega` its yaw rate for the heading;
  `sigma_t = sqrt(coefficient of v0^2 + v1^2)`); again with a column for
  model error correlated over the pair, `sum(v^2 dt)^2 / dt`; and on the
  fast pairs (over 1 m/s, resp. 0.7 rad/s at the fixes) divided by
  `(v0^2 + v1^2) / 2`, where the sensor's constant noise is a column
  `1 / v^2` and jitter the constant `2 sigma_t^2`;
- the squared residual per unit squared speed (yaw rate) at the
  commonest interval, by the quartile of the squared speed: level if
  jitter or white model error alone (both grow as `v^2`);
- the squared residual per unit squared speed (yaw rate) of the fast
  pairs, binned by the interval: flat in the interval if jitter
  dominates, growing with it if model error does.

The coefficients are printed with their standard errors in brackets.
INJECT (s) adds a known jitter to the log's stamps first (normal, that
std, seed 1), to see how jitter would show in these figures.

Usage: pose-stamp-jitter.py LOG ESTIMATE CLOCK [INJECT]
"""

import sys

import numpy as np

from logcsv import columns, fix_pair

MAX_PAIR = 0.7
STEP = 0.01


def fit(y, cols, names):
    x = np.column_stack(cols)
    # Scaled columns, coefficients and their standard errors.
    sc = np.sqrt((x**2).mean(axis=0))
    xs = x / sc
    beta, *_ = np.linalg.lstsq(xs, y, rcond=None)
    res = y - xs @ beta
    cov = np.linalg.inv(xs.T @ xs) * res.var() * len(y) / (len(y) - len(beta))
    beta, se = beta / sc, np.sqrt(np.diag(cov)) / sc
    return ", ".join(f"{n} {b:.3g} ({s:.2g})" for n, b, s in zip(names, beta, se)), beta, se


def main():
    if len(sys.argv) not in (4, 5):
        sys.exit(__doc__)
    log, est, clock = sys.argv[1], sys.argv[2], float(sys.argv[3])
    inject = float(sys.argv[4]) if len(sys.argv) == 5 else 0.0
    p, w, e = columns(f"{log}/pose.csv"), columns(f"{log}/wheels.csv"), columns(f"{est}/estimate.csv")
    name = log.rstrip("/").split("/")[-1]

    if inject > 0.0:
        # Known jitter on top of the log's stamps, to see how it shows.
        t = p["t"] + inject * np.random.default_rng(1).standard_normal(len(p["t"]))
        order = np.argsort(t)
        p = {k: v[order] for k, v in p.items()}
        p["t"] = t[order]
        name += f" with {inject:g} s of jitter added"
    ts = p["t"]
    gaps = np.diff(ts)
    wheel_step = np.median(np.diff(w["t"]))
    on_grid = np.abs(ts / wheel_step - np.round(ts / wheel_step)) < 0.02
    print(f"{name}: {len(ts)} pose stamps, {np.mean(on_grid):.1%} on the wheels' {wheel_step:g} s grid; "
          "intervals (1, 10, 50, 90, 99 %) " + ", ".join(f"{q:.2f}" for q in np.percentile(gaps, [1, 10, 50, 90, 99])) + " s")
    yaw = np.unwrap(p["yaw"])
    t_end = ts[-1]
    rows = []
    for i in range(1, len(ts)):
        t0, t1 = ts[i - 1], ts[i]
        if t1 - t0 > MAX_PAIR or t0 < ts[0] + 0.3 * (t_end - ts[0]):
            continue
        v, om, h, along, across, dyaw = fix_pair(p, yaw, w, e, i, clock, STEP)
        vm = 0.5 * (v[1:] + v[:-1])
        dt = t1 - t0
        rows.append((dt, v[0], v[-1], om[0], om[-1], np.sum(vm**2) * h,
                     np.sum((0.5 * (om[1:] + om[:-1])) ** 2) * h, along, across, dyaw))
    r = np.array(rows)
    dt, v0, v1, w0, w1, bv, bw, along, across, dyaw = r.T
    moving = ((np.abs(v0) > 0.3) | (np.abs(w0) > 0.2)) & ((np.abs(v1) > 0.3) | (np.abs(w1) > 0.2))
    print(f"{name}: {moving.sum()} moving pairs of {len(dt)}; interval median {np.median(dt[moving]):.2f} s; "
          f"rms along {np.sqrt(np.mean(along[moving]**2)):.3f} m, across {np.sqrt(np.mean(across[moving]**2)):.3f} m, "
          f"heading {np.sqrt(np.mean(dyaw[moving]**2)):.3f} rad")
    # Trim the 1 % largest squares (outliers swamp a regression of squares).
    for what, res, b, a0, a1 in [("along", along, bv, v0, v1), ("heading", dyaw, bw, w0, w1)]:
        y = res**2
        keep = moving & (y < np.percentile(y[moving], 99))
        jit = a0**2 + a1**2
        txt, beta, _ = fit(y[keep], [np.ones(keep.sum()), b[keep], jit[keep]], ["const", "white", "jitter"])
        print(f"  {what}: {txt}; sigma_t {np.sqrt(max(beta[2], 0)):.3f} s")
        cols = [np.ones(keep.sum()), b[keep], b[keep] ** 2 / dt[keep], jit[keep]]
        txt, beta, _ = fit(y[keep], cols, ["const", "white", "correlated", "jitter"])
        print(f"  {what}, with model error correlated over the pair: {txt}; sigma_t {np.sqrt(max(beta[3], 0)):.3f} s")
        # At the commonest interval, by the squared speed (rate) at the
        # fixes: jitter and white model error both grow as v^2 here.
        s2 = 0.5 * jit
        vals, cnt = np.unique(np.round(dt[keep], 2), return_counts=True)
        d = vals[np.argmax(cnt)]
        sel = keep & (np.abs(np.round(dt, 2) - d) < 1e-6)
        edges = np.percentile(s2[sel], [0, 25, 50, 75, 100])
        out = []
        for lo, hi in zip(edges[:-1], edges[1:]):
            k = sel & (s2 >= lo) & (s2 <= hi)
            out.append(f"{np.mean(s2[k]):.2f}: {np.mean(y[k]) / np.mean(s2[k]):.4f}")
        print(f"    {what} square / {'v' if what == 'along' else 'omega'}^2 at {d:.2f} s by its quartile: " + ", ".join(out))
        # Fast pairs, divided by the squared speed (rate) at the fixes:
        # the sensor's constant noise as 1 / v^2, jitter as a constant.
        fast = keep & (s2 > (1.0 if what == "along" else 0.5))
        if fast.sum() < 20:
            print(f"  {what}: {fast.sum()} fast pairs, too few to fit")
            continue
        cols = [1.0 / s2[fast], b[fast] / s2[fast], np.ones(fast.sum())]
        txt, beta, _ = fit(y[fast] / s2[fast], cols, ["const", "white", "2 jitter"])
        print(f"  {what}, fast pairs per squared speed: {txt}; sigma_t {np.sqrt(max(beta[2], 0) / 2):.3f} s")
        # The same by the interval: flat in the interval for jitter,
        # growing with it for model error.
        out = []
        for lo, hi in [(0.0, 0.125), (0.125, 0.175), (0.175, 0.225), (0.225, 0.275), (0.275, 0.375), (0.375, MAX_PAIR)]:
            k = fast & (dt > lo) & (dt <= hi)
            if k.sum() >= 20:
                q = res[k] ** 2 / s2[k]
                out.append(f"{np.mean(dt[k]):.2f} s {np.mean(q):.4f} ({k.sum()})")
        print(f"    {what} square / {'v' if what == 'along' else 'omega'}^2 by interval: " + ", ".join(out))


if __name__ == "__main__":
    main()
