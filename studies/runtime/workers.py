"""A command's trials over worker processes: how many (:func:`default_workers`, decided here
and nowhere else), which trials each takes (:func:`split_trials`, contiguous ranges) and the
pool that runs the batches (:func:`run_batches`).

A trial's trajectory is a function of its seed alone (any batch, any process), so the
batches' results put side by side in trial order are the single-process run's. The pool's
processes are forked from the command's (Linux; elsewhere started fresh): what it imported
they have, and each call runs in the caller's environment as it is at the call
(``ASTROCPG_CODEGEN`` included). Each worker ignores SIGINT
(Ctrl-C reaches the whole process group: the parent alone decides) and stops its Brian2 run
cleanly at the end of a step on SIGTERM, which the parent sends every worker when it is
interrupted, so that a training's workers write their checkpoints before they end.
"""

from __future__ import annotations

import os
import signal
import sys
from typing import Any, Callable, Sequence

from ...errors import Field, InputError, setting, shown_with

#: A command has at most this many worker processes per core: each simulates on one core, so
#: more only share the cores (and each holds its own Brian2 and MuJoCo).
MAX_WORKERS_PER_CORE = 4


def default_workers() -> int:
    """The cores this process may run on (``os.sched_getaffinity``: what ``taskset``, a
    container or a batch system's CPU set gives it, else ``os.cpu_count()``), at least 1: the
    default number of worker processes of every command that simulates trials, and of a
    study's local cluster."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):  # not Linux
        return max(1, os.cpu_count() or 1)


def check_workers(workers: Any, culprit: str | Field = setting("workers")) -> int | None:
    """``workers`` checked: a whole number, at least 1 and at most
    :data:`MAX_WORKERS_PER_CORE` per core here (InputError naming ``culprit``), or None (the
    default, :func:`default_workers`)."""
    if workers is None:
        return None
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise InputError(f"must be a whole number of processes, at least 1, got {workers!r}",
                         culprit=culprit)
    n = default_workers()
    if workers > MAX_WORKERS_PER_CORE * n:
        raise InputError(f"{workers} worker processes on {n} core(s) is more than "
                         f"{MAX_WORKERS_PER_CORE} per core (at most "
                         f"{MAX_WORKERS_PER_CORE * n} here; each worker simulates on one core)",
                         culprit=shown_with(culprit, workers))
    return workers


def resolve_workers(workers: Any, culprit: str | Field = setting("workers")) -> int:
    """``workers`` checked (:func:`check_workers`), None as :func:`default_workers`; in a
    daemonic process (a Dask worker, a multiprocessing pool's worker), which may start no
    processes of its own, None is 1 and more is refused."""
    import multiprocessing

    n = check_workers(workers, culprit)
    if multiprocessing.current_process().daemon:
        if n is not None and n > 1:
            raise InputError(f"this process is a worker of another (a Dask worker, a "
                             f"multiprocessing pool), which may start no processes of its own: "
                             f"its trials run here; leave it out or give 1", culprit=culprit)
        return 1
    return default_workers() if n is None else n


def workers_words(procs: int) -> str:
    """`` x workers=N`` (as each door names it) for a culprit where more than one process
    works, else nothing."""
    return f" x {setting('workers', procs)}" if procs > 1 else ""


def split_trials(n_trials: int, workers: int) -> list[tuple[int, int]]:
    """``(first trial, count)`` of each batch: ``min(workers, n_trials)`` contiguous ranges in
    trial order, their sizes differing by at most one (the larger first)."""
    k = max(1, min(int(workers), int(n_trials)))
    size, extra = divmod(int(n_trials), k)
    out, first = [], 0
    for b in range(k):
        count = size + (1 if b < extra else 0)
        out.append((first, count))
        first += count
    return out


def _stop_on_sigterm(signum: int, frame: Any) -> None:
    """A worker's SIGTERM: a Brian2 run in progress stops at the end of its step (the caller
    sees it stopped early, as after Ctrl-C: a training writes its checkpoint); a worker
    between runs (building, or waiting for work) ends at once, quietly (SystemExit: its
    queues' locks released as a process that ends does), with nothing to write."""
    brian2 = sys.modules.get("brian2")
    network = getattr(brian2, "Network", None)
    if network is not None and network._globally_running:
        network._globally_stopped = True
        return
    raise SystemExit(130)


#: Seconds between two looks of a worker at its parent, and how long an orphaned worker may
#: take to stop cleanly (a training writes its checkpoint) before it ends regardless.
PARENT_POLL_S = 1.0
ORPHAN_GRACE_S = 30.0


def _worker_start() -> None:
    """Each worker process as it starts: Brian2 imported (it installs a SIGINT handler of its
    own), then SIGINT ignored and SIGTERM a clean stop (:func:`_stop_on_sigterm`), and a
    watch on its parent (:func:`_watch_parent`)."""
    import threading

    import brian2  # noqa: F401

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, _stop_on_sigterm)
    threading.Thread(target=_watch_parent, args=(os.getppid(),), daemon=True,
                     name="astrocpg-parent-watch").start()


def _watch_parent(parent: int) -> None:
    """A worker whose command was killed outright (SIGKILL, the machine's out-of-memory
    killer: no chance to stop its workers) would wait for work forever. When its parent is
    gone, the worker stops as a SIGTERM stops it (a training at the end of its step, writing
    its checkpoint), and ends after :data:`ORPHAN_GRACE_S` whatever it was doing."""
    import time

    while os.getppid() == parent:
        time.sleep(PARENT_POLL_S)
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(ORPHAN_GRACE_S)
    os._exit(1)


def _in_environment(environ: dict[str, str], fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)`` with this process's environment made the caller's as it is at the call
    (a worker started fresh, or by a fork server, keeps the one it started with: a later
    ``codegen`` setting, or a variable the caller changed since, would not reach it)."""
    if environ != dict(os.environ):
        os.environ.clear()
        os.environ.update(environ)
    return fn(*args)


def _context(module: str | None) -> Any:
    """``fork`` (Linux, a process of one thread, as a command is): a worker starts as a copy of
    this process, with Python, Brian2, MuJoCo and astrocpg already imported (no second import
    of seconds; memory shared until written). With other threads running (a notebook that
    ran a study on Dask, say), a fork could copy a lock one of them holds: then ``forkserver``,
    one fresh server process that imports ``module`` (the batches' function's, Brian2 and
    MuJoCo with it) once and forks the workers; ``spawn`` where neither exists."""
    import importlib
    import multiprocessing
    import threading

    if module:
        importlib.import_module(module)
    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods and threading.active_count() == 1:
        return multiprocessing.get_context("fork")
    if "forkserver" in methods:
        ctx = multiprocessing.get_context("forkserver")
        if module:
            ctx.set_forkserver_preload([module])
        return ctx
    return multiprocessing.get_context("spawn")


def run_batches(fn: Callable[..., Any], calls: Sequence[tuple], workers: int,
                ended: Callable[[int, Any], None] | None = None,
                poll: Callable[[], None] | None = None) -> list[Any]:
    """``[fn(*args) for args in calls]``, each call in one of ``workers`` fresh processes (at
    most one process per call), the results in the order of ``calls``. ``ended(k, result)`` as
    call ``k`` ends (in the order they end), ``poll()`` about every second while any runs.

    An error a call raises stops the others (their processes are told to stop, SIGTERM) and
    comes out of this call once they have ended; so does the parent's KeyboardInterrupt (Ctrl-C,
    SIGTERM): the workers stop at the end of their step, a training's workers after writing
    their checkpoints."""
    import concurrent.futures as cf

    n = max(1, min(int(workers), len(calls)))
    ctx = _context(getattr(fn, "__module__", None))
    for stream in (sys.stdout, sys.stderr):  # a forked worker would write a copy of the rest
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):
            pass
    results: list[Any] = [None] * len(calls)
    pool = cf.ProcessPoolExecutor(max_workers=n, mp_context=ctx, initializer=_worker_start)
    futures: dict[Any, int] = {}
    try:
        environ = dict(os.environ)
        futures = {pool.submit(_in_environment, environ, fn, *args): k
                   for k, args in enumerate(calls)}
        waiting = set(futures)
        while waiting:
            done, waiting = cf.wait(waiting, timeout=1.0, return_when=cf.FIRST_COMPLETED)
            for f in sorted(done, key=futures.__getitem__):
                results[futures[f]] = f.result()  # a call's error comes out here
                if ended is not None:
                    ended(futures[f], results[futures[f]])
            if poll is not None:
                poll()
        return results
    except BaseException:
        _stop_workers(pool, futures)
        raise
    finally:
        pool.shutdown(wait=True, cancel_futures=True)
        # the pool's queues and locks released now: a command ends without the interpreter's
        # teardown, and the resource tracker then warns of "leaked semaphore objects"
        del pool, futures
        import gc
        gc.collect()


def _stop_workers(pool: Any, futures: dict[Any, int]) -> None:
    """Ask every running worker to stop (SIGTERM: the end of its step), the calls not started
    cancelled, and wait for the workers to end (a second Ctrl-C meanwhile is ignored)."""
    import concurrent.futures as cf

    for f in futures:
        f.cancel()
    for process in list(getattr(pool, "_processes", {}).values()):
        try:
            os.kill(process.pid, signal.SIGTERM)
        except (ProcessLookupError, OSError):
            pass
    running = [f for f in futures if not f.cancelled()]
    while True:
        try:
            cf.wait(running)
            return
        except KeyboardInterrupt:  # the workers are stopping already
            continue


__all__ = ["MAX_WORKERS_PER_CORE", "check_workers", "default_workers", "resolve_workers",
           "run_batches", "split_trials", "workers_words"]
