"""Export of a closed-loop run to NWB and npz: nwbinspector finds nothing critical, pynwb
reads back the same spikes, traces and robot data, and the metadata hold parameters and seed."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from astrocpg.studies.cli import main


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("run")
    # 0.4 s, 2 trials; traces every 2 ms, the robot every 2 steps, no interneuron spikes
    assert main(["run", "--seconds", "0.4", "--trials", "2", "--seed", "5", "--trace-dt", "2",
                 "--robot-stride", "2", "--spikes", "motor,astrocyte", "--set",
                 "tau_IP3=6*second", "--out", str(out), "--no-progress"]) == 0
    return out


def test_nwb_round_trip_and_inspector(run_dir: Path) -> None:
    from nwbinspector import Importance, inspect_nwbfile
    from pynwb import NWBHDF5IO

    assert main(["export", str(run_dir), "--format", "nwb"]) == 0
    path = run_dir.with_name(run_dir.name + ".nwb")  # beside the folder it reads
    messages = list(inspect_nwbfile(nwbfile_path=str(path)))
    assert not [m for m in messages if m.importance == Importance.CRITICAL], messages

    with np.load(run_dir / "spikes.npz") as z:
        spikes = {k: z[k] for k in z.files}
    with np.load(run_dir / "traces.npz") as z:
        traces = {k: z[k] for k in z.files}
    with np.load(run_dir / "robot.npz") as z:
        robot = {k: z[k] for k in z.files}
    with NWBHDF5IO(str(path), "r") as io:
        nwb = io.read()
        units = nwb.units.to_dataframe()
        assert set(units["population"]) == {"motor", "astrocyte"}  # as recorded
        motor = units[units["population"] == "motor"]
        assert len(motor) == 2 * 320 and set(motor["limb"]) == {"FR", "FL", "RR", "RL"}
        # neuron 0 of trial 1 is FR thigh flexor
        row = motor[motor["neuron_index"] == 320].iloc[0]
        assert (row["trial"], row["limb"], row["pool"]) == (1, "FR", "thigh_flexor")
        for pop in ("motor", "astrocyte"):
            t, i = spikes[f"{pop}_times"], spikes[f"{pop}_indices"]
            sub = units[units["population"] == pop]
            for k in np.unique(i)[:50]:
                got = sub[sub["neuron_index"] == k]["spike_times"].iloc[0]
                np.testing.assert_array_equal(np.sort(got), np.sort(t[i == k]))
            assert sum(len(x) for x in sub["spike_times"]) == len(t)
        assert nwb.units.resolution == pytest.approx(1e-3)
        # traces: motor Ca of trial 1, limb RL = columns 320+240 ... 320+320
        ts = nwb.acquisition["motor_Ca_trial1_RL"]
        np.testing.assert_array_equal(ts.data[:], traces["motor_Ca"][:, 560:640])
        assert ts.rate == pytest.approx(500.0)
        ado = nwb.acquisition["astrocyte_ADO_trial0"]
        np.testing.assert_array_equal(ado.data[:], traces["astrocyte_ADO"][:, :8])
        ca = nwb.acquisition["astrocyte_Ca_trial1"]
        assert ca.unit == "uM"
        np.testing.assert_array_equal(ca.data[:], traces["astrocyte_Ca"][:, 8:16])
        ja = nwb.acquisition["joint_angles_trial1"]
        assert ja.unit == "radian"
        np.testing.assert_array_equal(ja.data[:], robot["joint_angles"][1].reshape(-1, 12))
        tq = nwb.acquisition["torques_trial0"]
        np.testing.assert_array_equal(tq.data[:], robot["torques"][0].reshape(-1, 12))
        # parameters, seed and equations
        notes = json.loads(nwb.notes)
        assert notes["seed"] == 5 and "tau_IP3=6*second" in notes["settings"]["overrides"]
        params = nwb.processing["misc"]["parameters"].to_dataframe()
        tau = params[params["parameter"] == "tau_IP3"].iloc[0]
        assert tau["model"] == "astrocyte" and tau["value"].replace(" ", "") in ("6.s", "6s")
        eqs = nwb.processing["misc"]["equations"].to_dataframe()
        assert "dIP3/dt" in eqs[eqs["model"] == "astrocyte"]["text"].iloc[0]
        assert "seed 5" in nwb.session_description


def test_npz_export(run_dir: Path) -> None:
    out = run_dir / "copy.npz"
    assert main(["export", str(run_dir), "--format", "npz", "--out", str(out)]) == 0
    with np.load(out) as z, np.load(run_dir / "spikes.npz") as s:
        np.testing.assert_array_equal(z["spikes_motor_times"], s["motor_times"])
        assert list(z["units_motor_limb"][:80]) == ["FR"] * 80
        meta = json.loads(str(z["metadata_json"]))
        assert meta["seed"] == 5 and "astrocyte" in meta["models"]
        assert "spikes_interneuron_times" not in z.files
        with np.load(run_dir / "traces.npz") as t:
            for k in t.files:
                np.testing.assert_array_equal(z[f"trace_{k}"], t[k])
        with np.load(run_dir / "robot.npz") as r:
            for k in r.files:
                np.testing.assert_array_equal(z[f"robot_{k}"], r[k])


def test_export_refusals(run_dir: Path, tmp_path: Path) -> None:
    assert main(["export", str(run_dir), "--format", "csv"]) == 2
    assert main(["export", str(tmp_path)]) == 2
    assert main(["run", "--seconds", "0.1", "--traces", "astrocyte_Kplus", "--out",
                 str(tmp_path / "x")]) == 2
