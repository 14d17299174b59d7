"""Recordings of a fleet: finding them, naming their robot and date, and
bringing one onto the worker that processes it.

A recording is a drive-log directory (docs/log-format.md: has wheels.csv),
a ROS 2 bag directory (has metadata.yaml) or a single .mcap / .db3 file. It
is named by a local path or an fsspec URL (``s3://bucket/robot-07/drive``,
``memory://...``); a URL is copied to a worker-local temporary directory
before the binding reads it.
"""

from __future__ import annotations

import csv
import datetime as _dt
import io
import os
import posixpath
import shutil
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator, List, Optional, Sequence, Tuple

import fsspec

BAG_FILES = (".mcap", ".db3")
MANIFESTS = (".csv", ".parquet")


class FleetError(ValueError):
    """A manifest, path or option the fleet cannot use; the message names it."""


@dataclass(frozen=True)
class Recording:
    """One drive to process.

    ``path``: local path (absolute) or fsspec URL. ``kind``: ``log`` or
    ``bag``. ``robot``: the robot's name (the tables' partition). ``date``: ``YYYY-MM-DD`` (UTC) or None when
    the recording is to tell it. ``topics``: a ``--topics`` TOML file for a
    bag (local path or URL), or None for the fleet's.
    """

    path: str
    kind: str
    robot: str
    date: Optional[str] = None
    topics: Optional[str] = None


def _fs(url: str) -> Tuple[fsspec.AbstractFileSystem, str]:
    fs, path = fsspec.core.url_to_fs(url)
    return fs, path


def _protocols(fs: fsspec.AbstractFileSystem) -> Tuple[str, ...]:
    p = fs.protocol
    return (p,) if isinstance(p, str) else tuple(p)


def _join(url: str, name: str) -> str:
    return url.rstrip("/") + "/" + name


def _recording_kind(fs: fsspec.AbstractFileSystem, path: str) -> Optional[str]:
    """``log``, ``bag`` or None (not a recording) for ``path`` on ``fs``."""
    if fs.isfile(path):
        return "bag" if path.lower().endswith(BAG_FILES) else None
    if fs.isfile(_join(path, "metadata.yaml")):
        return "bag"
    if fs.isfile(_join(path, "wheels.csv")):
        return "log"
    return None


def discover(paths: Sequence[str]) -> List[Tuple[str, str]]:
    """The recordings named by ``paths``: each a recording, or a directory
    searched for recordings (a recording's own directory is not searched
    further). Sorted; raises FleetError for a path that exists nowhere or
    holds none."""
    found: List[Tuple[str, str]] = []
    for url in paths:
        fs, path = _fs(url)
        if not fs.exists(path):
            raise FleetError(f"{url}: no such file or directory")
        kind = _recording_kind(fs, path)
        if kind is not None:
            found.append((url, kind))
            continue
        here = _walk(fs, path, url)
        if not here:
            raise FleetError(
                f"{url}: no recording in it (a log directory has wheels.csv, a bag directory metadata.yaml, a bag file ends in .mcap or .db3)"
            )
        found.extend(here)
    return sorted(dict(found).items())


def _walk(fs: fsspec.AbstractFileSystem, path: str, url: str) -> List[Tuple[str, str]]:
    out: List[Tuple[str, str]] = []
    for entry in sorted(fs.ls(path, detail=False)):
        name = posixpath.basename(entry.rstrip("/"))
        if name.startswith("."):
            continue
        sub = _join(url, name)
        kind = _recording_kind(fs, entry)
        if kind is not None:
            out.append((sub, kind))
        elif fs.isdir(entry):
            out.extend(_walk(fs, entry, sub))
    return out


def read_manifest(url: str) -> List[Recording]:
    """A manifest: CSV or Parquet with a ``path`` column and optional
    ``robot``, ``date`` (YYYY-MM-DD) and ``topics`` columns. Relative paths
    are taken from the manifest's directory. Raises FleetError naming the
    file, row and column of a bad cell."""
    fs, path = _fs(url)
    if not fs.exists(path):
        raise FleetError(f"{url}: no such manifest")
    if url.lower().endswith(".parquet"):
        import pyarrow.parquet as pq

        with fs.open(path, "rb") as f:
            table = pq.read_table(f)
        rows = table.to_pylist()
        first_line = 0
    else:
        with fs.open(path, "r", encoding="utf-8", newline="") as f:
            rows = list(csv.DictReader(io.StringIO(f.read())))
        first_line = 2
    base = url.rstrip("/").rsplit("/", 1)[0] if "/" in url.rstrip("/") else "."
    recordings: List[Recording] = []
    for i, row in enumerate(rows):
        where = f"{url}: line {i + first_line}" if first_line else f"{url}: row {i}"
        cell = row.get("path")
        if cell is None or str(cell).strip() == "":
            raise FleetError(f"{where}: column path: empty (a manifest needs path[, robot, date, topics])")
        rec_url = _relative_to(base, str(cell).strip())
        robot = _cell(row, "robot")
        date = _cell(row, "date")
        if date is not None:
            date = _check_date(date, f"{where}: column date")
        topics = _cell(row, "topics")
        if topics is not None:
            topics = _relative_to(base, topics)
        rfs, rpath = _fs(rec_url)
        if not rfs.exists(rpath):
            raise FleetError(f"{where}: column path: {rec_url}: no such file or directory")
        kind = _recording_kind(rfs, rpath)
        if kind is None:
            raise FleetError(
                f"{where}: column path: {rec_url}: not a recording (a log directory has wheels.csv, a bag directory metadata.yaml, a bag file ends in .mcap or .db3)"
            )
        if robot is None:
            robot = robot_of(rec_url, kind)
        recordings.append(Recording(rec_url, kind, robot, date, topics))
    if not recordings:
        raise FleetError(f"{url}: the manifest lists no recording")
    return recordings


def _cell(row: dict, name: str) -> Optional[str]:
    v = row.get(name)
    if v is None:
        return None
    if isinstance(v, (_dt.date, _dt.datetime)):
        return v.strftime("%Y-%m-%d")
    s = str(v).strip()
    return s or None


def _relative_to(base: str, p: str) -> str:
    if "://" in p or os.path.isabs(p):
        return p
    if "://" in base:
        return _join(base, p)
    return os.path.normpath(os.path.join(base, p))


def _check_date(s: str, where: str) -> str:
    try:
        return _dt.date.fromisoformat(s[:10]).isoformat()
    except ValueError:
        raise FleetError(f"{where}: {s!r} is not a date (YYYY-MM-DD)") from None


def recordings(paths_or_manifest: Sequence[str], robot: Optional[str] = None) -> List[Recording]:
    """The fleet named by ``paths_or_manifest``: manifests (``.csv``,
    ``.parquet``) are read, other paths discovered (:func:`discover`).
    ``robot`` names the robot of every discovered recording; without it
    each robot is :func:`robot_of` its recording. Local paths are made
    absolute."""
    if isinstance(paths_or_manifest, (str, os.PathLike)):
        paths_or_manifest = [paths_or_manifest]
    out: List[Recording] = []
    # Local paths absolute: the workers' working directory is not ours.
    for p in (q if "://" in q else os.path.abspath(q) for q in map(str, paths_or_manifest)):
        if p.lower().endswith(MANIFESTS):
            out.extend(read_manifest(p))
        else:
            out.extend(Recording(u, k, robot or robot_of(u, k)) for u, k in discover([p]))
    return out


def _toml_string(text: str, key: str) -> Optional[str]:
    try:
        import tomllib  # type: ignore[import-not-found]
    except ImportError:  # Python < 3.11: the one line we need
        for line in text.splitlines():
            k, _, v = line.partition("=")
            if k.strip() == key and v.strip().startswith('"'):
                return v.strip().strip('"') or None
        return None
    try:
        v = tomllib.loads(text).get(key)
    except tomllib.TOMLDecodeError:
        return None
    return v if isinstance(v, str) and v else None


def robot_of(url: str, kind: str) -> str:
    """The robot of a recording without a manifest: a bag's
    ``custom_data: robot`` in metadata.yaml, a log's ``robot`` in
    meta.toml, else the name of the directory holding the recording."""
    fs, path = _fs(url)
    name = None
    try:
        if kind == "bag":
            meta = _join(path, "metadata.yaml")
            if fs.isdir(path) and fs.isfile(meta):
                name = _yaml_custom_robot(fs.cat_file(meta).decode("utf-8", "replace"))
        elif fs.isfile(_join(path, "meta.toml")):
            name = _toml_string(fs.cat_file(_join(path, "meta.toml")).decode("utf-8", "replace"), "robot")
    except OSError:
        name = None
    if name:
        return name
    parent = url.rstrip("/").rsplit("/", 1)[0]
    return posixpath.basename(parent.rstrip("/")) or "robot"


def _yaml_custom_robot(text: str) -> Optional[str]:
    """``rosbag2_bagfile_information.custom_data.robot`` (rosbag2 writes
    custom_data as a flat string map), read without a YAML parser."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.strip().startswith("custom_data:"):
            indent = len(line) - len(line.lstrip())
            for sub in lines[i + 1 :]:
                if len(sub) - len(sub.lstrip()) <= indent:
                    break
                k, _, v = sub.strip().partition(":")
                if k == "robot":
                    return v.strip().strip("'\"") or None
    return None


def bag_start(text: str) -> Optional[float]:
    """The ``starting_time.nanoseconds_since_epoch`` of a bag's
    metadata.yaml, s since the Unix epoch."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if line.strip() == "starting_time:" and i + 1 < len(lines):
            k, _, v = lines[i + 1].strip().partition(":")
            if k == "nanoseconds_since_epoch":
                try:
                    return int(v.strip()) / 1e9
                except ValueError:
                    return None
    return None


# A log's t is "any epoch" (log-format.md): a first time after this (s
# since 1970, i.e. 2001-09-09) is taken as a Unix time.
UNIX_TIME_MIN_S = 1.0e9


def start_time(local: str, kind: str) -> Tuple[Optional[_dt.datetime], str]:
    """When a recording (on this machine) started, UTC, and where that came
    from: ``bag metadata`` or ``log clock``, else None and ``unknown`` (a
    file's modification time says when it was copied, not recorded)."""
    if kind == "bag":
        meta = os.path.join(local, "metadata.yaml") if os.path.isdir(local) else None
        if meta and os.path.isfile(meta):
            with open(meta, encoding="utf-8", errors="replace") as f:
                t = bag_start(f.read())
            if t is not None:
                return _utc(t), "bag metadata"
    else:
        target = os.path.join(local, "wheels.csv")
        try:
            with open(target, encoding="utf-8", errors="replace") as f:
                f.readline()
                first = f.readline().split(",", 1)[0]
            t0 = float(first)
            if t0 > UNIX_TIME_MIN_S:
                return _utc(t0), "log clock"
        except (OSError, ValueError):
            pass
    return None, "unknown"


def _utc(t: float) -> _dt.datetime:
    return _dt.datetime.fromtimestamp(t, tz=_dt.timezone.utc)


@contextmanager
def local_copy(url: str) -> Iterator[str]:
    """The recording as a path of this machine: the path itself when local,
    else a copy in a temporary directory removed on exit."""
    fs, path = _fs(url)
    if "file" in _protocols(fs):
        yield path
        return
    tmp = tempfile.mkdtemp(prefix="terraslip-fleet-")
    try:
        name = posixpath.basename(path.rstrip("/")) or "recording"
        dest = os.path.join(tmp, name)
        if fs.isdir(path):
            fs.get(path.rstrip("/") + "/", dest, recursive=True)
        else:
            fs.get(path, dest)
        yield dest
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
