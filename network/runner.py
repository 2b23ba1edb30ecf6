"""A lean ``Network.run``: Brian2's own preparation, then a step loop that calls each scheduled
object's compiled code directly, so that the 1 ms step costs the compiled code, not Python.

``Network.run`` reaches the compiled code of each of the ~22 code objects of a step through
four Python calls (``obj.run()`` -> ``codeobj()`` -> ``update_namespace`` -> ``run_block`` ->
``main(namespace)``); with 20 trials that Python is a large share of the step. :func:`run`
does what ``Network.run`` does, in the same order, with the same objects:

* before the loop, everything is Brian2's: ``gc.collect()``, the clocks' intervals,
  ``Network.before_run`` (code generation, namespaces, checks);
* each step, in Brian2's schedule (``net.sorted_objects``: ``when``/``order``, the active
  objects only, the objects of the clocks due in that step when there are several clocks,
  chosen by Brian2's own ``Network._nextclocks``), it calls a Cython code object's compiled
  ``main(namespace)``, which is what its ``run_block`` does, and a numpy code object's own
  ``run_block("run")`` (what ``codeobj()`` comes down to). A code object whose namespace holds non-constant entries
  (dynamic arrays that a monitor resizes) is called as Brian2 calls it (``codeobj()``: the
  entries are refreshed first); a network operation is called as ``NetworkOperation.run`` calls
  it; an object whose ``run`` is its own (neither ``BrianObject.run`` nor
  ``NetworkOperation.run``, or replaced on the instance) has that ``run`` called;
* the network's time ``net.t_`` is set at each step, the clocks are advanced with the same
  arithmetic, ``net.stop()`` and Brian2's Ctrl-C stop request (``Network._globally_stopped``)
  end the loop at the end of the step, ``Network._globally_running`` is set as Brian2 sets it;
* after the loop: ``net.t_``, the device's last-run figures, the groups' end-of-run check of
  invalid states, ``Network.after_run``, as Brian2 leaves them. An error in compiled code is
  raised wrapped in the same ``BrianObjectException`` as ``run_block`` raises.

The results are bit-identical to ``Network.run`` (``benchmarks/behaviour.py --check``).

It calls ``net.run`` instead (Brian2's loop, same results) when it could not keep Brian2's
semantics: a ``profile`` run (Brian2 times each object), a ``report``, no ``namespace`` (Brian2
reads the caller's frame), a duration without a time unit (Brian2 raises the error), a device
other than Brian2's runtime device or one that overrides ``network_run``, a maximum run time
set on the device, or a network class with its own ``run``. :func:`lean_refusal` says which.
"""

from __future__ import annotations

import gc
import time
from functools import partial
from typing import Any, Callable

from brian2.codegen.codeobject import CodeObject
from brian2.codegen.runtime.numpy_rt.numpy_rt import NumpyCodeObject
from brian2.core.base import BrianObject, BrianObjectException
from brian2.core.network import Network
from brian2.core.network import logger as network_log  # Brian2's run messages, as its own
from brian2.core.operations import NetworkOperation
from brian2.devices.device import RuntimeDevice, get_device
from brian2.groups.group import Group
from brian2.units.allunits import second
from brian2.units.fundamentalunits import Quantity

from .invariants import check_constants

try:  # Brian2 registers its Cython target only where Cython is installed
    from brian2.codegen.runtime.cython_rt.cython_rt import CythonCodeObject
except ImportError:  # pragma: no cover - Cython is a dependency of astrocpg
    CythonCodeObject = None  # type: ignore[assignment,misc]

#: Brian2's ``Network.run`` as the class defines it: a network class whose ``run`` is another
#: (``MagicNetwork``, a subclass of the user's) is run by its own ``run``.
_BRIAN_RUN = Network.run


def lean_refusal(net: Network, duration: Any, report: Any = None, namespace: Any = None,
                 profile: Any = None, level: int = 0, report_period: Any = 10 * second,
                 **other: Any) -> str | None:
    """Why :func:`run` hands this run to ``net.run`` (a short reason), or None when it runs it
    itself."""
    if other:
        return f"unknown arguments {sorted(other)}"
    if not _is_time(report_period):
        return "a report period without a time unit (Brian2 raises the error)"
    if type(net).run is not _BRIAN_RUN:
        return f"{type(net).__name__} has its own run"
    if report is not None:
        return "a report"
    if namespace is None:
        return "no namespace (Brian2 reads the caller's frame)"
    if not _is_time(duration):
        return "a duration without a time unit (Brian2 raises the error)"
    device = get_device()
    if type(device) is not RuntimeDevice or hasattr(device, "network_run"):
        return f"device {type(device).__name__}"
    if profile is None:
        profile = device.build_options.get("profile", False)
    if profile:
        return "a profile run"
    if device._maximum_run_time is not None:
        return "a maximum run time"
    return None


def _is_time(value: Any) -> bool:
    """What ``Network.run``'s ``check_units(duration=second)`` accepts without an error."""
    return isinstance(value, Quantity) and value.dim == second.dim


def run(net: Network, duration: Any, report: Any = None, report_period: Any = 10 * second,
        namespace: Any = None, profile: Any = None, level: int = 0) -> None:
    """``net.run(duration, ...)`` with the lean step loop (see the module's docstring); the
    same arguments. Falls back to ``net.run`` where :func:`lean_refusal` gives a reason."""
    if lean_refusal(net, duration, report=report, namespace=namespace, profile=profile,
                    level=level, report_period=report_period) is not None:
        net.run(duration, report=report, report_period=report_period, namespace=namespace,
                profile=profile, level=level + 1)
        return
    # -- as Network.run, up to its loop
    if duration < 0:
        raise ValueError(f"Function 'run' expected a non-negative duration but got "
                         f"'{duration}'")
    gc.collect()  # Brian2's warnings for objects left out of the network
    device = get_device()
    all_objects = net.sorted_objects
    net._clocks = {obj.clock for obj in all_objects}
    single_clock = len(net._clocks) == 1
    t_start = net.t
    t_end = net.t + duration
    if single_clock:
        clock = next(iter(net._clocks))
        clock.set_interval(net.t, t_end)
    else:
        net._clock_variables = {c: (c.variables["timestep"].get_value(),
                                    c.variables["t"].get_value(),
                                    c.variables["dt"].get_value()) for c in net._clocks}
        for c in net._clocks:
            c.set_interval(net.t, t_end)
    net.before_run(namespace)
    # a constant of the equations that overflows is refused on every code generation (the
    # numpy target would stop on it at the first step; compiled code would run on with inf)
    check_constants(net)
    if len(all_objects) == 0:
        return
    start_time = time.time()
    network_log.debug(f"Simulating network '{net.name}' from time {t_start} to {t_end}.", "run")
    active = [obj for obj in all_objects if obj.active]
    if single_clock:
        clock = _single_clock_loop(net, clock, active)
    else:
        clock = _multi_clock_loop(net, active)
    # -- as Network.run, after its loop
    end_time = time.time()
    Network._globally_running = False
    if net._stopped or Network._globally_stopped:
        net.t_ = clock.t_
    else:
        net.t_ = float(t_end)
    device._last_run_time = end_time - start_time
    if duration > 0:
        device._last_run_completed_fraction = (net.t - t_start) / duration
    else:
        device._last_run_completed_fraction = 1.0
    for obj in all_objects:
        if isinstance(obj, Group):
            obj._check_for_invalid_states()
    net.after_run()
    network_log.debug(f"Finished simulating network '{net.name}' "
                      f"(took {end_time - start_time:.2f}s)", "run")
    net._profiling_info = None


def _single_clock_loop(net: Network, clock: Any, active: list) -> Any:
    """Brian2's loop for one clock, each object's compiled code called directly."""
    timestep = clock.variables["timestep"].get_value()
    t = clock.variables["t"].get_value()
    dt = clock.variables["dt"].get_value()
    calls, owners = step_calls(active)
    running = timestep[0] < clock._i_end
    i_end = clock._i_end
    Network._globally_running = True
    i = -1
    try:
        while running and not net._stopped and not Network._globally_stopped:
            net.t_ = t[0]
            for i, call in enumerate(calls):
                call()
            timestep[0] += 1
            t[0] = timestep[0] * dt[0]
            running = timestep[0] < i_end
    except Exception as exc:
        _reraise(exc, owners[i])
    return clock


def _multi_clock_loop(net: Network, active: list) -> Any:
    """Brian2's loop for several clocks: the clocks due are Brian2's ``_nextclocks``; the calls
    of each set of clocks are made once."""
    plans: dict[frozenset, tuple[list, list]] = {}
    clock, curclocks = net._nextclocks()
    timestep, _, _ = net._clock_variables[clock]
    running = timestep[0] < clock._i_end
    Network._globally_running = True
    owners: list = []
    i = -1
    try:
        while running and not net._stopped and not Network._globally_stopped:
            timestep, t, dt = net._clock_variables[clock]
            net.t_ = t[0]
            key = frozenset(curclocks)
            plan = plans.get(key)
            if plan is None:
                plan = plans[key] = step_calls([o for o in active if o._clock in curclocks])
            calls, owners = plan
            for i, call in enumerate(calls):
                call()
            for c in curclocks:
                timestep, t, dt = net._clock_variables[c]
                timestep[0] += 1
                t[0] = timestep[0] * dt[0]
            clock, curclocks = net._nextclocks()
            timestep, _, _ = net._clock_variables[clock]
            running = timestep[0] < clock._i_end
    except Exception as exc:
        _reraise(exc, owners[i])
    return clock


def step_calls(objects: list) -> tuple[list[Callable[[], Any]], list[Any]]:
    """The calls of one step for ``objects`` (in their order), and for each call what raised
    an error is attributed to: a code object (its error is wrapped as its ``run_block`` wraps
    it) or None (the error leaves as it is, as from ``obj.run()``)."""
    calls: list[Callable[[], Any]] = []
    owners: list[Any] = []
    for obj in objects:
        own_run = "run" in vars(obj)
        if not own_run and type(obj).run is NetworkOperation.run:
            calls.append(obj.run if obj._has_arg else obj.function)  # as its run() calls it
            owners.append(None)
        elif not own_run and type(obj).run is BrianObject.run:
            for codeobj in obj._code_objects:
                call = compiled_call(codeobj)
                if call is _NOTHING:
                    continue
                calls.append(call)
                # Brian2 wraps the errors of codeobj() and of run_block itself
                by_brian = call is codeobj or getattr(call, "func", None) == codeobj.run_block
                owners.append(None if by_brian else codeobj)
        else:
            calls.append(obj.run)
            owners.append(None)
    return calls, owners


_NOTHING = object()


def compiled_call(codeobj: Any) -> Any:
    """What ``codeobj()`` comes down to, as one call: its compiled ``main(namespace)``
    (Cython) or its ``run_block("run")`` (numpy); ``codeobj`` itself where its namespace has
    entries to refresh or its class is not one of Brian2's two runtime targets; ``_NOTHING``
    for an empty block (``run_block`` does nothing)."""
    cls = codeobj.__class__
    if ("__call__" in vars(codeobj) or "run" in vars(codeobj)
            or cls.__call__ is not CodeObject.__call__ or cls.run is not CodeObject.run
            or codeobj.nonconstant_values):
        return codeobj
    block = codeobj.compiled_code.get("run")
    if CythonCodeObject is not None and issubclass(cls, CythonCodeObject) \
            and cls.run_block is CythonCodeObject.run_block \
            and cls.update_namespace is CythonCodeObject.update_namespace:
        return partial(block.main, codeobj.namespace) if block else _NOTHING
    if issubclass(cls, NumpyCodeObject) \
            and cls.update_namespace is NumpyCodeObject.update_namespace:
        # Brian2's own run_block executes the numpy code (the package never executes code
        # itself: tests/test_checkpoint_format.py) and wraps its errors
        return partial(codeobj.run_block, "run") if block else _NOTHING
    return codeobj


def _reraise(exc: Exception, codeobj: Any) -> None:
    """Raise ``exc`` as Brian2 would have: wrapped as the code object's ``run_block`` wraps it,
    or as it is."""
    if codeobj is None:
        raise exc
    message = (f"An exception occured during the execution of the 'run' block of code object "
               f"'{codeobj.name}'.\n")
    raise BrianObjectException(message, codeobj.owner) from exc


__all__ = ["run", "lean_refusal", "step_calls", "compiled_call"]
