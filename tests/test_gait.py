"""Gait labels from leg phases, and the commands that use a training folder."""

from __future__ import annotations

import numpy as np
import pytest

from astrocpg.studies.cli import main
from astrocpg.studies.analysis.gait import phase_label, phase_matrix

LOCKED = {leg: 0.95 for leg in ("FR", "FL", "RR", "RL")}


@pytest.mark.parametrize("phases,label", [
    ({"FR": 0.0, "FL": 0.5, "RR": 0.52, "RL": 0.03}, "trot"),
    ({"FR": 0.0, "FL": 0.5, "RR": 0.02, "RL": 0.45}, "pace"),
    ({"FR": 0.0, "FL": 0.97, "RR": 0.5, "RL": 0.55}, "bound"),
    ({"FR": 0.0, "FL": 0.5, "RR": 0.75, "RL": 0.25}, "walk"),
    ({"FR": 0.0, "FL": 0.3, "RR": 0.6, "RL": 0.1}, "none"),
])
def test_labels(phases, label):
    assert phase_label(phases, LOCKED) == label


def test_unstable_phases_are_no_gait():
    phases = {"FR": 0.0, "FL": 0.5, "RR": 0.5, "RL": 0.0}
    assert phase_label(phases, {**LOCKED, "RR": 0.3}) == "none"


def test_phase_matrix_is_antisymmetric_mod_one():
    m = phase_matrix({"FR": 0.0, "FL": 0.5, "RR": 0.25, "RL": 0.1})
    assert np.allclose((m + m.T) % 1.0, 0.0)


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("g") / "run"
    assert main(["train", "--out", str(out), "--sessions", "2", "--trials", "2", "--no-progress",
                 "--set", "L_max=0.5*second"]) == 0
    return out


@pytest.mark.slow
def test_gait_plot_and_replay(trained, capsys, tmp_path):
    capsys.readouterr()
    assert main(["gait", str(trained), "--seconds", "3", "--repeats", "1", "--no-progress"]) == 0
    out = capsys.readouterr().out
    # a line per run (both measures named) and a summary per table
    runs = [x for x in out.splitlines() if x.startswith("table ") and " repeat " in x]
    tables = [x for x in out.splitlines() if x.startswith(("table 0:", "table 1:"))]
    assert len(runs) == 2 and len(tables) == 2, out
    assert all("rhythm (thigh-extensor bursts)" in x and "gait (footfalls)" in x for x in runs)
    assert "relative to FR" in out
    assert main(["plot", str(trained), "--seconds", "3"]) == 0
    for name in ("weights.png", "training.png", "thigh_extensor_activity.png", "gait.png"):
        assert (trained / "figures" / name).stat().st_size > 5000, name
    assert main(["run", "--weights", str(trained), "--trial", "1", "--seconds", "1",
                 "--no-progress", "--out", str(tmp_path / "replay")]) == 0
    with np.load(tmp_path / "replay" / "robot.npz") as z, np.load(trained / "weights.npz") as w:
        assert np.allclose(z["interlimb_weights_mV"][0], w["final_weights_mV"][1])


def test_weight_structure():
    from astrocpg.studies.analysis.gait import weight_structure
    t = np.zeros((8, 8))
    t[0:2, 2:4] = [[-1, 1], [1, -1]]  # FR -> FL: the paper's pattern
    t[4:6, 0:2] = 1.0  # RR -> FR: all excitatory
    s = weight_structure(t * 0.05e-3, 0.05e-3)
    assert s["mixed_limb_pairs"] == 1 and s["limb_pairs"] == 12
    assert s["share_above_0.9_w_max"] == pytest.approx((2 + 4) / 48)
