"""The lean step loop (network/runner.py) against Brian2's ``Network.run``: same schedule, same
states, same stops and errors, and Brian2's own loop where the lean one cannot be the same."""

from __future__ import annotations

import re

import brian2
import numpy as np
import pytest
from brian2 import (Function, Network, NetworkOperation, NeuronGroup, SpikeMonitor, Synapses,
                    ms, second)
from brian2.codegen.codeobject import CodeObject
from brian2.codegen.runtime.numpy_rt.numpy_rt import NumpyCodeObject
from brian2.core.base import BrianObjectException
from brian2.core.magic import magic_network
from brian2.units.fundamentalunits import DimensionMismatchError

from astrocpg.models import DEFAULT_MODELS
from astrocpg.network import DivergenceCheck, build_cpg, run_network
from astrocpg.network.runner import compiled_call, lean_refusal, step_calls


def _states(net: Network) -> dict[str, np.ndarray]:
    out = {"net.t_": np.asarray(float(np.asarray(net.t_)))}
    for obj in net.objects:
        for c in {obj.clock}:
            out[f"{obj.name}:clock"] = np.asarray(c.variables["timestep"].get_value()).copy()
        if hasattr(obj, "get_states"):
            for var, value in obj.get_states(units=False, read_only_variables=True).items():
                out[f"{obj.name}.{var}"] = np.asarray(value).copy()
    return out


def _same(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> None:
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].shape == b[k].shape and a[k].tobytes() == b[k].tobytes(), k


class Calls:
    """Counts ``CodeObject.__call__`` (Brian2's per-step Python path to compiled code)."""

    def __init__(self, monkeypatch) -> None:
        self.n = 0
        original = CodeObject.__call__

        def counted(codeobj, **kw):
            self.n += 1
            return original(codeobj, **kw)
        monkeypatch.setattr(CodeObject, "__call__", counted)


def _cpg(monitor: bool):
    """A one-leg CPG of two trials with its divergence check (a second clock: every 10
    steps) and, with ``monitor``, a spike monitor (dynamic arrays refreshed at every call)."""
    cpg = build_cpg(DEFAULT_MODELS, n_trials=2, seed=1, legs=("FR",))
    cpg.net.add(DivergenceCheck(cpg, every=10).operation())
    if monitor:
        motor = next(o for o in cpg.net.objects if o.name == "motor")
        cpg.net.add(SpikeMonitor(motor, name="motor_spikes"))
    return cpg


def test_the_cpg_runs_the_same_lean_and_through_brian2(monkeypatch):
    calls = Calls(monkeypatch)
    ran = {}
    for lean in (False, True):
        cpg = _cpg(monitor=True)
        calls.n = 0
        for seconds in (0.06, 0.04):  # two runs: the second one continues the first
            run_network(cpg.net, seconds * second, namespace={}, lean=lean)
        ran[lean] = (_states(cpg.net), calls.n)
    _same(ran[False][0], ran[True][0])
    assert len(ran[True][0]) > 50  # the groups' and synapses' variables were compared
    # Brian2 calls every code object through Python at every step, the lean loop none (the
    # spike monitor resizes its own arrays: no namespace entry to refresh)
    assert ran[False][1] >= 15 * 100 and ran[True][1] == 0


def test_a_lean_step_calls_compiled_code_directly():
    cpg = _cpg(monitor=False)
    run_network(cpg.net, 1 * ms, namespace={})
    active = [o for o in cpg.net.sorted_objects if o.active]
    calls, owners = step_calls(active)
    code_objects = [c for o in active for c in getattr(o, "_code_objects", [])
                    if c.compiled_code.get("run")]
    assert len(calls) >= 15 and not any(isinstance(c, CodeObject) for c in calls)
    # a code object whose namespace has entries to refresh at each call is called as Brian2
    # calls it (codeobj(): the entries first)
    codeobj = code_objects[0]
    assert compiled_call(codeobj) is not codeobj
    codeobj.nonconstant_values.append(("_unused", lambda: None))
    try:
        assert compiled_call(codeobj) is codeobj
    finally:
        codeobj.nonconstant_values.pop()


def _two_clocks(log: list, stop_at: int | None = None, stop_all: bool = False) -> Network:
    """Two groups on two clocks (0.1 ms and 0.3 ms), a synapse with a delay, and network
    operations on each clock that log the schedule; one may stop the run."""
    fast = NeuronGroup(3, "dv/dt = (1.1 - v) / (2*ms) : 1", threshold="v > 1", reset="v = 0",
                       dt=0.1 * ms, method="exact", codeobj_class=NumpyCodeObject, name="fast")
    slow = NeuronGroup(2, "dv/dt = -v / (5*ms) : 1", dt=0.3 * ms, method="exact",
                       codeobj_class=NumpyCodeObject, name="slow")
    fast.v = "i * 0.3"
    syn = Synapses(fast, slow, on_pre="v_post += 0.1", delay=0.2 * ms, dt=0.1 * ms,
                   codeobj_class=NumpyCodeObject, name="syn")
    syn.connect()
    net = Network(fast, slow, syn)

    def make(name, clock_of):
        def op():
            step = int(clock_of.clock.variables["timestep"].get_value()[0])
            log.append((name, step, float(net.t_)))
            if stop_at is not None and name == "fast_end" and step == stop_at:
                if stop_all:
                    Network._globally_stopped = True  # what Ctrl-C does in a run
                else:
                    net.stop()
        return op
    net.add(NetworkOperation(make("fast_start", fast), clock=fast.clock, when="start",
                             name="fast_start"),
            NetworkOperation(make("slow_end", slow), clock=slow.clock, when="end",
                             name="slow_end"),
            NetworkOperation(make("fast_end", fast), clock=fast.clock, when="end", order=5,
                             name="fast_end"))
    return net


@pytest.mark.parametrize("stop_at, stop_all", [(None, False), (7, False), (7, True)])
def test_several_clocks_and_stops_follow_brian2(stop_at, stop_all):
    ran = {}
    for lean in (False, True):
        log: list = []
        net = _two_clocks(log, stop_at, stop_all)
        run_network(net, 2 * ms, namespace={}, lean=lean)
        assert not Network._globally_running
        states = _states(net)
        run_network(net, 1 * ms, namespace={}, lean=lean)  # a stop ends one run only
        ran[lean] = (log, states, _states(net))
    assert ran[True][0] == ran[False][0]
    _same(ran[False][1], ran[True][1])
    _same(ran[False][2], ran[True][2])
    if stop_at is not None:
        assert float(ran[True][1]["net.t_"]) == pytest.approx((stop_at + 1) * 1e-4)


def test_an_error_in_compiled_code_is_wrapped_as_brian2_wraps_it():
    def too_large(x):
        if np.any(x > 0.5):
            raise ValueError("too large")
        return x
    explode = Function(too_large, arg_units=[1], return_unit=1)
    errors = {}
    for lean in (False, True):
        g = NeuronGroup(2, "dv/dt = 1 / ms : 1\nw = explode(v) : 1",
                        method="euler", codeobj_class=NumpyCodeObject, name="exploding")
        mon = brian2.StateMonitor(g, "w", record=True, codeobj_class=NumpyCodeObject,
                                  name="exploding_w")
        net = Network(g, mon)
        with pytest.raises(BrianObjectException) as info:
            run_network(net, 2 * ms, namespace={"explode": explode}, lean=lean)
        assert isinstance(info.value.__cause__, ValueError)
        e = info.value
        message = re.sub(r"_codeobject_\d+", "_codeobject", e._brian_message)  # 2nd network
        errors[lean] = (e._brian_objname, message, str(e.__cause__), float(g.v[0]))
    assert errors[True] == errors[False]
    assert errors[True][0] == "exploding_w" and "= explode(" in errors[True][1]


def test_a_profile_run_falls_back_to_brian2(monkeypatch):
    cpg = _cpg(monitor=False)
    net = cpg.net
    assert lean_refusal(net, 5 * ms, namespace={}) is None
    assert lean_refusal(net, 5 * ms, namespace={}, profile=True) == "a profile run"
    assert lean_refusal(net, 5 * ms, namespace={}, report="stderr") == "a report"
    assert lean_refusal(net, 5 * ms) is not None  # no namespace: Brian2 reads the frames
    assert lean_refusal(magic_network, 5 * ms, namespace={}) == "MagicNetwork has its own run"
    with pytest.raises(DimensionMismatchError):  # Brian2's own check of the units
        run_network(net, 0.005, namespace={})
    calls = Calls(monkeypatch)
    run_network(net, 5 * ms, namespace={}, profile=True)
    assert net.profiling_info and calls.n > 0  # Brian2's own loop ran, and timed each object
    calls.n = 0
    run_network(net, 5 * ms, namespace={})
    assert net._profiling_info is None and calls.n == 0
