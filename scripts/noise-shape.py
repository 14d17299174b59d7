#!/usr/bin/env python3
"""How the kinematic model's error grows with speed and turn rate: the
shape of the model noise.

For each pair of consecutive pose fixes at most 0.7 s apart after the
first 30 % of the drive (the pair method of `pose-stamp-jitter.py`: the
pose read CLOCK s late, the model's motion from the first fix integrated
over the wheels between them with the ICRs and speed factors of
`estimate.csv`), the second fix's residual along the model's track,
across it and in heading. Its square is `2 sigma^2 + sum(g dt)`: the
sensor's noise at both fixes and the model error's variance per second
`g` integrated over the pair. Fitted by maximum likelihood (a squared
normal residual: iteratively reweighted least squares with weights
`1 / E[y]^2`), the 1 % largest squares left out:

- `g` piecewise constant over bins of the model's `|v|` (resp. `|omega|`;
  and for the heading over bins of both): the rate per bin, and that rate
  over the bin's mean `v^2` and `|v|`;
- `g` of each candidate shape (`q v^2`, `q |v|`, `a + q v^2`,
  `a + q |v|`, `q v^2 / (v0 + |v|)`; for the heading the same in
  `omega`, and `q omega^2 + c v^2`): the log-likelihood against the
  `v^2` shape (positive: fits better; each extra parameter should buy at
  least 1).

CLOCK defaults to `summary.json`'s `clock_offset_s.value` in ESTIMATE.

Usage: noise-shape.py LOG ESTIMATE [CLOCK]
"""

import json
import sys

import numpy as np

from logcsv import columns, fix_pair

MAX_PAIR = 0.7
STEP = 0.01
V_EDGES = [0.0, 0.1, 0.4, 0.8, 1.2, 1.6, 2.0, 2.5, 10.0]
W_EDGES = [0.0, 0.05, 0.15, 0.3, 0.5, 0.8, 10.0]


def ml_fit(y, x, iters=60):
    """Non-negative coefficients of `E[y] = x @ beta` for squared normal
    residuals `y`; returns `(beta, log-likelihood)`."""
    beta = np.full(x.shape[1], max(y.mean(), 1e-12) / max(x.sum(axis=1).mean(), 1e-12))
    for _ in range(iters):
        s = np.maximum(x @ beta, 1e-12)
        w = 1.0 / s**2
        active = np.ones(x.shape[1], bool)
        for _ in range(x.shape[1]):
            xa = x[:, active]
            a = (xa * w[:, None]).T @ xa
            b = (xa * w[:, None]).T @ y
            sol = np.linalg.lstsq(a, b, rcond=None)[0]
            if (sol >= 0).all():
                break
            idx = np.flatnonzero(active)
            active[idx[np.argmin(sol)]] = False
        new = np.zeros(x.shape[1])
        new[active] = sol
        if np.allclose(new, beta, rtol=1e-6, atol=1e-15):
            beta = new
            break
        beta = 0.5 * (beta + new)
    s = np.maximum(x @ beta, 1e-12)
    return beta, -0.5 * np.sum(np.log(s) + y / s)


def pairs(log, est, clock):
    p, w, e = columns(f"{log}/pose.csv"), columns(f"{log}/wheels.csv"), columns(f"{est}/estimate.csv")
    ts, yaw = p["t"], np.unwrap(p["yaw"])
    out = []
    for i in range(1, len(ts)):
        t0, t1 = ts[i - 1], ts[i]
        if t1 - t0 > MAX_PAIR or t0 < ts[0] + 0.3 * (ts[-1] - ts[0]):
            continue
        v, om, h, along, across, dyaw = fix_pair(p, yaw, w, e, i, clock, STEP)
        vm, wm = 0.5 * (v[1:] + v[:-1]), 0.5 * (om[1:] + om[:-1])
        out.append((np.abs(vm), np.abs(wm), h, along, across, dyaw))
    return out


def design(prs, f):
    """One row per pair: `[1, sum(f(v, omega) dt) for each column of f]`."""
    rows = [np.concatenate([[1.0], np.atleast_1d(f(v, w)).reshape(-1, len(v)).sum(axis=1) * h])
            for v, w, h, *_ in prs]
    return np.array(rows)


def bins_of(x, edges):
    return np.array([(x >= lo) & (x < hi) for lo, hi in zip(edges[:-1], edges[1:])], float)


def main():
    if len(sys.argv) not in (3, 4):
        sys.exit(__doc__)
    log, est = sys.argv[1], sys.argv[2]
    if len(sys.argv) == 4:
        clock = float(sys.argv[3])
    else:
        with open(f"{est}/summary.json") as fh:
            clock = json.load(fh)["clock_offset_s"]["value"]
    name = log.rstrip("/").split("/")[-1]
    prs = pairs(log, est, clock)
    res = {k: np.array([p[3 + j] for p in prs]) for j, k in enumerate(("along", "across", "heading"))}
    print(f"{name}: {len(prs)} pairs, clock {clock:.3f} s")
    for what in ("along", "across", "heading"):
        y = res[what] ** 2
        keep = np.isfinite(y)
        keep &= y < np.percentile(y[keep], 99)
        y = y[keep]
        sel = [p for p, k in zip(prs, keep) if k]
        rate = (lambda v, w: v) if what != "heading" else (lambda v, w: w)
        edges = V_EDGES if what != "heading" else W_EDGES
        unit = "v" if what != "heading" else "omega"
        xb = design(sel, lambda v, w: bins_of(rate(v, w), edges))
        occupied = np.flatnonzero(xb[:, 1:].sum(axis=0) > 5.0) + 1
        xb = xb[:, np.concatenate([[0], occupied])]
        beta, _ = ml_fit(y, xb)
        mean_x = design(sel, lambda v, w: bins_of(rate(v, w), edges) * rate(v, w))[:, occupied].sum(axis=0)
        mean_x2 = design(sel, lambda v, w: bins_of(rate(v, w), edges) * rate(v, w) ** 2)[:, occupied].sum(axis=0)
        tb = xb[:, 1:].sum(axis=0)
        mx, mx2 = mean_x / tb, mean_x2 / tb
        print(f"  {what}: sensor 2 sigma^2 {beta[0]:.3g}; rate per second by |{unit}| "
              "(bin mean, seconds: rate, rate/" + unit + "^2, rate/|" + unit + "|):")
        print("    " + "; ".join(f"{a:.2f}, {t:.0f} s: {b:.3g}, {b / c:.3g}, {b / a:.3g}"
                                 for a, c, t, b in zip(mx, mx2, tb, beta[1:])))
        if what == "heading":
            # By both: the heading's rate over bins of |v| at low and high turn rate.
            vb = [0.0, 0.4, 1.2, 2.0, 10.0]
            cols = lambda v, w: np.concatenate([bins_of(v, vb) * (w < 0.15), bins_of(v, vb) * (w >= 0.15)])
            x2 = design(sel, cols)
            occ = np.flatnonzero(x2[:, 1:].sum(axis=0) > 5.0) + 1
            b2, _ = ml_fit(y, x2[:, np.concatenate([[0], occ])])
            lab = [f"|w|<0.15 v{lo}-{hi}" for lo, hi in zip(vb[:-1], vb[1:])] + \
                  [f"|w|>=0.15 v{lo}-{hi}" for lo, hi in zip(vb[:-1], vb[1:])]
            print("    by |v| and |omega|: " + "; ".join(f"{lab[k - 1]} {b:.3g}" for k, b in zip(occ, b2[1:])))
        shapes = {
            "x^2": lambda v, w: rate(v, w) ** 2,
            "|x|": lambda v, w: rate(v, w),
            "a + x^2": lambda v, w: np.array([np.ones_like(v), rate(v, w) ** 2]),
            "a + |x|": lambda v, w: np.array([np.ones_like(v), rate(v, w)]),
            "|x| + x^2": lambda v, w: np.array([rate(v, w), rate(v, w) ** 2]),
        }
        if what == "heading":
            shapes["w^2 + v^2"] = lambda v, w: np.array([w**2, v**2])
            shapes["|w| + v^2"] = lambda v, w: np.array([w, v**2])
        ll0 = None
        out = []
        for k, f in shapes.items():
            b, ll = ml_fit(y, design(sel, f))
            ll0 = ll if ll0 is None else ll0
            out.append(f"{k} {ll - ll0:+.1f} [" + ", ".join(f"{c:.3g}" for c in b[1:]) + "]")
        # The saturating shape x^2 / (x0 + |x|) over a grid of x0.
        best = max(((ml_fit(y, design(sel, lambda v, w: rate(v, w) ** 2 / (x0 + rate(v, w))))[1], x0)
                    for x0 in (0.05, 0.1, 0.2, 0.5, 1.0, 2.0, 5.0)))
        out.append(f"x^2/(x0+|x|) best x0 {best[1]:g} {best[0] - ll0:+.1f}")
        print(f"    shapes, log-likelihood against x^2 [coefficients]: " + "; ".join(out))


if __name__ == "__main__":
    main()
