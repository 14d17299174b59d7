"""Estimate a real drive and plot its track and ICRs.

    pip install ./crates/terraslip-py matplotlib
    python examples/python/quickstart.py [LOG] [--out quickstart.png]

LOG defaults to the repository's sample drive data/warthog_gravel (a
Clearpath Warthog, 600 s on gravel, with a lidar reference pose).
"""

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import terraslip

REPO = Path(__file__).resolve().parents[2]

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("log", nargs="?", default=REPO / "data" / "warthog_gravel")
parser.add_argument("--out", default="quickstart.png")
args = parser.parse_args()

est = terraslip.estimate(args.log, terrain_labels=True)
summary = est["summary"]
icr = summary["icr"]
print(
    f"{summary['rows']} rows over {summary['duration_s']:.0f} s; final ICRs "
    f"y_l = {icr['y_l']:.3f} m, y_r = {icr['y_r']:.3f} m, x_c = {icr['x_c']:.3f} m; "
    f"tread speed factors {icr['alpha_l']:.3f}, {icr['alpha_r']:.3f}"
)
if summary["prediction"]:
    print(f"2 s prediction error against the pose reference: {summary['prediction']['mean_m']:.3f} m (mean)")

fig, (track, icrs) = plt.subplots(1, 2, figsize=(13, 5.5))
pose_csv = Path(args.log) / "pose.csv"
if pose_csv.exists():
    pose = np.genfromtxt(pose_csv, delimiter=",", names=True)
    track.plot(pose["east"], pose["north"], ".", color="0.6", ms=2, label="pose reference")
track.plot(est["east"], est["north"], lw=1, label="estimate")
track.set(xlabel="east [m]", ylabel="north [m]", title="Track (ENU)", aspect="equal")
track.legend()

t = est["t"]
for name, colour in [("y_l", "C0"), ("y_r", "C1"), ("x_c", "C2")]:
    mean, std = est[name], est["std_" + name]
    icrs.plot(t, mean, colour, lw=1, label=name)
    icrs.fill_between(t, mean - 2 * std, mean + 2 * std, color=colour, alpha=0.2, lw=0)
icrs.set(xlabel="t [s]", ylabel="m (body frame: x forward, y left)", title="ICRs with 2σ bands")
icrs.legend()
fig.tight_layout()
fig.savefig(args.out, dpi=120)
print(f"wrote {args.out}")
