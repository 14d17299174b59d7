"""`terraslip.calibrate` and `terraslip.validate` against the command line."""

import json
import math

import terraslip
from conftest import DRIVE


def test_calibrate_and_validate_equal_the_cli(cli, tmp_path):
    out = tmp_path / "params.json"
    cli("calibrate", DRIVE, "--method", "lm", "--out", out)
    params = terraslip.calibrate([DRIVE], method="lm")
    assert params == json.loads(out.read_text())
    p = params["terrains"]["gravel"]["params"] if "terrains" in params else params["params"]
    assert 0.5 < p["y_l"] < 3.0 and -3.0 < p["y_r"] < -0.5
    got = terraslip.validate([DRIVE], params)
    want = json.loads(cli("calibrate", "validate", DRIVE, "--params", out, "--json").stdout)
    assert got == want
    assert terraslip.validate(DRIVE, out) == want
    assert got["segments"] > 100 and math.isfinite(got["position_mse_ratio"])
