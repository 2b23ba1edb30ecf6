"""The authors' discretisation as a Brian2 integration method.

The paper advances every first-order model as "add this step's input, then apply the decay"
(supplementary, "Computational Implementation"; docs/model.md). For an equation that is linear
in its own variable, ``dx/dt = A*x + B`` (A and B may depend on other variables), one step is

    x <- (x + dt*B) * exp(A*dt)

This differs from exponential Euler (``x <- x*exp(A dt) + B*(exp(A dt)-1)/A``) by a factor of
about 1 - dt/(2 tau) on the input; for tau = 9 ms and dt = 1 ms that is 5%, which moves the
membrane potential's steady state by ~0.7 mV against a 10 mV threshold and changes the burst's
firing rate by ~20%. The rhythm of the published figures (docs/model.md) was measured with
this scheme, so the neurons use it.

Schemes are registered by name in Brian2's table of state updaters (as Brian2 registers
``"euler"`` or ``"exponential_euler"``), so a model refers to its scheme by name
(``method="input_then_decay"``), a ``NeuronGroup`` accepts that name, and a manifest records it.
Importing :mod:`astrocpg.models` registers ``input_then_decay``; registering the same scheme again
(a re-import, a reload, a Dask worker) is harmless.
"""

from __future__ import annotations

import sympy as sp
from brian2.parsing.sympytools import sympy_to_str
from brian2.stateupdaters.base import (
    StateUpdateMethod,
    UnsupportedEquationsException,
    extract_method_options,
)
from brian2.stateupdaters.exponential_euler import get_conditionally_linear_system

from ..errors import InputError


class InputThenDecay(StateUpdateMethod):
    """``x <- (x + dt*B) * exp(A*dt)`` for ``dx/dt = A*x + B``; A = 0 gives forward Euler."""

    def __call__(self, equations, variables=None, method_options=None):
        extract_method_options(method_options, {})
        if equations.is_stochastic:
            raise UnsupportedEquationsException("input_then_decay: no stochastic equations")
        try:
            system = get_conditionally_linear_system(equations, variables)
        except ValueError:
            raise UnsupportedEquationsException(
                "input_then_decay: every equation must be linear in its own variable"
            )
        code = []
        dt = sp.Symbol("dt")
        for var, (A, B) in system.items():
            x = sp.Symbol(var)
            update = (x + dt * B) * sp.exp(A * dt) if A != 0 else x + dt * B
            code.append(f"_{var} = {sympy_to_str(update)}")
        code += [f"{var} = _{var}" for var in system]
        return "\n".join(code)


def register_method(name: str, method: StateUpdateMethod) -> str:
    """Register ``method`` under ``name`` in Brian2's table of state updaters; returns the name
    as registered (Brian2 lower-cases it). Registering the same scheme again (the same object, or
    an object of the same class after a re-import) is harmless; a different scheme under a name
    that is taken is an :class:`InputError`."""
    if not isinstance(name, str) or not name.isidentifier():
        raise InputError(f"a scheme's name must be an identifier, got {name!r}",
                         culprit="integration method")
    key = name.lower()
    if not isinstance(method, StateUpdateMethod):
        raise InputError(f"is not a Brian2 StateUpdateMethod ({type(method).__name__})",
                         culprit=f"integration method '{key}'")
    existing = StateUpdateMethod.stateupdaters.get(key)
    if existing is None:
        StateUpdateMethod.register(key, method)
    elif existing is not method:
        if not _same_scheme(existing, method):
            raise InputError(f"the name is already taken by another scheme "
                             f"({_qualified(existing)})", culprit=f"integration method '{key}'")
        StateUpdateMethod.stateupdaters[key] = method  # the same scheme, re-imported
    return key


def _same_scheme(a: object, b: object) -> bool:
    """The same class (by module and name: a re-imported module makes a new class object) and
    the same settings."""
    try:
        return _qualified(a) == _qualified(b) and bool(vars(a) == vars(b))
    except Exception:
        return False


def registered_methods() -> tuple[str, ...]:
    """The names every model may use as ``method`` (Brian2's and ours)."""
    return tuple(sorted(StateUpdateMethod.stateupdaters))


def method_name(method: object) -> str | None:
    """The registered name of ``method`` (a name, any case, or a registered scheme object), or
    None when it is not registered."""
    if isinstance(method, str):
        key = method.lower()
        return key if key in StateUpdateMethod.stateupdaters else None
    for key, registered in StateUpdateMethod.stateupdaters.items():
        if registered is method:
            return key
    for key, registered in StateUpdateMethod.stateupdaters.items():  # a re-imported scheme
        if isinstance(method, StateUpdateMethod) and _same_scheme(registered, method):
            return key
    return None


def _qualified(obj: object) -> str:
    return f"{type(obj).__module__}.{type(obj).__qualname__}"


INPUT_THEN_DECAY = "input_then_decay"
input_then_decay = InputThenDecay()
register_method(INPUT_THEN_DECAY, input_then_decay)

__all__ = ["InputThenDecay", "input_then_decay", "INPUT_THEN_DECAY", "register_method",
           "registered_methods", "method_name"]
