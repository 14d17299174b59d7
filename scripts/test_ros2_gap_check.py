"""Checks of scripts/ros2-gap-check.py (run: `python3 scripts/test_ros2_gap_check.py`
or pytest)."""
import math

from logcsv import interp, script

gap_check = script("ros2-gap-check.py")
gap_ceiling = script("ros2-gap-ceiling.py")


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


def test_a_track_split_into_its_heading_and_its_distance():
    """A track driven at a known speed and yaw rate gives them back: its
    heading changes as rates (across the +-pi wrap) and its steps as speeds
    along its own heading, so that the swapped dead reckonings rebuild it."""
    tw = [i * 0.1 for i in range(400)]
    speed = lambda i: 1.0 + 0.3 * math.sin(tw[i] / 4.0)
    rate = lambda i: 0.4 * math.cos(tw[i] / 3.0) + 0.2
    track = gap_check.dead_reckon(tw, speed, rate, 0, 40.0, (0.0, 0.0, 3.0))
    ts = [0.0] + [p[0] for p in track]
    east = [0.0] + [p[1] for p in track]
    north = [0.0] + [p[2] for p in track]
    yaw = [3.0]
    for i in range(len(ts) - 1):
        yaw.append(math.atan2(math.sin(yaw[-1] + rate(i) * 0.1), math.cos(yaw[-1] + rate(i) * 0.1)))
    rates = gap_check.heading_rates(ts, yaw)
    speeds = gap_check.along_speeds(ts, east, north, yaw)
    assert max(abs(r - rate(i)) for i, r in enumerate(rates)) < 1e-9
    assert max(abs(v - speed(i)) for i, v in enumerate(speeds)) < 1e-3
    again = gap_check.dead_reckon(tw, lambda i: speeds[i], lambda i: rates[i], 0, 40.0, (0.0, 0.0, 3.0))
    assert math.hypot(again[-1][1] - track[-1][1], again[-1][2] - track[-1][2]) < 0.05


def test_the_paired_rule_calls_a_tie_only_when_its_interval_holds_zero():
    """Windows every 10 s, resampled in 20 s blocks: a difference of one
    sign throughout is ahead (or behind), one that changes sign around zero
    block by block is a tie, and the mean is the plain mean."""
    starts = [40.0 + 10 * k for k in range(33)]
    ahead = [-0.3 + 0.1 * (k % 3) for k in range(33)]
    m, lo, hi = gap_check.paired(starts, ahead)
    assert abs(m - sum(ahead) / 33) < 1e-12 and hi < 0, (m, lo, hi)
    assert gap_check.verdict(lo, hi) == "ahead"
    noise = [0.5 * (1 if (k // 2) % 2 else -1) for k in range(33)]
    m, lo, hi = gap_check.paired(starts, noise)
    assert lo < 0 < hi and gap_check.verdict(lo, hi) == "tie", (m, lo, hi)
    assert gap_check.verdict(0.1, 0.4) == "behind"


def test_the_ceiling_finds_the_calibration_the_fixes_were_driven_with():
    """Fixes on the odometry's path turned 0.96 x and driven 0.94 x (a grid
    point): among the ceiling's calibrated tracks that one lands on them
    and the plain odometry does not; the gyro read 1.05 x the truth, divided
    by 1.05, lands on them with the same speed."""
    tw = [i * 0.1 for i in range(300)]
    vl = [0.9 + 0.3 * math.sin(t / 5.0) for t in tw]
    vr = [1.1 + 0.3 * math.sin(t / 5.0) for t in tw]
    true_rate = lambda i: 0.96 * (vr[i] - vl[i])
    truth = gap_check.dead_reckon(tw, lambda i: 0.94 * (vl[i] + vr[i]) / 2, true_rate, 0, 29.0, (0, 0, 0.5))
    fixes = [(t, e, n) for t, e, n in truth if abs(t * 2.5 - round(t * 2.5)) < 1e-6]
    found = gap_ceiling.tracks(tw, vl, vr, 1.0, lambda i: 1.05 * true_rate(i), 0, 29.0, (0, 0, 0.5))
    rms = {key: gap_check.rms_to_fixes(tr, fixes, 0.0, 29.0)[0] for key, tr in found.items()}
    assert min(rms, key=rms.get) in (("odometry", 0.96, 0.94), ("gyro", 1.05, 0.94)), min(rms, key=rms.get)
    assert rms[("odometry", 0.96, 0.94)] < 1e-6 and rms[("gyro", 1.05, 0.94)] < 0.01, rms
    assert rms[("odometry", 1.0, 1.0)] > 0.5, rms[("odometry", 1.0, 1.0)]
    assert gap_ceiling.row_at(tw, -1.0) == 0 and gap_ceiling.row_at(tw, 10.05) == 100


if __name__ == "__main__":
    test_gyro_moved_onto_the_wheels_clock()
    test_a_track_split_into_its_heading_and_its_distance()
    test_the_paired_rule_calls_a_tie_only_when_its_interval_holds_zero()
    test_the_ceiling_finds_the_calibration_the_fixes_were_driven_with()
    print("ok")
