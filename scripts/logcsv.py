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
