"""`terraslip node` against an independent ROS 2 peer: Cyclone DDS's Python
binding plays a rosbag2 recording into the node (each topic with its
sensor's QoS: IMU and GNSS best effort, the controller's odometry
reliable) and reads /terraslip/odom back; the answers are compared with
`terraslip estimate --mcap` on the same recording.

The message classes below are written from the ROS 2 interface definitions
and checked byte for byte: each recorded message is read with rosbags'
Humble and Jazzy type stores, rebuilt as our class, serialised by Cyclone,
and must equal the recorded bytes and both type stores' serialisation.

Usage (from .ci/node): node_interop.py BAG NODE_CMD_JSON OFFLINE_MCAP SPEED
  or node_interop.py --kill BAG NODE_CMD_JSON PARAMS SEED: the recording is
  played into the node, which is killed (SIGKILL) at seeded random moments
  while it saves every few seconds; after each kill the parameters file
  must be absent or whole, with no other file beside it but the killed
  process's temporary, and each restart reads it back (recalls).
"""

import json
import os
import random
import subprocess
import sys
import time
from dataclasses import dataclass, fields

from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsSubscription
from cyclonedds.core import Qos, Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, float64, int8, int32, uint8, uint16, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from rosbags.rosbag2 import Reader
from rosbags.typesys import Stores, get_typestore


def ros(name):
    pkg, _, ty = name.split("/")
    return f"{pkg}::msg::dds_::{ty}_"


@dataclass
class Time(IdlStruct, typename=ros("builtin_interfaces/msg/Time")):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename=ros("std_msgs/msg/Header")):
    stamp: Time
    frame_id: str


@dataclass
class Vector3(IdlStruct, typename=ros("geometry_msgs/msg/Vector3")):
    x: float64
    y: float64
    z: float64


@dataclass
class Point(IdlStruct, typename=ros("geometry_msgs/msg/Point")):
    x: float64
    y: float64
    z: float64


@dataclass
class Quaternion(IdlStruct, typename=ros("geometry_msgs/msg/Quaternion")):
    x: float64
    y: float64
    z: float64
    w: float64


@dataclass
class Pose(IdlStruct, typename=ros("geometry_msgs/msg/Pose")):
    position: Point
    orientation: Quaternion


@dataclass
class PoseWithCovariance(IdlStruct, typename=ros("geometry_msgs/msg/PoseWithCovariance")):
    pose: Pose
    covariance: array[float64, 36]


@dataclass
class Twist(IdlStruct, typename=ros("geometry_msgs/msg/Twist")):
    linear: Vector3
    angular: Vector3


@dataclass
class TwistWithCovariance(IdlStruct, typename=ros("geometry_msgs/msg/TwistWithCovariance")):
    twist: Twist
    covariance: array[float64, 36]


@dataclass
class Odometry(IdlStruct, typename=ros("nav_msgs/msg/Odometry")):
    header: Header
    child_frame_id: str
    pose: PoseWithCovariance
    twist: TwistWithCovariance


@dataclass
class Imu(IdlStruct, typename=ros("sensor_msgs/msg/Imu")):
    header: Header
    orientation: Quaternion
    orientation_covariance: array[float64, 9]
    angular_velocity: Vector3
    angular_velocity_covariance: array[float64, 9]
    linear_acceleration: Vector3
    linear_acceleration_covariance: array[float64, 9]


@dataclass
class NavSatStatus(IdlStruct, typename=ros("sensor_msgs/msg/NavSatStatus")):
    status: int8
    service: uint16


@dataclass
class NavSatFix(IdlStruct, typename=ros("sensor_msgs/msg/NavSatFix")):
    header: Header
    status: NavSatStatus
    latitude: float64
    longitude: float64
    altitude: float64
    position_covariance: array[float64, 9]
    position_covariance_type: uint8


CLASSES = {
    "nav_msgs/msg/Odometry": Odometry,
    "sensor_msgs/msg/Imu": Imu,
    "sensor_msgs/msg/NavSatFix": NavSatFix,
}


def rebuild(cls, m):
    """Our class from a rosbags message, field by field."""
    out = {}
    for f in fields(cls):
        v = getattr(m, f.name)
        t = f.type
        if isinstance(t, type) and issubclass(t, IdlStruct):
            out[f.name] = rebuild(t, v)
        elif hasattr(v, "tolist"):
            out[f.name] = [float(x) for x in v.tolist()]
        else:
            out[f.name] = v
    return cls(**out)


def body(b):
    """CDR without its trailing alignment padding (writers differ there)."""
    b = bytes(b)
    pad = b[3] & 3 if len(b) > 4 else 0
    return b[: len(b) - pad] if pad else b


def recording(bag):
    """The recording's sensor messages, each checked byte for byte."""
    stores = {s: get_typestore(s) for s in (Stores.ROS2_HUMBLE, Stores.ROS2_JAZZY)}
    reader = Reader(bag)
    reader.open()
    conns = [c for c in reader.connections if c.msgtype in CLASSES]
    msgs = list(reader.messages(connections=conns))
    # Byte check of every recorded message.
    checked = {}
    for conn, _, raw in msgs:
        cls = CLASSES[conn.msgtype]
        ours = None
        for store, ts in stores.items():
            m = ts.deserialize_cdr(raw, conn.msgtype)
            again = ts.serialize_cdr(m, conn.msgtype)
            if body(again) != body(raw):
                sys.exit(f"{conn.topic}: {store.name} serialises the recorded message differently")
            if ours is None:
                ours = rebuild(cls, m)
        mine = ours.serialize()
        if body(mine) != body(raw):
            sys.exit(f"{conn.topic} ({conn.msgtype}): Cyclone's bytes differ from the recording's:\n{bytes(mine)[:64].hex()}\n{bytes(raw)[:64].hex()}")
        checked[conn.topic] = checked.get(conn.topic, 0) + 1
    print(f"byte check: {checked} messages equal to the recording, Humble and Jazzy type stores")
    return stores, conns, msgs


def peer(conns):
    """The player's writers (sensors' QoS), the odometry reader, discovery."""
    dp = DomainParticipant()
    best_effort = Qos(Policy.Reliability.BestEffort, Policy.History.KeepLast(50))
    reliable = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(100))
    writers = {}
    for c in conns:
        qos = reliable if c.msgtype == "nav_msgs/msg/Odometry" else best_effort
        topic = Topic(dp, "rt" + c.topic, CLASSES[c.msgtype])
        writers[c.topic] = DataWriter(dp, topic, qos=qos)
    out_topic = Topic(dp, "rt/terraslip/odom", Odometry)
    out = DataReader(dp, out_topic, qos=Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10000)))
    subs = BuiltinDataReader(dp, BuiltinTopicDcpsSubscription)
    return dp, writers, out, subs


def start(node_cmd, conns, subs):
    """Starts the node and waits until it reads every sensor topic."""
    node = subprocess.Popen(node_cmd)
    want = {"rt" + c.topic for c in conns}
    seen = set()
    deadline = time.time() + 60
    while not want <= seen:
        if time.time() > deadline or node.poll() is not None:
            node.kill()
            sys.exit(f"the node's readers never appeared (seen {sorted(seen)})")
        for s in subs.take(N=100):
            seen.add(s.topic_name)
        time.sleep(0.1)
    time.sleep(2.0)
    return node


def play(msgs, stores, writers, speed, until=None, drain=lambda: None):
    """Plays the messages at `speed` x real time, for `until` s at most."""
    t0_bag = msgs[0][1]
    t0 = time.time()
    for conn, ts, raw in msgs:
        due = t0 + (ts - t0_bag) * 1e-9 / speed
        if until is not None and due - t0 > until:
            return
        while time.time() < due:
            drain()
            time.sleep(min(0.002, max(0.0, due - time.time())))
        m = stores[Stores.ROS2_HUMBLE].deserialize_cdr(raw, conn.msgtype)
        writers[conn.topic].write(rebuild(CLASSES[conn.msgtype], m))


def kill_rounds(bag, node_cmd, params, seed, rounds=4):
    """SIGKILL at random moments of a replay; the file stays whole."""
    rng = random.Random(seed)
    stores, conns, msgs = recording(bag)
    dp, writers, out, subs = peer(conns)
    folder, name = os.path.split(params)
    saved = 0
    for r in range(rounds):
        recalls = os.path.exists(params)
        node = start(node_cmd, conns, subs)
        if node.poll() is not None:
            sys.exit(f"round {r}: the node did not start (exit {node.returncode}) on the parameters file it left")
        # Start at a random place so the rounds see different driving.
        first = rng.randrange(0, len(msgs) // 2)
        play(msgs[first:], stores, writers, speed=16, until=rng.uniform(2.0, 8.0))
        if node.poll() is not None:
            sys.exit(f"round {r}: the node ended by itself (exit {node.returncode})")
        node.kill()
        node.wait()
        left = sorted(set(os.listdir(folder)) - {name})
        if any(f != f".{name}.{node.pid}.tmp" for f in left):
            sys.exit(f"round {r}: files left beside {name}: {left}")
        if os.path.exists(params):
            with open(params) as f:
                p = json.load(f)["params"]
            values = [p["y_l"], p["y_r"], p["x_c"]]
            if not all(isinstance(v, (int, float)) and abs(v) < 1e3 for v in values) or not p["y_l"] > p["y_r"]:
                sys.exit(f"round {r}: parameters not sane: {p}")
            saved += 1
        print(f"kill round {r}: {'recalled the file, ' if recalls else ''}killed after a random time; "
              f"{'file whole' if os.path.exists(params) else 'no file yet'}, left beside it: {left}")
    if saved == 0:
        sys.exit("the node never saved before it was killed: the test proved nothing")


def main():
    if sys.argv[1] == "--kill":
        kill_rounds(sys.argv[2], json.loads(sys.argv[3]), sys.argv[4], int(sys.argv[5]))
        return
    bag, node_cmd, offline_mcap, speed = sys.argv[1], json.loads(sys.argv[2]), sys.argv[3], float(sys.argv[4])
    stores, conns, msgs = recording(bag)
    dp, writers, out, subs = peer(conns)
    node = start(node_cmd, conns, subs)
    print(f"node subscribed to the sensor topics; playing {len(msgs)} messages at {speed}x")

    got = {}

    def drain():
        for s in out.take(N=1000):
            st = s.header.stamp
            got[st.sec * 1_000_000_000 + st.nanosec] = (s.pose.pose.position.x, s.pose.pose.position.y)

    t0 = time.time()
    play(msgs, stores, writers, speed, drain=drain)
    print(f"played in {time.time() - t0:.1f} s; waiting for the node to end")
    try:
        node.wait(timeout=60)
    except subprocess.TimeoutExpired:
        node.terminate()
        node.wait(timeout=10)
    end = time.time() + 2
    while time.time() < end:
        drain()
        time.sleep(0.05)
    if node.returncode != 0:
        sys.exit(f"the node exited with {node.returncode}")

    # The offline estimate at the same stamps.
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    offline = []
    with open(offline_mcap, "rb") as f:
        r = make_reader(f, decoder_factories=[DecoderFactory()])
        for _, _, _, m in r.iter_decoded_messages(topics=["/terraslip/odom"]):
            st = m.header.stamp
            offline.append((st.sec * 1_000_000_000 + st.nanosec, m.pose.pose.position.x, m.pose.pose.position.y))
    live = sorted(got.items())
    stamps = [s for s, _ in live]
    import bisect

    # The warm-up's rows reach the graph as one burst when it ends (a
    # reliable writer keeps the last 100 of them for a late reader); every
    # wheel message after it must be answered.
    warmup = float(node_cmd[node_cmd.index("--warmup") + 1]) if "--warmup" in node_cmd else 300.0
    warm_end = offline[0][0] + int(warmup * 1e9) if offline else 0
    answered = 0
    after = answered_after = 0
    worst = 0.0
    for ns, x, y in offline:
        after += ns > warm_end
        # The offline stamps went through a double (< 1 µs off).
        k = bisect.bisect_left(stamps, ns - 1000)
        if k < len(stamps) and abs(stamps[k] - ns) <= 1000:
            answered += 1
            answered_after += ns > warm_end
            lx, ly = live[k][1]
            worst = max(worst, ((lx - x) ** 2 + (ly - y) ** 2) ** 0.5)
    share = answered / len(offline)
    share_after = answered_after / after if after else 0.0
    print(f"/terraslip/odom: {len(live)} live, {len(offline)} offline; {answered} at the same stamps ({100 * share:.2f} %), "
          f"{answered_after} of the {after} after the {warmup:.0f} s warm-up ({100 * share_after:.2f} %), "
          f"largest position difference {1000 * worst:.4f} mm")
    if share_after < 0.99:
        sys.exit("fewer than 99 % of the wheel messages after the warm-up answered")
    if share < 0.9:
        sys.exit("fewer than 90 % of the warm-up's rows reached the peer")
    if worst > 1e-3:
        sys.exit("live and offline differ by more than 1 mm")


if __name__ == "__main__":
    main()
