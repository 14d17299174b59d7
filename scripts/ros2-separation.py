#!/usr/bin/env python3
"""The controller's effective wheel separation checked against a gyro, on a
log imported from a bag whose wheels came from an odometry twist.

The odometry's angular rate is (v_r - v_l)/S with the controller's S; the
gyro measures the true yaw rate. Least squares over the samples turning
faster than 0.1 rad/s gives k = gyro / odometry rate, and the true effective
separation S/k (the multiplier on the track width: S/(k * track)).
DELAY (s, default 0) moves the gyro's stamps onto the wheels' clock: give
the `gyro.wheels_late_by_s` that `terraslip estimate` reports in
summary.json (odometry and IMU drivers stamp at different points; compared
misaligned, the rates fit with a gain biased towards 0).

usage: ros2-separation.py LOG S TRACK [DELAY] [GYRO_COLUMN]   (default 0, gyro_z)
"""
import csv
import os
import sys

log, s, track = sys.argv[1], float(sys.argv[2]), float(sys.argv[3])
delay = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
col = sys.argv[5] if len(sys.argv) > 5 else "gyro_z"
with open(os.path.join(log, "wheels.csv")) as f:
    w = [(float(r["t"]), (float(r["v_right"]) - float(r["v_left"])) / s) for r in csv.DictReader(f)]
with open(os.path.join(log, "imu.csv")) as f:
    g = [(float(r["t"]) + delay, float(r[col])) for r in csv.DictReader(f) if r[col]]
num = den = 0.0
j = 0
n = 0
for t, gz in g:
    while j + 1 < len(w) and w[j + 1][0] <= t:
        j += 1
    if j + 1 >= len(w) or w[j][0] > t:
        continue
    (t0, a), (t1, b) = w[j], w[j + 1]
    om = a + (b - a) * (t - t0) / (t1 - t0)
    if abs(om) > 0.1:
        num += gz * om
        den += om * om
        n += 1
k = num / den
print(f"{n} turning samples: gyro / odometry yaw rate = {k:.4f}; effective separation "
      f"{s / k:.4f} m = {s / k / track:.3f} x {track} m (controller: {s} m = {s / track:.3f} x)")
