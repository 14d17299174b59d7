"""Reading a terraslip log directory's CSV files, for the scripts beside
this one (`import logcsv`: Python puts a script's own directory on the
path)."""
import bisect
import csv
import os


def rows(log, name):
    """`log/name` as a list of dicts, one per row, keyed by the header."""
    with open(os.path.join(log, name)) as f:
        return list(csv.DictReader(f))


def interp(ts, vs, t):
    """`vs` linearly interpolated at `t` over the sorted times `ts`, held at
    the ends."""
    if t <= ts[0]:
        return vs[0]
    if t >= ts[-1]:
        return vs[-1]
    i = bisect.bisect_right(ts, t)
    a = (t - ts[i - 1]) / (ts[i] - ts[i - 1])
    return vs[i - 1] + a * (vs[i] - vs[i - 1])


def columns(path):
    """The CSV file at `path` as numpy arrays keyed by the header (empty
    cells NaN; columns that are not numbers left out)."""
    import numpy as np

    with open(path) as f:
        table = list(csv.reader(f))
    cols = {}
    for i, name in enumerate(table[0]):
        try:
            cols[name] = np.array([float(r[i]) if r[i] != "" else np.nan for r in table[1:]])
        except ValueError:
            pass
    return cols


def model_twist(wheels, estimate, t):
    """The constant-ICR twist (forward speed m/s, yaw rate rad/s) at the
    wheel times `t` (an array, s): the tread speeds of `wheels` (the
    columns of `wheels.csv`) with the ICRs and speed factors `estimate`
    (the columns of an `estimate.csv`) gives at that time; without the
    turn laws and centripetal terms."""
    import numpy as np

    vl = np.interp(t, wheels["t"], wheels["v_left"])
    vr = np.interp(t, wheels["t"], wheels["v_right"])
    at = {c: np.interp(t, estimate["t"], estimate[c]) for c in ("y_l", "y_r", "alpha_l", "alpha_r")}
    gl, gr = at["alpha_l"] * vl, at["alpha_r"] * vr
    width = at["y_l"] - at["y_r"]
    return (gr * at["y_l"] - gl * at["y_r"]) / width, (gr - gl) / width
