"""Divergence: the one rule for a state that has left the numbers, the scan of the CPG's state
that applies it, a periodic check for runs without a robot, and how a
:class:`~astrocpg.errors.Diverged` raised inside a run reaches the caller.

The rule (:func:`invalid`): a state value is invalid when it is NaN, infinite, or beyond
:data:`LIMIT` (1e50, in SI units) in magnitude, which is Brian2's own bound of a valid state. A
run in which any float state variable of any group or synapse of the CPG (neurons, astrocytes,
pools, torque traces, synaptic weights and traces; constants too) is invalid has diverged: exit
3, whatever the variable. The override ``C_K_chan=1e300*mV/second`` drives the motor neurons'
``v`` to -3e251 V without ever reaching inf: that run has diverged too. The robot (MuJoCo's
qpos, qvel and ctrl) is held to MuJoCo's stricter bound (1e10), which its instability warnings
report the step it is crossed (:mod:`astrocpg.coupling.bridge`); beyond that the bridge
applies this rule.

The scan (:class:`StateScan`, :meth:`astrocpg.network.CPG.first_invalid`) runs in the 1 ms hot
loop every ``check_every`` steps (10), so it allocates nothing: one dot product per array (cached
once, about 1 us each) with a constant vector whose elements overflow the product for any
element beyond ``LIMIT / 2`` and propagate NaN and inf; only when one is not finite is the
element located, by the exact rule. :class:`InvalidState` is what it finds. Brian2's own
end-of-run scan of the same groups (a raw ``WARNING ... has NaN, very large values`` line) is
switched off for the CPG's objects (:func:`leave_to_the_scan`): the run reports its own line.

Getting the error out of ``Network.run``: a ``Diverged`` raised by a network operation (the
bridge, :class:`DivergenceCheck`) leaves Brian2 either as itself or wrapped in a
``BrianObjectException`` whose ``__cause__`` chain holds it. Call :func:`run_network` instead of
``net.run`` (or catch around ``net.run`` and use :func:`find_diverged`) to always get the
original ``Diverged``::

    from astrocpg.network import run_network
    try:
        run_network(cpg.net, 10 * second, namespace={})
    except Diverged as e:   # e.culprit, e.t, e.trial
        ...
"""

from __future__ import annotations

import logging
import math
import re
from dataclasses import dataclass
from typing import Any, Iterable, Protocol

import brian2
import numpy as np

from ..errors import Diverged, InputError
from .populations import BUILT_IN, PROJECTIONS, model_of_object
from .runlock import exclusive
from .invariants import overflow_refusal
from .runner import run as run_lean

#: Beyond this magnitude (SI units) a state value is invalid: Brian2's own bound
#: (``Group._check_for_invalid_values``), NaN and inf being invalid too.
LIMIT = 1e50
LIMIT_TEXT = f"{LIMIT:.0e}".replace("e+", "e")  # "1e50"


def invalid(values: Any) -> np.ndarray:
    """The rule, element by element: NaN, inf, or ``|x| > LIMIT`` (a bool array)."""
    with np.errstate(invalid="ignore"):
        return ~(np.abs(np.asarray(values, dtype=float)) <= LIMIT)  # NaN compares False


def _screen_vector(arr: np.ndarray) -> np.ndarray:
    """The constant vector ``c`` of :class:`StateScan`: ``arr @ c`` is not finite whenever an
    element of ``arr`` is invalid. Each ``|x| * c`` overflows for ``|x| > LIMIT / 2``, and no
    partial sum (finite, so at most the largest float) can bring back an element beyond
    ``LIMIT`` (whose product is over twice that), with or without fused multiply-adds; NaN and
    inf propagate. A float type that cannot hold ``LIMIT`` (float32) is screened for NaN/inf
    only (``c = 0``)."""
    top = float(np.finfo(arr.dtype).max)
    scale = top / LIMIT * 2.0 if top > LIMIT else 0.0
    return np.full(arr.size, scale, dtype=arr.dtype)


#: The model each Brian2 object of the built-in network is built from (object name -> model
#: name), read from the population table (:mod:`astrocpg.network.populations`).
MODEL_OF = {**{p.name: p.model_name for p in BUILT_IN}, **PROJECTIONS}


def model_of(name: str, rows: Any = None) -> str | None:
    """The model a Brian2 object of the network (or one of its code objects) is built from,
    by its name: ``interlimb_FR`` (a stage's object) and ``motor_stateupdater`` start with the
    name of their kind (``rows``: the network's population rows, added ones included; None:
    the built-in rows). None for a name of no model."""
    table = model_of_object(rows)
    for obj in sorted(table, key=len, reverse=True):  # pool_activity before pool
        if name.startswith(obj):
            return table[obj]
    return None


@dataclass(frozen=True)
class InvalidState:
    """An invalid state value (:func:`invalid`: NaN, inf or beyond :data:`LIMIT`):
    ``population.variable`` (Brian2 object and variable) of element ``index`` of that object,
    which belongs to trial ``trial`` (None for a shared variable)."""

    population: str
    variable: str
    trial: int | None
    index: int
    value: float
    others: tuple[str, ...] = ()  # the other ``population.variable`` invalid then

    @property
    def culprit(self) -> str:
        return f"{self.population}.{self.variable}"

    def error(self, t: float | None, rows: Any = None) -> Diverged:
        """The :class:`Diverged` to raise, at simulated time ``t`` (s), in a network of the
        population ``rows`` (None: the built-in rows)."""
        model = model_of(self.population, rows) or self.population
        where = f"trial {self.trial}" if self.trial is not None else "unknown trial"
        at = f" at t = {t:.3f} s" if t is not None else ""
        also = f" (also invalid: {', '.join(self.others)})" if self.others else ""
        value = (f"{self.value:.3g} (beyond {LIMIT_TEXT} in SI units, Brian2's bound of a valid "
                 f"state)" if math.isfinite(self.value) else f"{self.value}")
        return Diverged(f"{value} in {self.population} (model {model}) element "
                        f"{self.index}, {where}{at}{also}", culprit=self.culprit, t=t,
                        trial=self.trial)


class StateScan:
    """Applies :func:`invalid` to live state arrays, fast: see the module's docstring.

    ``entries``: (object name, variable, live 1-D float array, trial of each element or None,
    changes) per array; an array that cannot change during a run (``changes`` False: a
    constant) is scanned by the first :meth:`first` and by every ``full`` one only. List the
    arrays upstream first: the first invalid one found is reported as the likeliest origin.
    """

    def __init__(self, entries: Iterable[tuple[str, str, np.ndarray, np.ndarray | None, bool]]):
        self._hot: list[tuple[str, str, np.ndarray, Any, Any, np.ndarray]] = []
        self._all: list[tuple[str, str, np.ndarray, Any, Any, np.ndarray]] = []
        for name, var, arr, trials, changes in entries:
            entry = (name, var, arr, trials, arr.dot, _screen_vector(arr))
            self._all.append(entry)
            if changes:
                self._hot.append(entry)
        self._scanned_all = False

    def first(self, full: bool = False) -> InvalidState | None:
        """The first invalid value (in the entries' order), or None. One dot product per array,
        no allocation; the element is located only where one is not finite. ``full``: the
        constants too (they are anyway on the first call)."""
        entries = self._hot
        if full or not self._scanned_all:
            entries, self._scanned_all = self._all, True
        isfinite = math.isfinite
        with np.errstate(over="ignore", invalid="ignore"):  # the products overflow on purpose
            for entry in entries:
                if isfinite(entry[4](entry[5])):
                    continue
                found = self._locate(entry)
                if found is not None:
                    return found
        return None  # no element is invalid (a sum of large valid values overflowed)

    def _locate(self, entry: tuple) -> InvalidState | None:
        name, var, arr, trials, _, _ = entry
        bad = np.flatnonzero(invalid(arr))
        if not bad.size:
            return None
        k = int(bad[0])
        others = tuple(f"{n}.{v}" for n, v, a, _, _, _ in self._all
                       if (n, v) != (name, var) and invalid(a).any())
        trial = int(trials[k]) if trials is not None and len(trials) == arr.size else None
        return InvalidState(population=name, variable=var, trial=trial, index=k,
                            value=float(arr[k]), others=others)


def leave_to_the_scan(objects: Iterable[Any]) -> None:
    """Switch Brian2's own end-of-run check of invalid states off for ``objects`` (groups and
    synapses of the CPG): :class:`StateScan` applies the same rule to the same variables (and
    more), and reports it as the run's one line; Brian2's check added a raw multi-word
    ``WARNING`` on stderr after the run, once the harm was done."""
    for obj in objects:
        if hasattr(obj, "_check_for_invalid_states"):
            obj._check_for_invalid_states = _checked_by_the_scan


def _checked_by_the_scan() -> None:
    """Stands in for Brian2's ``Group._check_for_invalid_states`` (see
    :func:`leave_to_the_scan`)."""


def find_diverged(exc: BaseException | None) -> Diverged | None:
    """The :class:`Diverged` in ``exc`` or its ``__cause__``/``__context__`` chain (Brian2 wraps
    errors of code it runs in ``BrianObjectException``), or None."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, Diverged):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ if exc.__cause__ is not None else exc.__context__
    return None


def network_time(net: brian2.Network) -> float:
    """The network's time in s as a float (after a stopped run Brian2 leaves ``Network.t_`` as
    a view of the clock's variable, not a float)."""
    return float(np.asarray(net.t_))


@exclusive  # one Brian2 run at a time in a process (runlock.py)
def run_network(net: brian2.Network, duration: Any, *, lean: bool = True,
                **kwargs: Any) -> None:
    """``net.run(duration, **kwargs)``, but a :class:`Diverged` raised inside the run (by the
    bridge or a :class:`DivergenceCheck`) comes out as itself, whatever Brian2 wrapped it in.

    The run is :func:`astrocpg.network.runner.run` (``lean``, the default): Brian2's
    preparation and schedule, each step's compiled code called without Brian2's Python layers
    around each call, the same results as ``net.run`` (which it calls itself for a run it cannot
    do the same way, e.g. ``profile=True``). ``lean=False``: ``net.run`` itself.

    Ctrl-C during the run: Brian2 stops it at the end of the step and logs "Simulation stop
    requested. Press Ctrl+C again to interrupt." on the console; the caller turns the early
    stop into its own interruption (KeyboardInterrupt, exit 130 on the command line), so
    that line is dropped while a run of ours is in progress (a Brian2 run of the user's own
    keeps it)."""
    brian_log = logging.getLogger("brian2")
    brian_log.addFilter(_no_stop_chatter)
    try:
        if lean:
            run_lean(net, duration, **kwargs)
        else:
            net.run(duration, **kwargs)
    except Exception as e:
        found = find_diverged(e)
        if found is None:
            overflow = overflowed(e, net)
            if overflow is not None:
                raise overflow.with_traceback(None) from None
        if found is None or found is e:
            raise
        raise found.with_traceback(None) from None
    finally:
        brian_log.removeFilter(_no_stop_chatter)


#: what Brian2's numpy code objects say before the line their error came from
_FAILED_LINE = re.compile(r"raised in the following line:\s*\n\s*(.+)")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def overflowed(exc: BaseException, net: Any) -> InputError | None:
    """An InputError naming the parameters when ``exc`` is a Brian2 code object's arithmetic
    overflow (``OverflowError``: a constant of the equations computed from parameters, such
    as ``1/(w_max - w_min)**2`` with ``w_max=1e200*mV``, left the floats), else None. Such a
    run never started: its parameters are refused (exit 2), the largest first, each with its
    value; the line that overflowed is quoted."""
    from brian2.core.base import BrianObjectException

    wrapper, cause, seen = None, None, set()
    err: BaseException | None = exc
    while err is not None and id(err) not in seen:
        seen.add(id(err))
        if isinstance(err, BrianObjectException) and wrapper is None:
            wrapper = err
        if isinstance(err, (OverflowError, FloatingPointError)):
            cause = err
            break
        err = err.__cause__ if err.__cause__ is not None else err.__context__
    if cause is None or wrapper is None:
        return None
    name = getattr(wrapper, "_brian_objname", "")
    owner = next((o for o in getattr(net, "objects", ()) if getattr(o, "name", None) == name),
                 None)
    namespace = getattr(owner, "namespace", None) or {}
    m = _FAILED_LINE.search(str(wrapper))
    line = m.group(1).strip() if m else ""
    values = {ident: namespace[ident] for ident in dict.fromkeys(_NAME.findall(line))
              if not ident.startswith("_") and ident in namespace}
    rows = getattr(net, "population_rows", None)  # the rows the network was built from
    return overflow_refusal(model_of_object(rows).get(name, name or "the network"), line,
                            values)


def _no_stop_chatter(record: logging.LogRecord) -> bool:
    """False for Brian2's "Simulation stop requested" record (a filter of the brian2 logger)."""
    return not str(record.msg).startswith("Simulation stop requested")


class Scanned(Protocol):
    """What :class:`DivergenceCheck` needs of a network (:class:`~astrocpg.network.CPG`)."""

    dt: Any
    clock: Any

    def first_invalid(self, full: bool = False) -> InvalidState | None: ...


class DivergenceCheck:
    """Runs :meth:`CPG.first_invalid` every ``every`` steps inside a run (for networks without
    a bridge, e.g. the open-loop unit) and raises :class:`Diverged` at the first invalid state
    (NaN, inf or beyond :data:`LIMIT`). Call :meth:`check` once more after the run to cover its
    last steps.

    ``t`` in the error is the end of the step in which the value was found (state after step k:
    ``(k + 1) * dt``), so it lies at most ``every`` steps after the step that produced it.
    """

    def __init__(self, cpg: Scanned, every: int = 10) -> None:
        if int(every) < 1:
            raise ValueError(f"DivergenceCheck: every must be at least 1, got {every}")
        self.cpg, self.every = cpg, int(every)
        self._t = cpg.clock.variables["t"].get_value()  # live (1,) array, s
        self._dt = float(cpg.dt)

    def operation(self, when: str = "end", order: int = 100,
                  name: str = "divergence_check") -> brian2.NetworkOperation:
        return brian2.NetworkOperation(self._step, dt=self.every * self.cpg.dt, when=when,
                                       order=order, name=name)

    def _step(self) -> None:
        # in the "end" slot of the step that began at clock.t: the state after that step
        found = self.cpg.first_invalid()
        if found is not None:
            raise found.error(float(self._t[0]) + self._dt, _rows(self.cpg))

    def check(self) -> None:
        """Raise :class:`Diverged` if any state is invalid now (e.g. after the run)."""
        found = self.cpg.first_invalid(full=True)
        if found is not None:
            t = float(self._t[0])
            raise found.error(t if math.isfinite(t) else None, _rows(self.cpg))


def _rows(cpg: Any) -> Any:
    """A network's population rows (None where it has no layout: the built-in rows)."""
    layout = getattr(cpg, "layout", None)
    return None if layout is None else layout.rows


__all__ = ["LIMIT", "invalid", "InvalidState", "StateScan", "leave_to_the_scan",
           "DivergenceCheck", "find_diverged", "run_network", "MODEL_OF", "model_of"]
