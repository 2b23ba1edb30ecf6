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

What the framework sets, and why:

- ``codegen.target``: the framework's target (numpy, or Cython on request:
  :mod:`astrocpg.network.codegen`). Its groups and synapses carry their target themselves; the
  objects Brian2 adds to them (monitors, the state-variable setters) read the preference.
- ``codegen.loop_invariant_optimisations`` and ``logging.delete_log_on_exit``: on (Brian2's
  defaults), so a user's change of them does not change the framework's numbers or files.
- numpy's floating-point warnings from Brian2's generated code (exec'd source, module
  ``<string>``) are ignored: an invalid state (NaN, inf, beyond 1e50) is reported once, in one
  line, by the divergence check (:class:`~astrocpg.errors.Diverged`); the warnings would only
  repeat it on stderr, several lines per step.

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

_saved: dict[str, Any] | None = None  # the user's values while the framework's are applied
_added_filter = False
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


def enter(target: str) -> None:
    """Save the user's values of what the framework sets, and apply the framework's (target
    ``target``). Called by RUN_LOCK's outermost acquisition; :func:`leave` undoes it."""
    import re

    import brian2

    global _saved, _added_filter, _unused_filter_installed
    names = ("codegen.target", *FIXED)
    saved = {name: brian2.prefs[name] for name in names}
    brian2.prefs["codegen.target"] = target
    for name, value in FIXED.items():
        brian2.prefs[name] = value
    _saved = saved
    # the same entry as warnings.filterwarnings("ignore", category=RuntimeWarning,
    # module=r"<string>$"); added only where the user has no such entry, removed by leave()
    action, _, category, module, lineno = _FLOAT_WARNINGS
    entry = (action, None, category, re.compile(module), lineno)
    _added_filter = entry not in warnings.filters
    if _added_filter:
        warnings.filterwarnings(action, category=category, module=module)
    if not _unused_filter_installed:
        handler = getattr(brian2.BrianLogger, "console_handler", None)
        if handler is not None:
            handler.addFilter(_FrameworkObjectsOnly())
        _unused_filter_installed = True


def leave() -> None:
    """Put back the user's values saved by :func:`enter`."""
    import re

    import brian2

    global _saved, _added_filter
    if _saved is None:
        return
    saved, _saved = _saved, None
    for name, value in saved.items():
        brian2.prefs[name] = value
    if _added_filter:
        _added_filter = False
        action, _, category, module, lineno = _FLOAT_WARNINGS
        entry = (action, None, category, re.compile(module), lineno)
        try:
            warnings.filters.remove(entry)
        except ValueError:  # the user's code reset the filters meanwhile
            pass
        else:
            warnings._filters_mutated()  # type: ignore[attr-defined]  # as filterwarnings does


__all__ = ["FIXED", "active", "enter", "leave"]
