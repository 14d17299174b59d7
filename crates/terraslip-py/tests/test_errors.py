"""Bad input raises the right exception, with the command line's message."""

import numpy as np
import pytest

import terraslip
from conftest import DRIVE, cli_error


def test_the_error_types():
    assert issubclass(terraslip.TerraslipError, ValueError)


def test_a_missing_log_is_file_not_found(cli, tmp_path):
    missing = tmp_path / "nowhere"
    with pytest.raises(FileNotFoundError) as e:
        terraslip.estimate(missing)
    assert str(e.value) == cli_error(cli("estimate", missing, "--out", tmp_path / "o", check=False))


def test_a_broken_wheels_csv_gives_the_cli_message(cli, tmp_path):
    log = tmp_path / "log"
    log.mkdir()
    (log / "wheels.csv").write_text("t,v_left,v_right\n0,0.1,0.1\n0.1,zero,0.1\n")
    with pytest.raises(terraslip.TerraslipError) as e:
        terraslip.estimate(log)
    message = cli_error(cli("estimate", log, "--out", tmp_path / "o", check=False))
    assert str(e.value) == message
    assert "wheels.csv" in message


def test_a_bad_config_gives_the_cli_message(cli, tmp_path):
    config = tmp_path / "bad.toml"
    config.write_text("[filter]\nno_such_key = 1\n")
    with pytest.raises(terraslip.TerraslipError) as e:
        terraslip.estimate(DRIVE, config=config)
    message = cli_error(cli("estimate", DRIVE, "--out", tmp_path / "o", "--config", config, check=False))
    assert str(e.value) == message
    assert "no_such_key" in message
    with pytest.raises(terraslip.TerraslipError, match="no_such_key"):
        terraslip.estimate(DRIVE, config={"filter": {"no_such_key": 1}})
    with pytest.raises(FileNotFoundError):
        terraslip.estimate(DRIVE, config=tmp_path / "missing.toml")


def test_terrain_labels_without_terrain_csv(cli, tmp_path):
    log = tmp_path / "log"
    log.mkdir()
    (log / "wheels.csv").write_text((DRIVE / "wheels.csv").read_text())
    with pytest.raises(terraslip.TerraslipError) as e:
        terraslip.estimate(log, terrain_labels=True)
    message = cli_error(cli("estimate", log, "--out", tmp_path / "o", "--terrain-labels", check=False))
    assert str(e.value) == message


def test_bad_init_and_model_files(tmp_path):
    with pytest.raises(FileNotFoundError):
        terraslip.estimate(DRIVE, init=tmp_path / "missing.json")
    with pytest.raises(terraslip.TerraslipError, match="neither `params` nor `terrains`"):
        terraslip.estimate(DRIVE, init={"cost": 1.0})
    bad = tmp_path / "model.json"
    bad.write_text("{}")
    with pytest.raises(terraslip.TerraslipError, match="format_version"):
        terraslip.TerrainModel.load(bad)
    with pytest.raises(FileNotFoundError):
        terraslip.TerrainModel.load(tmp_path / "missing.json")


def test_bad_arrays():
    t = np.arange(5) * 0.1
    v = np.ones(5)
    with pytest.raises(ValueError, match="missing required column `v_right`"):
        terraslip.estimate({"wheels": {"t": t, "v_left": v}})
    with pytest.raises(ValueError, match="has 4 values"):
        terraslip.estimate({"wheels": {"t": t, "v_left": v, "v_right": v[:4]}})
    with pytest.raises(ValueError, match="must increase"):
        terraslip.estimate({"wheels": {"t": t[::-1], "v_left": v, "v_right": v}})
    with pytest.raises(ValueError, match="one-dimensional"):
        terraslip.estimate({"wheels": {"t": t, "v_left": v, "v_right": np.ones((5, 2))}})
    with pytest.raises(ValueError, match="east and north"):
        terraslip.estimate({"wheels": {"t": t, "v_left": v, "v_right": v}, "pose": {"t": t, "east": v}})
    with pytest.raises(terraslip.TerraslipError, match="not finite"):
        terraslip.estimate({"wheels": {"t": t, "v_left": v * np.nan, "v_right": v}})
    with pytest.raises(TypeError):
        terraslip.estimate(42)


def test_bad_streaming_input():
    with pytest.raises(ValueError, match="track_width"):
        terraslip.Estimator(track_width=-1.0)
    est = terraslip.Estimator(track_width=0.5)
    est.on_wheels(0.0, 0.1, 0.1)
    with pytest.raises(terraslip.TerraslipError, match="backwards"):
        est.on_wheels(-1.0, 0.1, 0.1)
    with pytest.raises(terraslip.TerraslipError, match="not finite"):
        est.on_wheels(1.0, float("nan"), 0.1)
    with pytest.raises(ValueError, match="east and north"):
        est.on_pose(1.0, east=1.0)
    with pytest.raises(ValueError, match="std_xy"):
        est.on_pose(1.0, east=1.0, north=0.0, std_xy=0.0)
    with pytest.raises(TypeError):
        est.on_wheels("now", 0.1, 0.1)
    # The estimator is still usable after refused input.
    est.on_wheels(0.1, 0.1, 0.1)
    assert est.state()["t"] == 0.1


def test_bad_calibration_input(tmp_path):
    with pytest.raises(ValueError, match="method"):
        terraslip.calibrate(DRIVE, method="magic")
    with pytest.raises(FileNotFoundError):
        terraslip.calibrate([tmp_path / "nowhere"])
