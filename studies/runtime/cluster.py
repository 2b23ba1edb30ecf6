"""Dask for the studies' runs and the evaluations' cells: connect to a cluster (a local one or a
running scheduler) and keep every worker thread busy while tasks remain."""

from __future__ import annotations

import logging
import os
import re
import socket
import time
from typing import Any, Callable, Sequence

from ...errors import Field, InputError, setting, shown_with
from .workers import MAX_WORKERS_PER_CORE, default_workers


#: A local cluster has at most MAX_WORKERS_PER_CORE worker processes per core (the commands'
#: bound, :mod:`.workers`): each trains one run at a time on one core, so more only share the
#: cores, while starting hundreds takes minutes.

#: Dask's settings for a local cluster. Its defaults serve an interactive dashboard and cost a
#: study CPU on every core: each worker's statistical profiler walks the running task's stack
#: every 10 ms, and every server (the scheduler, each nanny and worker) wakes every 20 ms to
#: check that its event loop is not blocked, every 500 ms to sample the system and every 100 ms
#: to read its workers' memory. A study hands a worker one long run at a time and reads its
#: progress from the run folders, so none of it is used. Off or slower, Dask's own CPU beside
#: 2 workers' tasks fell from 4.9 % of a core in each worker and 4.8 % in the study's process to
#: 0.4 % and 1.0 %; the tasks' own CPU did not change measurably
#: (``python benchmarks/dask_overhead.py``). A ``scheduler``'s cluster keeps its own settings.
LEAN_DASK: dict[str, Any] = {
    "distributed.worker.profile.enabled": False,
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "5s",
    "distributed.worker.memory.monitor-interval": "1s",
}


def cores() -> int:
    """The cores this process may run on (:func:`~.workers.default_workers`): what bounds a
    local cluster, and its size by default."""
    return default_workers()


def check_workers(workers: int | None, culprit: str | Field = setting("workers")) -> int | None:
    """``workers`` for a local cluster: at least 1 and at most :data:`MAX_WORKERS_PER_CORE`
    per core of this machine (InputError naming ``culprit``), or None (one per core)."""
    if workers is None:
        return None
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"must be at least 1, got {workers}", culprit=culprit)
    n = cores()
    if workers > MAX_WORKERS_PER_CORE * n:
        raise InputError(f"{workers} worker processes on {n} core(s) is more than "
                         f"{MAX_WORKERS_PER_CORE} per core (at most "
                         f"{MAX_WORKERS_PER_CORE * n} here; each worker trains on one core)",
                         culprit=shown_with(culprit, workers))
    return workers


def connect_cluster(workers: int | None, scheduler: str | None):
    """(client, local cluster or None): a running scheduler, or a local cluster (of
    ``workers`` processes, :func:`check_workers`)."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        check_scheduler(scheduler)
        try:
            return Client(scheduler, timeout="10s"), None
        except Exception as e:  # OSError / TimeoutError / ValueError for a bad address
            first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
            raise InputError(f"cannot connect ({first})", culprit=setting("scheduler", scheduler)) \
                from None
    n = check_workers(workers) or default_workers()
    check_main_guarded()
    # worker processes started with SIGINT ignored keep ignoring it (Python installs its
    # KeyboardInterrupt handler only where SIGINT is not ignored): Ctrl-C stops the study in
    # this process, which closes the cluster; the workers print nothing of their own
    import signal
    import threading

    in_main = threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if in_main else None
    try:
        # read when the scheduler, nannies and workers are made (a restarted worker too);
        # a task's error is the caller's to report (a study's failures.csv and its one
        # line): the worker's own "Compute Failed" record with its traceback stays quiet
        with dask.config.set(LEAN_DASK):
            cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                                   dashboard_address=":0", silence_logs=logging.CRITICAL)
    finally:
        if in_main:
            signal.signal(signal.SIGINT, previous)
    return Client(cluster), cluster


def _is_main_test(test: Any) -> bool:
    """Whether an ``if`` tests ``__name__ == "__main__"`` (either way round)."""
    import ast

    if not (isinstance(test, ast.Compare) and len(test.ops) == 1
            and isinstance(test.ops[0], ast.Eq)):
        return False
    sides = [test.left, test.comparators[0]]
    return (any(isinstance(x, ast.Name) and x.id == "__name__" for x in sides)
            and any(isinstance(x, ast.Constant) and x.value == "__main__" for x in sides))


def unguarded_call() -> tuple[str, int] | None:
    """(script, line) when this call comes from the top level of the ``__main__`` script
    outside an ``if __name__ == "__main__":`` block, where a local cluster's worker processes,
    which import that script again (the ``spawn`` start method Dask uses), would each run the
    call again; else None. Mirrors what ``multiprocessing`` re-imports: nothing for a notebook,
    ``python -c`` or stdin (no file), nor for a package's ``__main__`` run with ``-m``."""
    import ast
    import sys

    import dask

    if dask.config.get("distributed.worker.multiprocessing-method", "spawn") == "fork":
        return None
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    spec_name = getattr(getattr(main, "__spec__", None), "name", None) or ""
    if main is None or not path or spec_name == "__main__" or spec_name.endswith(".__main__"):
        return None
    frame = sys._getframe(1)
    while frame is not None and not (frame.f_globals is vars(main)
                                     and frame.f_code.co_name == "<module>"):
        frame = frame.f_back
    if frame is None:  # not called from the script's top level
        return None
    line = frame.f_lineno
    try:
        if os.path.getsize(path) > 10_000_000:
            return None
        with open(path, "rb") as f:
            tree = ast.parse(f.read())
    except (OSError, SyntaxError, ValueError):
        return None
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and _is_main_test(node.test) \
                and node.lineno <= line <= (node.end_lineno or node.lineno):
            return None
    return path, line


def check_main_guarded() -> None:
    """Refuse, in one line saying what to write, to start a local cluster from a script's top
    level without ``if __name__ == "__main__":``: each worker would import the script and run
    the study again, and Dask would fail with "Nanny failed to start" and pages of
    traceback."""
    found = unguarded_call()
    if found is None:
        return
    path, line = found
    raise InputError(f"line {line} starts Dask worker processes, which import this script "
                     f"again and would run it again: put the script's work under "
                     f"'if __name__ == \"__main__\":' (see 'Studies from a script' in the "
                     f"manual's studies page)", culprit=path)


#: Seconds the probe of a ``scheduler`` waits to connect, and then for the scheduler to greet.
PROBE_TIMEOUT = 5.0
#: A Dask comm's first message starts with its header's length (8 bytes, little-endian): a
#: handshake is a few hundred bytes. Anything longer is not a Dask scheduler (an HTTP server,
#: e.g. the dashboard on 8787, answers "HTTP/1.1", read as 3.5e18 bytes: "Unable to allocate
#: 3.07 EiB").
MAX_GREETING = 1 << 20


def check_scheduler(scheduler: str) -> None:
    """Refuse in a few seconds, with one line naming ``scheduler``, an address where no Dask
    scheduler answers: a malformed address, a closed port or an unreachable host (instead of
    Dask's client waiting out its whole timeout), or a server that speaks something else (an
    HTTP server such as the dashboard, SSH). ``tcp://`` addresses are probed; other protocols
    (tls://, ucx://, inproc://) are left to Dask's client."""
    culprit = setting("scheduler", scheduler)
    if not isinstance(scheduler, str) or not scheduler.strip():
        raise InputError("needs an address such as tcp://127.0.0.1:8786", culprit=culprit)
    text = scheduler.strip()
    if "://" in text and not text.startswith("tcp://"):
        return  # other protocols: Dask's client says what is wrong
    m = re.fullmatch(r"(?:tcp://)?\[?([^\]/]+?)\]?:(\d+)/?", text)
    if not m or not 0 < int(m.group(2)) < 65536:
        raise InputError("is not an address of the form tcp://HOST:PORT (e.g. "
                         "tcp://127.0.0.1:8786)", culprit=culprit)
    try:
        sock = socket.create_connection((m.group(1), int(m.group(2))), timeout=PROBE_TIMEOUT)
    except OSError as e:
        reason = e.strerror or ("timed out" if isinstance(e, TimeoutError)
                                else type(e).__name__)
        raise InputError(f"cannot connect ({reason})", culprit=culprit) from None
    try:
        sock.settimeout(PROBE_TIMEOUT)
        head = b""
        try:
            while len(head) < 8:
                chunk = sock.recv(8 - len(head))
                if not chunk:
                    break
                head += chunk
        except OSError:  # silent (a scheduler greets at once): decided below
            pass
    finally:
        sock.close()
    hint = ("a scheduler's address is printed when it starts, by default on port 8786 "
            "(8787 is its dashboard)")
    if len(head) < 8:  # a Dask scheduler greets every connection at once
        raise InputError("the server there does not answer like a Dask scheduler (no greeting "
                         f"within {PROBE_TIMEOUT:g} s); {hint}", culprit=culprit)
    size = int.from_bytes(head, "little")
    if size > MAX_GREETING:
        spoken = head.split(b"/")[0].split(b"-")[0].decode("ascii", "replace")
        what = f" (it speaks {spoken})" if spoken.isalpha() else ""
        raise InputError(f"is not a Dask scheduler{what}; {hint}", culprit=culprit)


class _ImportBrian2:
    """Worker plugin: Brian2 installs a SIGINT handler when imported, which only works in a
    process's main thread; Dask runs tasks in other threads, so import it at worker start-up
    (plugins are set up on the worker's event loop, in its main thread), with the module of the
    task's function (``module``: what the tasks will import, Brian2's users among it)."""

    name = "astrocpg-import-brian2"

    def __init__(self, module: str) -> None:
        self.module = module

    def setup(self, worker: Any) -> None:
        import importlib
        import signal

        import brian2  # noqa: F401

        # the caller's module (a command, a study's runs), named by the caller: the runtime
        # imports nothing above it
        importlib.import_module(self.module)

        # Ctrl-C reaches the whole process group: the study's own process stops the cluster
        # and says "interrupted" once; a worker that also took it printed Brian2's "stop
        # requested" and its event loop's KeyboardInterrupt traceback
        signal.signal(signal.SIGINT, signal.SIG_IGN)

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
    queued on one worker while the others sat idle). With at most one task per thread
    in flight, no task ever waits on a busy worker while another is free, whatever the
    scheduler's settings (a ``scheduler``'s cluster included), and a freed thread gets the next
    task at once. Interrupted, the tasks in flight are released (they stop with the cluster).
    """
    from distributed import wait
    from distributed.diagnostics.plugin import WorkerPlugin

    plugin = type("ImportBrian2", (_ImportBrian2, WorkerPlugin), {})(fn.__module__)
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


__all__ = ["LEAN_DASK", "MAX_WORKERS_PER_CORE", "check_main_guarded", "check_scheduler",
           "check_workers",
           "connect_cluster", "cores", "run_on_cluster"]
