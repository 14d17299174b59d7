"""Reading a terraslip log directory's CSV files, for the scripts beside
this one (`import logcsv`: Python puts a script's own directory on the
path)."""
import bisect
import csv
import os


def script(name):
    """The script `name` beside this module (a file name with hyphens, which
    `import` cannot name) loaded as a module, for its tests."""
    import importlib.util

    path = os.path.join(os.path.dirname(os.path.abspath(__file__)), name)
    spec = importlib.util.spec_from_file_location(name.replace("-", "_")[:-3], path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


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


def fix_pair(pose, yaw, wheels, estimate, i, clock, step):
    """The second of the pose fixes `i - 1`, `i` against the model's motion
    from the first: the tread speeds between them (the pose read `clock` s
    late) through `model_twist`, integrated in steps of about `step` s
    (trapezoidal heading, midpoint position). `yaw` is the pose's heading
    unwrapped. Returns `(v, omega, h, along, across, heading)`: the model's
    speed (m/s) and yaw rate (rad/s) at the `n + 1` step ends, the step
    (s), and the second fix's residual along the model's track at it,
    across it (m) and in heading (rad)."""
    import numpy as np

    t0, t1 = pose["t"][i - 1], pose["t"][i]
    n = max(1, int(round((t1 - t0) / step)))
    v, om = model_twist(wheels, estimate, np.linspace(t0, t1, n + 1) - clock)
    h = (t1 - t0) / n
    psi = yaw[i - 1] + np.concatenate([[0.0], np.cumsum(0.5 * (om[1:] + om[:-1]) * h)])
    pm, vm = 0.5 * (psi[1:] + psi[:-1]), 0.5 * (v[1:] + v[:-1])
    de, dn = np.sum(vm * np.cos(pm) * h), np.sum(vm * np.sin(pm) * h)
    re = pose["east"][i] - pose["east"][i - 1] - de
    rn = pose["north"][i] - pose["north"][i - 1] - dn
    c, s = np.cos(psi[-1]), np.sin(psi[-1])
    return v, om, h, c * re + s * rn, -s * re + c * rn, yaw[i] - psi[-1]
