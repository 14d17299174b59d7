"""The fleet's Parquet tables: their schemas, hive-partitioned parts
(``robot=NAME/date=YYYY-MM-DD/``, so DuckDB, polars, pandas and Spark
prune by robot and date), and an output directory that is replaced table by
table only once every part is written.
"""

from __future__ import annotations

import hashlib
import posixpath
import uuid
from typing import Any, Dict, Iterable, List, Optional, Sequence
from urllib.parse import quote

import fsspec
import pyarrow as pa
import pyarrow.parquet as pq

f64 = pa.float64()
STR = pa.string()
STRS = pa.list_(pa.string())
# The ICR model's parameters (m, body frame; speed factors 1).
ICR = ("y_l", "y_r", "x_c", "alpha_l", "alpha_r")

# One row per recording. Partition columns robot and date are the
# directories' names (hive), not stored in the files.
RECORDINGS = pa.schema(
    [
        ("path", STR),
        ("kind", STR),
        ("time", pa.timestamp("us", tz="UTC")),
        ("time_source", STR),
        ("duration_s", f64),
        ("rows", pa.int64()),
        ("distance_m", f64),
        ("terrains", STRS),
        ("terrain_labels", pa.bool_()),
        ("variant", STR),
        ("init", STR),
        ("track_width_m", f64),
        *[(k, f64) for k in ICR],
        *[(f"std_{k}", f64) for k in ICR],
        ("std_spread", f64),
        ("controller_factor", f64),
        ("turn_law_s_per_m", f64),
        ("pose_std_xy_m", f64),
        ("pose_std_yaw_rad", f64),
        ("clock_offset_s", f64),
        ("clock_offset_std_s", f64),
        ("fixes", pa.int64()),
        ("prediction_mean_m", f64),
        ("prediction_p90_m", f64),
        ("prediction_segments", pa.int64()),
        ("no_slip_mean_m", f64),
        ("no_slip_p90_m", f64),
        ("warnings", STRS),
        ("error", STR),
        ("terraslip_version", STR),
        ("config_hash", STR),
        ("summary_json", STR),
    ]
)

# One row per robot and terrain (partitioned by robot).
CALIBRATIONS = pa.schema(
    [
        ("terrain", STR),
        ("drives", STRS),
        ("n_drives", pa.int64()),
        *[(k, f64) for k in ICR],
        *[(f"std_{k}", f64) for k in ICR],
        ("method", STR),
        ("chi", f64),
        ("e", f64),
        ("time_offset_s", f64),
        ("segments_used", pa.int64()),
        ("sigma_m", f64),
        ("error", STR),
        ("terraslip_version", STR),
        ("config_hash", STR),
        ("params_json", STR),
    ]
)



def partition_dir(root: str, robot: str, date: Optional[str] = None) -> str:
    """``root/robot=NAME[/date=DATE]``, values URI-encoded as pyarrow's
    hive partitioning does."""
    d = f"{root.rstrip('/')}/robot={quote(robot, safe='')}"
    return d if date is None else f"{d}/date={quote(date, safe='')}"


def _write(table: pa.Table, path: str) -> None:
    """Writes ``table`` to ``path`` (any fsspec URL) through a temporary
    name in the same directory, then moves it into place."""
    fs, p = fsspec.core.url_to_fs(path)
    fs.makedirs(posixpath.dirname(p), exist_ok=True)
    tmp = posixpath.join(posixpath.dirname(p), f".{posixpath.basename(p)}.{uuid.uuid4().hex}.tmp")
    with fs.open(tmp, "wb") as f:
        pq.write_table(table, f, compression="zstd")
    fs.mv(tmp, p)


def write_part(root: str, rec: Any, date: str, table: pa.Table) -> None:
    """One recording's part of a per-row table (rows, tracks): ``path`` is
    added as the first column, the file named by a hash of it."""
    table = table.add_column(0, "path", pa.array([rec.path] * table.num_rows, STR))
    name = hashlib.sha1(rec.path.encode()).hexdigest()[:16]
    _write(table, f"{partition_dir(root, rec.robot, date)}/part-{name}.parquet")


def write_partitioned(root: str, rows: Sequence[Dict[str, Any]], schema: pa.Schema, by_date: bool) -> None:
    """Rows (dicts) as one Parquet file per robot (and date) under
    ``root``, with ``schema``'s columns in its order."""
    groups: Dict[tuple, List[Dict[str, Any]]] = {}
    for r in rows:
        key = (r["robot"], r["date"]) if by_date else (r["robot"], None)
        groups.setdefault(key, []).append(r)
    for (robot, date), part in sorted(groups.items(), key=lambda kv: (kv[0][0], kv[0][1] or "")):
        table = pa.Table.from_pylist([{n: r.get(n) for n in schema.names} for r in part], schema=schema)
        _write(table, f"{partition_dir(root, robot, date)}/part-0.parquet")


class Output:
    """An output directory (local path or fsspec URL) whose tables are
    written into a staging directory inside it and each moved into place by
    :meth:`commit`: a reader sees the old table or the new one, and a run
    that fails leaves the old tables."""

    def __init__(self, url: str):
        self.url = url.rstrip("/")
        self.fs, self.root = fsspec.core.url_to_fs(self.url)
        self.staging = f"{self.url}/.staging-{uuid.uuid4().hex[:12]}"
        self.fs.makedirs(self.root, exist_ok=True)

    def table(self, name: str) -> str:
        """Where to write table ``name`` before the commit."""
        return f"{self.staging}/{name}"

    def final(self, name: str) -> str:
        """Where table ``name`` lives after the commit."""
        return f"{self.url}/{name}"

    def commit(self, names: Iterable[str]) -> None:
        """Moves each staged table over the previous one; tables not staged
        (e.g. rows when not asked for) are left as they were. Refuses, before
        moving any, to replace a directory that is not such a table."""
        from ._recording import FleetError

        _, staging = fsspec.core.url_to_fs(self.staging)
        moves = [(f"{staging}/{n}", f"{self.root}/{n}", f"{staging}/{n}.old") for n in names]
        moves = [m for m in moves if self.fs.exists(m[0])]
        for _, dest, _ in moves:
            if self.fs.exists(dest):
                foreign = [e for e in self.fs.ls(dest, detail=False) if not posixpath.basename(e.rstrip("/")).startswith("robot=")]
                if foreign:
                    raise FleetError(f"{dest}: holds {posixpath.basename(foreign[0])}, not a table of terraslip.fleet; not replaced (choose another --out)")
        for new, dest, old in moves:
            if self.fs.exists(dest):
                self.fs.mv(dest, old, recursive=True)
            self.fs.mv(new, dest, recursive=True)
        self.discard()

    def discard(self) -> None:
        """Removes the staging directory."""
        _, staging = fsspec.core.url_to_fs(self.staging)
        if self.fs.exists(staging):
            self.fs.rm(staging, recursive=True)


def read(out: str, name: str):
    """Table ``name`` of an output directory as a pyarrow Table (partition
    columns restored), or None when it was not written."""
    import pyarrow.dataset as ds

    fs, root = fsspec.core.url_to_fs(f"{out.rstrip('/')}/{name}")
    if not fs.exists(root):
        return None
    keys = [("robot", STR)] if name == "calibrations" else [("robot", STR), ("date", STR)]
    part = ds.partitioning(pa.schema(keys), flavor="hive")
    return ds.dataset(root, filesystem=fs, format="parquet", partitioning=part).to_table()
