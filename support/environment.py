"""The environment variables astrocpg reads, parsed in one place.

A switch (``ASTROCPG_COMPILED_PHYSICS``, ``ASTROCPG_COMPILED_RECORDING``, ``ASTROCPG_DEBUG``)
is a boolean: ``1``, ``true``,
``yes``, ``on`` or ``0``, ``false``, ``no``, ``off`` (any case, spaces around ignored; unset
or empty: its default). Any other value is an :class:`~astrocpg.errors.InputError` naming the
variable, never a guess: ``ASTROCPG_COMPILED_PHYSICS=false`` once meant "on", since only ``0``
turned it off.

:func:`recorded` is what a run's manifest keeps of the environment: the variables that choose
how a result is computed, as they were set.
"""

from __future__ import annotations

import os
from typing import Mapping

from ..errors import InputError

TRUE = ("1", "true", "yes", "on")
FALSE = ("0", "false", "no", "off")

#: The boolean switches astrocpg reads, with their defaults.
SWITCHES = {"ASTROCPG_COMPILED_PHYSICS": True, "ASTROCPG_COMPILED_RECORDING": True,
            "ASTROCPG_DEBUG": False}

#: The variables that choose how a result is computed, kept in every manifest as set (None:
#: unset). ASTROCPG_CODEGEN: Brian2's code-generation target (numpy or cython: the same
#: equations, rounding may differ in the last bits). ASTROCPG_COMPILED_PHYSICS: whether the
#: robots' physics steps in one compiled C loop or from Python; both make the same MuJoCo calls
#: in the same order, so the results are bit-identical (tests/test_compiled_physics.py checks
#: it), and it is kept as part of the environment all the same. ASTROCPG_COMPILED_RECORDING:
#: whether a run's traces are sampled by compiled C or by numpy (the same bytes:
#: tests/test_trace_recorder.py), kept likewise. MUJOCO_GL: the renderer of videos (not of any
#: number).
RECORDED = ("ASTROCPG_CODEGEN", "ASTROCPG_COMPILED_PHYSICS", "ASTROCPG_COMPILED_RECORDING",
            "MUJOCO_GL")


def flag(name: str, default: bool | None = None,
         environ: Mapping[str, str] | None = None) -> bool:
    """The boolean environment variable ``name`` (default: :data:`SWITCHES`'s); InputError
    naming it for a value that is not one of :data:`TRUE` / :data:`FALSE`."""
    env = os.environ if environ is None else environ
    if default is None:
        default = SWITCHES[name]
    raw = env.get(name)
    if raw is None or not raw.strip():
        return default
    value = raw.strip().lower()
    if value in TRUE:
        return True
    if value in FALSE:
        return False
    raise InputError(f"must be a boolean: one of {', '.join(TRUE)} (on) or {', '.join(FALSE)} "
                     f"(off), got {raw!r}", culprit=name)


def check(environ: Mapping[str, str] | None = None) -> None:
    """Every switch of :data:`SWITCHES` parsed: a bad value is refused before a command runs
    (nothing written)."""
    for name in SWITCHES:
        flag(name, environ=environ)


def recorded(environ: Mapping[str, str] | None = None) -> dict[str, str | None]:
    """``{variable: value or None}`` of :data:`RECORDED`, for a manifest."""
    env = os.environ if environ is None else environ
    return {name: env.get(name) for name in RECORDED}


__all__ = ["flag", "check", "recorded", "SWITCHES", "RECORDED", "TRUE", "FALSE"]
