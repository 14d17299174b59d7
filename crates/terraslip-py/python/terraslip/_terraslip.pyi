"""Type stubs of terraslip's native module (re-exported by ``terraslip``).

Units SI (m, s, rad, m/s). Frames ROS REP-103: body x forward, y left;
world ENU (east, north), yaw counter-clockwise from east, in (-pi, pi].
"""

import os
from typing import Any, Dict, List, Mapping, Optional, Sequence, Union, final

_PathLike = Union[str, "os.PathLike[str]"]

__all__ = [
    "COLUMNS",
    "Estimator",
    "TerrainModel",
    "TerraslipError",
    "calibrate",
    "estimate",
    "validate",
]

COLUMNS: List[str]
"""The columns of ``estimate.csv`` in order, as ``estimate`` returns them."""

class TerraslipError(ValueError):
    """Bad input or a failed run; the message is the command line's."""

def estimate(
    log: Union[_PathLike, Mapping[str, Any]],
    *,
    config: Union[None, _PathLike, Mapping[str, Any]] = None,
    init: Union[None, _PathLike, Mapping[str, Any]] = None,
    terrain_labels: bool = False,
    terrain_model: Optional[_PathLike] = None,
    preset: Optional[str] = None,
    topics: Union[None, _PathLike, Mapping[str, Any]] = None,
) -> Dict[str, Any]:
    """Runs the online ICR estimator over a drive log, as ``terraslip estimate``.

    ``log`` is a log directory (docs/log-format.md: wheels.csv, pose.csv,
    terrain.csv, meta.toml; imu.csv or images.csv for ``terrain_model``),
    a ROS 2 bag (a directory with metadata.yaml, or a single .mcap or .db3
    file; read as the command reads it, through the log ``terraslip
    import`` makes of it) or a mapping of arrays::

        {"wheels": {"t": s, "v_left": m/s, "v_right": m/s},      # required
         "pose": {"t": s, "east": m, "north": m, "yaw": rad,      # optional;
                  "std_xy": m, "std_yaw": rad},                   # NaN = empty
         "terrain": {"t": s, "terrain": [str, ...]},              # optional
         "meta": {"track_width": m, "wheel_radius": m, ...}}      # optional

    Each table is a dict of arrays or a pandas DataFrame. Times must
    increase strictly. float64 arrays are read without a copy
    into numpy; other numbers are converted.

    ``config``: a TOML file (``terraslip estimate --print-config`` lists
    every key) or a mapping of its tables, applied on top of ``preset``
    (a named variant such as ``"ta-iekf"``; default: the default filter).
    ``init``: starting ICRs, a parameters file from ``terraslip calibrate``
    or the dict ``calibrate`` returns. ``terrain_labels``: the log's
    terrain.csv is the terrain evidence. ``terrain_model``: a model from
    ``terraslip terrain train`` classifies the log's imu or camera stream.
    ``topics``: for a bag, which topic feeds which stream and the numbers a
    bag cannot tell (``--topics FILE.toml``): the TOML file's path or a
    mapping of its tables, e.g. ``{"wheels": {"separation": 1.04}}``;
    None chooses topics by message type.

    Returns one numpy array per column of ``estimate.csv`` (``COLUMNS``),
    one value per wheels row, equal to what the command writes (rounded to
    the same decimals): ``t`` s; ``east``, ``north`` m (ENU); ``yaw`` rad;
    ``y_l``, ``y_r``, ``x_c`` m (ICRs in the body frame, in effect at that
    row's tread speeds); their standard deviations ``std_*``; ``terrain``
    (str, "" when unknown); ``alpha_l``, ``alpha_r`` (tread speed factors)
    and their stds; ``std_spread`` m (std of y_l - y_r); ``fused``,
    ``gated`` (bool: a fix part was fused / gated since the previous row);
    ``nis``; ``q_scale``; ``change`` (bool: the slip-change detector
    fired); ``clock_offset`` s (pose stream's clock offset). Key
    ``summary`` holds the dict of ``summary.json``.

    The GIL is released while the log is read and the filter runs.

    Raises FileNotFoundError for a missing file or directory, TerraslipError
    (a ValueError) for bad data or configuration, ValueError for malformed
    arrays and TypeError for arguments of the wrong type.
    """

@final
class Estimator:
    """The online estimator, one event at a time: the filter
    ``terraslip estimate`` runs, with the same configuration.

    Feed events in time order: before each wheels row, the pose fixes
    stamped at or before it (that is the order ``estimate`` uses, and the
    order in which streaming equals batch).
    """

    def __new__(
        cls,
        track_width: float,
        config: Union[None, _PathLike, Mapping[str, Any]] = None,
        init: Union[None, _PathLike, Mapping[str, Any]] = None,
        *,
        preset: Optional[str] = None,
        pose_reference: Optional[str] = None,
    ) -> "Estimator":
        """``track_width``: distance between the tread centre lines, m.
        ``config``, ``init`` and ``preset`` as for ``estimate``;
        ``pose_reference`` as meta.toml's: ``"localiser"`` (a lidar or visual
        localiser, motion capture: the fixes' error does not wander) or
        ``"gnss"`` (the default: part of it wanders). With
        ``init``, the filter starts from its pooled set (or its only set);
        per-terrain sets are recalled when ``on_terrain`` names them."""
    def on_wheels(self, t: float, v_left: float, v_right: float) -> None:
        """Tread speeds ``v_left``, ``v_right`` (m/s, measured tread surface
        speeds) over the interval ending at ``t`` (s). Times must not go
        backwards."""
    def on_pose(
        self,
        t: float,
        east: Optional[float] = None,
        north: Optional[float] = None,
        yaw: Optional[float] = None,
        std_xy: Optional[float] = None,
        std_yaw: Optional[float] = None,
    ) -> None:
        """A pose fix stamped ``t`` (s): position ``east``, ``north`` (m,
        ENU; both or neither), heading ``yaw`` (rad, counter-clockwise from
        east), their 1-sigma errors ``std_xy`` (m) and ``std_yaw`` (rad);
        without stds the configuration's (learned from the residuals)."""
    def on_gyro(self, t: float, rate: float) -> None:
        """A yaw-rate gyro sample ``rate`` (rad/s, counter-clockwise about
        body z, bias included: it is learned) at ``t`` (s, the wheels'
        clock). The samples between two wheels rows are averaged and fused
        with the next one."""
    def on_terrain(self, label: str) -> Optional[str]:
        """The terrain evidence declares terrain ``label``. Returns what the
        noise schedule did (``"recalled"``, ``"learning"``, ``"none"``), or
        None when ``label`` is the current terrain."""
    def state(self) -> Dict[str, Any]:
        """The estimate now, one row of ``estimate.csv`` unrounded: the keys
        of ``COLUMNS`` (``terrain`` a str or None; ``fused``, ``gated``,
        ``change`` and ``nis`` about the fixes since the previous
        ``state()`` call)."""
    @property
    def track_width(self) -> float:
        """m"""
    @property
    def init_source(self) -> str:
        """Where the starting ICRs came from: ``prior`` or ``init:<set>``."""
    @property
    def warnings(self) -> List[str]:
        """What the set-up had to say about ``init``."""
    @property
    def terrains(self) -> List[str]:
        """Terrain labels seen by ``on_terrain``, in order of appearance."""

def calibrate(
    logs: Union[_PathLike, Sequence[_PathLike]],
    method: Optional[str] = "lm",
    *,
    topics: Union[None, _PathLike, Mapping[str, Any]] = None,
) -> Dict[str, Any]:
    """Identifies the ICR parameters offline, as ``terraslip calibrate``
    with its defaults: ``method`` ``"lm"``, ``"ga"``, ``"symmetric"`` or
    None (all three, the best kept). ``logs``: log directories or ROS 2
    bags (``topics`` as for ``estimate``). Logs need wheels and a pose
    reference; with terrain.csv one set per terrain. Returns the parameters file's
    content (``params`` and/or ``terrains``; y_l, y_r, x_c in m, alpha_l,
    alpha_r, 1-sigma ``std``, ``time_offset_s``...), which ``estimate``
    and ``validate`` take as ``init`` / ``params``. The GIL is released."""

def validate(
    logs: Union[_PathLike, Sequence[_PathLike]],
    params: Union[_PathLike, Mapping[str, Any]],
    *,
    topics: Union[None, _PathLike, Mapping[str, Any]] = None,
) -> Dict[str, Any]:
    """Scores parameters on drives, as ``terraslip calibrate validate
    --json``: mean squared segment errors ``dx``, ``dy`` (m^2) and ``dyaw``
    (rad^2) in the frame of each segment start, for the calibrated, the
    constant and the no-slip models, per terrain, and the 2 s prediction
    error. ``logs``: log directories or ROS 2 bags (``topics`` as for
    ``estimate``); ``params``: a parameters file or the dict ``calibrate``
    returns. The GIL is released."""

@final
class TerrainModel:
    """A terrain classifier trained by ``terraslip terrain train``."""

    @staticmethod
    def load(path: _PathLike) -> "TerrainModel":
        """Reads a model file (JSON), refusing other format versions."""
    @property
    def classes(self) -> List[str]:
        """Terrain names; column k of ``probabilities`` is ``classes[k]``."""
    def classify(
        self,
        log: Union[_PathLike, Mapping[str, Any]],
        *,
        topics: Union[None, _PathLike, Mapping[str, Any]] = None,
    ) -> Dict[str, Any]:
        """Classifies every window (imu model) or frame (camera model) of a
        log directory, a ROS 2 bag (``topics`` as for ``estimate``) or a
        mapping of arrays, causally. Returns ``t`` (s, end of each window),
        ``probabilities`` (windows x classes), ``label`` (the most probable
        class of each window), ``terrain`` (the terrain the Bayesian filter
        and the lambda-vote declare, what the estimator's schedule would
        use; "" before any), ``changes`` (s, camera change detections),
        ``outside_envelope`` (bool per window: driven at a tread speed and
        tread speed difference that no training run of the terrain it is
        read as had, so its probabilities are mixed half and half with a
        uniform distribution; None for a model without an envelope: camera
        or ``paper`` features) and ``outside_envelope_share`` (their share,
        0..1; None likewise or without windows). A high share says: record
        that kind of driving on every terrain and retrain."""
