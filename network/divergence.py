"""Divergence of the CPG: where a state variable went non-finite, a periodic check for runs without
a robot, and how a :class:`~astrocpg.errors.Diverged` raised inside a run reaches the caller.

The scan itself is :meth:`astrocpg.network.CPG.first_nonfinite`: it walks the raw arrays of every
group's float state variables (cached once) with one reduction per array, and locates the element
only when a reduction is not finite. :class:`NonFinite` is what it finds.

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

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import brian2
import numpy as np

from ..errors import Diverged
from .runlock import exclusive

if TYPE_CHECKING:  # pragma: no cover
    from .build import CPG

#: The model each Brian2 object of the network is built from (object name -> model name).
MODEL_OF = {"motor": "motor_neuron", "interneuron": "interneuron", "astrocyte": "astrocyte",
            "pool": "pool", "torque": "torque", "pool_activity": "pool_activity",
            "intra_pool": "intra_pool_synapse", "pool_to_interneuron": "pool_to_interneuron",
            "interneuron_to_pool": "interneuron_to_pool", "interlimb": "interlimb_synapse"}


def model_of(name: str) -> str | None:
    """The model a Brian2 object of the network (or one of its code objects) is built from,
    by its name: ``interlimb_FR`` (a stage's object) and ``motor_stateupdater`` start with the
    name of their kind. None for a name of no model."""
    for obj in sorted(MODEL_OF, key=len, reverse=True):  # pool_activity before pool
        if name.startswith(obj):
            return MODEL_OF[obj]
    return None


@dataclass(frozen=True)
class NonFinite:
    """A non-finite state value: ``population.variable`` (Brian2 group and variable) of element
    ``index`` of that group, which belongs to trial ``trial``."""

    population: str
    variable: str
    trial: int | None
    index: int
    value: float
    others: tuple[str, ...] = ()  # the other ``population.variable`` holding NaN/inf then

    @property
    def culprit(self) -> str:
        return f"{self.population}.{self.variable}"

    def error(self, t: float | None) -> Diverged:
        """The :class:`Diverged` to raise, at simulated time ``t`` (s)."""
        model = model_of(self.population) or self.population
        where = f"trial {self.trial}" if self.trial is not None else "unknown trial"
        at = f" at t = {t:.3f} s" if t is not None else ""
        also = f" (also non-finite: {', '.join(self.others)})" if self.others else ""
        return Diverged(f"{self.value} in {self.population} (model {model}) element "
                        f"{self.index}, {where}{at}{also}", culprit=self.culprit, t=t,
                        trial=self.trial)


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
def run_network(net: brian2.Network, duration: Any, **kwargs: Any) -> None:
    """``net.run(duration, **kwargs)``, but a :class:`Diverged` raised inside the run (by the
    bridge or a :class:`DivergenceCheck`) comes out as itself, whatever Brian2 wrapped it in."""
    try:
        net.run(duration, **kwargs)
    except Exception as e:
        found = find_diverged(e)
        if found is None or found is e:
            raise
        raise found.with_traceback(None) from None


class DivergenceCheck:
    """Runs :meth:`CPG.first_nonfinite` every ``every`` steps inside a run (for networks without
    a bridge, e.g. the open-loop unit) and raises :class:`Diverged` at the first non-finite state.
    Call :meth:`check` once more after the run to cover its last steps.

    ``t`` in the error is the end of the step in which the value was found (state after step k:
    ``(k + 1) * dt``), so it lies at most ``every`` steps after the step that produced it.
    """

    def __init__(self, cpg: "CPG", every: int = 10) -> None:
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
        found = self.cpg.first_nonfinite()
        if found is not None:
            raise found.error(float(self._t[0]) + self._dt)

    def check(self) -> None:
        """Raise :class:`Diverged` if any state is non-finite now (e.g. after the run)."""
        found = self.cpg.first_nonfinite()
        if found is not None:
            t = float(self._t[0])
            raise found.error(t if math.isfinite(t) else None)


__all__ = ["NonFinite", "DivergenceCheck", "find_diverged", "run_network", "MODEL_OF", "model_of"]
