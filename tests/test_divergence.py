"""A simulation that leaves the numbers stops with Diverged (exit 3) naming what diverged, when,
and in which trial: a model parameter, a weights table, an unstable robot, the open-loop unit,
and a training (whose diverged session is kept as a row marked diverged)."""

from __future__ import annotations

import brian2
import numpy as np
import pytest
from brian2 import mV, second, umolar
from brian2.units.allunits import newton

from astrocpg.coupling.assembly import build_closed_loop
from astrocpg.coupling.robot import export_xml, load_robot
from astrocpg.coupling.training import SESSION_COLUMNS, Training
from astrocpg.errors import Diverged
from astrocpg.models import DEFAULT_MODELS
from astrocpg.network import DivergenceCheck, build_cpg, find_diverged, run_network


def _diverges(seconds: float = 0.5, **kw) -> Diverged:
    loop = build_closed_loop(DEFAULT_MODELS if "models" not in kw else kw.pop("models"),
                             check=False, **kw)
    with pytest.raises(Diverged) as info:
        loop.run(seconds)
    e = info.value
    assert e.exit_code == 3 and len(e.line.splitlines()) == 1
    assert e.t is not None and 0 < e.t <= seconds
    # the run stopped at the check that found it
    assert loop.bridge.step_count == round(e.t / loop.bridge.dt)
    return e


@pytest.mark.parametrize("values, culprit, t_max", [
    # the background drive is finite (1e303 V/s: its constant does not overflow, which
    # would be refused before the run) but takes v beyond 1e50 V at once
    ({"A_random": 1e300, "I_background_0": 1e6 * mV / second}, "motor.v", 0.011),
    # IP3 without bound: the Li-Rinzel terms go NaN
    ({"r_IP3": 1e306 * umolar / second}, "astrocyte.", 0.05),
    # torque traces overflow; reported as the CPG's, not as MuJoCo's bad ctrl
    ({"I_thigh": 1e308 * newton * brian2.meter}, "torque.h", 0.05),
])
def test_a_parameter_that_blows_up_the_network(values, culprit, t_max):
    e = _diverges(models=DEFAULT_MODELS.with_values(values), n_trials=2, seed=1)
    assert e.culprit.startswith(culprit), e.line
    assert e.trial in (0, 1) and e.t <= t_max  # the trial whose spikes overflowed first
    assert f"trial {e.trial}" in e.message


def test_enormous_interlimb_weights():
    w = np.full((8, 8), 1e300)  # volt
    for leg in range(4):
        w[2 * leg:2 * leg + 2, 2 * leg:2 * leg + 2] = 0.0
    e = _diverges(n_trials=1, seed=1, weights=w)
    # the weights go NaN first (0 * inf in the learning rule), then the pools' input
    assert e.culprit == "interlimb.w", e.line
    assert e.t == pytest.approx(0.010) and e.trial == 0
    assert "pool.I_interlimb" in e.message


def test_unstable_robot(tmp_path, monkeypatch):
    """The project's A1 exported to MJCF with a huge motor gear: MuJoCo's bad qacc at the first
    step (MuJoCo resets such a robot itself; the counter is read the same step)."""
    monkeypatch.chdir(tmp_path)  # MuJoCo writes its warnings to MUJOCO_LOG.TXT here
    path = tmp_path / "a1_geared.xml"
    export_xml(path)
    text = path.read_text()
    assert text.count('ctrllimited="true"/>') == 12
    path.write_text(text.replace('ctrllimited="true"/>', 'ctrllimited="true" gear="1e12"/>'))
    e = _diverges(n_trials=2, seed=1, robot=load_robot(path))
    assert e.culprit == "MuJoCo mjWARN_BADQACC", e.line
    assert e.t == pytest.approx(0.001) and e.trial == 0


def test_open_loop_unit_diverges():
    models = DEFAULT_MODELS.with_values({"r_IP3": 1e306 * umolar / second})
    cpg = build_cpg(models, n_trials=2, seed=1, legs=("FR",))
    check = DivergenceCheck(cpg, every=10)
    cpg.net.add(check.operation())
    with pytest.raises(Diverged) as info:
        run_network(cpg.net, 1 * second, namespace={})
    e = info.value
    assert e.culprit.startswith("astrocyte.") and e.trial == 0
    assert 0 < e.t <= 0.05 and e.t == pytest.approx(float(cpg.net.t_) + float(cpg.dt))
    # after a run: the last steps are covered by check()
    cpg2 = build_cpg(models, n_trials=1, seed=1, legs=("FR",))
    cpg2.net.run(0.05 * second, namespace={})
    with pytest.raises(Diverged):
        DivergenceCheck(cpg2).check()
    assert build_cpg(DEFAULT_MODELS, n_trials=1, seed=1).first_invalid() is None


def test_find_diverged_through_wrapping():
    d = Diverged("nan in motor", culprit="motor.v", t=0.1, trial=2)
    try:
        try:
            raise d
        except Diverged as inner:
            raise brian2.core.base.BrianObjectException("during run", brian2.Network()) \
                from inner
    except Exception as outer:
        assert find_diverged(outer) is d
    assert find_diverged(ValueError("x")) is None


def _poison_at(loop, step: int, trial: int) -> None:
    """At the end of physics step ``step``, an astrocyte of ``trial`` gets a NaN."""
    ca = loop.cpg.array("astrocyte", "Ca")
    k = trial * loop.cpg.layout.thigh_pools_per_trial + 3

    def poison() -> None:
        if loop.bridge.step_count == step:
            ca[k] = np.nan

    loop.bridge.add_hook("after_physics", "poison", poison, order=0)


@pytest.mark.parametrize("check_every, found_at, last_length", [
    (7, 28, 0.008),  # the bridge's check at step 28, inside trial 1's 3rd session
    (0, 30, 0.010),  # no periodic check: the check at the session end (step 30)
])
def test_training_keeps_the_diverged_session(check_every, found_at, last_length):
    models = DEFAULT_MODELS.with_values({"L_max": 0.01 * second})  # 10-step sessions
    loop = build_closed_loop(models, n_trials=2, seed=1, check=False, check_every=check_every)
    training = Training(loop.cpg, loop.bridge, models, n_sessions=5)
    _poison_at(loop, 25, trial=1)
    with pytest.raises(Diverged) as info:
        loop.run(1.0)
    e = info.value
    assert e.culprit == "astrocyte.Ca" and e.trial == 1
    assert e.t == pytest.approx(found_at * 1e-3)
    rows = training.memory.rows
    assert [(r["trial"], r["session"], r["diverged"]) for r in rows] == [
        (0, 1, 0), (1, 1, 0), (0, 2, 0), (1, 2, 0), (1, 3, 1)]
    assert all(set(r) == set(SESSION_COLUMNS) for r in rows)
    # the diverged session ran until the end of the step in which it was found
    assert rows[-1]["length_s"] == pytest.approx(last_length)
    assert rows[2]["length_s"] == pytest.approx(0.010)
    assert training.sessions_done.tolist() == [2, 3]
    assert len(training.memory.weights[1]) == 3


def test_trainer_writes_the_diverged_row(tmp_path):
    import csv

    from astrocpg.models.compose import model_set
    from astrocpg.studies.commands.train import Trainer, TrainSettings

    settings = TrainSettings(n_sessions=5, seed=1, n_trials=1, astrocytes=True,
                             overrides=["L_max=0.01*second"])
    trainer = Trainer(model_set(settings.overrides), settings, tmp_path, progress=False)
    _poison_at(trainer, 25, trial=0)
    with pytest.raises(Diverged):
        trainer.run()  # writes the outputs, then raises
    with open(tmp_path / "sessions.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert list(rows[0]) == list(SESSION_COLUMNS)
    assert [r["diverged"] for r in rows] == ["0", "0", "1"]


def test_a_constant_that_overflows_names_its_parameter() -> None:
    """A finite parameter whose arithmetic leaves the floats (Brian2 computes a code object's
    constants in Python floats: OverflowError) is refused as bad input naming the largest
    parameter of the line, not an internal error."""
    import brian2

    from astrocpg.errors import InputError
    from astrocpg.network.divergence import run_network

    group = brian2.NeuronGroup(1, "dv/dt = -v/tau + 1/(big - small)**2/second : 1",
                               namespace={"big": 1e200, "small": 1.0, "tau": 10 * brian2.ms},
                               name="overflowing", codeobj_class=brian2.NumpyCodeObject)
    net = brian2.Network(group)
    with pytest.raises(InputError) as e:
        run_network(net, 1 * brian2.ms, namespace={})
    assert e.value.culprit == "big=1e+200" and "overflow" in e.value.message


@pytest.mark.parametrize("target", ["numpy", pytest.param("cython", marks=pytest.mark.slow)])
def test_a_constant_that_overflows_is_refused_on_every_target(target: str) -> None:
    """Compiled code computes an overflowing constant as inf (or 1/inf as 0) without a word and
    runs on with it: the constants are checked before the first step, whatever the target, and
    refused the same way (the code objects' own loop-invariants, numpy errors raised)."""
    import brian2

    from astrocpg.errors import InputError
    from astrocpg.network.divergence import run_network

    if target == "cython":
        pytest.importorskip("Cython")
    codeobj = {"numpy": brian2.NumpyCodeObject}.get(target)
    if codeobj is None:
        from brian2.codegen.runtime.cython_rt.cython_rt import CythonCodeObject as codeobj
    group = brian2.NeuronGroup(1, "dv/dt = -v/tau + 1/(big - small)**2/second : 1",
                               namespace={"big": 1e200, "small": 1.0, "tau": 10 * brian2.ms},
                               name=f"overflowing_{target}", codeobj_class=codeobj)
    net = brian2.Network(group)
    with pytest.raises(InputError) as e:
        run_network(net, 1 * brian2.ms, namespace={})
    assert e.value.culprit == "big=1e+200" and "overflow" in e.value.message, e.value
    assert float(group.v[0]) == 0.0  # refused before its first step


def test_plausible_constants_run() -> None:
    """The check refuses only what overflows: the same equations at plausible sizes run."""
    import brian2

    from astrocpg.network.divergence import run_network

    group = brian2.NeuronGroup(1, "dv/dt = -v/tau + 1/(big - small)**2/second : 1",
                               namespace={"big": 3.0, "small": 1.0, "tau": 10 * brian2.ms},
                               name="plausible", codeobj_class=brian2.NumpyCodeObject)
    run_network(brian2.Network(group), 1 * brian2.ms, namespace={})
    assert float(group.v[0]) > 0
