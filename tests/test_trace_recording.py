"""The traces a run records: the same data Brian2's StateMonitor records (float32 by default,
float64 on request), at the same sampling times, in the files' column order, for one stage of
limbs and for limbs in stages; and a default run's memory per trial per simulated second."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from brian2 import StateMonitor, ms

from astrocpg.coupling.assembly import build_closed_loop
from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS
from astrocpg.models.compose import model_set
from astrocpg.network.populations import trace_columns, trace_sources
from astrocpg.studies.runtime.resources import estimate_bytes
from astrocpg.studies.commands.simulate import _collect, add_monitors

AUTHORS_DELAYS = (Path(__file__).resolve().parents[1] / "models" / "variants"
                  / "interlimb_authors_delays.toml")


def _brian_reference(cpg, trace_dt):
    """Brian2 StateMonitors of every trace, read as astrocpg read them before its own recorder:
    in the stored unit, columns in the files' order."""
    monitors = {}
    for name, (group, var, scale, _) in trace_sources().items():
        parts = [(StateMonitor(p.obj, var, record=True, dt=trace_dt), p.number)
                 for p in cpg.parts(group)]
        cpg.net.add(*(m for m, _ in parts))
        monitors[name] = (parts, var, scale)

    def read():
        out = {}
        for name, (parts, var, scale) in monitors.items():
            pieces = [(getattr(m, var + "_")[:].T * scale, number) for m, number in parts]
            if len(pieces) == 1 and pieces[0][1] is None:
                values = pieces[0][0]
            else:
                values = np.zeros((pieces[0][0].shape[0], sum(v.shape[1] for v, _ in pieces)))
                for v, number in pieces:
                    values[:, number] = v
            out[name] = (np.asarray(parts[0][0].t_[:]), values)
        return out
    return read


@pytest.mark.parametrize("delays", ["default", "authors"])
@pytest.mark.parametrize("trace_dt_ms", [1, 3])
def test_default_traces_are_brian2s_data_as_float32_and_float64_is_exact(delays, trace_dt_ms):
    models = (DEFAULT_MODELS if delays == "default"
              else model_set(models={"interlimb_synapse": AUTHORS_DELAYS.read_text()}))
    seconds = 0.25
    recorded = {}
    for dtype in ("float32", "float64"):
        loop = build_closed_loop(models, n_trials=2, seed=4)
        cpg = loop.cpg
        steps = int(round(seconds / float(cpg.dt)))
        mons = add_monitors(cpg, trace_dt_ms * ms, True, n_steps=steps, trace_dtype=dtype)
        reference = _brian_reference(cpg, trace_dt_ms * ms)
        loop.run(seconds)
        _, traces = _collect(cpg, mons)
        recorded[dtype] = (traces, reference())
    traces32, ref = recorded["float32"]
    traces64, ref64 = recorded["float64"]
    assert set(traces32) == set(trace_sources())
    for name, (t, values) in traces32.items():
        t_ref, v_ref = ref[name]
        assert values.dtype == np.float32
        assert values.shape == v_ref.shape == (-(-250 // trace_dt_ms), values.shape[1])
        np.testing.assert_array_equal(t, t_ref, err_msg=name)
        # what a run wrote before: Brian2's float64, in the stored unit, then float32
        np.testing.assert_array_equal(values, v_ref.astype(np.float32), err_msg=name)
        t64, v64 = traces64[name]
        assert v64.dtype == np.float64
        np.testing.assert_array_equal(v64, ref64[name][1], err_msg=name)
        np.testing.assert_array_equal(t64, ref64[name][0], err_msg=name)
    # the same run twice: the float32 traces are the float64 ones rounded
    np.testing.assert_array_equal(traces32["motor_Ca"][1],
                                  traces64["motor_Ca"][1].astype(np.float32))


def test_run_keeps_float64_on_request_and_refuses_other_dtypes(tmp_path):
    import astrocpg as ac

    r32 = ac.run(seconds=0.05, seed=2, progress=False)
    r64 = ac.run(seconds=0.05, seed=2, progress=False, trace_dtype="float64",
                 out=tmp_path / "run64")
    assert r32.traces["motor_Ca"][1].dtype == np.float32
    assert r64.traces["motor_Ca"][1].dtype == np.float64
    np.testing.assert_array_equal(r32.traces["motor_Ca"][1],
                                  r64.traces["motor_Ca"][1].astype(np.float32))
    assert r64.manifest["settings"]["trace_dtype"] == "float64"
    with np.load(tmp_path / "run64" / "traces.npz") as saved:
        assert saved["motor_Ca"].dtype == np.float64
    with pytest.raises(InputError, match="float32, float64") as e:
        ac.run(seconds=0.05, trace_dtype="float16", progress=False)
    assert e.value.culprit == "trace_dtype"  # the API names its keyword


def test_a_default_run_keeps_at_most_2_mib_per_trial_per_simulated_second():
    """What the recorders of a default run (every trace at 1 ms, spikes, the robot every step)
    allocate, measured on their arrays, against the estimate a run is refused by."""
    import astrocpg as ac

    seconds, trials = 1.0, 2
    r = ac.run(seconds=seconds, trials=trials, seed=1, progress=False, workers=1)
    sim = r.simulation
    traces = sim.monitors["traces"].nbytes()
    spikes = sum(m.t_[:].nbytes + m.i_[:].nbytes for k, m in sim.monitors.items()
                 if k != "traces")
    robot = sum(np.asarray(getattr(sim.robot, f)).nbytes for f in
                ("joint_angles", "torques", "torso_position", "torso_velocity", "reward",
                 "alive", "foot_force", "torso_quaternion"))
    per_trial_second = (traces + spikes + robot) / trials / seconds
    assert per_trial_second <= 2 * 2**20, per_trial_second / 2**20
    estimate = estimate_bytes(trials=trials, seconds=seconds, traces=trace_columns(trace_sources()),
                              robot_stride=1)
    assert estimate >= traces + spikes + robot  # the estimate a run is refused by covers it


@pytest.mark.parametrize("codegen", ["numpy", pytest.param("cython", marks=pytest.mark.slow)])
def test_the_spike_recorder_records_what_brian2s_spike_monitor_records(codegen):
    """SpikeRecorder grows its arrays through the dynamic arrays themselves, not through
    Brian2's variables and device: every spike, time and count is Brian2's own."""
    import brian2

    from astrocpg.network.recording import SpikeRecorder

    if codegen == "cython":
        pytest.importorskip("Cython")
    was = brian2.prefs.codegen.target
    brian2.prefs.codegen.target = codegen
    try:
        brian2.start_scope()
        group = brian2.NeuronGroup(50, "dv/dt = (1.2 - v) / (10*ms) + 0.3*xi/sqrt(ms) : 1",
                                   threshold="v > 1", reset="v = 0", method="euler")
        group.v = "rand()"
        theirs, ours = brian2.SpikeMonitor(group), SpikeRecorder(group)
        part = brian2.SpikeMonitor(group[10:30])  # a subgroup: only its spikes, renumbered
        ours_part = SpikeRecorder(group[10:30])
        net = brian2.Network(group, theirs, ours, part, ours_part)
        net.run(200 * ms)
        net.run(100 * ms)  # a second run appends to the same arrays
    finally:
        brian2.prefs.codegen.target = was
    assert ours._dynamic and ours_part._dynamic  # the direct path was taken
    assert theirs.num_spikes > 1000 and part.num_spikes > 300
    for a, b in ((theirs, ours), (part, ours_part)):
        np.testing.assert_array_equal(a.i[:], b.i[:])
        np.testing.assert_array_equal(a.t_[:], b.t_[:])
        np.testing.assert_array_equal(a.count[:], b.count[:])
        assert a.num_spikes == b.num_spikes


def _spill_run(tmp_path, monkeypatch, spill_bytes, name, **kw):
    import astrocpg
    from astrocpg.network import recording
    from astrocpg.studies.outputs import writing

    monkeypatch.setattr(recording, "SPILL_BYTES", spill_bytes)
    # every file written past the page cache, as a run's large files are (a spilled trace's
    # .npz always is): the same writer on both sides
    monkeypatch.setattr(writing, "DIRECT_BYTES", 0)
    return astrocpg.run(seconds=0.3, trials=2, seed=3, progress=False, out=tmp_path / name,
                        workers=1, **kw)  # in this process: its spill is tested


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_a_run_that_spills_its_traces_to_disk_writes_the_same_folder(tmp_path, monkeypatch,
                                                                     dtype):
    """A run that writes a folder puts its large traces on disk as it goes: every trace spilled
    (threshold 0 bytes), the folder's files are byte for byte those of the same run holding its
    traces, the result reads the same values, and no spill file is left."""
    held = _spill_run(tmp_path, monkeypatch, 1 << 60, "held", trace_dtype=dtype)
    spilled = _spill_run(tmp_path, monkeypatch, 0, "spilled", trace_dtype=dtype)
    for f in ("traces.npz", "spikes.npz", "robot.npz"):
        assert (tmp_path / "held" / f).read_bytes() == (tmp_path / "spilled" / f).read_bytes(), f
    for name, (t, v) in held.traces.items():
        t2, v2 = spilled.traces[name]
        assert isinstance(v2, np.memmap) and v2.dtype == np.dtype(dtype)
        np.testing.assert_array_equal(t, t2)
        np.testing.assert_array_equal(v, v2)
    assert held.summary["mechanisms"] == spilled.summary["mechanisms"]
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_spilled_traces_that_overflow_float32_are_counted_as_held_ones(tmp_path, monkeypatch):
    held = _spill_run(tmp_path, monkeypatch, 1 << 60, "held", overrides={"r_Ca": 1e45})
    spilled = _spill_run(tmp_path, monkeypatch, 0, "spilled", overrides={"r_Ca": 1e45})
    over = held.summary["trace_overflow"]
    assert over and over == spilled.summary["trace_overflow"]
    assert (tmp_path / "held" / "traces.npz").read_bytes() == \
        (tmp_path / "spilled" / "traces.npz").read_bytes()


def test_a_run_stopped_by_divergence_or_an_interrupt_leaves_no_spill(tmp_path, monkeypatch):
    """Diverged: the folder keeps what ran, its spilled traces copied in; interrupted: nothing
    written. Either way the spill files beside the folder are gone."""
    import astrocpg
    from astrocpg.errors import Diverged
    from astrocpg.network import recording

    monkeypatch.setattr(recording, "SPILL_BYTES", 0)
    with pytest.raises(Diverged):
        astrocpg.run(seconds=0.5, trials=2, seed=3, progress=False, out=tmp_path / "diverged",
                     overrides={"r_Ca": 1e60})
    with np.load(tmp_path / "diverged" / "traces.npz") as z:
        n = len(z["motor_Ca_t"])
        assert 0 < n < 500 and z["motor_Ca"].shape[0] == n
    calls = []

    def interrupt(self, *args):  # the fourth flush of the recorder: mid-run
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return flush(self, *args)

    flush = recording.TraceRecorder.flush
    monkeypatch.setattr(recording.TraceRecorder, "flush", interrupt)
    with pytest.raises(KeyboardInterrupt):
        astrocpg.run(seconds=0.5, trials=2, seed=3, progress=False, out=tmp_path / "stopped",
                     workers=1)  # the recorder interrupted in this process
    assert not (tmp_path / "stopped").exists()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_the_memory_a_run_needs_leaves_out_the_traces_it_spills():
    """A run that writes its folder holds no trace of SPILL_BYTES or more: the memory check
    counts only the traces it holds (60 s x 20 trials: motor_Ca alone is 1.4 GiB)."""
    from astrocpg.network.recording import SPILL_BYTES

    names = trace_columns(trace_sources())
    held = estimate_bytes(trials=20, seconds=60, traces=names)
    spilled = estimate_bytes(trials=20, seconds=60, traces=names, spill_bytes=SPILL_BYTES)
    none = estimate_bytes(trials=20, seconds=60)
    assert spilled == none < held and held - none > 1.5 * 2 ** 30
    # a short run's traces stay in memory (each under the threshold)
    assert estimate_bytes(trials=1, seconds=1, traces=names, spill_bytes=SPILL_BYTES) == \
        estimate_bytes(trials=1, seconds=1, traces=names)


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_traces_sampled_by_compiled_code_are_numpys_byte_for_byte(tmp_path, monkeypatch, dtype):
    """The compiled sampler (ASTROCPG_COMPILED_RECORDING, on by default) and numpy write the
    same folder, traces held or spilled, the overflow counts and peaks of the summary
    included (float32 traces beyond its range: inf, counted)."""
    from astrocpg.network import recording

    if recording.kernel() is None:
        pytest.skip("no C compiler here: traces are sampled with numpy")
    kw = {"trace_dtype": dtype}
    if dtype == "float32":
        kw["overrides"] = {"r_Ca": 1e45}
    for where, spill_bytes in (("held", 1 << 60), ("spilled", 0)):
        got = {}
        for switch in ("1", "0"):
            monkeypatch.setenv("ASTROCPG_COMPILED_RECORDING", switch)
            got[switch] = _spill_run(tmp_path, monkeypatch, spill_bytes, f"{where}{switch}", **kw)
        for f in ("traces.npz", "spikes.npz", "robot.npz"):
            assert (tmp_path / f"{where}1" / f).read_bytes() == \
                (tmp_path / f"{where}0" / f).read_bytes(), (where, f)
        for key in ("trace_overflow", "mechanisms"):
            assert got["1"].summary[key] == got["0"].summary[key], (where, key)
    if dtype == "float32":
        assert got["1"].summary["trace_overflow"]


def test_spill_files_go_inside_the_folder_being_written_never_the_current_folder(
        tmp_path, monkeypatch):
    """The README's first run, ``--out out/run`` with ``out/`` not yet there: the spilled
    traces are hidden temporaries inside the run's own temporary folder, never in the
    current folder (a clone's root, which a file there would make "dirty")."""
    import astrocpg
    from astrocpg.network import recording
    from astrocpg.studies.commands import run as run_module
    from astrocpg.studies.outputs.folder import parse_temp_name

    monkeypatch.setattr(recording, "SPILL_BYTES", 0)
    monkeypatch.chdir(tmp_path)
    seen: list[tuple[Path, list[str]]] = []
    spill_files = run_module.spill_files

    def watched(folder):
        make, made = spill_files(folder)

        def spill(name):
            path, sink = make(name)
            seen.append((path, sorted(os.listdir(tmp_path))))
            return path, sink
        return spill, made
    monkeypatch.setattr(run_module, "spill_files", watched)
    astrocpg.run(seconds=0.3, progress=False, out="out/run")
    assert seen
    for path, cwd in seen:
        assert path.parent.parent == tmp_path / "out", path
        assert (parse_temp_name(path.parent.name) or {}).get("kind") == "partial", path
        assert cwd == ["out"], cwd
    assert sorted(os.listdir(tmp_path)) == ["out"]
    assert sorted(os.listdir(tmp_path / "out")) == ["run"]
