"""Checks of scripts/ros2-gap-check.py (run: `python3 scripts/test_ros2_gap_check.py`
or pytest)."""
import importlib.util
import math
import os

from logcsv import interp

_spec = importlib.util.spec_from_file_location(
    "gap_check", os.path.join(os.path.dirname(os.path.abspath(__file__)), "ros2-gap-check.py"))
gap_check = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(gap_check)


def test_gyro_moved_onto_the_wheels_clock():
    """Wheels stamped 0.35 s after the gyro sees the same turn: the gyro's
    rate, moved onto the wheels' clock, is the treads' turn at each wheels
    row, and the two dead reckonings end on the same heading."""
    late = 0.35

    def turn(t):
        return 0.5 * math.sin(2 * math.pi * (t - 5.0) / 15.0) if 5.0 < t < 20.0 else 0.0

    tw = [i * 0.1 for i in range(300)]
    gyro = [(i / 30.0, turn(i / 30.0 + late)) for i in range(900)]
    tg, gz = gap_check.on_wheels_clock(gyro, late)
    worst = max(abs(interp(tg, gz, t) - turn(t)) for t in tw if 1.0 < t < 28.0)
    assert worst < 0.01, worst
    by_gyro = gap_check.dead_reckon(tw, lambda i: 1.0, lambda i: interp(tg, gz, tw[i]), 0, 29.0, (0, 0, 0))
    by_treads = gap_check.dead_reckon(tw, lambda i: 1.0, lambda i: turn(tw[i]), 0, 29.0, (0, 0, 0))
    end = math.hypot(by_gyro[-1][1] - by_treads[-1][1], by_gyro[-1][2] - by_treads[-1][2])
    assert end < 0.05, end


if __name__ == "__main__":
    test_gyro_moved_onto_the_wheels_clock()
    print("ok")
