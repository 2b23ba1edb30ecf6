"""The loop closes: `astrocpg run` moves the robot, the thighs swing, torques follow spikes,
batched trials are independent, and an edited equation string takes effect."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from astrocpg.studies.cli import main


def _run(out: Path, *args: str) -> dict:
    code = main(["run", "--no-progress", "--out", str(out), *args])
    assert code == 0
    return {
        "robot": np.load(out / "robot.npz"),
        "spikes": np.load(out / "spikes.npz"),
        "manifest": json.loads((out / "manifest.json").read_text()),
    }


@pytest.fixture(scope="module")
def ten_seconds(tmp_path_factory):
    return _run(tmp_path_factory.mktemp("run10"), "--seconds", "10", "--seed", "1")


def _reversals(angle: np.ndarray, min_swing: float = 0.05) -> int:
    """Direction reversals of a joint: turning points that the angle leaves by at least
    ``min_swing`` rad (so noise and small wobbles don't count)."""
    turns, direction, hi, lo = 0, 0, angle[0], angle[0]
    for a in angle[1:]:
        if direction >= 0:
            hi = max(hi, a)
        if direction <= 0:
            lo = min(lo, a)
        if direction >= 0 and a < hi - min_swing:
            turns += direction > 0
            direction, lo = -1, a
        elif direction <= 0 and a > lo + min_swing:
            turns += direction < 0
            direction, hi = 1, a
    return turns


def test_reversal_counter():
    t = np.linspace(0, 5, 5000)
    assert _reversals(np.sin(2 * np.pi * 2 * t)) == 20  # 10 cycles: 20 turning points
    assert _reversals(0.01 * np.sin(2 * np.pi * 2 * t)) == 0  # below min_swing


@pytest.mark.slow
def test_outputs_and_manifest(ten_seconds):
    m = ten_seconds["manifest"]
    assert m["seed"] == 1 and m["settings"]["seconds"] == 10
    assert "brian2" in m["package_versions"] and "mujoco" in m["package_versions"]
    assert m["models"]["motor_neuron"]["parameters"]["tau_motor"]["value"] == "9. ms"
    spikes = ten_seconds["spikes"]
    for pop in ("motor", "interneuron", "astrocyte"):
        assert f"{pop}_times" in spikes and f"{pop}_indices" in spikes
    assert len(spikes["motor_times"]) > 10_000


@pytest.mark.slow
def test_robot_moves_and_every_thigh_reverses(ten_seconds):
    rob = ten_seconds["robot"]
    pos = rob["torso_position"][0]
    assert np.linalg.norm(pos[-1, :2] - pos[0, :2]) > 0.05
    thighs = rob["joint_angles"][0, :, :, 1]  # (t, leg)
    for leg, name in enumerate(("FR", "FL", "RR", "RL")):
        n = _reversals(thighs[:, leg])
        assert n >= 10, f"{name} thigh reversed {n} times"


@pytest.mark.slow
def test_thigh_torque_follows_extensor_minus_flexor(ten_seconds):
    rob, spikes = ten_seconds["robot"], ten_seconds["spikes"]
    t, i = spikes["motor_times"], spikes["motor_indices"]
    steps = rob["t"].size
    torque = rob["torques"][0, :, :, 1]  # thigh torque (t, leg)
    tau_h, dt = 0.1, 1e-3
    for leg in range(4):
        def count(pool):
            lo = (leg * 4 + pool) * 20
            sel = (i >= lo) & (i < lo + 20)
            return np.bincount(np.round(t[sel] / dt).astype(int), minlength=steps + 1)[:steps]
        drive = count(1) - count(0)  # extensor minus flexor spikes per step
        # the activity difference filtered by the torque trace's decay
        filtered = np.zeros(steps)
        acc = 0.0
        decay = np.exp(-dt / tau_h)
        for k in range(steps):
            acc = (acc + drive[k]) * decay
            filtered[k] = acc
        strong = np.abs(torque[:, leg]) > 0.5
        agree = np.sign(torque[strong, leg]) == np.sign(filtered[strong])
        assert agree.mean() > 0.97, f"leg {leg}: sign agreement {agree.mean():.3f}"
        assert np.corrcoef(torque[:, leg], filtered)[0, 1] > 0.95


@pytest.mark.slow
def test_batched_trials_differ(tmp_path):
    r = _run(tmp_path / "b4", "--seconds", "2", "--seed", "3", "--trials", "4")
    pos = r["robot"]["torso_position"]
    assert pos.shape[0] == 4
    finals = pos[:, -1, :2]
    for a in range(4):
        for b in range(a + 1, 4):
            assert np.linalg.norm(finals[a] - finals[b]) > 1e-4
    i = r["spikes"]["motor_indices"]
    per_trial = np.bincount(i // 320, minlength=4)
    assert np.all(per_trial > 0) and len(set(per_trial)) == 4


@pytest.mark.slow
def test_edited_equation_takes_effect_in_run(tmp_path):
    """Add a term to the motor neuron's equation string; no edit to network/ or coupling/."""
    from astrocpg.models.motor_neuron import EQUATIONS

    edited = EQUATIONS.replace(
        "+ int(not_refractory)*I_input", "+ int(not_refractory)*(I_input - I_extra)") + \
        "I_extra = 700*mV/second : volt/second\n"
    assert edited != EQUATIONS
    eqs = tmp_path / "motor.txt"
    eqs.write_text(edited)
    base = _run(tmp_path / "base", "--seconds", "2", "--seed", "2")
    changed = _run(tmp_path / "edit", "--seconds", "2", "--seed", "2",
                   "--equations", f"motor_neuron={eqs}")
    r0 = base["manifest"]["results"]["rate_per_neuron_Hz"]
    r1 = changed["manifest"]["results"]["rate_per_neuron_Hz"]
    assert "I_extra" in changed["manifest"]["models"]["motor_neuron"]["equations"]
    for pool in ("thigh_flexor", "thigh_extensor", "calf_flexor", "calf_extensor"):
        assert r1[pool][0] < 0.7 * r0[pool][0], (pool, r0[pool], r1[pool])


@pytest.mark.slow
def test_runs_a_user_supplied_a1(tmp_path, reference_a1_path):
    """--robot takes any MJCF with the A1's joint and motor names (here the authors' model)."""
    r = _run(tmp_path / "user", "--seconds", "1", "--robot", str(reference_a1_path))
    assert r["manifest"]["results"]["robot"]["file"] == str(reference_a1_path)
    q = r["robot"]["joint_angles"][0, :, :, 1]
    assert np.ptp(q, axis=0).min() > 0.05  # every thigh moved
