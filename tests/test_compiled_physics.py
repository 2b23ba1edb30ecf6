"""Every trial's physics step in one call of compiled code gives what the Python loop gives,
bit for bit, warnings included; without it the robots are stepped from Python."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from astrocpg.coupling import compiled
from astrocpg.coupling.robot import RobotLayout, build_model
from astrocpg.coupling.robots import Robots


def _robots(monkeypatch, on: bool, n: int = 3) -> Robots:
    monkeypatch.setenv("ASTROCPG_COMPILED_PHYSICS", "1" if on else "0")
    model = build_model()
    robots = Robots(model, RobotLayout.from_model(model), n)
    for b in range(n):
        robots.reset(b)
    return robots


def test_the_compiled_step_is_the_python_loop_bit_for_bit(monkeypatch):
    if compiled.library() is None:
        pytest.skip("no C compiler here: the robots are stepped from Python")
    fast, slow = _robots(monkeypatch, True), _robots(monkeypatch, False)
    assert fast._compiled is not None and slow._compiled is None
    rng = np.random.default_rng(0)
    act = fast.act.ravel()
    for step in range(400):
        torques = rng.uniform(-20, 20, size=(3, len(act)))
        for r in (fast, slow):
            r.ctrl[:, act] = torques
            r.physics()
            assert not r.unstable()
        np.testing.assert_array_equal(fast.state, slow.state)
    for d_fast, d_slow in zip(fast.data, slow.data):
        np.testing.assert_array_equal(d_fast.qacc, d_slow.qacc)
        np.testing.assert_array_equal(d_fast.sensordata, d_slow.sensordata)
        assert d_fast.time == d_slow.time


def test_an_instability_warning_is_reported_by_the_compiled_step(monkeypatch):
    if compiled.library() is None:
        pytest.skip("no C compiler here")
    robots = _robots(monkeypatch, True, n=2)
    robots.physics()
    assert not robots.unstable()
    robots.qvel[1, 0] = 1e12  # beyond MuJoCo's own bound: it warns and resets the robot
    robots.data[1].qvel[0] = 1e12
    robots.physics()
    assert robots.unstable()
    assert robots.instability(0.002).trial == 1


def test_without_a_compiler_the_robots_step_from_python(monkeypatch):
    monkeypatch.setattr(compiled, "_LIBRARY", None)
    monkeypatch.setattr(compiled, "_build", lambda: (_ for _ in ()).throw(OSError("no cc")))
    robots = _robots(monkeypatch, True, n=2)
    assert robots._compiled is None
    robots.physics()
    assert robots.data[0].time == pytest.approx(robots.model.opt.timestep)
    monkeypatch.setattr(compiled, "_LIBRARY", None)  # let later tests build it again
