"""Every trial's physics step in one call of compiled code gives what the Python loop gives,
bit for bit, warnings included; without it the robots are stepped from Python."""

from __future__ import annotations

import json

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


# ---------------------------------------------------------------- the switch and the cache
@pytest.mark.parametrize("value, on", [("0", False), ("false", False), ("FALSE", False),
                                       ("no", False), (" Off ", False), ("1", True),
                                       ("true", True), ("Yes", True), ("on", True), ("", True)])
def test_the_switch_is_a_boolean(monkeypatch, value, on):
    from astrocpg.support.environment import flag

    monkeypatch.setenv("ASTROCPG_COMPILED_PHYSICS", value)
    assert flag("ASTROCPG_COMPILED_PHYSICS") is on
    if not on:
        assert compiled.library() is None
        assert compiled.state() == "python (ASTROCPG_COMPILED_PHYSICS off)"


@pytest.mark.parametrize("name", ["ASTROCPG_COMPILED_PHYSICS", "ASTROCPG_DEBUG"])
def test_a_switch_that_is_not_a_boolean_is_refused_naming_it(monkeypatch, tmp_path, capsys,
                                                              name):
    from astrocpg.errors import InputError
    from astrocpg.studies.cli import main

    monkeypatch.setenv(name, "maybe")
    if name == "ASTROCPG_COMPILED_PHYSICS":
        with pytest.raises(InputError, match=name):
            compiled.library()
    code = main(["run", "--seconds", "0.01", "--no-progress", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith(f"astrocpg: error: {name}:"), err
    assert not (tmp_path / "o").exists()


def test_the_manifest_records_the_environment(monkeypatch, tmp_path, capsys):
    from astrocpg.studies.cli import main

    monkeypatch.setenv("ASTROCPG_COMPILED_PHYSICS", "off")
    assert main(["run", "--seconds", "0.01", "--no-progress", "--out", str(tmp_path / "o")]) == 0
    env = json.loads((tmp_path / "o" / "manifest.json").read_text())["environment"]
    assert env["ASTROCPG_COMPILED_PHYSICS"] == "off"
    assert env["physics"] == "python (ASTROCPG_COMPILED_PHYSICS off)"
    assert "ASTROCPG_CODEGEN" in env


@pytest.fixture
def own_cache(monkeypatch, tmp_path):
    """An empty cache of this test's own, and a library built afresh in it."""
    monkeypatch.setenv("ASTROCPG_CACHE", str(tmp_path / "cache"))
    monkeypatch.setenv("ASTROCPG_COMPILED_PHYSICS", "1")
    monkeypatch.setattr(compiled, "_LIBRARY", None)
    monkeypatch.setattr(compiled, "PROBLEM", None)
    yield compiled._target()
    monkeypatch.setattr(compiled, "_LIBRARY", None)  # later tests load the usual one again


def _needs_a_compiler() -> None:
    import shutil
    import sysconfig

    if not shutil.which((sysconfig.get_config_var("CC") or "cc").split()[0]):
        pytest.skip("no C compiler here")


def test_a_corrupt_cached_library_is_rebuilt(own_cache):
    _needs_a_compiler()
    own_cache.parent.mkdir(parents=True)
    own_cache.write_bytes(b"\x7fELF not really a library")
    lib = compiled.library()
    assert lib is not None and hasattr(lib, "astrocpg_step_all")
    assert own_cache.read_bytes()[:4] == b"\x7fELF" and own_cache.stat().st_size > 1000
    assert compiled.state() == "compiled"


def test_a_cached_library_without_the_loop_is_rebuilt(own_cache):
    import subprocess
    import sysconfig

    _needs_a_compiler()
    own_cache.parent.mkdir(parents=True)
    src = own_cache.parent / "other.c"
    src.write_text("int something_else(void) { return 1; }\n")
    cc = (sysconfig.get_config_var("CC") or "cc").split()
    subprocess.run([*cc, "-shared", "-fPIC", "-o", str(own_cache), str(src)], check=True)
    lib = compiled.library()  # the old code: AttributeError, an internal error on every run
    assert lib is not None and hasattr(lib, "astrocpg_step_all")
    robots = _robots_here(n=2)
    assert robots._compiled is not None
    robots.physics()


def _robots_here(n: int) -> Robots:
    model = build_model()
    robots = Robots(model, RobotLayout.from_model(model), n)
    for b in range(n):
        robots.reset(b)
    return robots


def test_a_bad_library_that_cannot_be_rebuilt_warns_and_steps_from_python(own_cache,
                                                                         monkeypatch):
    import subprocess

    own_cache.parent.mkdir(parents=True)
    own_cache.write_bytes(b"garbage")

    def fail(target):
        raise subprocess.CalledProcessError(1, "cc")

    monkeypatch.setattr(compiled, "_compile", fail)
    with pytest.warns(RuntimeWarning, match="stepped from Python"):
        assert compiled.library() is None
    assert "building it again failed" in compiled.state()
    robots = _robots_here(n=2)
    assert robots._compiled is None
    robots.physics()
    assert robots.data[0].time == pytest.approx(robots.model.opt.timestep)


def test_the_command_line_says_when_the_physics_fell_back(own_cache, monkeypatch, tmp_path,
                                                          capsys):
    import subprocess

    from astrocpg.studies.cli import main

    own_cache.parent.mkdir(parents=True)
    own_cache.write_bytes(b"garbage")
    monkeypatch.setattr(compiled, "_compile",
                        lambda target: (_ for _ in ()).throw(subprocess.CalledProcessError(1, "cc")))
    assert main(["run", "--seconds", "0.01", "--no-progress", "--out", str(tmp_path / "o")]) == 0
    out = capsys.readouterr().out
    assert "warning: the compiled physics cannot be used" in out, out
    env = json.loads((tmp_path / "o" / "manifest.json").read_text())["environment"]
    assert env["physics"].startswith("python (the compiled physics cannot be used")


def test_the_feet_touch_sensors_gathered_by_compiled_code_are_the_trials_own(monkeypatch):
    """``touch_into`` copies every trial's four touch sensors in one compiled call (recorders and
    senses read them every step): the values are each MjData's own, as the Python copy gives."""
    if compiled.library() is None:
        pytest.skip("no C compiler here")
    fast, slow = _robots(monkeypatch, True, n=4), _robots(monkeypatch, False, n=4)
    rng = np.random.default_rng(1)
    act = fast.act.ravel()
    seen_contact = False
    for step in range(300):
        torques = rng.uniform(-20, 20, size=(4, len(act)))
        for r in (fast, slow):
            r.ctrl[:, act] = torques
            r.physics()
        got_fast, got_slow = np.full((4, 4), np.nan), np.full((4, 4), np.nan)
        assert fast.touch_into(got_fast) and slow.touch_into(got_slow)
        assert fast._touch_batch[1] is not None and slow._touch_batch[1] is None
        want = np.array([d.sensordata[fast.layout.touch_adr] for d in fast.data])
        np.testing.assert_array_equal(got_fast, want)
        np.testing.assert_array_equal(got_slow, want)
        seen_contact |= bool((want > 0).any())
    assert seen_contact  # the feet touched the ground: the copy was not of zeros only


def test_the_compiled_robot_sample_is_what_numpy_copies(monkeypatch):
    """A run's robot recording takes every trial's sample in one compiled call
    (``Recording.taker``): joint angles, torques as applied (clamped to the motors' range, NaN
    kept), torso position, velocity and quaternion, reward, alive and the feet's sensors are
    what ``Recording.take`` copies with numpy, sample for sample, on a stride of 3."""
    from types import SimpleNamespace

    from astrocpg.coupling.robot_recording import Recording

    if compiled.library() is None:
        pytest.skip("no C compiler here")
    robots = _robots(monkeypatch, True, n=4)
    senses = SimpleNamespace(reward=np.zeros(4), alive=np.ones(4, dtype=bool))
    fast_rec, slow_rec = (Recording.allocate(4, 300, 3, 0.001) for _ in range(2))
    fast = fast_rec.taker(robots, senses)
    assert "lambda" not in fast.__qualname__  # the compiled one, not the numpy fallback
    rng = np.random.default_rng(2)
    act = robots.act.ravel()
    for step in range(1, 301):
        robots.ctrl[:, act] = rng.uniform(-60, 60, size=(4, len(act)))  # beyond the range too
        robots.physics()
        if step % 50 == 0:  # NaN torques (the network diverging) are recorded as NaN
            robots.ctrl[1, act[0]] = np.nan
        senses.reward[:] = rng.normal(size=4)
        senses.alive[:] = rng.random(4) < 0.5
        fast(step)
        slow_rec.take(step, robots, senses)
    for name in ("joint_angles", "torques", "torso_position", "torso_velocity",
                 "torso_quaternion", "reward", "alive", "foot_force"):
        np.testing.assert_array_equal(getattr(fast_rec, name), getattr(slow_rec, name),
                                      err_msg=name)
    assert np.isnan(fast_rec.torques).any() and (fast_rec.foot_force > 0).any()
    assert np.abs(fast_rec.torques[np.isfinite(fast_rec.torques)]).max() < 60


def test_without_the_compiled_step_the_robot_sample_is_taken_with_numpy(monkeypatch):
    from types import SimpleNamespace

    from astrocpg.coupling.robot_recording import Recording

    robots = _robots(monkeypatch, False, n=2)
    senses = SimpleNamespace(reward=np.ones(2), alive=np.ones(2, dtype=bool))
    rec = Recording.allocate(2, 10, 1, 0.001)
    take = rec.taker(robots, senses)
    robots.physics()
    take(1)
    np.testing.assert_array_equal(rec.torso_position[:, 0], robots.torso["position"])
    assert rec.reward[:, 0].tolist() == [1.0, 1.0]
