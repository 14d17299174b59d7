#!/usr/bin/env python3
"""Throughput of terraslip.fleet estimate: recordings per minute with 1 and
2 Dask workers, and each worker's peak memory against the number of
recordings it went through (a benchmark, not a test; docs/benchmarks.md).

The fleet is every recording under DATA (default ../shared/data) listed
REPEAT times in a manifest (each copy a robot of its own), so the mix of
lengths and kinds is the real one and only the count grows. For each
worker count and each repeat, a fresh LocalCluster (one thread per worker
process) runs `terraslip.fleet.estimate` into a temporary directory; the
time counted is from the first task submitted to the tables written
(cluster start-up excluded, printed apart). Worker memory is the peak RSS
of each worker process (getrusage), read when the run ends; worker CPU is the
workers' user + system time during the run (Dask's own work included), the
figure a cluster is sized by when the machine is shared.

Dask talks over loopback TCP: the script re-runs itself in a private
network namespace (`unshare -n`, lo up) unless --no-netns.

usage: fleet-bench.py [--data DIR] [--topics FILE.toml] [--workers 1,2] [--repeat 1,2,4]
Prints a Markdown table.
"""

import argparse
import logging
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

HUSKY_TOPICS = '[wheels]\nseparation = 1.040625\n[heading]\ntopic = ""\n'


def _peak_rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _cpu_s():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def run_one(recs, workers, topics):
    from distributed import Client, LocalCluster

    from terraslip import fleet

    t0 = time.perf_counter()
    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None, silence_logs=logging.ERROR) as cluster, Client(cluster) as c:
        c.wait_for_workers(workers)
        start_s = time.perf_counter() - t0
        out = tempfile.mkdtemp(prefix="fleet-bench-")
        try:
            cpu0 = c.run(_cpu_s)
            t1 = time.perf_counter()
            table = fleet.estimate(recs, out, scheduler=c, topics=topics, progress=False)
            wall = time.perf_counter() - t1
            cpu = sum(c.run(_cpu_s).values()) - sum(cpu0.values())
        finally:
            shutil.rmtree(out, ignore_errors=True)
        rss = list(c.run(_peak_rss_mb).values())
    rows = table.to_pylist()
    failed = sum(r["error"] is not None for r in rows)
    hours = sum(r["duration_s"] or 0.0 for r in rows) / 3600.0
    return {"start_s": start_s, "cpu_s": cpu, "wall_s": wall, "n": len(rows), "failed": failed, "hours": hours, "rss": rss}


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    here = os.path.dirname(os.path.abspath(__file__))
    p.add_argument("--data", default=os.path.join(here, "..", "..", "shared", "data"))
    p.add_argument("--topics", help="--topics file for the bags (default: the Husky recording's)")
    p.add_argument("--workers", default="1,2")
    p.add_argument("--repeat", default="1,2,4")
    p.add_argument("--no-netns", action="store_true")
    args = p.parse_args()
    if not args.no_netns:
        inner = " ".join(["ip link set lo up && exec", sys.executable, *map(_q, [os.path.abspath(__file__), *sys.argv[1:], "--no-netns"])])
        return subprocess.call(["unshare", "-n", "sh", "-c", inner])

    from terraslip import fleet

    topics = args.topics
    tmp = tempfile.mkdtemp(prefix="fleet-bench-in-")
    if topics is None:
        topics = os.path.join(tmp, "husky.toml")
        with open(topics, "w") as f:
            f.write(HUSKY_TOPICS)
    base = fleet.recordings([os.path.abspath(args.data)])
    print(f"fleet: {len(base)} recordings under {args.data}; cores {os.cpu_count()}; load {os.getloadavg()[0]:.1f}", file=sys.stderr)
    # A first run, not counted: the workers' first imports and the page cache.
    run_one(base, 1, topics)
    print("| workers | recordings | recording h | cluster start s | run s | recordings/min | recording h per wall h | worker CPU s per recording h | worker peak RSS MB |")
    print("|---|---|---|---|---|---|---|---|---|")
    for workers in map(int, args.workers.split(",")):
        for k in map(int, args.repeat.split(",")):
            recs = [fleet.Recording(r.path, r.kind, f"{r.robot}-{i}", r.date, r.topics) for i in range(k) for r in base]
            res = run_one(recs, workers, topics)
            assert res["failed"] == 0, f"{res['failed']} recordings failed"
            rate = res["n"] / res["wall_s"] * 60
            speed = res["hours"] / (res["wall_s"] / 3600)
            rss = "/".join(f"{m:.0f}" for m in sorted(res["rss"]))
            print(
                f"| {workers} | {res['n']} | {res['hours']:.2f} | {res['start_s']:.1f} | {res['wall_s']:.1f} | {rate:.0f} | {speed:.0f} | {res['cpu_s'] / res['hours']:.2f} | {rss} |",
                flush=True,
            )
    shutil.rmtree(tmp, ignore_errors=True)
    return 0


def _q(s):
    return "'" + str(s).replace("'", "'\\''") + "'"


if __name__ == "__main__":
    sys.exit(main())
