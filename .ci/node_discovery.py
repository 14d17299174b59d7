"""`ros2 node list` as a Cyclone DDS peer sees it: the node announces itself
on `ros_discovery_info` (rmw_dds_common/msg/ParticipantEntitiesInfo), which
the ROS 2 tools read to list nodes.

Usage: node_discovery.py NODE_CMD_JSON NAME [GID_BYTES]
Starts the node, reads `ros_discovery_info` for up to 30 s and exits 0 when
a participant lists node NAME (GID_BYTES: 16 for a Jazzy build, 24 for
Humble).
"""

import json
import subprocess
import sys
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, sequence, uint8
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

GID_BYTES = int(sys.argv[3]) if len(sys.argv) > 3 else 16


@dataclass
class Gid(IdlStruct, typename="rmw_dds_common::msg::dds_::Gid_"):
    data: array[uint8, GID_BYTES]


@dataclass
class NodeEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::NodeEntitiesInfo_"):
    node_namespace: str
    node_name: str
    reader_gid_seq: sequence[Gid]
    writer_gid_seq: sequence[Gid]


@dataclass
class ParticipantEntitiesInfo(IdlStruct, typename="rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_"):
    gid: Gid
    node_entities_info_seq: sequence[NodeEntitiesInfo]


def main():
    node_cmd, name = json.loads(sys.argv[1]), sys.argv[2]
    dp = DomainParticipant()
    topic = Topic(dp, "ros_discovery_info", ParticipantEntitiesInfo)
    qos = Qos(
        Policy.Reliability.Reliable(duration(seconds=1)),
        Policy.Durability.TransientLocal,
        Policy.History.KeepLast(100),
    )
    reader = DataReader(dp, topic, qos=qos)
    node = subprocess.Popen(node_cmd)
    seen = set()
    try:
        deadline = time.time() + 30
        while time.time() < deadline:
            for info in reader.take(N=100):
                for n in info.node_entities_info_seq:
                    seen.add(f"{n.node_namespace.rstrip('/')}/{n.node_name}")
            if f"/{name}" in seen:
                print(f"ros_discovery_info lists /{name} (all: {sorted(seen)})")
                return
            if node.poll() is not None:
                sys.exit(f"the node exited ({node.returncode}) before it was listed")
            time.sleep(0.2)
        sys.exit(f"/{name} never appeared on ros_discovery_info (seen: {sorted(seen)})")
    finally:
        node.terminate()
        node.wait(timeout=20)


if __name__ == "__main__":
    main()
