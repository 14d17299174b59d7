"""terraslip.fleet: the fleet's tables equal the command line's outputs.

The Dask run (a LocalCluster of 2 worker processes over every log and bag
in ../shared/data, skipped where it is missing unless
TERRASLIP_REQUIRE_SHARED=1) talks over loopback TCP, so it runs in a network
namespace of its own (`unshare -n`, lo up), bounded in time; the rest runs
in this process."""

import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np
import pytest

pa = pytest.importorskip("pyarrow", reason="the fleet extra (pip install terraslip[fleet]) is not installed")
pytest.importorskip("distributed", reason="the fleet extra (pip install terraslip[fleet]) is not installed")
fsspec = pytest.importorskip("fsspec", reason="the fleet extra (pip install terraslip[fleet]) is not installed")

import terraslip  # noqa: E402
from conftest import REPO, SHARED, read_csv, require_shared  # noqa: E402
from terraslip import fleet  # noqa: E402
from terraslip.fleet import _report, _tables  # noqa: E402
from terraslip.fleet._tasks import Options, estimate_recording  # noqa: E402

needs_shared = pytest.mark.usefixtures("shared_present")
HUSKY_TOPICS = '[wheels]\nseparation = 1.040625\n[heading]\ntopic = ""\n'
# The whole fleet run in its namespace: start-up of 2 workers, 56
# recordings, 8 calibration groups; generous for a loaded 2-core machine.
CLUSTER_TIMEOUT_S = 600


# A cluster started apart, given to the command by its scheduler address
# (as a remote one would be).
BY_ADDRESS = (
    "import sys, logging; from distributed import LocalCluster; from terraslip.fleet.__main__ import main; "
    "c = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=logging.ERROR); "
    "rc = main(sys.argv[1:] + ['--scheduler', c.scheduler_address]); c.close(); sys.exit(rc)"
)


def _in_netns(args, timeout, by_address=False):
    """Runs `python -m terraslip.fleet ARGS` (with ``by_address``: against a
    LocalCluster of 2 started apart, by its tcp:// address) in a private
    network namespace with only loopback up; returns the CompletedProcess."""
    if shutil.which("unshare") is None or shutil.which("ip") is None:
        pytest.fail("unshare and ip (util-linux, iproute2) are needed to run the Dask cluster on a private loopback")
    how = ["-c", BY_ADDRESS] if by_address else ["-m", "terraslip.fleet"]
    inner = " ".join(["ip link set lo up &&", "exec", sys.executable, *map(_q, how), *map(_q, args)])
    proc = subprocess.run(["unshare", "-n", "sh", "-c", inner], capture_output=True, text=True, timeout=timeout)
    if proc.returncode != 0 and "unshare" in proc.stderr and "Operation not permitted" in proc.stderr:
        pytest.fail(f"unshare -n needs root (or CAP_SYS_ADMIN): {proc.stderr}")
    return proc


# The data sets the figures below are of (other recordings kept beside
# them in ../shared/data would add groups of their own).
FLEET_SETS = [SHARED / "borealtc", SHARED / "drive", SHARED / "ros2"]


def _q(s):
    s = str(s)
    return "'" + s.replace("'", "'\\''") + "'"


@pytest.fixture(scope="module")
def fleet_run(tmp_path_factory):
    """estimate (with --rows) of ../shared/data on a LocalCluster of 2
    processes (--scheduler local:2), calibrate on one given by address."""
    require_shared(SHARED)
    tmp = tmp_path_factory.mktemp("fleet")
    topics = tmp / "husky.toml"
    topics.write_text(HUSKY_TOPICS)
    out = tmp / "out"
    est = _in_netns(["estimate", *FLEET_SETS, "--topics", topics, "--out", out, "--scheduler", "local:2", "--rows", "--report"], CLUSTER_TIMEOUT_S)
    assert est.returncode == 0, est.stderr
    # Calibration groups: the Warthog's drives (lidar pose) per terrain and
    # the Husky bags (GNSS fixes, a position-only reference) calibrate; the
    # BorealTC Husky's, without a pose, fail: as rows.
    cal = _in_netns(["calibrate", *FLEET_SETS, "--topics", topics, "--out", out], CLUSTER_TIMEOUT_S, by_address=True)
    assert cal.returncode == 0, cal.stderr
    assert "2 Dask worker(s)" in cal.stderr and "6 of 11 robot and terrain groups" in cal.stderr, cal.stderr
    return {"out": out, "topics": topics, "estimate": est, "calibrate": cal}


def _by_path(table):
    return {r["path"]: r for r in table.to_pylist()}


@needs_shared
def test_the_fleet_recordings_table_equals_terraslip_estimate(cli, fleet_run, tmp_path):
    out, topics = fleet_run["out"], fleet_run["topics"]
    assert "Dask worker(s); dashboard" in fleet_run["estimate"].stderr
    rows = _by_path(_tables.read(str(out), "recordings"))
    # Every recording: 46 BorealTC logs, 6 DRIVE logs, the Husky bag in two
    # storage formats.
    assert len(rows) == 54, sorted(rows)
    kinds = sorted(r["kind"] for r in rows.values())
    assert kinds.count("bag") == 2 and kinds.count("log") == 52
    assert {r["robot"] for r in rows.values()} == {"clearpath-husky-a200", "clearpath-warthog", "ros2"}
    per_row = _tables.read(str(out), "rows").to_pandas()
    for path, row in sorted(rows.items()):
        assert row["error"] is None, (path, row["error"])
        cmd = ["estimate", path, "--out", tmp_path / "cli"]
        if row["kind"] == "bag":
            cmd += ["--topics", topics]
        if os.path.isfile(os.path.join(path, "terrain.csv")):
            cmd.append("--terrain-labels")
        assert row["terrain_labels"] == ("--terrain-labels" in cmd)
        cli(*cmd)
        summary = json.loads((tmp_path / "cli" / "summary.json").read_text())
        summary["log"] = path
        # The command also keeps the topics file it was given, for `report`.
        if row["kind"] == "bag":
            assert summary.pop("bag_topics")["file"] == str(topics)
        assert json.loads(row["summary_json"]) == summary, path
        csv = read_csv(tmp_path / "cli" / "estimate.csv")
        for k in ("y_l", "y_r", "x_c", "alpha_l", "alpha_r"):
            assert row[k] == summary["icr"][k], (path, k)
        assert row["std_alpha_l"] == float(csv[-1]["std_alpha_l"]), path
        assert row["duration_s"] == summary["duration_s"]
        assert row["rows"] == len(csv)
        east = np.array([float(c["east"]) for c in csv])
        north = np.array([float(c["north"]) for c in csv])
        assert math.isclose(row["distance_m"], float(np.hypot(np.diff(east), np.diff(north)).sum()), rel_tol=1e-12, abs_tol=1e-12)
        assert row["warnings"] == summary["warnings"]
        # The factor is the whole drive's spread over the track width where
        # the drive taught the spread in metres (positions); without them
        # (the speed factor held) only the turn is taught, and no factor.
        spread = summary["recommendation"]["spread_m"]
        if spread is not None:
            assert row["controller_factor"] == pytest.approx(spread["value"] / summary["track_width"], rel=1e-15)
        else:
            assert row["controller_factor"] is None, path
        if summary["learning"]["spread"].startswith("held"):
            assert spread is None, path
        if summary["prediction"]:
            assert row["prediction_mean_m"] == summary["prediction"]["mean_m"]
            assert row["no_slip_mean_m"] == summary["prediction"]["no_slip"]["mean_m"]
        terrains = list(dict.fromkeys(c["terrain"] for c in csv if c["terrain"]))
        assert row["terrains"] == terrains
        # The per-row table: estimate.csv's rows, in order.
        mine = per_row[per_row["path"] == path]
        assert len(mine) == len(csv), path
        for name in ("t", "east", "north", "yaw", "y_l", "alpha_r", "std_alpha_l", "nis", "clock_offset"):
            assert np.array_equal(mine[name].to_numpy(), np.array([float(c[name]) for c in csv])), (path, name)
        assert list(mine["terrain"]) == [c["terrain"] for c in csv]
    # Partitioned by robot and date: the bag's date is its metadata's.
    bag = rows[str(SHARED / "ros2" / "husky_test1_mcap")]
    assert str(bag["date"]) == "2015-05-21" and bag["time_source"] == "bag metadata"
    assert (out / "recordings" / "robot=ros2" / "date=2015-05-21").is_dir()
    # The map: the Warthog drives and the bags have a pose reference.
    tracks = _tables.read(str(out), "tracks")
    assert {p for p in tracks.column("path").to_pylist()} == {p for p, r in rows.items() if r["fixes"] > 0}
    report = (out / "report.html").read_text()
    # Charts (controller factor, two speed factors) for the two robots with
    # a pose reference, a map each; the BorealTC Husky has none.
    assert "Where the fleet slips" in report and report.count("<svg") == 3 * 2 + 2
    assert "46 recording(s) without a pose reference, not charted" in report


@needs_shared
def test_the_fleet_calibrations_equal_terraslip_calibrate_per_robot_and_terrain(cli, fleet_run, tmp_path):
    out, topics = fleet_run["out"], fleet_run["topics"]
    cal = _tables.read(str(out), "calibrations").to_pylist()
    groups = {(str(c["robot"]), c["terrain"]): c for c in cal}
    drive = SHARED / "drive"
    assert set(groups) == {
        ("clearpath-warthog", "asphalt"),
        ("clearpath-warthog", "grass"),
        ("clearpath-warthog", "gravel"),
        ("clearpath-warthog", "ice"),
        ("clearpath-warthog", "sand"),
        ("clearpath-husky-a200", "asphalt"),
        ("clearpath-husky-a200", "flooring"),
        ("clearpath-husky-a200", "ice"),
        ("clearpath-husky-a200", "sandy_loam"),
        ("clearpath-husky-a200", "snow"),
        ("ros2", ""),
    }
    assert groups[("clearpath-husky-a200", "snow")]["n_drives"] == 18
    assert groups[("ros2", "")]["drives"] == [str(SHARED / "ros2" / "husky_test1_db3"), str(SHARED / "ros2" / "husky_test1_mcap")]
    sand = groups[("clearpath-warthog", "sand")]
    assert sand["drives"] == [str(drive / "warthog_sand_a"), str(drive / "warthog_sand_b")]
    for (robot, terrain), c in groups.items():
        params_file = tmp_path / f"{robot}-{terrain}.json"
        args = ["calibrate", *c["drives"], "--out", params_file]
        if robot == "ros2":
            args += ["--topics", topics]
        proc = cli(*args, check=False)
        if c["error"] is None:
            assert proc.returncode == 0, proc.stderr
            params = json.loads(params_file.read_text())
            want = params["terrains"][terrain] if terrain else params
            assert json.loads(c["params_json"]) == want, (robot, terrain)
            assert c["y_l"] == want["params"]["y_l"] and c["std_alpha_r"] == want["std"]["alpha_r"]
        else:
            # Failed groups: the command refuses them too, with the same message.
            assert proc.returncode != 0, (robot, terrain)
            msg = [l for l in proc.stderr.splitlines() if l.startswith("error: ")][-1][len("error: "):]
            assert msg.split(": ", 1)[-1] in c["error"], (c["error"], msg)
    assert sum(c["error"] is None for c in cal) == 6
    assert groups[("ros2", "")]["error"] is None


def _copy_to(fs, src, dest):
    for root, _, files in os.walk(src):
        for name in files:
            rel = os.path.relpath(os.path.join(root, name), src)
            with open(os.path.join(root, name), "rb") as f:
                fs.pipe_file(f"{dest}/{rel}", f.read())


def test_a_recording_on_an_object_store_is_copied_and_gives_the_local_numbers(tmp_path):
    fs = fsspec.filesystem("memory")
    _copy_to(fs, REPO / "data" / "warthog_gravel", "/store/site-a/warthog_gravel")
    fs.pipe_file("/store/fleet.csv", b"path,robot,date\nsite-a/warthog_gravel,w-07,2026-05-01\n")
    recs = fleet.recordings(["memory://store/fleet.csv"])
    assert recs == [fleet.Recording("memory://store/site-a/warthog_gravel", "log", "w-07", "2026-05-01")]
    remote = estimate_recording(recs[0], Options(rows=True), str(tmp_path / "rows"), str(tmp_path / "tracks"))
    local = terraslip.estimate(REPO / "data" / "warthog_gravel", terrain_labels=True)
    assert remote["error"] is None
    summary = json.loads(remote["summary_json"])
    assert summary["log"] == "memory://store/site-a/warthog_gravel"
    summary["log"] = local["summary"]["log"]
    assert summary == local["summary"]
    assert remote["date"] == "2026-05-01" and remote["terrains"] == ["gravel"]
    part = _tables.read(str(tmp_path), "rows").to_pandas()
    assert np.array_equal(part["yaw"].to_numpy(), local["yaw"])
    assert set(part["robot"].astype(str)) == {"w-07"} and set(part["date"].astype(str)) == {"2026-05-01"}


def test_a_recording_that_fails_is_a_row_with_its_error(tmp_path):
    bad = tmp_path / "robot-3" / "broken"
    bad.mkdir(parents=True)
    (bad / "wheels.csv").write_text("t,v_left,v_right\n0,0.1,0.1\n0.1,zero,0.1\n")
    recs = fleet.recordings([tmp_path])
    assert recs == [fleet.Recording(str(bad), "log", "robot-3")]
    row = estimate_recording(recs[0], Options(), None, None)
    assert row["error"] is not None and f"{bad}/wheels.csv:3: column `v_left`" in row["error"], row["error"]
    assert row["date"] not in (None, "")


def test_manifest_errors_name_the_file_line_and_column(tmp_path):
    m = tmp_path / "m.csv"
    m.write_text(f"path,robot,date\n{REPO / 'data' / 'warthog_gravel'},a,2026-05-01\n{REPO / 'data' / 'warthog_gravel'},a,yesterday\n")
    with pytest.raises(fleet.FleetError, match=r"m.csv: line 3: column date: 'yesterday' is not a date"):
        fleet.recordings([str(m)])
    m.write_text("path,robot\nnowhere,a\n")
    with pytest.raises(fleet.FleetError, match=r"m.csv: line 2: column path: .*nowhere: no such file"):
        fleet.recordings([str(m)])
    with pytest.raises(fleet.FleetError, match="no such file or directory"):
        fleet.recordings([str(tmp_path / "missing")])


def test_the_output_never_goes_into_a_recording(tmp_path):
    log = REPO / "data" / "warthog_gravel"
    with pytest.raises(fleet.FleetError, match="would write into recording"):
        fleet.estimate([str(log)], log / "fleet-out", scheduler="local:1", progress=False)
    assert not (log / "fleet-out").exists()


def test_the_control_chart_flags_a_drift_against_the_robots_own_history():
    steady = [1.50, 1.52, 1.49, 1.51, 1.50, 1.51]
    flags = _report.control_flags(steady + [1.51, 1.80], [0.005] * 8)
    assert flags[:5] == [None] * 5  # too little history to judge
    assert flags[5][2] is False and flags[6][2] is False
    centre, half, out = flags[7]
    assert out and centre == pytest.approx(sum(steady + [1.51]) / 7)
    # A recording's own wide band keeps it inside: it is not evidence of a change.
    assert _report.control_flags(steady + [1.56], [0.005] * 6 + [0.05])[6][2] is False


def test_the_command_teaches_in_its_help():
    proc = subprocess.run([sys.executable, "-m", "terraslip.fleet", "estimate", "--help"], capture_output=True, text=True)
    assert proc.returncode == 0
    for words in ("--scheduler", "local:N", "--rows", "--topics"):
        assert words in proc.stdout
    top = subprocess.run([sys.executable, "-m", "terraslip.fleet", "--help"], capture_output=True, text=True).stdout
    assert "manifest" in top and "duckdb" in top
    bad = subprocess.run([sys.executable, "-m", "terraslip.fleet", "estimate", "x", "--out", "y", "--scheduler", "local:zero"], capture_output=True, text=True)
    assert bad.returncode == 1 and "error: " in bad.stderr


@needs_shared
def test_the_docs_duckdb_query_reads_the_tables_as_written(fleet_run):
    duckdb = pytest.importorskip("duckdb", reason="duckdb (the docs' query engine) is not installed")
    doc = (REPO / "docs" / "fleet.md").read_text()
    sql = doc.split("<!-- duckdb -->")[1].split("<!-- /duckdb -->")[0].split("```sql")[1].split("```")[0]
    sql = sql.replace("'fleet/", f"'{fleet_run['out']}/")
    got = duckdb.sql(sql).fetchall()
    rows = _tables.read(str(fleet_run["out"]), "recordings").to_pylist()
    assert sum(r[2] for r in got) == sum(r["error"] is None for r in rows) == 54
    assert {r[0] for r in got} == {"clearpath-husky-a200", "clearpath-warthog", "ros2"}


def test_the_report_flags_a_robot_that_left_its_own_history(tmp_path):
    import datetime as dt

    day = dt.datetime(2026, 5, 1, 8, tzinfo=dt.timezone.utc)
    spread = [3.30, 3.32, 3.29, 3.31, 3.30, 3.31, 3.80]  # m; the last drive's tyres are soft
    rows = [
        {
            "robot": "w-07", "date": (day + dt.timedelta(days=i)).date().isoformat(), "path": f"drive-{i}",
            "kind": "log", "time": day + dt.timedelta(days=i), "fixes": 900, "terrains": ["gravel"],
            "track_width_m": 1.1, "controller_factor": s / 1.1, "std_spread": 0.01,
            "alpha_l": 0.91, "alpha_r": 0.92, "std_alpha_l": 0.005, "std_alpha_r": 0.005,
            "duration_s": 600.0, "distance_m": 900.0, "warnings": [], "error": None,
        }
        for i, s in enumerate(spread)
    ]
    _tables.write_partitioned(str(tmp_path / "recordings"), rows, _tables.RECORDINGS, by_date=True)
    page = (tmp_path / "report.html")
    assert fleet.report(str(tmp_path)) == str(page)
    flagged = page.read_text().split("<h2>Flagged recordings</h2>")[1].split("<h2>")[0]
    assert flagged.count("<tr>") == 2 and "drive-6" in flagged and "controller factor" in flagged


def test_tables_replace_only_tables(tmp_path):
    rows = [{"robot": "r", "date": "2026-05-01", "path": "a", "error": None}]
    first = _tables.Output(str(tmp_path))
    _tables.write_partitioned(first.table("recordings"), rows, _tables.RECORDINGS, by_date=True)
    first.commit(["recordings"])
    assert _tables.read(str(tmp_path), "recordings").column("path").to_pylist() == ["a"]
    # A second run replaces the table; a directory of something else under
    # a table's name is left alone, and so is every table of that run.
    (tmp_path / "rows").mkdir()
    (tmp_path / "rows" / "notes.txt").write_text("mine")
    second = _tables.Output(str(tmp_path))
    _tables.write_partitioned(second.table("recordings"), [dict(rows[0], path="b")], _tables.RECORDINGS, by_date=True)
    _tables.write_partitioned(second.table("rows"), rows, _tables.RECORDINGS, by_date=True)
    with pytest.raises(fleet.FleetError, match=r"rows: holds notes.txt, not a table"):
        second.commit(["recordings", "rows"])
    second.discard()
    assert (tmp_path / "rows" / "notes.txt").read_text() == "mine"
    assert _tables.read(str(tmp_path), "recordings").column("path").to_pylist() == ["a"]
    third = _tables.Output(str(tmp_path))
    _tables.write_partitioned(third.table("recordings"), [dict(rows[0], path="c")], _tables.RECORDINGS, by_date=True)
    third.commit(["recordings"])
    assert _tables.read(str(tmp_path), "recordings").column("path").to_pylist() == ["c"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["recordings", "rows"]


def test_a_factor_not_learned_is_null_and_no_file_time_dates_a_recording(tmp_path):
    from terraslip.fleet._recording import start_time
    from terraslip.fleet._tasks import controller_factor

    held = "held (no position, heading or gyro: nothing measures the motion; its starting value)"
    s = {"icr": {"y_l": 0.25, "y_r": -0.25}, "track_width": 0.5, "learning": {"spread": held}}
    assert controller_factor(s) is None
    s["learning"]["spread"] = "learned"
    s["recommendation"] = {"spread_m": {"value": 0.6, "std": 0.01}}
    assert controller_factor(s) == pytest.approx(1.2)
    log = tmp_path / "log"
    log.mkdir()
    (log / "wheels.csv").write_text("t,v_left,v_right\n0.0,1,1\n")
    assert start_time(str(log), "log") == (None, "unknown")
