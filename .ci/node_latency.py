"""End-to-end latency of `terraslip node`'s odometry, as a ROS 2 peer sees
it: after a short warm-up (the node run with --lag 0, so that a wheel
message is answered on arrival), the peer (Cyclone DDS's Python binding)
writes the recording's messages in order and, for each message of the
wheel source, waits for the /terraslip/odom with that stamp. The round
trip covers the peer's DDS write, the node's receipt, CDR decoding, the
estimator, CDR encoding, the node's DDS write and the peer's receipt.

A figure, reported, not a pass/fail check (speed targets live in
docs/benchmarks.md): the run fails only when an answer does not come.

Usage (from .ci/node): node_latency.py BAG NODE_CMD_JSON SPEED
"""

import json
import subprocess
import sys
import time

from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.util import duration
from rosbags.typesys import Stores

sys.path.insert(0, __file__.rsplit("/", 1)[0])
import node_interop as ni  # noqa: E402
from node_compensate import percentile  # noqa: E402

TIMEOUT_S = 0.5


def stamp_ns(header):
    return header.stamp.sec * 1_000_000_000 + header.stamp.nanosec


def main():
    bag, node_cmd, speed = sys.argv[1], json.loads(sys.argv[2]), float(sys.argv[3])
    warmup = float(node_cmd[node_cmd.index("--warmup") + 1])
    stores, conns, msgs = ni.recording(bag)
    wheels = next(c.topic for c in conns if c.msgtype == "nav_msgs/msg/Odometry")
    dp, writers, out, subs = ni.peer(conns)
    waitset = WaitSet(dp)
    waitset.attach(ReadCondition(out, SampleState.Any | ViewState.Any | InstanceState.Any))
    node = ni.start(node_cmd, conns, subs)

    # The warm-up (and a little more) played at `speed`, then the rest pinged.
    t0_bag = msgs[0][1]
    split = next(i for i, (_, ts, _) in enumerate(msgs) if (ts - t0_bag) * 1e-9 > warmup + 2.0)
    ni.play(msgs[:split], stores, writers, speed, drain=lambda: out.take(N=1000))
    time.sleep(0.5)
    out.take(N=10000)

    store = stores[Stores.ROS2_HUMBLE]
    trips, late = [], 0
    for conn, _, raw in msgs[split:]:
        m = ni.rebuild(ni.CLASSES[conn.msgtype], store.deserialize_cdr(raw, conn.msgtype))
        if conn.topic != wheels:
            writers[conn.topic].write(m)
            continue
        want = stamp_ns(m.header)
        t0 = time.perf_counter()
        writers[conn.topic].write(m)
        while True:
            if any(stamp_ns(s.header) == want for s in out.take(N=100)):
                trips.append(time.perf_counter() - t0)
                break
            left = TIMEOUT_S - (time.perf_counter() - t0)
            if left <= 0:
                late += 1
                break
            waitset.wait(duration(seconds=left))
    node.terminate()
    try:
        node.wait(timeout=30)
    except subprocess.TimeoutExpired:
        node.kill()
    if not trips:
        sys.exit("no wheel message was answered")
    print(f"/terraslip/odom end to end (peer write -> node -> peer receipt), {len(trips)} wheel messages after "
          f"the warm-up: p50 {1e3 * percentile(trips, 0.5):.3f} ms, p99 {1e3 * percentile(trips, 0.99):.3f} ms, "
          f"max {1e3 * max(trips):.3f} ms; {late} not answered within {1e3 * TIMEOUT_S:.0f} ms")
    if late > 0.01 * (len(trips) + late):
        sys.exit(f"{late} wheel messages not answered within {1e3 * TIMEOUT_S:.0f} ms")


if __name__ == "__main__":
    main()
