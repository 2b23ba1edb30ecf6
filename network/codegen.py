"""Which Brian2 code-generation target builds the network: numpy (default) or Cython (opt-in).

Brian2 runs each of the network's ~20 code objects every 1 ms step. With the numpy target each
costs a fixed Python/numpy overhead, which dominates at small batches; Cython compiles every
code object to a C extension, which ran the closed loop 2.0 x as fast per trial for 1 and 4
trials and 1.5 x at 20 (``python benchmarks/speed.py``, given both targets). The first build
compiles ~20 modules (minutes); Brian2 caches them on disk (``cache_dir()``) keyed by their
code, so later runs, other seeds, batch sizes and parameter values load them in seconds; an
edited equation compiles its own modules once.

The target is chosen per process: the command line's ``codegen`` setting, or the environment
variable ``ASTROCPG_CODEGEN`` (which a study's local Dask workers inherit). Both targets draw
the same counter-based noise, bit for bit (:mod:`astrocpg.network.noise`: NumPy's Philox in
blocks on numpy, the same Philox in C on Cython), so a seed gives the same trajectory up to
floating-point rounding
(``python benchmarks/codegen_agreement.py`` compares the two). C's and numpy's rounding can
still part after long training, so every output records its target (``codegen`` in
manifest.json) and a training resumes only under the target it started with.
"""

from __future__ import annotations

import contextlib
import os
import sys
from pathlib import Path
from typing import Iterator

import brian2

from ..errors import EnvironmentFault, InputError, did_you_mean

TARGETS = ("numpy", "cython")
DEFAULT = "numpy"
ENV = "ASTROCPG_CODEGEN"

_said_cold = False  # the first-build note is printed once per process
# The target the framework's runs use, chosen by the last use_codegen (None: initial_target()).
# It is the framework's, not Brian2's global preference: RUN_LOCK (runlock.py) applies it to
# brian2.prefs only while a build or run of the framework holds the lock, and restores the
# user's value after.
_chosen: str | None = None


def codegen_target(value: str | None = None) -> str:
    """The target to use: ``value`` if given, else ``$ASTROCPG_CODEGEN``, else numpy."""
    culprit = "codegen" if value is not None else ENV
    chosen = value if value is not None else os.environ.get(ENV, "").strip() or DEFAULT
    if chosen not in TARGETS:
        raise InputError(f"unknown code-generation target '{chosen}'"
                         f"{did_you_mean(chosen, TARGETS)} (one of "
                         f"{', '.join(TARGETS)})", culprit=culprit)
    return chosen


def initial_target() -> str:
    """The framework's target before any :func:`use_codegen`: $ASTROCPG_CODEGEN if valid, else
    numpy (an invalid value is reported by the first :func:`use_codegen`, i.e. the first network
    built)."""
    value = os.environ.get(ENV, "").strip()
    return value if value in TARGETS else DEFAULT


def framework_target() -> str:
    """The target of the framework's builds and runs in this process: the last
    :func:`use_codegen`'s, else :func:`initial_target`. Brian2's own ``prefs.codegen.target``
    holds it only inside :data:`~astrocpg.network.RUN_LOCK`; outside, it is the user's."""
    return _chosen or initial_target()


def cache_dir() -> Path:
    """Where Brian2 keeps the compiled Cython modules."""
    from brian2.codegen.runtime.cython_rt.extension_manager import get_cython_cache_dir

    found = get_cython_cache_dir()  # None without the Cython package
    return Path(found) if found else Path("~/.cython/brian_extensions").expanduser()


def _cache_is_empty() -> bool:
    try:
        return not any(p.suffix in (".so", ".pyd") for p in cache_dir().iterdir())
    except OSError:
        return True


@contextlib.contextmanager
def _compiler_output_hidden() -> Iterator[None]:
    """Brian2's test compilation runs the C compiler, whose messages (a broken compiler's
    errors) go straight to file descriptor 2, and logs its failure in eight lines: both are
    kept out of the terminal (the one line is ours, below). Brian2's log records are muted
    too, for callers that have not muted them (the command line mutes all logging)."""
    import logging

    brian_log = logging.getLogger("brian2")
    level = brian_log.level
    brian_log.setLevel(logging.CRITICAL + 1)
    saved = None
    try:
        sys.stderr.flush()
        saved = os.dup(2)
        devnull = os.open(os.devnull, os.O_WRONLY)
        try:
            os.dup2(devnull, 2)
        finally:
            os.close(devnull)
    except (OSError, ValueError):  # no usable descriptor 2: nothing to hide
        if saved is not None:
            os.close(saved)
            saved = None
    try:
        yield
    finally:
        if saved is not None:
            try:
                sys.stderr.flush()
            except (OSError, ValueError):
                pass
            os.dup2(saved, 2)
            os.close(saved)
        brian_log.setLevel(level)


def use_codegen(value: str | None = None) -> str:
    """Choose the framework's target for the networks built from now on
    (``codegen_target(value)``, see :func:`framework_target`) and return it; Brian2's global
    preference is set only inside the framework's runs (:data:`~astrocpg.network.RUN_LOCK`). Cython needs the Cython package and a working C compiler: without them this is
    an :class:`EnvironmentFault`, never a silent fall-back to numpy."""
    target = codegen_target(value)
    if target == "cython":
        from brian2.codegen.runtime.cython_rt import CythonCodeObject

        cold = _cache_is_empty()  # before Brian2's test compilation adds a module to it
        with _compiler_output_hidden():
            available = CythonCodeObject.is_available()
        if not available:
            raise EnvironmentFault(
                "the Cython target needs the Cython package and a C compiler that Brian2 can "
                "use (pip install cython; a compiler such as gcc); numpy needs neither",
                culprit="codegen cython")
        global _said_cold
        if cold and not _said_cold:
            _said_cold = True
            sys.stderr.write(f"astrocpg: Brian2 compiles the network with Cython on first use "
                             f"(several minutes, once); the modules are cached in {cache_dir()}\n")
    return choose_target(target)


def choose_target(value: str | None = None) -> str:
    """Record ``codegen_target(value)`` as the framework's target (:func:`framework_target`)
    without checking that it can compile (:func:`use_codegen` does, at the first build), and
    return it. Inside a build or run of the framework it applies at once."""
    global _chosen
    target = codegen_target(value)
    _chosen = target
    if _applied() and brian2.prefs.codegen.target != target:
        brian2.prefs.codegen.target = target  # chosen inside a build: its own objects use it
    return target


def _applied() -> bool:
    """Does the framework's session (RUN_LOCK, runlock.py) hold Brian2's preferences now?"""
    from . import brian_prefs

    return brian_prefs.active()


__all__ = ["TARGETS", "DEFAULT", "ENV", "codegen_target", "use_codegen", "initial_target",
           "framework_target", "choose_target", "cache_dir"]
