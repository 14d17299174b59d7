"""Where the tasks run: a Dask ``LocalCluster`` of N worker processes on
this machine, or an existing Dask scheduler by address; the same calls
either way."""

from __future__ import annotations

import importlib.util
import logging
import os
import sys
from contextlib import contextmanager
from typing import Any, Callable, Iterator, List, Optional, Sequence

from ._recording import FleetError


def parse_scheduler(spec: Optional[str]) -> Any:
    """``None`` or ``local`` (one worker per CPU), ``local:N`` (N worker
    processes) or a scheduler address ``tcp://HOST:PORT`` (also
    ``tls://``, ``ws://``...). Returns an int (local workers) or the
    address; raises FleetError otherwise."""
    if spec is None or spec == "local":
        return os.cpu_count() or 1
    if spec.startswith("local:"):
        n = spec[len("local:") :]
        if not n.isdigit() or int(n) < 1:
            raise FleetError(f"--scheduler {spec}: N in local:N is a number of worker processes, 1 or more")
        return int(n)
    if "://" in spec:
        return spec
    raise FleetError(f"--scheduler {spec}: expected local:N or an address such as tcp://HOST:8786")


@contextmanager
def client(scheduler: Any = None, *, quiet: bool = False) -> Iterator[Any]:
    """A ``distributed.Client``: given one, that client; else one on
    :func:`parse_scheduler`'s cluster (a LocalCluster of processes, one
    thread each, closed on exit). Prints the dashboard link on stderr."""
    from distributed import Client

    if isinstance(scheduler, Client):
        yield scheduler
        return
    spec = parse_scheduler(scheduler) if not isinstance(scheduler, int) else scheduler
    if isinstance(spec, int):
        from distributed import LocalCluster

        with LocalCluster(
            n_workers=spec,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        ) as cluster, Client(cluster) as c:
            _announce(c, quiet)
            yield c
    else:
        with Client(spec) as c:
            _announce(c, quiet)
            yield c


def _announce(c: Any, quiet: bool) -> None:
    if quiet:
        return
    link = getattr(c, "dashboard_link", None)
    if importlib.util.find_spec("bokeh") is None:  # Dask's dashboard is drawn with it
        link = None if isinstance(c.cluster, _local_cluster_type()) else link
    workers = len(c.scheduler_info().get("workers", {}))
    where = link or "not available (pip install bokeh, for the local cluster's)"
    print(f"fleet: {workers} Dask worker(s); dashboard {where}", file=sys.stderr)


def _local_cluster_type() -> type:
    from distributed import LocalCluster

    return LocalCluster


def run(c: Any, fn: Callable[..., Any], args: Sequence[Sequence[Any]], what: str, *, progress: bool = True) -> List[Any]:
    """``fn(*a)`` for each ``a`` in ``args`` on the cluster, one task each,
    results in the order of ``args``. A progress bar on stderr when it is
    a terminal (``progress``), else one line per tenth done."""
    from distributed import as_completed

    futures = [c.submit(fn, *a, pure=False) for a in args]
    index = {f.key: i for i, f in enumerate(futures)}
    results: List[Any] = [None] * len(futures)
    total = len(futures)
    tty = progress and sys.stderr.isatty()
    step = max(1, total // 10)
    for done, f in enumerate(as_completed(futures), start=1):
        results[index[f.key]] = f.result()
        if tty:
            width = 30
            fill = width * done // max(total, 1)
            print(f"\r{what}: [{'#' * fill}{'.' * (width - fill)}] {done}/{total}", end="", file=sys.stderr, flush=True)
        elif progress and (done % step == 0 or done == total):
            print(f"{what}: {done}/{total}", file=sys.stderr, flush=True)
    if tty:
        print(file=sys.stderr)
    return results
