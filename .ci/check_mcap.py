"""Reads an `estimate --mcap` file with the independent Python readers
(mcap + mcap-ros2-support) and checks topics, types and counts.

usage: check_mcap.py OUT.mcap ROWS [TOPIC=COUNT ...]
"""
import sys
from collections import Counter

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

path, rows = sys.argv[1], int(sys.argv[2])
want = {
    "/terraslip/odom": ("nav_msgs/msg/Odometry", rows),
    "/tf": ("tf2_msgs/msg/TFMessage", rows),
    "/terraslip/icr": ("terraslip_msgs/msg/Icr", rows),
    "/terraslip/innovation": ("terraslip_msgs/msg/Innovation", rows),
    "/terraslip/terrain": ("std_msgs/msg/String", None),
}
for arg in sys.argv[3:]:
    topic, n = arg.split("=")
    want[topic] = (None, int(n))

counts, types = Counter(), {}
with open(path, "rb") as f:
    reader = make_reader(f, decoder_factories=[DecoderFactory()])
    for schema, channel, message, decoded in reader.iter_decoded_messages():
        counts[channel.topic] += 1
        types[channel.topic] = schema.name
        if channel.topic == "/terraslip/icr":
            assert decoded.y_l > decoded.y_r, (decoded.y_l, decoded.y_r)
        if channel.topic == "/tf":
            assert decoded.transforms[0].child_frame_id == "base_link"

bad = []
for topic, (ty, n) in want.items():
    if ty is not None and types.get(topic) != ty:
        bad.append(f"{topic}: type {types.get(topic)}, want {ty}")
    if n is not None and counts[topic] != n:
        bad.append(f"{topic}: {counts[topic]} messages, want {n}")
    if n is None and counts[topic] == 0:
        bad.append(f"{topic}: no messages")
if bad:
    sys.exit("check_mcap: " + "; ".join(bad))
print(f"check_mcap: {path}: {dict(counts)}")
