"""``astrocpg run`` says which mechanisms acted, from what it recorded (short runs)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from astrocpg.studies.cli import main


def test_run_says_what_acted(tmp_path: Path, capsys) -> None:
    out = tmp_path / "run"
    assert main(["run", "--seconds", "0.3", "--out", str(out), "--no-progress"]) == 0
    printed = capsys.readouterr().out
    mech = json.loads((out / "manifest.json").read_text())["results"]["mechanisms"]
    block = printed.split("what acted (from the recorded data):\n")[1].splitlines()
    assert [line.strip() for line in block[:len(mech["statements"])]] == mech["statements"]
    said = "\n".join(mech["statements"])
    # default weights: zero, and a run does not learn
    assert "inter-limb weights all zero: limbs uncoupled" in said
    assert "learning off: the inter-limb weights did not change" in said
    assert mech["interlimb_max_change_mV"] == [0.0]
    # the counts are those of the files the run wrote
    with np.load(out / "spikes.npz") as s:
        assert mech["adenosine_releases"] == [len(s["astrocyte_indices"])]
        assert mech["motor_spikes"] == [len(s["motor_indices"])]
    with np.load(out / "traces.npz") as t:
        assert mech["peak_astrocyte_ADO"][0] == np.float32(t["astrocyte_ADO"].max())
        assert mech["peak_astrocyte_Ca"][0] == np.float32(t["astrocyte_Ca"].max())
    assert f"motor neurons: {mech['motor_spikes'][0]} spikes" in said
    assert "peak [ADO]" in said and "peak [Ca2+]" in said


def test_limit_inhibition_and_coupling_counted_per_trial(monkeypatch) -> None:
    """Coupled limbs, two trials, astrocyte spikes not recorded; the steps with limit-position
    inhibition are those whose recorded thigh angles lie beyond the limits. ``run`` refuses a
    table outside the synapse's bounds; the range check is lifted here so that the clip the
    summary reports (what any table past the bounds would get) is still tested."""
    from astrocpg.coupling.robot import A1Parameters, RobotLayout, build_model
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.studies.commands import run as run_module
    from astrocpg.studies.commands.run import run
    from brian2 import volt

    monkeypatch.setattr(run_module, "check_table", lambda *a, **k: None)

    # 0.03 mV within [w_min, w_max]; one weight above w_max, clipped by the synapse's update
    weights = np.full((8, 8), 0.03e-3)
    weights[0, 2] = 0.5e-3
    for leg in range(4):  # a limb's own 2x2 block holds no inter-limb synapse
        weights[2 * leg:2 * leg + 2, 2 * leg:2 * leg + 2] = 0.0
    result = run(seconds=0.3, trials=2, weights=weights * volt, spikes=("motor",),
                 traces=("astrocyte_ADO",), progress=False)
    mech = result.summary["mechanisms"]
    said = "\n".join(mech["statements"])
    n = mech["interlimb_synapses"]
    assert n > 0 and f"limbs coupled: {n} of {n} inter-limb weights non-zero" in said
    assert list(mech["interlimb_clipped_to_bounds"]) == [1, 1]
    assert ("learning off: the only change to the inter-limb weights is the clip to [w_min, "
            "w_max] = [" in said and "of 1 given weights (by up to 0.45 mV)" in said), said
    assert "astrocytes: releases not recorded" in said and "peak [ADO]" in said
    assert "adenosine_releases" not in mech and "peak_astrocyte_Ca" not in mech

    params = A1Parameters()
    ranges = RobotLayout.from_model(build_model(params), params).joint_range  # (leg, joint, 2)
    margin = float(np.asarray(DEFAULT_MODELS.pool.parameters["limit_margin"].value))
    thigh = result.robot["joint_angles"][:, :, :, 1]  # (trial, step, leg)
    outside = (thigh < ranges[:, 1, 0] + margin) | (thigh > ranges[:, 1, 1] - margin)
    np.testing.assert_array_equal(mech["limit_inhibition_steps"], outside.any(axis=2).sum(axis=1))
    assert all(np.asarray(mech["limit_inhibition_onsets"]) >= (outside.any(axis=(1, 2))))
    if np.any(mech["limit_inhibition_steps"]):
        assert "limit-position inhibition engaged" in said
