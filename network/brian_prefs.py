"""The Brian2 settings of the framework's own builds and runs, applied only while they last.

Brian2's preferences, its log filters and Python's warning filters are process-wide. Set at
import (as they once were, in ``network/build.py``), they changed the Brian2 models a user
writes in the same process (a notebook): their code-generation target became numpy, Brian2's
warnings about their own unused objects disappeared, and so did numpy's floating-point warnings
from their generated code. So the framework sets them only while it holds
:data:`~astrocpg.network.RUN_LOCK` (every build and run of the framework does, see
:mod:`astrocpg.network.runlock`): :func:`enter` saves what it changes and applies the
framework's values, :func:`leave` puts the user's back. Before, between and after the
framework's runs the user's Brian2 is as the user left it.

A run is a function of its inputs only, and the user's process is as it was after it. What
the framework sets for the length of a run, and puts back after it:

- every Brian2 preference but the logging ones: Brian2's default (a user's
  ``core.default_float_dtype = float32`` changed the robot's and the traces' numbers), except
  ``codegen.target``: the framework's target (numpy, or Cython on request:
  :mod:`astrocpg.network.codegen`), and :data:`FIXED`;
- Brian2's default clock: its default step (:data:`DEFAULT_DT`);
- numpy's error state and print options: numpy's defaults (:data:`NUMPY_ERR`,
  :data:`NUMPY_PRINT`);
- numpy's and Python's global generators: whatever the run draws or seeds (Brian2's ``seed``
  seeds numpy's), the user's streams go on afterwards where they stood;
- the warning filters: numpy's floating-point warnings from Brian2's generated code (exec'd
  source, module ``<string>``) are ignored: an invalid state (NaN, inf, beyond 1e50) is reported
  once, in one line, by the divergence check (:class:`~astrocpg.errors.Diverged`); the warnings
  would only repeat it on stderr, several lines per step. The user's filters follow, an
  "error" among them shown instead: they choose what is shown, never whether a run fails.

The environment variables the framework reads are recorded where they choose something
(``ASTROCPG_CODEGEN``: the manifest's ``codegen``); the others choose where files go or what is
printed, not a result.

One filter outlives the runs because the warning it holds back comes at garbage collection,
whenever that happens: Brian2's "deleted, but was never included in a network" warning is
dropped for objects created by the framework's own code (a network that failed validation is
dropped on purpose), and for those only. It is added at the first run, not at import.
"""

from __future__ import annotations

import logging
import os
import warnings
from typing import Any

#: The preferences the framework sets during its runs (other than the target), with its values.
FIXED = {"codegen.loop_invariant_optimisations": True, "logging.delete_log_on_exit": True}
#: numpy's floating-point warnings from Brian2's generated code (warnings.filters entry).
_FLOAT_WARNINGS = ("ignore", None, RuntimeWarning, r"<string>$", 0)

#: Brian2's default clock step during a run (seconds): Brian2's own default.
DEFAULT_DT = 1e-4
#: numpy's error state during a run: numpy's defaults (a user's ``np.seterr(all="raise")``
#: would make a finite run fail, ``"ignore"`` hide nothing the framework relies on).
NUMPY_ERR = {"divide": "warn", "over": "warn", "under": "ignore", "invalid": "warn"}
#: numpy's print options during a run: numpy's defaults.
NUMPY_PRINT = {"edgeitems": 3, "threshold": 1000, "floatmode": "maxprec", "precision": 8,
               "suppress": False, "linewidth": 75, "nanstr": "nan", "infstr": "inf",
               "sign": "-", "formatter": None, "legacy": False, "override_repr": None}

_saved: dict[str, Any] | None = None  # the user's values while the framework's are applied
_unused_filter_installed = False
_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def active() -> bool:
    """Are the framework's settings applied now (a build or run of it holds RUN_LOCK)?"""
    return _saved is not None


class _FrameworkObjectsOnly(logging.Filter):
    """Drops Brian2's ``unused_brian_object`` warning for objects created in astrocpg's code
    (the warning quotes where the object was created); a user's objects still warn."""

    def filter(self, record: logging.LogRecord) -> bool:
        if not record.name.endswith("unused_brian_object"):
            return True
        return _PACKAGE not in record.getMessage()


def _brian_defaults(brian2: Any) -> dict[str, Any]:
    """Brian2's default value of every registered preference but the logging ones (read by
    Brian2 at import only, and the framework's own choice there: ``_quiet_brian``)."""
    defaults = {}
    for category, (prefs, _doc) in brian2.prefs.pref_register.items():
        if category == "logging" or category.startswith("logging."):
            continue
        for name, pref in prefs.items():
            defaults[f"{category}.{name}"] = pref.default
    return defaults


def _framework_filters(user: list) -> list:
    """The warning filters of a run: the framework's (numpy's floating-point warnings from
    generated code ignored), then the user's with "error" shown instead: the user's filters
    choose what is shown, never whether a run fails."""
    import re

    action, _, category, module, lineno = _FLOAT_WARNINGS
    ours = (action, None, category, re.compile(module), lineno)
    shown = [("default", *f[1:]) if f[0] == "error" else f for f in user]
    return [ours, *[f for f in shown if f != ours]]


def enter(target: str) -> None:
    """Save the user's process state that a run reads or changes, and apply the framework's
    (codegen target ``target``). Called by RUN_LOCK's outermost acquisition; :func:`leave`
    undoes it."""
    import random

    import brian2
    import numpy as np

    global _saved, _unused_filter_installed
    prefs = {**_brian_defaults(brian2), **FIXED, "codegen.target": target}
    saved: dict[str, Any] = {
        "prefs": {name: brian2.prefs[name] for name in prefs},
        "dt": brian2.defaultclock.dt_,
        "err": np.geterr(),
        "print": np.get_printoptions(),
        "np_random": np.random.get_state(),
        "random": random.getstate(),
        "filters": list(warnings.filters),
    }
    try:
        for name, value in prefs.items():
            brian2.prefs[name] = value
        brian2.defaultclock.dt = DEFAULT_DT * brian2.second
        np.seterr(**NUMPY_ERR)
        np.set_printoptions(**{k: v for k, v in NUMPY_PRINT.items() if k in saved["print"]})
        warnings.filters[:] = _framework_filters(saved["filters"])
        warnings._filters_mutated()  # type: ignore[attr-defined]  # as filterwarnings does
    except BaseException:
        _saved = saved
        leave()
        raise
    _saved = saved
    if not _unused_filter_installed:
        handler = getattr(brian2.BrianLogger, "console_handler", None)
        if handler is not None:
            handler.addFilter(_FrameworkObjectsOnly())
        _unused_filter_installed = True


def leave() -> None:
    """Put back the user's state saved by :func:`enter`: Brian2's preferences and default
    clock, numpy's error state and print options, numpy's and Python's global generators
    (Brian2's ``seed`` sets numpy's) and the warning filters."""
    import random

    import brian2
    import numpy as np

    global _saved
    if _saved is None:
        return
    saved, _saved = _saved, None
    for name, value in saved["prefs"].items():
        brian2.prefs[name] = value
    brian2.defaultclock.dt_ = saved["dt"]
    np.seterr(**saved["err"])
    np.set_printoptions(**saved["print"])
    np.random.set_state(saved["np_random"])
    random.setstate(saved["random"])
    warnings.filters[:] = saved["filters"]
    warnings._filters_mutated()  # type: ignore[attr-defined]


__all__ = ["FIXED", "active", "enter", "leave"]
