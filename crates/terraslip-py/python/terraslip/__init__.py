"""terraslip: how a skid-steering robot really moves.

Online ICR slip estimation, offline calibration and terrain models, from
numpy, pandas and notebooks: the Rust library the ``terraslip`` command is
built from, with the same configuration, filter and numbers.

Units are SI (m, s, rad, m/s). Frames follow ROS REP-103: body x forward,
y left; world ENU (east, north), yaw counter-clockwise from east. Log
directories follow docs/log-format.md.
"""

from ._terraslip import (
    COLUMNS,
    Estimator,
    TerrainModel,
    TerraslipError,
    calibrate,
    estimate,
    validate,
)

__all__ = [
    "COLUMNS",
    "Estimator",
    "TerrainModel",
    "TerraslipError",
    "calibrate",
    "estimate",
    "validate",
]
