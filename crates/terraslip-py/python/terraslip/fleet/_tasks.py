"""The work of one task: one recording estimated, or one robot's drives on
one terrain calibrated. Runs on a Dask worker (or in the calling process);
every failure becomes the row's ``error``, never an exception.

Each function calls the binding the command calls (``terraslip.estimate``
is ``terraslip estimate``, ``terraslip.calibrate`` is ``terraslip
calibrate``), so a row holds the command's numbers.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
import traceback
from contextlib import ExitStack
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence

import fsspec
import numpy as np

from ._recording import Recording, local_copy, start_time
from ._tables import ICR, write_part


@dataclass(frozen=True)
class Options:
    """What every task of a run is given (picklable, file contents inline so
    a remote worker needs no access to the caller's files).

    ``config``: TOML text of an ``estimate`` configuration, or None.
    ``preset``: a named variant (``terraslip estimate --preset``).
    ``topics``: TOML text of a ``--topics`` file for the bags, or None.
    ``terrain_labels``: ``"auto"`` (a log's terrain.csv is the terrain
    evidence when it has one, as ``--terrain-labels``), True or False.
    ``method``: the calibration method (None: all three, the command's
    default). ``rows``: also write the per-row estimates. ``track_period_s``:
    the spacing of the map's track points, s.
    """

    config: Optional[str] = None
    preset: Optional[str] = None
    topics: Optional[str] = None
    terrain_labels: Any = "auto"
    method: Optional[str] = None
    rows: bool = False
    track_period_s: float = 1.0

    def config_hash(self, topics: Optional[str]) -> str:
        """sha256 (first 16 hex digits) of everything that decides a row's
        numbers besides the recording: configuration and topics text,
        preset, terrain evidence, calibration method."""
        key = json.dumps(
            [self.config, self.preset, topics, self.terrain_labels, self.method], sort_keys=True
        )
        return hashlib.sha256(key.encode()).hexdigest()[:16]


def version() -> str:
    """The installed terraslip package's version."""
    try:
        from importlib.metadata import version as v

        return v("terraslip")
    except Exception:  # noqa: BLE001 - metadata missing (source tree)
        return "unknown"


def _text_file(stack: ExitStack, text: Optional[str], name: str) -> Optional[str]:
    if text is None:
        return None
    d = stack.enter_context(tempfile.TemporaryDirectory(prefix="terraslip-fleet-"))
    path = os.path.join(d, name)
    with open(path, "w", encoding="utf-8") as f:
        f.write(text)
    return path


def read_text(url: Optional[str]) -> Optional[str]:
    """The text of a small file (local path or fsspec URL), or None."""
    if url is None:
        return None
    with fsspec.open(url, "r", encoding="utf-8") as f:
        return f.read()


def _error(e: BaseException) -> str:
    if isinstance(e, (OSError, ValueError, TypeError)):
        return f"{type(e).__name__}: {e}"
    return f"{type(e).__name__}: {e}\n{traceback.format_exc(limit=3)}"


def _f(x: Any) -> Optional[float]:
    """A JSON number as float; None (null in Parquet) for a missing one."""
    if x is None:
        return None
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def _get(d: Any, *keys: str) -> Any:
    for k in keys:
        if not isinstance(d, dict):
            return None
        d = d.get(k)
    return d


def estimate_recording(rec: Recording, opts: Options, rows_root: Optional[str], tracks_root: Optional[str]) -> Dict[str, Any]:
    """Estimates one recording; returns its row of the recordings table
    and writes its per-row estimates (when ``opts.rows``) and its map track
    (when it has a pose reference) as Parquet parts under the roots."""
    row: Dict[str, Any] = {"path": rec.path, "robot": rec.robot, "kind": rec.kind, "date": rec.date}
    row["terraslip_version"] = version()
    local = rec.path
    try:
        topics = read_text(rec.topics) if rec.topics else opts.topics
        row["config_hash"] = opts.config_hash(topics if rec.kind == "bag" else None)
        with ExitStack() as stack:
            local = stack.enter_context(local_copy(rec.path))
            when, source = start_time(local, rec.kind)
            row["time"] = when
            row["time_source"] = source
            if row["date"] is None:
                row["date"] = when.date().isoformat() if when is not None else "unknown"
            labels = opts.terrain_labels
            if labels == "auto":
                labels = rec.kind == "log" and os.path.isfile(os.path.join(local, "terrain.csv"))
            row["terrain_labels"] = bool(labels)
            est = _estimate(stack, local, rec.kind, opts, topics, bool(labels))
        est["summary"]["log"] = rec.path
        row.update(summary_columns(est))
        if rows_root is not None and opts.rows:
            write_part(rows_root, rec, row["date"], estimate_table(est))
        track = track_table(est, opts.track_period_s)
        if tracks_root is not None and track is not None:
            write_part(tracks_root, rec, row["date"], track)
        row["error"] = None
    except BaseException as e:  # noqa: BLE001 - a failed recording is a row
        if isinstance(e, (KeyboardInterrupt, SystemExit)):
            raise
        row["error"] = _error(e).replace(local, rec.path)
        if row["date"] is None:
            row["date"] = "unknown"
    return row


def _estimate(stack: ExitStack, local: str, kind: str, opts: Options, topics: Optional[str], labels: bool) -> Dict[str, Any]:
    import terraslip

    return terraslip.estimate(
        local,
        config=_text_file(stack, opts.config, "config.toml"),
        preset=opts.preset,
        topics=_text_file(stack, topics, "topics.toml") if kind == "bag" else None,
        terrain_labels=labels,
    )


def controller_factor(summary: Dict[str, Any]) -> Optional[float]:
    """The ``diff_drive_controller`` ``wheel_separation_multiplier`` the
    learned ICRs give, (y_l - y_r) / track_width (user-guide §3): a
    summary's own ``controller_factor`` when it states one; the whole
    drive's spread (``recommendation``) when the summary has one, else the
    final ICRs'. None when the drive did not teach the spread (``learning``
    says it is held): its starting value is no finding."""
    own = _f(summary.get("controller_factor"))
    if own is not None:
        return own
    if str(_get(summary, "learning", "spread") or "learned").startswith("held"):
        return None
    width = _f(summary.get("track_width"))
    if isinstance(summary.get("recommendation"), dict):
        spread = _f(_get(summary, "recommendation", "spread_m", "value"))
    else:
        y_l, y_r = _f(_get(summary, "icr", "y_l")), _f(_get(summary, "icr", "y_r"))
        spread = None if y_l is None or y_r is None else y_l - y_r
    if spread is None or not width:
        return None
    return spread / width


def summary_columns(est: Dict[str, Any]) -> Dict[str, Any]:
    """The recordings-table columns of one ``estimate`` result."""
    s = est["summary"]
    east, north = np.asarray(est["east"], float), np.asarray(est["north"], float)
    steps = np.hypot(np.diff(east), np.diff(north))
    terrains = list(dict.fromkeys(t for t in est["terrain"] if t))
    last = {k: _f(est[k][-1]) if len(est[k]) else None for k in ("std_alpha_l", "std_alpha_r")}
    pred = s.get("prediction") or {}
    stats = s.get("stats") or {}
    return {
        "duration_s": _f(s.get("duration_s")),
        "rows": int(s.get("rows", len(est["t"]))),
        "distance_m": float(np.sum(steps[np.isfinite(steps)])) if len(steps) else 0.0,
        "terrains": terrains,
        "variant": s.get("variant"),
        "init": s.get("init"),
        "track_width_m": _f(s.get("track_width")),
        "y_l": _f(_get(s, "icr", "y_l")),
        "y_r": _f(_get(s, "icr", "y_r")),
        "x_c": _f(_get(s, "icr", "x_c")),
        "alpha_l": _f(_get(s, "icr", "alpha_l")),
        "alpha_r": _f(_get(s, "icr", "alpha_r")),
        "std_y_l": _f(_get(s, "icr_std", "y_l")),
        "std_y_r": _f(_get(s, "icr_std", "y_r")),
        "std_x_c": _f(_get(s, "icr_std", "x_c")),
        "std_spread": _f(_get(s, "icr_std", "spread")),
        "std_alpha_l": last["std_alpha_l"],
        "std_alpha_r": last["std_alpha_r"],
        "controller_factor": controller_factor(s),
        "turn_law_s_per_m": _f(_get(s, "turn_law_s_per_m", "slope")),
        "pose_std_xy_m": _f(_get(s, "pose_noise", "std_xy_m")),
        "pose_std_yaw_rad": _f(_get(s, "pose_noise", "std_yaw_rad")),
        "clock_offset_s": _f(_get(s, "clock_offset_s", "value")),
        "clock_offset_std_s": _f(_get(s, "clock_offset_s", "std")),
        "fixes": int(stats.get("fixes") or 0),
        "prediction_mean_m": _f(pred.get("mean_m")),
        "prediction_p90_m": _f(pred.get("p90_m")),
        "prediction_segments": int(pred.get("segments") or 0) if pred else 0,
        "no_slip_mean_m": _f(_get(pred, "no_slip", "mean_m")),
        "no_slip_p90_m": _f(_get(pred, "no_slip", "p90_m")),
        "warnings": [str(w) for w in s.get("warnings") or []],
        "summary_json": json.dumps(s, sort_keys=True),
    }


def estimate_table(est: Dict[str, Any]):
    """The per-row estimates (the columns of estimate.csv) as an Arrow table."""
    import pyarrow as pa

    import terraslip

    return pa.table({name: est[name] for name in terraslip.COLUMNS})


# The map's slip measure: 1 - (alpha_l + alpha_r) / 2, the fraction of the
# encoders' speed the robot does not make good, at each track point.
def track_table(est: Dict[str, Any], period_s: float):
    """The recording's track every ``period_s`` with its slip, or None
    when no pose fix was fused (the track is then dead reckoning in a
    frame of its own)."""
    import pyarrow as pa

    fused = np.asarray(est["fused"], bool)
    if not fused.any():
        return None
    t = np.asarray(est["t"], float)
    keep = _every(t, period_s)
    slip = 1.0 - 0.5 * (np.asarray(est["alpha_l"], float) + np.asarray(est["alpha_r"], float))
    return pa.table(
        {
            "t": t[keep],
            "east": np.asarray(est["east"], float)[keep],
            "north": np.asarray(est["north"], float)[keep],
            "slip": slip[keep],
        }
    )


def _every(t: np.ndarray, period: float) -> np.ndarray:
    if len(t) == 0:
        return np.zeros(0, dtype=int)
    bins = np.floor((t - t[0]) / max(period, 1e-9))
    _, first = np.unique(bins, return_index=True)
    return first


def calibrate_group(robot: str, terrain: str, recs: Sequence[Recording], opts: Options) -> Dict[str, Any]:
    """Calibrates ``robot`` on ``terrain`` ("" for drives without terrain
    labels) from all of ``recs`` in one ``terraslip.calibrate`` call; returns
    the calibration-table row, naming the drives it came from."""
    row: Dict[str, Any] = {
        "robot": robot,
        "terrain": terrain,
        "drives": [r.path for r in recs],
        "n_drives": len(recs),
        "terraslip_version": version(),
    }
    local: List[str] = []
    try:
        topic_files = {r.topics for r in recs if r.kind == "bag"}
        if len(topic_files) > 1:
            raise ValueError(f"the bags of {robot} on {terrain or 'unlabelled ground'} name different topics files: {sorted(map(str, topic_files))}")
        topic_url = next(iter(topic_files), None)
        topics = read_text(topic_url) if topic_url else (opts.topics if any(r.kind == "bag" for r in recs) else None)
        row["config_hash"] = opts.config_hash(topics)
        import terraslip

        with ExitStack() as stack:
            local.extend(stack.enter_context(local_copy(r.path)) for r in recs)
            params = terraslip.calibrate(local, method=opts.method, topics=_text_file(stack, topics, "topics.toml"))
        row.update(calibration_columns(params, terrain))
        row["error"] = None
    except BaseException as e:  # noqa: BLE001 - a failed group is a row
        if isinstance(e, (KeyboardInterrupt, SystemExit)):
            raise
        message = _error(e)
        for here, r in zip(local, recs):
            message = message.replace(here, r.path)
        row["error"] = message
    return row


def calibration_set(params: Dict[str, Any], terrain: str) -> Dict[str, Any]:
    """The set of a parameters file for ``terrain`` ("": the pooled set)."""
    if terrain:
        sets = params.get("terrains") or {}
        if terrain not in sets:
            raise ValueError(f"the calibration has no set for terrain {terrain!r} (sets: {sorted(sets)})")
        return sets[terrain]
    if "params" in params:
        return params
    raise ValueError("the calibration has no pooled set")


def calibration_columns(params: Dict[str, Any], terrain: str) -> Dict[str, Any]:
    """The calibration-table columns of one ``calibrate`` result."""
    s = calibration_set(params, terrain)
    p, std = s.get("params") or {}, s.get("std") or {}
    cols: Dict[str, Any] = {k: _f(p.get(k)) for k in ICR}
    cols.update({f"std_{k}": _f(std.get(k)) for k in ICR})
    cols.update(
        {
            "method": s.get("method"),
            "chi": _f(s.get("chi")),
            "e": _f(s.get("e")),
            "time_offset_s": _f(s.get("time_offset_s")),
            "segments_used": int(s.get("segments_used") or 0),
            "sigma_m": _f(s.get("sigma_m")),
            "params_json": json.dumps(s, sort_keys=True),
        }
    )
    return cols
