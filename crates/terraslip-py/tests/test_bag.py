"""ROS 2 bags in place of log directories, against the command line on the
same bag (the Husky recording the repository ships, data/husky_test1; its
sqlite3 form from ../shared beside the checkout)."""

import json

import numpy as np
import pytest

import terraslip
from conftest import BOREAL, DRIVE, HUSKY, SHARED, cli_error, require_shared
from test_estimate import assert_matches_csv

HUSKY_DB3 = SHARED / "ros2" / "husky_test1_db3"
# The Husky's odometry twist needs the controller's separation; its IMU
# heading is not used (as in .ci/run).
TOPICS = {"wheels": {"separation": 1.040625}, "heading": {"topic": ""}}
TOPICS_TOML = '[wheels]\nseparation = 1.040625\n[heading]\ntopic = ""\n'

@pytest.fixture
def topics(tmp_path):
    path = tmp_path / "husky.toml"
    path.write_text(TOPICS_TOML)
    return path


@pytest.mark.parametrize(
    "bag",
    [HUSKY, HUSKY / "husky_test1.mcap", HUSKY_DB3],
    ids=["mcap-directory", "mcap-file", "db3-directory"],
)
def test_estimate_on_a_bag_equals_the_cli(cli, tmp_path, topics, bag):
    if bag == HUSKY_DB3:
        require_shared(bag)
    out = tmp_path / "est"
    cli("estimate", bag, "--topics", topics, "--out", out)
    got = terraslip.estimate(bag, topics=topics)
    assert_matches_csv(got, out / "estimate.csv")
    written = json.loads((out / "summary.json").read_text())
    # The command also keeps the topics file it was given, for `report`.
    assert written.pop("bag_topics")["file"] == str(topics)
    assert got["summary"] == written
    assert got["summary"]["rows"] == 3952
    assert got["summary"]["log"] == str(bag)
    # The topics as a mapping of the file's tables: the same run.
    again = terraslip.estimate(bag, topics=TOPICS)
    for name in terraslip.COLUMNS:
        assert np.array_equal(again[name], got[name]), name


def test_a_bag_equals_its_imported_log(cli, tmp_path, topics):
    log = tmp_path / "log"
    cli("import", HUSKY, "--topics", topics, "--out", log)
    from_bag = terraslip.estimate(HUSKY, topics=topics)
    from_log = terraslip.estimate(log)
    for name in terraslip.COLUMNS:
        assert np.array_equal(from_bag[name], from_log[name]), name
    # Classified from the bag's IMU as from the imported imu.csv, by a
    # model of the bag's own 30 Hz IMU (two made-up grounds; no currents).
    labelled = tmp_path / "labelled"
    cli("import", HUSKY, "--topics", topics, "--out", labelled)
    (labelled / "terrain.csv").write_text("t,terrain\n0,grass\n200,gravel\n")
    model = tmp_path / "model.json"
    cli("terrain", "train", labelled, "--no-currents", "--out", model)
    m = terraslip.TerrainModel.load(model)
    a, b = m.classify(HUSKY, topics=TOPICS), m.classify(log)
    assert len(a["t"]) > 100
    for key in ("t", "probabilities", "changes"):
        assert np.array_equal(a[key], b[key]), key
    for key in ("label", "terrain"):
        assert list(a[key]) == list(b[key]), key
    assert set(a["label"]) == {"grass", "gravel"}


def test_calibrate_and_validate_read_a_bag_as_the_cli(cli, tmp_path):
    # The Husky's GNSS gives no heading: calibrated on windows of fixes (a
    # position-only reference), the same parameters as the command's.
    topics = tmp_path / "husky.toml"
    topics.write_text(TOPICS_TOML + "[meta]\ntrack_width = 0.555\n")
    got = terraslip.calibrate(HUSKY, method="lm", topics=topics)
    out = tmp_path / "params.json"
    cli("calibrate", HUSKY, "--topics", topics, "--method", "lm", "--out", out)
    written = json.loads(out.read_text())
    # The whole file, the scale of the ICRs (`separation`) included.
    assert got == written
    assert any("position-only reference" in n for n in got["notes"])
    # `validate` on a position-only reference: the 2 s prediction with each
    # model's start heading profiled out of the fixes, the same figures as
    # the command's.
    got = terraslip.validate([HUSKY], out, topics=topics)
    want = json.loads(
        cli("calibrate", "validate", HUSKY, "--topics", topics, "--params", out, "--json").stdout
    )
    assert got == want
    assert got["prediction"]["segments"] > 100
    # A file with only terrain sets cannot score a position-only reference;
    # the message says why, as the command's does.
    cli("calibrate", DRIVE, "--method", "lm", "--out", out)
    with pytest.raises(terraslip.TerraslipError) as e:
        terraslip.validate([HUSKY], out, topics=topics)
    message = cli_error(
        cli("calibrate", "validate", HUSKY, "--topics", topics, "--params", out, check=False)
    )
    assert str(e.value) == message
    assert "pooled parameter set" in message


def test_a_bag_without_its_topics_runs_as_the_cli(cli, tmp_path):
    # No separation given: a nominal one, stated, and the controller's
    # correction as a factor.
    out = tmp_path / "o"
    cli("estimate", HUSKY, "--out", out)
    got = terraslip.estimate(HUSKY)
    written = json.loads((out / "summary.json").read_text())
    # The command also keeps the topics file it was given (none), for `report`.
    assert written.pop("bag_topics") is None
    assert got["summary"] == written
    controller = got["summary"]["controller"]
    assert controller["separation_source"] == "default"
    assert controller["wheel_separation_m"] is None
    assert 0.8 < controller["separation_factor"] < 1.0
    assert got["summary"]["prediction"]["start_heading"] == "estimate"


def test_a_broken_bag_gives_the_cli_message(cli, tmp_path):
    bag = tmp_path / "broken.mcap"
    bag.write_bytes(b"\x89MCAP0\r\n this is not a recording")
    with pytest.raises(terraslip.TerraslipError) as e:
        terraslip.estimate(bag)
    message = cli_error(cli("estimate", bag, "--out", tmp_path / "o", check=False))
    assert str(e.value) == message
    assert str(bag) in message
    with pytest.raises(terraslip.TerraslipError) as e:
        terraslip.calibrate([bag])
    assert str(e.value) == message


def test_bad_topics(cli, tmp_path):
    bag = tmp_path / "drive.mcap"
    bag.write_bytes(b"")
    missing = tmp_path / "missing.toml"
    with pytest.raises(FileNotFoundError) as e:
        terraslip.estimate(bag, topics=missing)
    message = cli_error(cli("estimate", bag, "--topics", missing, "--out", tmp_path / "o", check=False))
    assert str(e.value) == message
    bad = tmp_path / "bad.toml"
    bad.write_text("[wheels]\nseperation = 1.0\n")
    with pytest.raises(terraslip.TerraslipError) as e:
        terraslip.estimate(bag, topics=bad)
    message = cli_error(cli("estimate", bag, "--topics", bad, "--out", tmp_path / "o", check=False))
    assert str(e.value) == message
    assert message.startswith(f"{bad}: line 2: unknown field `seperation`")
    with pytest.raises(terraslip.TerraslipError, match="^topics: line 2: unknown field `seperation`"):
        terraslip.estimate(bag, topics={"wheels": {"seperation": 1.0}})
    # Topics are for bags.
    with pytest.raises(terraslip.TerraslipError, match="--topics is for ROS 2 bags"):
        terraslip.estimate(tmp_path / "wheels.csv", topics=bad)
    with pytest.raises(ValueError, match="topics: for ROS 2 bags"):
        terraslip.estimate({"wheels": {"t": [0.0], "v_left": [0.0], "v_right": [0.0]}}, topics=bad)
    with pytest.raises(TypeError):
        terraslip.estimate(BOREAL, topics=3)
