"""`ros2 param list/get/set` as a Cyclone DDS peer does them: the
rcl_interfaces services ListParameters, GetParameters and SetParameters
called over their DDS topics (rq/NODE/list_parametersRequest and
rr/NODE/list_parametersReply, ...), as `ros2 param` does under a middleware
speaking the RPC-over-DDS "enhanced" mapping (rmw_fastrtps: the request's
identity is the sample's own, no header in the payload), which is the one
ros2-client's node serves.

Usage: node_params.py NODE_CMD_JSON NAME
Starts the node (given `--ros-args -p lag:=0.25`, no sensor data) and
checks, within 60 s:
- the list holds the node's own parameters;
- get gives each at the value in use, typed (lag 0.25 as a double, a
  frame as a string, publish_tf as a bool, an unset limit as not set);
- set takes a live parameter (save_every, odom_frame, max_speed), and the
  node's loop says so on its standard error;
- set refuses, with a reason, an unknown name, a wrong type, a parameter
  read at start only, and a value out of range; get then shows the values
  unchanged.
"""

import json
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsSubscription
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64, int64, sequence, uint8, uint64
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

NOT_SET, BOOL, INTEGER, DOUBLE, STRING = 0, 1, 2, 3, 4


def msg(name):
    return f"rcl_interfaces::msg::dds_::{name}_"


def srv(name):
    return f"rcl_interfaces::srv::dds_::{name}_"


@dataclass
class ParameterValue(IdlStruct, typename=msg("ParameterValue")):
    type: uint8
    bool_value: bool
    integer_value: int64
    double_value: float64
    string_value: str
    byte_array_value: sequence[uint8]
    bool_array_value: sequence[bool]
    integer_array_value: sequence[int64]
    double_array_value: sequence[float64]
    string_array_value: sequence[str]


@dataclass
class Parameter(IdlStruct, typename=msg("Parameter")):
    name: str
    value: ParameterValue


@dataclass
class SetParametersResult(IdlStruct, typename=msg("SetParametersResult")):
    successful: bool
    reason: str


@dataclass
class ListParametersResult(IdlStruct, typename=msg("ListParametersResult")):
    names: sequence[str]
    prefixes: sequence[str]


@dataclass
class ListParametersRequest(IdlStruct, typename=srv("ListParameters_Request")):
    prefixes: sequence[str]
    depth: uint64


@dataclass
class ListParametersResponse(IdlStruct, typename=srv("ListParameters_Response")):
    result: ListParametersResult


@dataclass
class GetParametersRequest(IdlStruct, typename=srv("GetParameters_Request")):
    names: sequence[str]


@dataclass
class GetParametersResponse(IdlStruct, typename=srv("GetParameters_Response")):
    values: sequence[ParameterValue]


@dataclass
class SetParametersRequest(IdlStruct, typename=srv("SetParameters_Request")):
    parameters: sequence[Parameter]


@dataclass
class SetParametersResponse(IdlStruct, typename=srv("SetParameters_Response")):
    results: sequence[SetParametersResult]


def value(v):
    """A ParameterValue of a Python bool, int, float or str."""
    kind = {bool: BOOL, int: INTEGER, float: DOUBLE, str: STRING}[type(v)]
    return ParameterValue(
        type=kind,
        bool_value=v if kind == BOOL else False,
        integer_value=v if kind == INTEGER else 0,
        double_value=v if kind == DOUBLE else 0.0,
        string_value=v if kind == STRING else "",
        byte_array_value=[],
        bool_array_value=[],
        integer_array_value=[],
        double_array_value=[],
        string_array_value=[],
    )


def plain(v):
    """A ParameterValue as (type, Python value)."""
    return {
        NOT_SET: (NOT_SET, None),
        BOOL: (BOOL, v.bool_value),
        INTEGER: (INTEGER, v.integer_value),
        DOUBLE: (DOUBLE, v.double_value),
        STRING: (STRING, v.string_value),
    }.get(v.type, (v.type, "an array"))


class Service:
    """A client of one of the node's services."""

    def __init__(self, dp, node, name, request, response):
        qos = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10))
        self.topic = f"rq/{node}/{name}Request"
        self.writer = DataWriter(dp, Topic(dp, self.topic, request), qos=qos)
        self.reader = DataReader(dp, Topic(dp, f"rr/{node}/{name}Reply", response), qos=qos)

    def call(self, req, timeout=2.0):
        """The reply to `req` (sent again, up to 3 times, while unanswered:
        the node's reader may not have matched the request writer yet)."""
        for _ in range(3):
            self.reader.take(N=100)
            self.writer.write(req)
            deadline = time.time() + timeout
            while time.time() < deadline:
                got = self.reader.take(N=10)
                if got:
                    return got[0]
                time.sleep(0.02)
        sys.exit(f"no reply on the reply topic of {self.topic}")


def main():
    node_cmd, name = json.loads(sys.argv[1]), sys.argv[2]
    dp = DomainParticipant()
    subs = BuiltinDataReader(dp, BuiltinTopicDcpsSubscription)
    list_ = Service(dp, name, "list_parameters", ListParametersRequest, ListParametersResponse)
    get = Service(dp, name, "get_parameters", GetParametersRequest, GetParametersResponse)
    set_ = Service(dp, name, "set_parameters", SetParametersRequest, SetParametersResponse)
    log = tempfile.TemporaryFile(mode="w+")
    node = subprocess.Popen(node_cmd, stderr=log)
    try:
        started = time.time()
        want = {s.topic for s in (list_, get, set_)}
        seen = set()
        while not want <= seen:
            if time.time() - started > 30 or node.poll() is not None:
                sys.exit(f"the parameter services never appeared (node exit {node.poll()}; seen {sorted(seen)})")
            seen |= {s.topic_name for s in subs.take(N=100)}
            time.sleep(0.1)
        time.sleep(0.5)

        names = list_.call(ListParametersRequest(prefixes=[], depth=0)).result.names
        for p in ("lag", "save_every", "publish_tf", "odom_frame", "max_speed", "compensate"):
            if p not in names:
                sys.exit(f"ros2 param list: {p} missing from {names}")
        print(f"ros2 param list /{name}: {len(names)} parameters: {', '.join(names)}")

        def get_values(keys):
            vals = get.call(GetParametersRequest(names=keys)).values
            if len(vals) != len(keys):
                sys.exit(f"get {keys}: {len(vals)} values")
            return dict(zip(keys, map(plain, vals)))

        got = get_values(["lag", "odom_frame", "publish_tf", "max_speed", "save_every"])
        expect = {
            "lag": (DOUBLE, 0.25),
            "odom_frame": (STRING, "odom"),
            "publish_tf": (BOOL, True),
            "max_speed": (NOT_SET, None),
            "save_every": (DOUBLE, 300.0),
        }
        if got != expect:
            sys.exit(f"ros2 param get: {got}, expected {expect}")
        print(f"ros2 param get: {got}")

        def set_one(key, v):
            r = set_.call(SetParametersRequest(parameters=[Parameter(name=key, value=value(v))])).results
            if len(r) != 1:
                sys.exit(f"set {key}: {len(r)} results")
            return r[0]

        for key, v in [("save_every", 60.0), ("odom_frame", "odom_params_test"), ("max_speed", 1.5)]:
            r = set_one(key, v)
            if not r.successful:
                sys.exit(f"ros2 param set {key} {v!r} refused: {r.reason}")
            print(f"ros2 param set {key} {v!r}: taken")
        for key, v, why in [
            ("lagg", 0.5, "not a parameter of this node"),
            ("save_every", 60, "is a double"),
            ("lag", 1.0, "start only"),
            ("max_yaw_rate", -1.0, "max_yaw_rate"),
        ]:
            r = set_one(key, v)
            if r.successful or why not in r.reason:
                sys.exit(f"ros2 param set {key} {v!r}: successful={r.successful}, reason {r.reason!r} (expected one naming {why!r})")
            print(f"ros2 param set {key} {v!r}: refused: {r.reason[:100]}")
        got = get_values(["save_every", "odom_frame", "max_speed", "lag", "max_yaw_rate"])
        expect = {
            "save_every": (DOUBLE, 60.0),
            "odom_frame": (STRING, "odom_params_test"),
            "max_speed": (DOUBLE, 1.5),
            "lag": (DOUBLE, 0.25),
            "max_yaw_rate": (NOT_SET, None),
        }
        if got != expect:
            sys.exit(f"ros2 param get after the sets: {got}, expected {expect}")
        # The node's loop applies each taken value and says so.
        deadline = time.time() + 5
        said = []
        while time.time() < deadline:
            log.seek(0)
            said = [line for line in log.read().splitlines() if line.startswith("parameter ")]
            if len(said) >= 3:
                break
            time.sleep(0.1)
        for key in ("save_every = 60.0 (was 300.0)", "odom_frame = \"odom_params_test\"", "max_speed = 1.5"):
            if not any(key in line for line in said):
                sys.exit(f"the node did not say it applied {key!r}; it said: {said}")
        print(f"the node applied them: {said}")
        print(f"parameter services answered in {time.time() - started:.1f} s")
    finally:
        node.terminate()
        node.wait(timeout=20)


if __name__ == "__main__":
    main()
