"""Export of a closed-loop run to NWB and npz: nwbinspector finds nothing at any importance
(given experimenter and institution), pynwb reads back the same spikes, traces and robot data,
each trace column leads to its cell through table references, rates are exact, and the
metadata hold parameters and seed; the npz says the unit of every array."""

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
    messages = list(inspect_nwbfile(nwbfile_path=str(path),
                                    importance_threshold=Importance.BEST_PRACTICE_SUGGESTION))
    # only the person exporting knows who and where (--experimenter, --institution)
    assert sorted(m.check_function_name for m in messages) == [
        "check_experimenter_exists", "check_institution"], messages

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
        assert ts.rate == 500.0 and ts.unit == "dimensionless"  # every 2 ms, exactly
        ado = nwb.acquisition["astrocyte_ADO_trial0"]
        np.testing.assert_array_equal(ado.data[:], traces["astrocyte_ADO"][:, :8])
        assert ado.unit == "dimensionless"
        ca = nwb.acquisition["astrocyte_Ca_trial1"]
        # stored in uM as recorded; data * conversion is in the SI unit (mol/m^3 = mM)
        assert (ca.unit, ca.conversion) == ("mol/m^3", 1e-3)
        np.testing.assert_array_equal(ca.data[:], traces["astrocyte_Ca"][:, 8:16])
        ja = nwb.acquisition["joint_angles_trial1"]
        assert ja.unit == "rad" and ja.rate == 500.0
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
    out = run_dir.parent / "copy.npz"  # beside: inside, the run would no longer verify
    assert main(["export", str(run_dir), "--format", "npz", "--out", str(out)]) == 0
    with np.load(out) as z, np.load(run_dir / "spikes.npz") as s:
        np.testing.assert_array_equal(z["spikes_motor_times"], s["motor_times"])
        assert list(z["units_motor_limb"][:80]) == ["FR"] * 80
        meta = json.loads(str(z["metadata_json"]))
        assert meta["seed"] == 5 and "astrocyte" in meta["models"]
        # the unit of every array (null: labels, indices, flags)
        units = json.loads(str(z["array_units_json"]))
        assert set(units) == set(z.files) - {"array_units_json", "metadata_json"}
        assert units["spikes_motor_times"] == "s" and units["spikes_motor_indices"] is None
        assert units["units_motor_limb"] is None
        assert (units["trace_astrocyte_Ca"], units["trace_astrocyte_IP3"]) == ("uM", "uM")
        assert units["trace_astrocyte_Ca_t"] == "s"
        for name in ("motor_Ca", "astrocyte_AG", "astrocyte_ADO"):
            assert units[f"trace_{name}"] == "dimensionless"
        assert (units["robot_t"], units["robot_joint_angles"], units["robot_torques"],
                units["robot_torso_position"], units["robot_torso_velocity"],
                units["robot_foot_force"], units["robot_alive"]) == (
            "s", "rad", "N*m", "m", "m/s", "N", None)
        assert "spikes_interneuron_times" not in z.files
        with np.load(run_dir / "traces.npz") as t:
            for k in t.files:
                np.testing.assert_array_equal(z[f"trace_{k}"], t[k])
        with np.load(run_dir / "robot.npz") as r:
            for k in r.files:
                np.testing.assert_array_equal(z[f"robot_{k}"], r[k])


def test_export_refusals(run_dir: Path, tmp_path: Path) -> None:
    assert main(["export", str(run_dir), "--format", "csv"]) == 2
    # nwbinspector (DANDI) wants "Last, First"
    assert main(["export", str(run_dir), "--out", str(tmp_path / "x.nwb"), "--experimenter",
                 "Jane Doe"]) == 2
    assert not (tmp_path / "x.nwb").exists()
    assert main(["export", str(tmp_path)]) == 2
    assert main(["run", "--seconds", "0.1", "--traces", "astrocyte_Kplus", "--out",
                 str(tmp_path / "x")]) == 2


@pytest.fixture(scope="module")
def short_run(tmp_path_factory) -> Path:
    """``astrocpg run --seconds 0.2 --trials 2``: every population, every trace, 1 ms."""
    out = tmp_path_factory.mktemp("short") / "run"
    assert main(["run", "--seconds", "0.2", "--trials", "2", "--seed", "3", "--out", str(out),
                 "--no-progress"]) == 0
    return out


@pytest.fixture(scope="module")
def short_nwb(short_run: Path) -> Path:
    path = short_run.with_name("short.nwb")
    assert main(["export", str(short_run), "--out", str(path), "--experimenter", "Doe, Jane",
                 "--experimenter", "Roe, Richard", "--institution", "Example Institute"]) == 0
    return path


def test_nwb_inspector_finds_nothing(short_nwb: Path) -> None:
    from nwbinspector import Importance, available_checks, inspect_nwbfile

    # every check nwbinspector has, down to its lowest importance, none skipped
    assert min(Importance, key=lambda i: i.value) == Importance.BEST_PRACTICE_SUGGESTION
    messages = list(inspect_nwbfile(nwbfile_path=str(short_nwb), checks=available_checks,
                                    importance_threshold=Importance.BEST_PRACTICE_SUGGESTION))
    assert messages == []


def test_nwb_trace_columns_lead_to_their_cells(short_run: Path, short_nwb: Path) -> None:
    """From a column of a trace TimeSeries to its astrocyte or motor neuron by the file's
    references (DynamicTableRegion), never by reading a description."""
    from pynwb import NWBHDF5IO

    with np.load(short_run / "traces.npz") as z:
        traces = {k: z[k] for k in z.files}
    with NWBHDF5IO(str(short_nwb), "r") as io:
        nwb = io.read()
        misc = nwb.processing["misc"]

        def cell_of(series, k: int, table: str, region: str):
            columns = misc[table]
            rows = [i for i in range(len(columns))
                    if columns["timeseries"][i].object_id == series.object_id
                    and columns["column"][i] == k]
            assert len(rows) == 1, rows
            return columns[region][rows[0]].iloc[0]

        ca = nwb.acquisition["astrocyte_Ca_trial1"]
        astro = cell_of(ca, 3, "astrocyte_trace_columns", "astrocyte")
        # astrocytes of a trial: FR flexor, FR extensor, FL flexor, FL extensor, ...
        assert (astro["trial"], astro["limb"], astro["pool"]) == (1, "FL", "thigh_extensor")
        np.testing.assert_array_equal(ca.data[:, 3],
                                      traces["astrocyte_Ca"][:, astro["neuron_index"]])
        assert astro["neuron_index"] == 11

        motor = nwb.acquisition["motor_Ca_trial1_RL"]
        neuron = cell_of(motor, 5, "motor_trace_columns", "motor_neuron")
        assert (neuron["trial"], neuron["limb"], neuron["pool"]) == (1, "RL", "thigh_flexor")
        assert neuron["neuron_index"] == 320 + 240 + 5
        np.testing.assert_array_equal(motor.data[:, 5],
                                      traces["motor_Ca"][:, neuron["neuron_index"]])
        # the same neuron in the Units table (its spikes)
        units = nwb.units.to_dataframe()
        unit = units[(units["population"] == "motor")
                     & (units["neuron_index"] == neuron["neuron_index"])].iloc[0]
        assert (unit["trial"], unit["limb"], unit["pool"]) == (1, "RL", "thigh_flexor")

        # every column of every trace series has exactly one cell
        for table in ("astrocyte_trace_columns", "motor_trace_columns"):
            columns = misc[table]
            pairs = [(columns["timeseries"][i].name, int(columns["column"][i]))
                     for i in range(len(columns))]
            assert len(set(pairs)) == len(pairs)
            population = table.split("_")[0]
            series = [s for s in nwb.acquisition.values() if s.name.startswith(population)]
            assert sorted(pairs) == sorted((s.name, k) for s in series
                                           for k in range(s.data.shape[1]))


def test_nwb_units_rates_and_one_time_convention(short_run: Path, short_nwb: Path) -> None:
    from pynwb import NWBHDF5IO

    with np.load(short_run / "traces.npz") as z:
        traces = {k: z[k] for k in z.files}
    with np.load(short_run / "robot.npz") as z:
        robot_t = z["t"]
    with NWBHDF5IO(str(short_nwb), "r") as io:
        nwb = io.read()
        assert "state at the end of the" in nwb.data_collection
        assert nwb.subject.species == "http://purl.obolibrary.org/obo/NCBITaxon_32630"
        assert list(nwb.experimenter) == ["Doe, Jane", "Roe, Richard"]
        for series in nwb.acquisition.values():
            assert series.rate == 1000.0  # exactly, for dt = 1 ms
            assert series.unit in ("dimensionless", "mol/m^3", "rad", "N*m", "m", "m/s")
            assert "end of the simulation step" in series.comments
            times = series.starting_time + np.arange(series.data.shape[0]) / series.rate
            name = next((n for n in traces if not n.endswith("_t")
                         and series.name.startswith(n + "_trial")), None)
            # a sample at t is the state at t: the times are those recorded with it
            np.testing.assert_allclose(times, traces[f"{name}_t"] if name else robot_t,
                                       rtol=0, atol=1e-12)
        assert nwb.acquisition["astrocyte_IP3_trial0"].starting_time == 0.0  # initial state
        assert nwb.acquisition["torques_trial0"].starting_time == 0.001  # after step 1
        assert nwb.units.resolution == 0.001
        assert set(nwb.units.to_dataframe()["population"]) == {"motor", "interneuron",
                                                               "astrocyte"}


def test_experimenter_and_institution_from_the_environment(short_run: Path, tmp_path: Path,
                                                          monkeypatch) -> None:
    from nwbinspector import Importance, inspect_nwbfile
    from pynwb import NWBHDF5IO

    monkeypatch.setenv("ASTROCPG_EXPERIMENTER", "Doe, Jane; Roe, Richard")
    monkeypatch.setenv("ASTROCPG_INSTITUTION", "Example Institute")
    path = tmp_path / "env.nwb"
    assert main(["export", str(short_run), "--out", str(path)]) == 0
    with NWBHDF5IO(str(path), "r") as io:
        nwb = io.read()
        assert list(nwb.experimenter) == ["Doe, Jane", "Roe, Richard"]
        assert nwb.institution == "Example Institute"
    messages = list(inspect_nwbfile(nwbfile_path=str(path),
                                    importance_threshold=Importance.BEST_PRACTICE_SUGGESTION))
    assert messages == []
    monkeypatch.setenv("ASTROCPG_EXPERIMENTER", "Jane Doe")  # not 'Last, First': named
    assert main(["export", str(short_run), "--out", str(tmp_path / "bad.nwb")]) == 2
