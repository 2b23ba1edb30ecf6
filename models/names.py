"""Which names a model parameter may take: the one name check of every model (built-in ones,
model files, models built in Python).

A parameter reaches Brian2's code through the group's namespace, which Brian2 consults *after*
the group's own variables and *together with* its units, functions and constants, and the
first of those wins. A parameter named ``dt``, ``t``, ``ms``, ``exp``, ``rand``, ``pi`` or like
one of the model's own state variables (``Ca``) would therefore be declared, shown in every
table and accepted by ``overrides``, yet never read: the equations would use Brian2's ``dt`` or the
state variable instead. Such names are refused when the model is made
(:func:`check_parameter_names`), so that a value set on a parameter is the value the network
uses.
"""

from __future__ import annotations

import keyword
from typing import Any, Iterable, Mapping

#: Names Brian2 gives a meaning in a group's code besides those its Equations refuse (t, dt,
#: t_in_timesteps, xi, xi_*, i, N, not_refractory, lastspike): the synapses' indices, sizes,
#: delay and bookkeeping variables.
SPECIAL_NAMES = frozenset({
    "t", "dt", "t_in_timesteps", "timestep", "xi", "i", "j", "N", "N_pre", "N_post",
    "N_incoming", "N_outgoing", "i_pre", "i_post", "delay", "lastupdate", "lastspike",
    "not_refractory",
})


#: The framework rewrites the k-th ``rand()``/``randn()`` of a model's code into a call of its
#: own counter-based draw, named with one of these prefixes (astrocpg.network.noise).
DRAW_PREFIXES = ("rand_stream_", "randn_stream_")


def _brian_tables() -> tuple[Mapping[str, Any], Mapping[str, Any], Mapping[str, Any]]:
    from brian2.core.functions import DEFAULT_CONSTANTS, DEFAULT_FUNCTIONS
    from brian2.core.namespace import DEFAULT_UNITS
    return DEFAULT_UNITS, DEFAULT_FUNCTIONS, DEFAULT_CONSTANTS


def why_reserved(name: str) -> str | None:
    """Why ``name`` cannot name a parameter of any model (it would not be the value the code
    reads), or None when it can."""
    from brian2 import Equations

    from .expressions import FUNCTIONS
    from .units import UNITS

    if not isinstance(name, str) or not name.isidentifier():
        return f"a parameter's name must be an identifier, got {name!r}"
    if keyword.iskeyword(name) or name in ("True", "False", "None"):
        return f"'{name}' is a Python keyword"
    if name.startswith("_"):
        return f"'{name}' starts with an underscore (Brian2 keeps those for its own variables)"
    if name.startswith(DRAW_PREFIXES):
        return (f"'{name}' is a name astrocpg gives the draws of rand() and randn() in a "
                f"model's code")
    units, functions, constants = _brian_tables()
    if name in SPECIAL_NAMES or name.startswith("xi_"):
        return (f"'{name}' is one of Brian2's special names (t, dt, i, j, N, xi, lastspike, "
                f"not_refractory...): the code would read Brian2's {name}, not this parameter")
    if name in units or name in UNITS:
        return (f"'{name}' is the name of a Brian2 unit: the code would read the unit, not "
                f"this parameter")
    if name in functions or name in FUNCTIONS:
        return (f"'{name}' is the name of a function (Brian2's or the expressions'): the code "
                f"would call the function, not read this parameter")
    if name in constants:
        return f"'{name}' is a constant (pi, e, inf): the code would read the constant"
    try:  # any check Brian2 adds (its Equations' registered identifier checks)
        Equations.check_identifier(name)
    except SyntaxError as e:
        return f"Brian2 refuses it: {e}"
    return None


def check_parameter_names(owner: str, parameters: Iterable[str],
                          own: Mapping[str, str] | None = None) -> None:
    """Raise :class:`~astrocpg.errors.InputError` (culprit ``<owner>.<parameter>``) at the first
    parameter whose name is reserved (:func:`why_reserved`) or is one of the model's own names
    (``own``: name -> what it is, e.g. ``{"Ca": "a state variable of the equations"}``)."""
    from ..errors import InputError

    own = own or {}
    for name in parameters:
        why = why_reserved(name)
        if why is None and name in own:
            why = (f"'{name}' is also {own[name]}: the code would read that, not this "
                   f"parameter")
        if why is not None:
            raise InputError(f"cannot name a parameter: {why}; rename it",
                             culprit=f"{owner}.{name}")


__all__ = ["why_reserved", "check_parameter_names", "SPECIAL_NAMES", "DRAW_PREFIXES"]
