"""The checks of the values every command takes (durations, counts, seeds, sampling, what to
record): each refuses a bad value in one line naming its setting (:func:`astrocpg.errors.setting`),
which each door says in its own words. The settings values (:mod:`astrocpg.studies.settings`)
are built with them, and the commands call them too.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np

from ...coupling.robot import A1Parameters
from ...errors import Field, InputError, did_you_mean, setting
from ...models.units import finite_number, whole_steps
from ...network.populations import spike_populations, trace_sources
from ...network.recording import TRACE_DTYPES

#: The closed loop's step (s): the A1's physics step, which the CPG shares.
STEP = A1Parameters().timestep

#: Brian2 seeds its (and numpy's legacy) generator with an unsigned 32-bit integer.
MAX_SEED = 2**32 - 1

#: The most units of work one grid may hold, refused before any is built: a study's trainings
#: (sweep points x conditions x seeds), the worlds of a worlds file and the cells of an
#: evaluation (trained trainings x worlds; each cell one closed-loop simulation). There is no
#: switch past it: split the work into several studies or worlds files.
MAX_GRID = 100_000


def number(value: Any, culprit: str, *, integer: bool = False, minimum: float | None = None,
           positive: bool = False) -> Any:
    """A finite number (int if ``integer``) within bounds, or an InputError naming the culprit
    (:func:`astrocpg.models.units.finite_number`)."""
    return finite_number(value, culprit=culprit, kind=int if integer else float,
                         minimum=minimum, strictly_positive=positive)


def check_grid(cells: int, what: str, culprit: str) -> None:
    """Refuse a grid of more than :data:`MAX_GRID` ``cells``, in one line naming its size
    (``what``: how it is made) and the bound."""
    if cells > MAX_GRID:
        raise InputError(f"{cells} {what} is more than {MAX_GRID}, the most one grid may hold "
                         f"(split it into several files)", culprit=culprit)


def seed_number(value: Any, culprit: str | Field = setting("seed"), trials: int = 1) -> int:
    """A seed for ``trials`` trials (seeds value .. value + trials - 1), each in Brian2's range
    0 .. 2**32 - 1, or an InputError naming the culprit."""
    seed = number(value, culprit, integer=True, minimum=0)
    if seed + trials - 1 > MAX_SEED:
        raise InputError(f"must be at most {MAX_SEED - trials + 1} (seeds of {trials} trial(s) "
                         f"up to 2**32 - 1), got {seed}", culprit=culprit)
    return seed


def names_list(value: Any, culprit: str) -> tuple[str, ...]:
    """Names from a list (tuple, set...) of texts or one text of names separated by commas
    (never read one character at a time); InputError naming ``culprit`` for anything else."""
    if isinstance(value, str):
        text = value.strip()
        return () if text in ("", "none") else tuple(x.strip() for x in text.split(","))
    if isinstance(value, (bytes, bytearray)) or not isinstance(value, Iterable):
        raise InputError(f"expected names (a list of texts, or one text of names separated by "
                         f"commas), got {type(value).__name__}", culprit=culprit)
    names = tuple(value)
    for name in names:
        if not isinstance(name, str):
            raise InputError(f"expected names as text, got {name!r} ({type(name).__name__})",
                             culprit=culprit)
    return names


def check_selection(spikes: tuple[str, ...] | None, traces: tuple[str, ...] | None,
                    rows: Any = None) -> tuple[tuple[str, ...], tuple[str, ...]]:
    """Validate which populations' spikes and which traces to record (None: all). Each is a
    list of names or one text of names separated by commas (``"motor"``, ``"motor,astrocyte"``;
    ``"none"`` or ``""``: nothing), as the command line takes them. The names are those of the
    population table ``rows`` (the built-in rows and the added ones; None: the built-in rows,
    :mod:`astrocpg.network.populations`)."""
    POPULATIONS, TRACES = spike_populations(rows), tuple(trace_sources(rows))
    spikes = POPULATIONS if spikes is None else names_list(spikes, setting("spikes"))
    traces = TRACES if traces is None else names_list(traces, setting("traces"))
    for name in spikes:
        if name not in POPULATIONS:
            raise InputError(f"unknown population '{name}'{did_you_mean(name, POPULATIONS)} "
                             f"(populations: {', '.join(POPULATIONS)})", culprit=setting("spikes"))
    for name in traces:
        if name not in TRACES:
            raise InputError(f"unknown trace '{name}'{did_you_mean(name, TRACES)} (traces: "
                             f"{', '.join(TRACES)})",
                             culprit=setting("traces"))
    return spikes, traces


def check_duration(seconds: float, dt: float = STEP,
                   culprit: str | Field = setting("seconds")) -> int:
    """A run lasts a whole number of steps, at least one; returns that number (an
    InputError names ``culprit`` and the nearest valid durations otherwise)."""
    if not np.isfinite(seconds) or seconds <= 0:
        raise InputError(f"must be positive, got {seconds:g}", culprit=culprit)
    return whole_steps(seconds, dt, culprit=culprit, unit="s")


def check_trace_dt(trace_dt_ms: float, dt: float = STEP,
                   culprit: str | Field = setting("trace_dt")) -> int:
    """A trace sampling interval (ms) is a whole number of steps: samples are taken at steps,
    and labelled with the sampling times. Returns the steps between samples."""
    return whole_steps(trace_dt_ms, dt * 1e3, culprit=culprit, unit="ms")


def check_trace_dtype(dtype: Any, culprit: str | Field = setting("trace_dtype")) -> str:
    """What the traces are kept as: "float32" or "float64" (InputError otherwise)."""
    if dtype not in TRACE_DTYPES:
        raise InputError(f"must be one of {', '.join(TRACE_DTYPES)}, got {dtype!r}",
                         culprit=culprit)
    return str(dtype)
