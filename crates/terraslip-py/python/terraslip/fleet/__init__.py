"""terraslip over a fleet: every recording of every robot, one Dask task
each, into Parquet tables partitioned by robot and date.

Needs the ``fleet`` extra (``pip install "terraslip[fleet]"``: dask's
distributed scheduler, pyarrow, fsspec). Recordings are log directories,
ROS 2 bag directories, or .mcap / .db3 files, as local paths or fsspec URLs
(``s3://...`` with s3fs installed); a URL is copied to the worker before
it is read. Each row holds what ``terraslip estimate`` /
``terraslip calibrate`` give on that recording: the same function runs.

    from terraslip import fleet
    recs = fleet.recordings(["s3://bucket/drives/"])    # or a manifest
    fleet.estimate(recs, "fleet-out", scheduler="local:4")
    fleet.calibrate(recs, "fleet-out", scheduler="tcp://10.0.0.5:8786")
    fleet.report("fleet-out")                            # fleet-out/report.html

Tables (docs/fleet.md has every column): ``recordings`` (one row per
recording), ``rows`` (the per-row estimates, with ``rows=True``),
``tracks`` (the map: 1 s track points with their slip), ``calibrations``
(per robot and terrain, with the drives it came from).
"""

from __future__ import annotations

import os
from collections import defaultdict
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union

from ._recording import FleetError, Recording, recordings
from ._tasks import Options, calibrate_group, estimate_recording, read_text

__all__ = ["FleetError", "Recording", "calibrate", "estimate", "recordings", "report", "terrains_of"]

_Fleet = Union[str, "os.PathLike[str]", Sequence[Union[str, "os.PathLike[str]", Recording]]]


def _as_recordings(fleet: _Fleet) -> List[Recording]:
    if isinstance(fleet, (str, os.PathLike)):
        fleet = [fleet]
    recs = [r for r in fleet if isinstance(r, Recording)]
    paths = [str(r) for r in fleet if not isinstance(r, Recording)]
    return recs + (recordings(paths) if paths else [])


def _check_out(out: str, recs: Sequence[Recording]) -> None:
    """Refuses an output directory that is, holds or lies in a recording."""

    def norm(p: str) -> str:
        return os.path.realpath(p) if "://" not in p else p.rstrip("/")

    o = norm(out)
    for r in recs:
        p = norm(r.path)
        if o == p or o.startswith(p + "/") or p.startswith(o + "/"):
            raise FleetError(f"--out {out}: it would write into recording {r.path}; choose a directory outside the recordings")


def _options(config: Any, preset: Optional[str], topics: Any, terrain_labels: Any, method: Optional[str], rows: bool) -> Options:
    def text(v: Any) -> Optional[str]:
        if v is None:
            return None
        if isinstance(v, Mapping):
            return _toml(v)
        return read_text(str(v))

    return Options(config=text(config), preset=preset, topics=text(topics), terrain_labels=terrain_labels, method=method, rows=rows)


def _toml(tables: Mapping[str, Any]) -> str:
    """A mapping of TOML tables of scalars (a config or topics dict) as TOML."""

    def value(v: Any) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (int, float)):
            return repr(v)
        if isinstance(v, str):
            return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        raise FleetError(f"configuration value {v!r}: give a TOML file for anything but numbers, strings, booleans and lists")

    lines: List[str] = []
    for name, table in tables.items():
        if not isinstance(table, Mapping):
            raise FleetError(f"configuration key {name!r}: expected a table (a mapping)")
        lines.append(f"[{name}]")
        lines.extend(f"{k} = {value(v)}" for k, v in table.items())
    return "\n".join(lines) + "\n"


def estimate(
    fleet: _Fleet,
    out: Union[str, "os.PathLike[str]"],
    *,
    scheduler: Any = None,
    config: Any = None,
    preset: Optional[str] = None,
    topics: Any = None,
    terrain_labels: Any = "auto",
    rows: bool = False,
    progress: bool = True,
):
    """Runs ``terraslip estimate`` on every recording of ``fleet`` (paths,
    URLs, manifests or :class:`Recording`\\ s), one Dask task each, and
    writes ``out/recordings`` (and ``out/rows`` with ``rows=True``,
    ``out/tracks`` for recordings with a pose reference).

    ``scheduler``: ``"local:N"`` (a LocalCluster of N processes), an
    address ``"tcp://HOST:PORT"``, a ``distributed.Client``, or None (one
    local worker per CPU). ``config``, ``preset``: as for
    ``terraslip.estimate`` (a TOML path/URL or a mapping). ``topics``: the
    ``--topics`` file (or mapping) for the bags without their own in the
    manifest. ``terrain_labels``: ``"auto"`` uses a log's terrain.csv as
    the terrain evidence when it has one (``--terrain-labels``).

    A recording that fails is a row with its ``error``. Returns the
    recordings table as a pyarrow Table.
    """
    recs, out = _prepare(fleet, out, scheduler)
    opts = _options(config, preset, topics, terrain_labels, None, rows)
    return _fan_out(
        out,
        scheduler,
        progress,
        estimate_recording,
        lambda target: [(r, opts, target.table("rows"), target.table("tracks")) for r in recs],
        "recordings",
        also=("rows", "tracks"),
    )


def _prepare(fleet: _Fleet, out: Any, scheduler: Any):
    """The recordings and the output directory, checked before any work."""
    from . import _cluster

    if isinstance(scheduler, str):
        _cluster.parse_scheduler(scheduler)
    recs = _as_recordings(fleet)
    if not recs:
        raise FleetError("no recording given")
    out = str(out) if "://" in str(out) else os.path.abspath(out)
    _check_out(out, recs)
    return recs, out


def _fan_out(out: str, scheduler: Any, progress: bool, task: Any, args_of: Any, table: str, also: Sequence[str] = ()):
    """Runs ``task(*a)`` for each ``a`` in ``args_of(target)`` on the
    cluster, writes the rows it returns as ``table`` and moves ``table``
    (and the tables the tasks wrote, ``also``) into ``out``."""
    from . import _cluster, _tables

    schema, by_date = {"recordings": (_tables.RECORDINGS, True), "calibrations": (_tables.CALIBRATIONS, False)}[table]
    target = _tables.Output(out)
    try:
        with _cluster.client(scheduler, quiet=not progress) as c:
            result = _cluster.run(c, task, args_of(target), "estimate" if table == "recordings" else "calibrate", progress=progress)
        _tables.write_partitioned(target.table(table), result, schema, by_date=by_date)
        target.commit([table, *also])
    except BaseException:
        target.discard()
        raise
    return _tables.read(out, table)


def terrains_of(rec: Recording) -> List[str]:
    """The terrain labels of a log's terrain.csv in order of appearance
    ([] for a bag, a log without one, or one without a terrain column:
    calibrating it then says what is wrong with it)."""
    import fsspec

    if rec.kind != "log":
        return []
    url = rec.path.rstrip("/") + "/terrain.csv"
    fs, path = fsspec.core.url_to_fs(url)
    if not fs.exists(path):
        return []
    import csv
    import io

    text = fs.cat_file(path).decode("utf-8", "replace")
    rows = csv.DictReader(io.StringIO(text))
    if rows.fieldnames is None or "terrain" not in rows.fieldnames:
        return []
    return list(dict.fromkeys(r["terrain"].strip() for r in rows if r.get("terrain") and r["terrain"].strip()))


def groups(recs: Sequence[Recording]) -> Dict[tuple, List[Recording]]:
    """(robot, terrain) -> the recordings with that robot that drove on that
    terrain (terrain "" for drives without labels); a drive over several
    terrains is in the group of each."""
    out: Dict[tuple, List[Recording]] = defaultdict(list)
    for r in sorted(recs, key=lambda r: (r.robot, r.path)):
        for t in terrains_of(r) or [""]:
            out[(r.robot, t)].append(r)
    return dict(sorted(out.items()))


def calibrate(
    fleet: _Fleet,
    out: Union[str, "os.PathLike[str]"],
    *,
    scheduler: Any = None,
    method: Optional[str] = None,
    topics: Any = None,
    progress: bool = True,
):
    """Calibrates each robot on each terrain from all of its drives there
    (one ``terraslip calibrate`` of those drives per group, one Dask task
    each) into ``out/calibrations``. ``method``: ``"lm"``, ``"ga"``,
    ``"symmetric"`` or None (all three, the best kept: the command's
    default). A group that fails is a row with its ``error``. Returns the
    calibrations table as a pyarrow Table."""
    recs, out = _prepare(fleet, out, scheduler)
    opts = _options(None, None, topics, False, method, False)
    plan = groups(recs)
    return _fan_out(
        out,
        scheduler,
        progress,
        calibrate_group,
        lambda _: [(robot, terrain, members, opts) for (robot, terrain), members in plan.items()],
        "calibrations",
    )


def report(out: Union[str, "os.PathLike[str]"], html: Optional[str] = None) -> str:
    """Writes the fleet report of an output directory (``html``, default
    ``out/report.html``) and returns its path; see :mod:`terraslip.fleet._report`."""
    from ._report import write_report

    return write_report(str(out), html)
