"""`terraslip.estimate` and `terraslip.Estimator` against the command line."""

import csv
import json

import numpy as np
import pytest

import terraslip
from conftest import BOREAL, DRIVE, REPO, read_csv

FLAGS = {"fused", "gated", "change"}


def assert_matches_csv(result, csv_path, tol=1e-9):
    rows = read_csv(csv_path)
    assert list(result) == terraslip.COLUMNS + ["summary"]
    assert list(rows[0]) == terraslip.COLUMNS
    for name in terraslip.COLUMNS:
        got = result[name]
        assert len(got) == len(rows), name
        if name == "terrain":
            assert list(got) == [r[name] for r in rows]
            continue
        want = np.array([float(r[name]) for r in rows])
        if name in FLAGS:
            assert got.dtype == bool, name
        else:
            assert got.dtype == np.float64, name
        assert np.max(np.abs(got - want)) <= tol, name


@pytest.mark.parametrize("labels", [False, True])
def test_estimate_equals_the_cli_on_a_real_drive(cli, tmp_path, monkeypatch, labels):
    extra = ["--terrain-labels"] if labels else []
    cli("estimate", DRIVE.relative_to(REPO), "--out", tmp_path, *extra)
    monkeypatch.chdir(REPO)
    got = terraslip.estimate(DRIVE.relative_to(REPO), terrain_labels=labels)
    assert_matches_csv(got, tmp_path / "estimate.csv")
    written = json.loads((tmp_path / "summary.json").read_text())
    # The summary names the log as given; summary.json, a file that outlives
    # the working directory, by its absolute path (for `report`).
    assert got["summary"]["log"] == str(DRIVE.relative_to(REPO))
    assert written.pop("log") == str(DRIVE)
    del got["summary"]["log"]
    assert got["summary"] == written
    assert got["summary"]["rows"] == 12000
    if labels:
        assert set(got["terrain"]) == {"gravel"}


def test_config_and_init_reach_the_filter_as_in_the_cli(cli, tmp_path):
    config = tmp_path / "estimator.toml"
    config.write_text("[measurement]\nstd_xy = 0.05\n")
    params = tmp_path / "params.json"
    cli("calibrate", DRIVE, "--method", "lm", "--out", params)
    out = tmp_path / "est"
    cli("estimate", DRIVE, "--out", out, "--config", config, "--init", params)
    got = terraslip.estimate(DRIVE, config=config, init=params)
    assert_matches_csv(got, out / "estimate.csv")
    assert got["summary"]["init"] == json.loads((out / "summary.json").read_text())["init"]
    # The same as mappings: a dict of TOML tables, the parameters' content.
    again = terraslip.estimate(
        DRIVE,
        config={"measurement": {"std_xy": 0.05}},
        init=json.loads(params.read_text()),
    )
    for name in terraslip.COLUMNS:
        assert np.array_equal(again[name], got[name]), name
    default = terraslip.estimate(DRIVE)
    assert not np.array_equal(default["y_l"], got["y_l"])


def test_terrain_model_classifies_and_feeds_the_estimator(cli, tmp_path):
    model = tmp_path / "model.json"
    cli("terrain", "train", *sorted(REPO.glob("data/*_borealtc_*")), "--out", model)
    m = terraslip.TerrainModel.load(model)
    assert m.classes == sorted(["asphalt", "flooring", "ice", "sandy_loam", "snow"])
    c = m.classify(BOREAL)
    n = len(c["t"])
    assert n > 10 and np.all(np.diff(c["t"]) > 0)
    assert c["probabilities"].shape == (n, len(m.classes))
    assert np.allclose(c["probabilities"].sum(axis=1), 1.0)
    assert set(c["label"]) <= set(m.classes)
    # A model trained on this very run recognises it.
    assert np.mean(c["label"] == "ice") > 0.5
    out = tmp_path / "est"
    cli("estimate", BOREAL, "--out", out, "--terrain-model", model)
    got = terraslip.estimate(BOREAL, terrain_model=model)
    assert_matches_csv(got, out / "estimate.csv")
    assert got["summary"] == json.loads((out / "summary.json").read_text())


def test_windows_driven_unlike_the_training_runs_are_outside_the_envelope(cli, tmp_path):
    model = tmp_path / "model.json"
    cli("terrain", "train", *sorted(REPO.glob("data/*_borealtc_*")), "--out", model)
    m = terraslip.TerrainModel.load(model)
    # The same run with its treads three times as fast: no training run of
    # any terrain drove like that.
    fast = tmp_path / "fast"
    fast.mkdir()
    for name in ("imu.csv", "meta.toml", "terrain.csv"):
        (fast / name).write_bytes((BOREAL / name).read_bytes())
    rows = read_csv(BOREAL / "wheels.csv")
    with open(fast / "wheels.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        for r in rows:
            w.writerow({**r, "v_left": 3 * float(r["v_left"]), "v_right": 3 * float(r["v_right"])})
    for log, lo, hi in ((BOREAL, 0.0, 0.2), (fast, 0.9, 1.0)):
        c = m.classify(log)
        out = c["outside_envelope"]
        assert out.dtype == bool and out.shape == c["t"].shape
        assert lo <= c["outside_envelope_share"] <= hi, (log, c["outside_envelope_share"])
        assert c["outside_envelope_share"] == pytest.approx(np.mean(out))
        # Flagged windows are mixed half and half with uniform: no class
        # above 0.5 + 0.5 / 5.
        if out.any():
            assert np.all(c["probabilities"][out].max(axis=1) <= 0.6 + 1e-9)
        report = json.loads(cli("terrain", "eval", log, "--model", model, "--json").stdout)
        assert c["outside_envelope_share"] == pytest.approx(report["logs"][0]["outside_envelope_share"])


def test_a_mapping_of_arrays_is_the_same_log():
    wheels = read_csv(DRIVE / "wheels.csv")
    pose = read_csv(DRIVE / "pose.csv")
    col = lambda rows, k: np.array([float(r[k]) if r[k] != "" else np.nan for r in rows])
    log = {
        "wheels": {k: col(wheels, k) for k in ("t", "v_left", "v_right")},
        "pose": {k: col(pose, k) for k in ("t", "east", "north", "yaw")},
        "meta": {"track_width": 1.10},
    }
    got = terraslip.estimate(log)
    want = terraslip.estimate(DRIVE)
    for name in terraslip.COLUMNS:
        assert np.array_equal(got[name], want[name]), name
    assert got["summary"]["icr"] == want["summary"]["icr"]
    assert got["summary"]["log"] == "<mapping>"


def as_written(x, digits):
    """A value as estimate.csv writes it (half away from zero)."""
    scale = 10.0**digits
    r = np.floor(np.abs(x) * scale + 0.5) / scale
    return np.where(r == 0, 0.0, np.copysign(r, x))


DIGITS = dict(
    east=4, north=4, yaw=6, y_l=6, y_r=6, x_c=6, std_east=4, std_north=4, std_yaw=6,
    std_y_l=6, std_y_r=6, std_x_c=6, alpha_l=5, alpha_r=5, std_alpha_l=5, std_alpha_r=5,
    std_spread=6, nis=3, q_scale=3, clock_offset=4,
)


def stream(est, wheels, pose, terrain=None):
    """Feeds `est` the rows of wheels.csv, each after the pose fixes stamped
    at or before it (and the terrain, when given): its state after each."""
    states, pi = [], 0
    for w in wheels:
        t = float(w["t"])
        if terrain is not None:
            est.on_terrain(terrain)
        while pi < len(pose) and float(pose[pi]["t"]) <= t:
            p = pose[pi]
            est.on_pose(float(p["t"]), east=float(p["east"]), north=float(p["north"]), yaw=float(p["yaw"]))
            pi += 1
        est.on_wheels(t, float(w["v_left"]), float(w["v_right"]))
        states.append(est.state())
    return states


@pytest.mark.parametrize("calibrated", [False, True])
def test_streaming_equals_batch(calibrated):
    # Calibrated per terrain: the set of `gravel`, recalled on entering it.
    init = terraslip.calibrate(DRIVE) if calibrated else None
    if calibrated:
        assert list(init["terrains"]) == ["gravel"]
    batch = terraslip.estimate(DRIVE, terrain_labels=True, init=init)
    wheels = read_csv(DRIVE / "wheels.csv")
    pose = read_csv(DRIVE / "pose.csv")
    est = terraslip.Estimator(track_width=1.10, init=init)
    assert est.init_source == batch["summary"]["init"]
    # The terrain.csv of this drive: gravel from the start.
    states = stream(est, wheels, pose, terrain="gravel")
    assert len(states) == len(batch["t"])
    for name in terraslip.COLUMNS:
        got = [s[name] for s in states]
        if name in DIGITS:
            got = as_written(np.array(got), DIGITS[name])
            assert np.max(np.abs(got - batch[name])) <= 1e-12, name
        else:
            assert list(got) == list(batch[name]), name
    assert est.terrains == ["gravel"]


def test_a_localiser_streams_as_its_log_estimates():
    # meta.toml's pose_reference and the Estimator's keyword are one decision.
    wheels = read_csv(DRIVE / "wheels.csv")
    pose = read_csv(DRIVE / "pose.csv")
    col = lambda rows, k: np.array([float(r[k]) for r in rows])
    log = {
        "wheels": {k: col(wheels, k) for k in ("t", "v_left", "v_right")},
        "pose": {k: col(pose, k) for k in ("t", "east", "north", "yaw")},
        "meta": {"track_width": 1.10, "pose_reference": "localiser"},
    }
    batch = terraslip.estimate(log)
    assert batch["summary"]["pose_noise"]["reference"] == "localiser"
    assert batch["summary"]["pose_noise"]["correlated_std_m"] == 0.0
    est = terraslip.Estimator(track_width=1.10, pose_reference="localiser")
    states = stream(est, wheels, pose)
    east = np.array([s["east"] for s in states])
    assert np.max(np.abs(as_written(east, DIGITS["east"]) - batch["east"])) <= 1e-12
    # Unstated, the fixes' error wanders: another estimate.
    assert np.max(np.abs(terraslip.estimate(DRIVE)["east"] - batch["east"])) > 1e-3
    with pytest.raises(ValueError, match="pose_reference"):
        terraslip.Estimator(track_width=1.10, pose_reference="lidar")


def test_runs_in_threads_give_the_same_numbers():
    from concurrent.futures import ThreadPoolExecutor

    with ThreadPoolExecutor(4) as pool:
        runs = list(pool.map(lambda _: terraslip.estimate(DRIVE), range(4)))
    for r in runs[1:]:
        for name in terraslip.COLUMNS:
            assert np.array_equal(r[name], runs[0][name]), name


def test_pandas_tables():
    pd = pytest.importorskip("pandas")
    log = {
        "wheels": pd.read_csv(DRIVE / "wheels.csv"),
        "pose": pd.read_csv(DRIVE / "pose.csv"),
        "meta": {"track_width": 1.10},
    }
    got = pd.DataFrame({k: v for k, v in terraslip.estimate(log).items() if k != "summary"})
    batch = terraslip.estimate(DRIVE)
    for name in terraslip.COLUMNS:
        assert np.array_equal(got[name].to_numpy(), batch[name]), name


def test_streaming_takes_a_gyro():
    # Driving straight by the wheels while the gyro says the robot turns:
    # with the gyro fused, the heading turns with it.
    yaws = []
    for gyro in (False, True):
        est = terraslip.Estimator(track_width=0.5)
        est.on_pose(0.0, east=0.0, north=0.0, yaw=0.0, std_xy=0.1, std_yaw=0.01)
        for i in range(1, 201):
            t = i * 0.05
            if gyro:
                est.on_gyro(t - 0.025, 0.2)
                est.on_gyro(t, 0.2)
            est.on_wheels(t, 1.0, 1.0)
        yaws.append(est.state()["yaw"])
    assert abs(yaws[0]) < 1e-6
    assert yaws[1] > 0.05, yaws
    est = terraslip.Estimator(track_width=0.5)
    with pytest.raises(ValueError, match="gyro sample at t = 1"):
        est.on_gyro(1.0, float("nan"))
