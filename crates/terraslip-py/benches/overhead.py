"""Speed of the Python package against the command line (docs/benchmarks.md).

    python crates/terraslip-py/benches/overhead.py LOG [--cli target/release/terraslip] [--repeat 5]

Prints the best wall time of `terraslip estimate LOG --out DIR` (a process,
writing estimate.csv and summary.json), of `terraslip.estimate(LOG)` in this
process and of a whole `python -c` process doing it; four runs one after
the other and on threads; then the rate of `Estimator.on_wheels` calls
from a Python loop.
"""

import argparse
import subprocess
import sys
import tempfile
import time

import terraslip


def best(f, repeat):
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("log")
    p.add_argument("--cli", default="target/release/terraslip")
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--calls", type=int, default=2_000_000)
    p.add_argument("--threads", type=int, default=2)
    a = p.parse_args()

    out = tempfile.mkdtemp()
    cli = best(
        lambda: subprocess.run([a.cli, "estimate", a.log, "--out", out], check=True, capture_output=True),
        a.repeat,
    )
    call = best(lambda: terraslip.estimate(a.log), a.repeat)
    code = f"import terraslip; terraslip.estimate({a.log!r})"
    proc = best(lambda: subprocess.run([sys.executable, "-c", code], check=True), a.repeat)
    rows = terraslip.estimate(a.log)["summary"]["rows"]
    print(f"{rows} wheels rows, best of {a.repeat}")
    print(f"  CLI estimate (process)        {cli:7.3f} s")
    print(f"  terraslip.estimate (call)     {call:7.3f} s  {100 * (call / cli - 1):+6.1f} %")
    print(f"  python -c estimate (process)  {proc:7.3f} s  {100 * (proc / cli - 1):+6.1f} %")

    # The GIL is released while a log runs: threads run logs in parallel.
    from concurrent.futures import ThreadPoolExecutor

    seq = best(lambda: [terraslip.estimate(a.log) for _ in range(4)], 1)
    with ThreadPoolExecutor(a.threads) as pool:
        par = best(lambda: list(pool.map(terraslip.estimate, [a.log] * 4)), 1)
    print(f"  4 x estimate: one after the other {seq:.3f} s, {a.threads} threads {par:.3f} s ({seq / par:.2f}x)")

    est = terraslip.Estimator(track_width=0.5)
    on_wheels = est.on_wheels
    n = a.calls
    t0 = time.perf_counter()
    for i in range(n):
        on_wheels(i * 0.02, 1.0, 0.8)
    dt = time.perf_counter() - t0
    print(f"  Estimator.on_wheels           {n / dt / 1e6:7.2f} M calls/s ({1e9 * dt / n:.0f} ns per call)")


if __name__ == "__main__":
    main()
