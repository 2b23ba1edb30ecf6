"""One Brian2 simulation at a time per process: the run lock.

Brian2 is not thread-safe. Its device, its preferences, its random generator and the flags of
the running network are process-wide (the network's own noise is counter-based and per
trial, :mod:`astrocpg.network.noise`, but a build still seeds Brian2's generator for any code
that uses it). Two runs in two threads of one process, when the noise still came from Brian2's
generator, interleaved their draws: both returned, each with spikes that matched neither the
other nor ``astrocpg run`` with the same seed. So every entry of the framework that builds and runs a network holds :data:`RUN_LOCK` from
the build to its last step (:func:`exclusive`); a second thread waits for the first to finish,
then gets exactly the result it would have got alone (the command line's, for the same
settings). Processes do not share it: the workers of a study are processes.

The lock is reentrant (an entry that calls another holds it once more). :func:`build_cpg`,
:func:`check_runs` and :func:`run_network` take it too, so code that builds and runs a network
itself holds it around the whole, as the entries do::

    from astrocpg.network import RUN_LOCK, build_cpg, run_network
    with RUN_LOCK:                       # build, run, read: nobody else's draws in between
        cpg = build_cpg(seed=3)
        run_network(cpg.net, 1 * second, namespace={})

Holding the lock is also what applies the framework's Brian2 settings (its code-generation
target, :mod:`astrocpg.network.brian_prefs`): the outermost acquisition saves the user's values
and applies the framework's, the matching release puts the user's back. A user's own Brian2
objects built or run outside the lock see their own settings only.

Taking the lock in the main thread also installs Brian2's Ctrl-C handler where Brian2 was first
imported in another thread (which could not install it).
"""

from __future__ import annotations

import functools
import threading
from typing import Callable, TypeVar

from ..support._quiet_brian import install_interrupt_handler
from . import brian_prefs
from .codegen import framework_target


class RunLock:
    """A reentrant lock whose holder has the framework's Brian2 settings applied
    (:mod:`~astrocpg.network.brian_prefs`), from the outermost acquisition to its release.
    Used as ``threading.RLock``: ``with``, :meth:`acquire`, :meth:`release`."""

    def __init__(self) -> None:
        self._lock = threading.RLock()
        self._depth = 0  # acquisitions of the holding thread (only it changes the count)

    def acquire(self, blocking: bool = True, timeout: float = -1) -> bool:
        """Acquire (reentrant); the outermost acquisition applies the framework's settings."""
        if not self._lock.acquire(blocking, timeout):
            return False
        if self._depth == 0:
            try:
                brian_prefs.enter(framework_target())
            except BaseException:
                self._lock.release()
                raise
        self._depth += 1
        return True

    def release(self) -> None:
        """Release; the outermost release puts the user's Brian2 settings back."""
        self._depth -= 1
        try:
            if self._depth == 0:
                brian_prefs.leave()
        finally:
            self._lock.release()

    def __enter__(self) -> bool:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


#: Held by the thread that builds or runs a Brian2 network of the framework (reentrant).
RUN_LOCK = RunLock()

F = TypeVar("F", bound=Callable)


def exclusive(fn: F) -> F:
    """``fn`` runs holding :data:`RUN_LOCK`: one build-and-run of Brian2 at a time in this
    process, later callers in other threads waiting their turn."""

    @functools.wraps(fn)
    def holding_the_run_lock(*args, **kwargs):  # noqa: ANN002, ANN003, ANN202
        with RUN_LOCK:
            install_interrupt_handler()  # no-op unless Brian2 was imported in another thread
            return fn(*args, **kwargs)

    return holding_the_run_lock  # type: ignore[return-value]


__all__ = ["RUN_LOCK", "exclusive"]
