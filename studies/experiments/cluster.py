"""Dask for the studies' runs and the evaluations' cells: connect to a cluster (a local one or a
running scheduler) and keep every worker thread busy while tasks remain."""

from __future__ import annotations

import logging
import os
import re
import socket
import time
from typing import Any, Callable, Sequence

from ...errors import InputError


def connect_cluster(workers: int | None, scheduler: str | None):
    """(client, local cluster or None): a running scheduler, or a local cluster."""
    from distributed import Client, LocalCluster

    if scheduler:
        _reachable(scheduler)
        try:
            return Client(scheduler, timeout="10s"), None
        except Exception as e:  # OSError / TimeoutError / ValueError for a bad address
            first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            raise InputError(f"cannot connect ({first})", culprit=f"--scheduler {scheduler}") \
                from None
    n = workers or os.cpu_count() or 1
    cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                           dashboard_address=":0", silence_logs=logging.ERROR)
    return Client(cluster), cluster


def _reachable(scheduler: str) -> None:
    """A closed port is refused at once (Dask's client would wait out its whole timeout)."""
    m = re.fullmatch(r"(?:tcp://)?\[?([^\]/]+?)\]?:(\d+)/?", scheduler.strip())
    if not m:
        return  # other protocols and forms: Dask's client says what is wrong
    try:
        socket.create_connection((m.group(1), int(m.group(2))), timeout=3).close()
    except OSError as e:
        raise InputError(f"cannot connect ({e.strerror or type(e).__name__})",
                         culprit=f"--scheduler {scheduler}") from None


class _ImportBrian2:
    """Worker plugin: Brian2 installs a SIGINT handler when imported, which only works in a
    process's main thread; Dask runs tasks in other threads, so import it at worker start-up
    (plugins are set up on the worker's event loop, in its main thread)."""

    name = "astrocpg-import-brian2"

    def setup(self, worker: Any) -> None:
        import brian2  # noqa: F401

        from ..experiments import train  # noqa: F401

    def teardown(self, worker: Any) -> None:
        pass


def run_on_cluster(client: Any, fn: Callable[..., Any], items: Sequence[tuple[str, tuple]],
                   ended: Callable[[str, Any], None],
                   tick: Callable[[int], None] | None = None) -> None:
    """``fn(*args)`` for each ``(name, args)`` of ``items`` on the cluster, in that order, one
    task per free worker thread; ``ended(name, future)`` as each one ends (after the freed
    threads have their next tasks), ``tick(in_flight)`` about every second.

    Tasks are handed to the scheduler only as threads free up, never all at once: a batch of
    at most twice as many tasks as threads is not "root-ish" to Dask, so submitted at once
    they were assigned two per worker up front, and when the first worker fell idle work
    stealing moved every waiting task onto it (measured with 8 workers x 16 study runs: 7 runs
    queued on one worker while the others sat idle, issue 13). With at most one task per thread
    in flight, no task ever waits on a busy worker while another is free, whatever the
    scheduler's settings (``--scheduler`` clusters included), and a freed thread gets the next
    task at once. Interrupted, the tasks in flight are released (they stop with the cluster).
    """
    from distributed import wait
    from distributed.diagnostics.plugin import WorkerPlugin

    plugin = type("ImportBrian2", (_ImportBrian2, WorkerPlugin), {})()
    client.register_plugin(plugin)
    waiting = list(items)
    in_flight: dict[Any, str] = {}
    try:
        finished: list[tuple[Any, str]] = []
        while waiting or in_flight or finished:
            # the threads now in the cluster (workers may join, leave or be restarted)
            threads = max(1, sum(client.nthreads().values()))
            while waiting and len(in_flight) < threads:
                name, args = waiting.pop(0)
                f = client.submit(fn, *args, pure=False,
                                  key=f"astrocpg-{name}-{os.getpid()}-{time.time_ns()}")
                in_flight[f] = name
            for f, name in finished:
                ended(name, f)
                f.release()
            if tick is not None:
                tick(len(in_flight))
            finished = []
            if in_flight:  # back as soon as a task ends (a thread is free), or after 1 s
                try:
                    done = wait(list(in_flight), timeout=1.0, return_when="FIRST_COMPLETED").done
                except TimeoutError:
                    done = set()
                finished = [(f, in_flight.pop(f)) for f in done]
    finally:
        for f in in_flight:
            f.release()


__all__ = ["connect_cluster", "run_on_cluster"]
