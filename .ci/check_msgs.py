"""The terraslip_msgs package's .msg files, parsed by rosbags' message
parser, equal the definitions the node and `estimate --mcap` embed
(`ICR_DEF`, `INNOVATION_DEF` in crates/terraslip-ros2/src/out.rs).

Usage: check_msgs.py  (from the repository's root)
"""

import pathlib
import re
import sys

from rosbags.typesys import get_types_from_msg

root = pathlib.Path(__file__).resolve().parent.parent
out_rs = (root / "crates/terraslip-ros2/src/out.rs").read_text()
written = {}
for const, ty in re.findall(r'pub const (\w+)_TYPE: &str = "([^"]+)"', out_rs):
    m = re.search(rf"pub const {const}_DEF: &str =\s*\"((?:[^\"\\]|\\.)*)\"", out_rs)
    if m is None:
        sys.exit(f"out.rs: no {const}_DEF for {ty}")
    written[ty] = m.group(1).encode().decode("unicode_escape")
msgs = sorted((root / "ros/terraslip_msgs/msg").glob("*.msg"))
files = {f"terraslip_msgs/msg/{p.stem}": p.read_text() for p in msgs}
if set(files) != set(written):
    sys.exit(f"types written {sorted(written)} but .msg files {sorted(files)}")
for ty in sorted(written):
    a = get_types_from_msg(files[ty], ty)[ty]
    b = get_types_from_msg(written[ty], ty)[ty]
    if a != b:
        sys.exit(f"{ty}: the .msg file parses to\n  {a}\nthe written definition to\n  {b}")
    print(f"{ty}: {len(a[1])} fields, equal")
