"""Checks of scripts/ros2-gyro-state.py (run: `python3 scripts/test_ros2_gyro_state.py`
or pytest)."""
import os
import tempfile

from logcsv import script

gyro_state = script("ros2-gyro-state.py")


def test_a_log_cut_keeps_the_rows_up_to_the_time_and_every_other_file():
    """Each CSV keeps its header and its rows stamped at or before the cut;
    meta.toml is copied as it is; the source is left untouched."""
    with tempfile.TemporaryDirectory() as src, tempfile.TemporaryDirectory() as dst:
        with open(os.path.join(src, "wheels.csv"), "w") as f:
            f.write("t,v_left,v_right\n0.0,1,1\n1.0,1,1\n2.5,1,1\n")
        with open(os.path.join(src, "pose.csv"), "w") as f:
            f.write("t,east,north,yaw,std_xy,std_yaw\n0.4,0,0,,0.9,\n2.0,1,0,,0.9,\n")
        with open(os.path.join(src, "meta.toml"), "w") as f:
            f.write("separation = 1.0\n")
        gyro_state.cut(src, dst, 2.0)
        with open(os.path.join(dst, "wheels.csv")) as f:
            assert f.read().split() == ["t,v_left,v_right", "0.0,1,1", "1.0,1,1"]
        with open(os.path.join(dst, "pose.csv")) as f:
            assert len(f.read().split()) == 3
        with open(os.path.join(dst, "meta.toml")) as f:
            assert f.read() == "separation = 1.0\n"
        with open(os.path.join(src, "wheels.csv")) as f:
            assert len(f.read().split()) == 4


if __name__ == "__main__":
    test_a_log_cut_keeps_the_rows_up_to_the_time_and_every_other_file()
    print("ok")
