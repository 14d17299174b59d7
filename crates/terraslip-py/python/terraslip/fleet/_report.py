"""The fleet report: one HTML page (the report crate's style, inline SVG)
from an output directory's tables.

Per robot, for the recordings with a pose reference (without one the
estimator learns nothing): the controller factor (``wheel_separation_multiplier``) and the
speed factors of each recording over time, with each recording's 2σ band,
and the control limits of the robot's own history on that terrain. A
recording is flagged by a Shewhart individuals chart: with at least
``MIN_HISTORY`` earlier recordings of the robot on the same terrain, the
centre is their mean, their spread σ_h the mean moving range / 1.128 (the
I-MR chart's estimate), and the recording is out of control when it lies
more than 3·sqrt(σ_h² + σ²) from the centre (σ: its own std).

The map: the track points of recordings with a pose reference (GNSS in
ENU or a map-frame pose), coloured by slip 1 − (α_l + α_r)/2, drawn in
their pose source's frame (recordings of one site share it).
"""

from __future__ import annotations

import datetime as _dt
import html
import math
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple

import fsspec

from ._tables import read

MIN_HISTORY = 5
SIGMAS = 3.0
# The report crate's palette (Okabe-Ito), colour-blind safe.
PALETTE = ["#000000", "#e69f00", "#56b4e9", "#009e73", "#f0e442", "#0072b2", "#d55e00", "#cc79a7"]
STYLE = (
    "body{font-family:sans-serif;max-width:1150px;margin:2em auto;color:#222}"
    "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #bbb;padding:4px 8px;text-align:right}"
    "th{background:#eee}svg{border:1px solid #ddd;background:#fff}figcaption{color:#555;font-size:90%}"
    "td.flag{background:#fdd}pre{background:#f6f6f6;padding:8px;overflow-x:auto}"
)

# (column, its std column or None, label); the controller factor's std is
# std_spread / track_width.
SERIES = [
    ("controller_factor", None, "controller factor (y_l − y_r) / track width"),
    ("alpha_l", "std_alpha_l", "left speed factor α_l"),
    ("alpha_r", "std_alpha_r", "right speed factor α_r"),
]


def _std(row: Dict[str, Any], col: str, std_col: Optional[str]) -> Optional[float]:
    if std_col is not None:
        return row.get(std_col)
    s, w = row.get("std_spread"), row.get("track_width_m")
    return s / w if s is not None and w else None


def control_flags(values: Sequence[Optional[float]], stds: Sequence[Optional[float]]) -> List[Optional[Tuple[float, float, bool]]]:
    """For a time-ordered series: per point None (too little history, or no
    value) or (centre, limit half-width, out of control) by the module's
    Shewhart individuals rule."""
    out: List[Optional[Tuple[float, float, bool]]] = []
    history: List[float] = []
    for v, s in zip(values, stds):
        if v is None or not math.isfinite(v):
            out.append(None)
            continue
        if len(history) >= MIN_HISTORY:
            centre = sum(history) / len(history)
            mr = [abs(b - a) for a, b in zip(history, history[1:])]
            sigma_h = (sum(mr) / len(mr)) / 1.128
            half = SIGMAS * math.sqrt(sigma_h**2 + (s or 0.0) ** 2)
            out.append((centre, half, abs(v - centre) > half))
        else:
            out.append(None)
        history.append(v)
    return out


class _Axes:
    """Linear map of data ranges onto an SVG plot area."""

    def __init__(self, xs: Sequence[float], ys: Sequence[float], w: int = 720, h: int = 240, equal: bool = False):
        self.w, self.h, self.l, self.r, self.t, self.b = w, h, 70, 15, 12, 36
        x0, x1 = (min(xs), max(xs)) if xs else (0.0, 1.0)
        y0, y1 = (min(ys), max(ys)) if ys else (0.0, 1.0)
        if x1 - x0 < 1e-12:
            x0, x1 = x0 - 0.5, x1 + 0.5
        if y1 - y0 < 1e-12:
            y0, y1 = y0 - 0.5, y1 + 0.5
        py = 0.05 * (y1 - y0)
        px = 0.03 * (x1 - x0)
        self.x0, self.x1, self.y0, self.y1 = x0 - px, x1 + px, y0 - py, y1 + py
        if equal:  # metres on both axes: one scale
            sx = (self.x1 - self.x0) / (w - self.l - self.r)
            sy = (self.y1 - self.y0) / (h - self.t - self.b)
            s = max(sx, sy)
            cx, cy = (self.x0 + self.x1) / 2, (self.y0 + self.y1) / 2
            self.x0, self.x1 = cx - s * (w - self.l - self.r) / 2, cx + s * (w - self.l - self.r) / 2
            self.y0, self.y1 = cy - s * (h - self.t - self.b) / 2, cy + s * (h - self.t - self.b) / 2

    def x(self, v: float) -> float:
        return self.l + (v - self.x0) / (self.x1 - self.x0) * (self.w - self.l - self.r)

    def y(self, v: float) -> float:
        return self.h - self.b - (v - self.y0) / (self.y1 - self.y0) * (self.h - self.t - self.b)

    def frame(self, xlabel: str, ylabel: str, xticks: Sequence[Tuple[float, str]]) -> List[str]:
        out = [f'<rect x="{self.l}" y="{self.t}" width="{self.w - self.l - self.r}" height="{self.h - self.t - self.b}" fill="none" stroke="#888"/>']
        for v in nice_ticks(self.y0, self.y1):
            out.append(f'<line x1="{self.l}" x2="{self.w - self.r}" y1="{self.y(v):.1f}" y2="{self.y(v):.1f}" stroke="#eee"/>')
            out.append(f'<text x="{self.l - 4}" y="{self.y(v) + 4:.1f}" font-size="11" text-anchor="end">{v:g}</text>')
        for v, label in xticks:
            out.append(f'<text x="{self.x(v):.1f}" y="{self.h - self.b + 14}" font-size="11" text-anchor="middle">{html.escape(label)}</text>')
        out.append(f'<text x="{(self.l + self.w - self.r) / 2}" y="{self.h - 4}" font-size="12" text-anchor="middle">{html.escape(xlabel)}</text>')
        out.append(f'<text x="12" y="{(self.t + self.h - self.b) / 2}" font-size="12" text-anchor="middle" transform="rotate(-90 12 {(self.t + self.h - self.b) / 2})">{html.escape(ylabel)}</text>')
        return out

    def svg(self, parts: Sequence[str]) -> str:
        return f'<svg xmlns="http://www.w3.org/2000/svg" width="{self.w}" height="{self.h}" viewBox="0 0 {self.w} {self.h}" font-family="sans-serif">' + "".join(parts) + "</svg>"


def nice_ticks(lo: float, hi: float, n: int = 5) -> List[float]:
    """About ``n`` round values (1, 2 or 5 times a power of ten apart) in [lo, hi]."""
    raw = (hi - lo) / max(n, 1)
    if not raw > 0 or not math.isfinite(raw):
        return [lo]
    mag = 10 ** math.floor(math.log10(raw))
    step = next(m * mag for m in (1, 2, 5, 10) if m * mag >= raw)
    first = math.ceil(lo / step) * step
    return [first + k * step for k in range(int((hi - first) / step + 1e-9) + 1)]


def _when(row: Dict[str, Any], i: int) -> float:
    t = row.get("time")
    return t.timestamp() if isinstance(t, _dt.datetime) else float(i)


def _ticks(xs: Sequence[float], dated: bool) -> List[Tuple[float, str]]:
    if not xs:
        return []
    lo, hi = min(xs), max(xs)
    n = 1 if hi - lo < 1e-9 else 5
    vals = [lo + (hi - lo) * k / max(n - 1, 1) for k in range(n)]
    if dated:
        # Within two days the hour tells the recordings apart.
        form = "%Y-%m-%d" if hi - lo > 2 * 86400 else "%m-%d %H:%M"
        return [(v, _dt.datetime.fromtimestamp(v, tz=_dt.timezone.utc).strftime(form)) for v in vals]
    return [(v, f"{v:.0f}") for v in nice_ticks(lo, hi)]


def _terrain(row: Dict[str, Any]) -> str:
    return "+".join(row.get("terrains") or []) or "unlabelled"


def series_chart(rows: Sequence[Dict[str, Any]], col: str, std_col: Optional[str], label: str, colours: Dict[str, str]) -> Tuple[str, List[Tuple[Dict[str, Any], float, float, float]]]:
    """One robot's chart of ``col`` over time (rows in time order) and the
    flagged recordings (row, value, centre, limit)."""
    dated = all(isinstance(r.get("time"), _dt.datetime) for r in rows)
    pts = []
    for i, r in enumerate(rows):
        v = r.get(col)
        if v is None or not math.isfinite(v):
            continue
        pts.append((_when(r, i) if dated else float(i), v, _std(r, col, std_col), r))
    flagged: List[Tuple[Dict[str, Any], float, float, float]] = []
    limits: Dict[str, List[Tuple[float, float, float]]] = {}
    by_terrain: Dict[str, List[Tuple[float, float, Optional[float], Dict[str, Any]]]] = {}
    for p in pts:
        by_terrain.setdefault(_terrain(p[3]), []).append(p)
    flags: Dict[int, bool] = {}
    for terrain, tp in by_terrain.items():
        for p, f in zip(tp, control_flags([q[1] for q in tp], [q[2] for q in tp])):
            if f is None:
                continue
            centre, half, out = f
            limits.setdefault(terrain, []).append((p[0], centre - half, centre + half))
            if out:
                flags[id(p[3])] = True
                flagged.append((p[3], p[1], centre, half))
    ys = [p[1] + k * 2 * (p[2] or 0.0) for p in pts for k in (-1, 1)]
    ys += [y for lim in limits.values() for _, lo, hi in lim for y in (lo, hi)]
    ax = _Axes([p[0] for p in pts], ys)
    parts = ax.frame("recording start (UTC)" if dated else "recording", label, _ticks([p[0] for p in pts], dated))
    for terrain, lim in limits.items():
        c = colours[terrain]
        for k in (1, 2):
            path = " ".join(f"{'M' if j == 0 else 'L'}{ax.x(x):.1f},{ax.y(v[k - 1]):.1f}" for j, (x, *v) in enumerate(lim))
            parts.append(f'<path d="{path}" fill="none" stroke="{c}" stroke-dasharray="4 3" opacity="0.7"/>')
    for x, v, s, r in pts:
        c = colours[_terrain(r)]
        if s:
            parts.append(f'<line x1="{ax.x(x):.1f}" x2="{ax.x(x):.1f}" y1="{ax.y(v - 2 * s):.1f}" y2="{ax.y(v + 2 * s):.1f}" stroke="{c}" stroke-width="3" opacity="0.35"/>')
        ring = ' stroke="#d00" stroke-width="2"' if flags.get(id(r)) else ""
        parts.append(f'<circle cx="{ax.x(x):.1f}" cy="{ax.y(v):.1f}" r="3.5" fill="{c}"{ring}><title>{html.escape(r["path"])}: {v:.4f}</title></circle>')
    return ax.svg(parts), flagged


def slip_map(tracks: Sequence[Dict[str, Any]]) -> str:
    """An SVG scatter of track points (east, north) coloured by slip."""
    xs = [p["east"] for p in tracks]
    ys = [p["north"] for p in tracks]
    ax = _Axes(xs, ys, w=720, h=480, equal=True)
    slips = sorted(p["slip"] for p in tracks)
    lo = slips[int(0.02 * (len(slips) - 1))]
    hi = slips[int(0.98 * (len(slips) - 1))]
    parts = ax.frame("east (m)", "north (m)", [(v, f"{v:g}") for v in nice_ticks(ax.x0, ax.x1)])
    for p in tracks:
        u = 0.0 if hi - lo < 1e-12 else min(1.0, max(0.0, (p["slip"] - lo) / (hi - lo)))
        parts.append(f'<circle cx="{ax.x(p["east"]):.1f}" cy="{ax.y(p["north"]):.1f}" r="2" fill="{_ramp(u)}"/>')
    for k in range(11):
        u = k / 10
        parts.append(f'<rect x="{ax.w - 160 + 12 * k}" y="{ax.t + 6}" width="12" height="10" fill="{_ramp(u)}"/>')
    parts.append(f'<text x="{ax.w - 164}" y="{ax.t + 15}" font-size="11" text-anchor="end">slip {lo:.2f}</text>')
    parts.append(f'<text x="{ax.w - 24}" y="{ax.t + 28}" font-size="11" text-anchor="end">{hi:.2f}</text>')
    return ax.svg(parts)


def _ramp(u: float) -> str:
    """Blue (little slip) to orange-red (much)."""
    a, b = (0x56, 0xB4, 0xE9), (0xD5, 0x5E, 0x00)
    return "#" + "".join(f"{round(x + (y - x) * u):02x}" for x, y in zip(a, b))


def _fmt(v: Any, digits: int = 4) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return f"{v:.{digits}f}"
    return html.escape(str(v))


def write_report(out: str, path: Optional[str] = None) -> str:
    """Writes the report of the tables in ``out`` to ``path`` (default
    ``out/report.html``) through a temporary file; returns ``path``."""
    recs_t = read(out, "recordings")
    if recs_t is None:
        from ._recording import FleetError

        raise FleetError(f"{out}: no recordings table (run `python -m terraslip.fleet estimate ... --out {out}` first)")
    recs = recs_t.to_pylist()
    tracks_t = read(out, "tracks")
    cal_t = read(out, "calibrations")
    body: List[str] = []
    ok = [r for r in recs if r.get("error") is None]
    failed = [r for r in recs if r.get("error") is not None]
    robots = sorted({str(r["robot"]) for r in recs})
    body.append(
        f"<p>{len(recs)} recordings of {len(robots)} robot(s): {len(ok)} estimated, {len(failed)} failed. "
        f"{sum(r.get('duration_s') or 0 for r in ok) / 3600:.2f} h, {sum(r.get('distance_m') or 0 for r in ok) / 1000:.2f} km.</p>"
    )
    body.append(
        "<p><b>Rule.</b> Each point is one recording's final estimate with its 2σ band. Dashed lines: the control limits "
        f"of the robot's own history on that terrain (Shewhart individuals chart: centre the mean of at least {MIN_HISTORY} earlier "
        "recordings, σ<sub>h</sub> their mean moving range / 1.128, limits ±3·sqrt(σ<sub>h</sub>² + σ²) with σ the recording's own std). "
        "A red ring marks a recording outside them: the robot no longer moves as it used to (tyres, load, wear) or the ground differs.</p>"
    )
    all_flags: List[Tuple[str, str, Dict[str, Any], float, float, float]] = []
    for robot in robots:
        mine = sorted(
            (r for r in ok if str(r["robot"]) == robot),
            key=lambda r: (r["time"].timestamp() if isinstance(r.get("time"), _dt.datetime) else 0.0, r["path"]),
        )
        body.append(f"<h2>{html.escape(robot)}</h2>")
        blind = [r for r in mine if not r.get("fixes")]
        mine = [r for r in mine if r.get("fixes")]
        if blind:
            body.append(f"<p>{len(blind)} recording(s) without a pose reference, not charted: without fixes the estimator learns nothing from the drive.</p>")
        if not mine:
            continue
        terrains = sorted({_terrain(r) for r in mine})
        colours = {t: PALETTE[(i + 1) % len(PALETTE)] for i, t in enumerate(terrains)}
        legend = ", ".join(f'<span style="color:{colours[t]}">●</span> {html.escape(t)}' for t in terrains)
        body.append(f"<p>{len(mine)} recordings; terrain: {legend}</p>")
        for col, std_col, label in SERIES:
            svg, flagged = series_chart(mine, col, std_col, label, colours)
            body.append(f"<figure>{svg}<figcaption>{html.escape(label)}</figcaption></figure>")
            all_flags.extend((robot, label, r, v, c, h) for r, v, c, h in flagged)
    body.append("<h2>Flagged recordings</h2>")
    if all_flags:
        body.append("<table><tr><th>robot</th><th>quantity</th><th>recording</th><th>value</th><th>centre</th><th>limit ±</th></tr>")
        for robot, label, r, v, c, h in all_flags:
            body.append(f'<tr><td>{html.escape(robot)}</td><td>{html.escape(label)}</td><td>{html.escape(r["path"])}</td><td class="flag">{v:.4f}</td><td>{c:.4f}</td><td>{h:.4f}</td></tr>')
        body.append("</table>")
    else:
        body.append(f"<p>None: every recording with {MIN_HISTORY} or more earlier ones of its robot on its terrain lies within its limits.</p>")
    body.append("<h2>Where the fleet slips</h2>")
    if tracks_t is not None and tracks_t.num_rows:
        t = tracks_t.to_pylist()
        for robot in sorted({str(p["robot"]) for p in t}):
            pts = [p for p in t if str(p["robot"]) == robot]
            n = len({p["path"] for p in pts})
            body.append(f"<figure>{slip_map(pts)}<figcaption>{html.escape(robot)}: {n} recording(s) with a pose reference, a point per second coloured by slip 1 − (α_l + α_r)/2, in the pose source's frame (ENU or map).</figcaption></figure>")
    else:
        body.append("<p>No recording with a pose reference.</p>")
    if cal_t is not None and cal_t.num_rows:
        body.append("<h2>Calibrations per robot and terrain</h2><table><tr><th>robot</th><th>terrain</th><th>drives</th><th>y_l</th><th>y_r</th><th>x_c</th><th>α_l</th><th>α_r</th><th>error</th></tr>")
        for c in sorted(cal_t.to_pylist(), key=lambda c: (str(c["robot"]), c["terrain"])):
            body.append(
                "<tr>" + "".join(f"<td>{_fmt(c.get(k))}</td>" for k in ("robot", "terrain", "n_drives", "y_l", "y_r", "x_c", "alpha_l", "alpha_r")) + f'<td style="text-align:left">{_fmt((c.get("error") or "")[:160])}</td></tr>'
            )
        body.append("</table>")
    if failed:
        body.append("<h2>Recordings that failed</h2><table><tr><th>robot</th><th>recording</th><th>error</th></tr>")
        for r in failed:
            body.append(f'<tr><td>{html.escape(str(r["robot"]))}</td><td>{html.escape(r["path"])}</td><td style="text-align:left">{html.escape(r["error"][:300])}</td></tr>')
        body.append("</table>")
    page = f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8"><title>terraslip fleet</title>\n<style>{STYLE}</style></head>\n<body><h1>terraslip fleet</h1>\n' + "\n".join(body) + "\n</body></html>\n"
    path = path or f"{out.rstrip('/')}/report.html"
    fs, p = fsspec.core.url_to_fs(path)
    tmp = f"{p}.tmp"
    with fs.open(tmp, "w", encoding="utf-8") as f:
        f.write(page)
    fs.mv(tmp, p)
    return path if "://" in path else os.path.abspath(path)
