"""A population added by one model file with a ``[population]`` table
(tests/data/renshaw_population.toml) is built, scanned, recorded, loaded, exported to npz and
NWB, plotted and run from the command line, with no other change to the package
(docs/model-files.md, "A new population"); a folder it wrote describes itself: a process that
has not added the row reads it whole."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from astrocpg.errors import InputError
from astrocpg.models.files import model_from_toml
from astrocpg.network import build_cpg, populations
from astrocpg.network.wiring import Wiring
from astrocpg.network.layout import POOLS

MODEL_FILE = Path(__file__).parent / "data" / "renshaw.toml"
POPULATION_FILE = Path(__file__).parent / "data" / "renshaw_population.toml"


def wire_renshaw(w: Wiring) -> None:
    """Each Renshaw cell (one per pool) is driven by every motor neuron of its pool, through
    the built-in pool_to_interneuron synapse model; stage by stage (0 ms inter-limb delays)."""
    L, renshaw = w.layout, w.groups["renshaw"]
    n_per_trial = L.cells_per_trial("renshaw")
    src, tgt = [], []
    for b in range(L.n_trials):
        for leg in range(L.n_legs):
            for p, pool in enumerate(POOLS):
                neurons = L.motor_neurons(b, leg, pool)
                src.append(neurons)
                tgt.append(np.full(len(neurons), b * n_per_trial + leg * len(POOLS) + p))
    stage, local = L.motor_local(np.concatenate(src))
    target = np.concatenate(tgt)
    for s, motor in enumerate(w.motors):
        here = stage == s
        w.add("motor_to_renshaw", w.synapses(w.models.pool_to_interneuron, motor, renshaw,
                                             "motor_to_renshaw" + w.suffix(s),
                                             local[here], target[here]))


def renshaw_row() -> populations.Population:
    model = model_from_toml(MODEL_FILE.read_text(), culprit=str(MODEL_FILE))
    return populations.Population(
        name="renshaw", model=model, cells_per_leg=lambda pool_size: POOLS, spikes=True,
        traces={"renshaw_v": populations.TraceSource("v", 1e3, "mV",
                                                     "Renshaw cell membrane potential")},
        cell_noun="renshaw_cell", label_meaning="the motor pool that drives the cell",
        wire=wire_renshaw)


def file_row() -> populations.Population:
    return populations.population_from_toml(POPULATION_FILE.read_text(),
                                            culprit=str(POPULATION_FILE))


@pytest.fixture
def renshaw():
    return file_row()


def test_built_and_scanned(renshaw):
    cpg = build_cpg(n_trials=2, seed=3, populations=[renshaw])
    assert len(cpg.groups["renshaw"]) == 2 * 4 * len(POOLS)
    assert cpg.table("renshaw", "v").values.shape == (2, 16)
    assert "motor_to_renshaw" in cpg.synapse_kinds
    assert len(cpg.synapses["motor_to_renshaw"]) == 2 * 4 * len(POOLS) * cpg.layout.pool_size
    assert ("renshaw", "v") in {(n, v) for n, v, _, _ in cpg.state_arrays()}
    assert cpg.layout.to_json()["cells_per_leg"]["renshaw"] == list(POOLS)
    cpg.table("renshaw", "v").values[1, 5] = np.nan  # the divergence scan finds it
    bad = cpg.first_invalid()
    assert bad is not None and bad.population == "renshaw" and bad.trial == 1


def test_staged_limbs(renshaw):
    """0 ms inter-limb delays split the motor neurons by stage: the wiring step follows."""
    from astrocpg.models.compose import model_set

    authors = Path(__file__).parents[1] / "models" / "variants" / "interlimb_authors_delays.toml"
    models = model_set(models={"interlimb_synapse": authors.read_text()})
    cpg = build_cpg(models, n_trials=1, seed=0, populations=[renshaw])
    assert len(cpg.motor_groups) > 1
    total = sum(len(s) for s in cpg.synapse_kinds["motor_to_renshaw"])
    assert total == 4 * len(POOLS) * cpg.layout.pool_size


def test_recorded_exported_plotted(renshaw, tmp_path):
    pynwb = pytest.importorskip("pynwb")
    import astrocpg as ac

    folder = tmp_path / "unit"
    result = ac.unit(seconds=1.0, seed=1, out=folder, progress=False,
                     populations=[POPULATION_FILE.read_text()])
    assert "renshaw" in result.spikes and "renshaw_v" in result.traces
    loaded = ac.load(folder)
    spikes = loaded.spike_times("renshaw", trial=0, leg="FR", pool="thigh_flexor")
    assert len(spikes) > 0  # the cell is driven by its pool's bursts
    trace = loaded.trace("renshaw_v")
    assert trace.unit == "mV" and len(trace.columns) == loaded.layout.cells_per_trial("renshaw")
    assert {c["pool"] for c in trace.columns} == set(POOLS)

    nwb_path = ac.export(folder, "nwb", out=tmp_path / "unit.nwb")
    with pynwb.NWBHDF5IO(str(nwb_path), "r") as io:
        nwb = io.read()
        units = nwb.units.to_dataframe()
        renshaw_units = units[units["population"] == "renshaw"]
        assert len(renshaw_units) == loaded.layout.cells_per_trial("renshaw")
        assert set(renshaw_units["pool"]) == set(POOLS)
        assert "renshaw_v_trial0" in nwb.acquisition
        misc = nwb.processing["misc"]
        assert "renshaw_cells" in misc.data_interfaces
        assert "renshaw_trace_columns" in misc.data_interfaces

    from astrocpg.studies.figures.traces import raster_figures

    figure = raster_figures(loaded, 0, (0.0, 1.0))["rasters"]
    assert "renshaw (leg)" in [ax.get_ylabel() for ax in figure.axes]
    paths = ac.plot(folder, out=tmp_path / "figures", progress=False)
    assert any(p.name.startswith("rasters") for p in paths)

    # read without the row given: the folder's manifest holds its rows
    plain = ac.load(folder)
    assert "renshaw" in plain.spikes and "renshaw_v" in plain.traces
    assert plain.trace("renshaw_v").unit == "mV"
    with pynwb.NWBHDF5IO(str(ac.export(folder, "nwb", out=tmp_path / "plain.nwb")), "r") as io:
        nwb = io.read()
        assert "renshaw_v_trial0" in nwb.acquisition
        assert "motor_Ca_trial0_FR" in nwb.acquisition
        assert "renshaw_cells" in nwb.processing["misc"].data_interfaces
    with np.load(ac.export(folder, "npz", out=tmp_path / "plain.npz")) as z:
        assert len(z["spikes_renshaw_times"]) > 0
        assert set(z["units_renshaw_pool"]) == set(POOLS)
    figure = raster_figures(plain, 0, (0.0, 1.0))["rasters"]
    assert "renshaw (leg)" in [ax.get_ylabel() for ax in figure.axes]


def test_python_wiring_step():
    """A row made in Python may wire its population with a step of its own."""
    cpg = build_cpg(n_trials=1, seed=3, populations=[renshaw_row()])
    assert len(cpg.synapses["motor_to_renshaw"]) == 4 * len(POOLS) * cpg.layout.pool_size


def test_file_row_wires_like_the_python_step(renshaw):
    """The file's declared input (motor -> renshaw by pool) makes the same pairs as the Python
    wiring step."""
    cpg = build_cpg(n_trials=2, seed=3, populations=[renshaw])
    s = cpg.synapses["motor_to_renshaw"]
    declared = sorted(zip(np.asarray(s.i[:]), np.asarray(s.j[:])))
    by_hand = build_cpg(n_trials=2, seed=3,
                        populations=[renshaw_row()]).synapses["motor_to_renshaw"]
    assert declared == sorted(zip(np.asarray(by_hand.i[:]), np.asarray(by_hand.j[:])))


@pytest.mark.slow
def test_command_line(tmp_path):
    """astrocpg run with --population: the run records, and plot and export read the folder in
    processes that were never told about the population."""
    pytest.importorskip("mujoco")
    env = dict(os.environ, MPLBACKEND="Agg")
    out = tmp_path / "run"

    def astrocpg(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "astrocpg", *args], env=env, text=True,
                              capture_output=True, timeout=300)

    done = astrocpg("run", "--seconds", "0.2", "--trials", "1", "--no-progress",
                    "--population", str(POPULATION_FILE), "--out", str(out))
    assert done.returncode == 0, done.stderr
    import json

    manifest = json.loads((out / "manifest.json").read_text())
    assert "renshaw" in manifest["settings"]["populations"]
    rows = {r["name"]: r for r in manifest["results"]["layout"]["populations"]}
    assert rows["renshaw"]["cells_per_leg"] == list(POOLS)
    assert rows["renshaw"]["traces"]["renshaw_v"]["unit"] == "mV"
    with np.load(out / "spikes.npz") as z:
        assert "renshaw_times" in z.files
    done = astrocpg("export", str(out), "--format", "npz", "--out", str(tmp_path / "run.npz"))
    assert done.returncode == 0, done.stderr
    with np.load(tmp_path / "run.npz") as z:
        assert "trace_renshaw_v" in z.files
    done = astrocpg("plot", str(out), "--out", str(tmp_path / "figures"))
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "figures" / "rasters.png").exists()


@pytest.mark.parametrize("change, words", [
    ('name = "renshaw"', 'name = "motor"'),
    ('from = "motor"', 'from = "nowhere"'),
    ('synapse = "pool_to_interneuron"', 'synapse = "no_synapse"'),
    ('variable = "v"', 'variable = "u"'),
    ('cells_per_leg = "pool"', 'cells_per_leg = 3'),
])
def test_bad_population_file(change, words):
    text = POPULATION_FILE.read_text().replace(*((change, words)))
    from astrocpg.studies.settings.populations import population_table

    with pytest.raises(InputError):
        population_table({"bad.toml": text})


def test_an_added_row_with_a_taken_name_is_refused():
    row = renshaw_row()
    for name in ("interneuron", "interlimb"):
        with pytest.raises(InputError, match="already in the population table"):
            populations.with_added([populations.Population(name=name, model=row.model,
                                                           cells_per_leg=row.cells_per_leg,
                                                           wire=wire_renshaw)])
    with pytest.raises(InputError, match="inputs, outputs or its wiring step"):
        populations.with_added([populations.Population(name="x", model=row.model,
                                                       cells_per_leg=row.cells_per_leg)])
    with pytest.raises(InputError, match="already in the population table"):
        populations.with_added([row, renshaw_row()])  # the same name twice


def test_the_table_is_a_value_not_the_process_state():
    """Building with an added row leaves nothing behind: the next build, the recording
    checks and the views read the built-in rows unless they are given the rows."""
    from astrocpg.studies.settings.checks import check_selection

    cpg = build_cpg(n_trials=1, seed=3, populations=[renshaw_row()])
    assert "renshaw" in cpg.layout.to_json()["cells_per_leg"]
    assert populations.names() == tuple(p.name for p in populations.BUILT_IN)
    assert "renshaw" not in build_cpg(n_trials=1, seed=3).groups
    with pytest.raises(InputError, match="unknown population 'renshaw'"):
        check_selection(("renshaw",), None)
    assert check_selection(("renshaw",), ("renshaw_v",), cpg.layout.rows) == (
        ("renshaw",), ("renshaw_v",))
    assert not hasattr(populations, "register") and not hasattr(populations, "registered")


def test_built_in_rows_are_the_former_lists():
    """The views read from the table are the lists the modules held before it."""
    from astrocpg.network.divergence import MODEL_OF
    from astrocpg.network.layout import Layout

    POPULATIONS = populations.spike_populations()
    TRACE_SOURCES = populations.trace_sources()
    TRACES = tuple(TRACE_SOURCES)

    assert POPULATIONS == ("motor", "interneuron", "astrocyte")
    assert TRACES == ("motor_Ca", "astrocyte_Ca", "astrocyte_IP3", "astrocyte_AG",
                      "astrocyte_ADO")
    assert TRACE_SOURCES["astrocyte_Ca"] == ("astrocyte", "Ca", 1e3, "uM")
    assert MODEL_OF == {
        "motor": "motor_neuron", "interneuron": "interneuron", "astrocyte": "astrocyte",
        "pool": "pool", "torque": "torque", "pool_activity": "pool_activity",
        "intra_pool": "intra_pool_synapse", "pool_to_interneuron": "pool_to_interneuron",
        "interneuron_to_pool": "interneuron_to_pool", "interlimb": "interlimb_synapse"}
    L = Layout(n_trials=3, pool_size=5)
    assert [L.cells_per_trial(p) for p in ("motor", "interneuron", "astrocyte", "pool",
                                           "torque")] == [80, 24, 8, 16, 8]
    assert L.interneurons_per_trial == 24 and L.joints_per_trial == 8


def test_a_folder_written_before_rows_reads_the_built_in_rows():
    """A manifest without ``results.layout.populations`` (written before manifests held the
    rows) is read with the built-in rows; one with them, with its own, whatever this process's
    table holds."""
    from astrocpg.network.layout import Layout
    from astrocpg.studies.outputs.export import unit_rows

    old = {"n_trials": 1, "pool_size": 3, "legs": ["FR"]}
    assert Layout.from_json(old).rows == populations.BUILT_IN
    assert list(unit_rows({"results": {"layout": old}})) == ["motor", "interneuron", "astrocyte"]
    new = Layout(n_trials=1, pool_size=3, legs=("FR",),
                 populations=populations.with_added([file_row()])).to_json()
    read = Layout.from_json(new)
    assert [r.name for r in read.rows][-1] == "renshaw" and read.cells_per_trial("renshaw") == 4
    assert read.row("renshaw").traces["renshaw_v"].unit == "mV"
    assert list(unit_rows({"results": {"layout": new}}))[-1] == "renshaw"


def test_a_training_without_layout_takes_its_pool_size_from_its_models():
    """A training manifest written before it held the layout: the pool size is the one its
    models record (read as the models read it), not a default."""
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.studies.outputs.result import _training_layout

    models = DEFAULT_MODELS.with_values({"pool_size": 7}).to_json()
    layout = _training_layout({"settings": {"n_trials": 3}, "models": models}, Path("t"))
    assert (layout.n_trials, layout.pool_size) == (3, 7)
    with pytest.raises(InputError, match="pool size"):
        _training_layout({"settings": {"n_trials": 3}}, Path("t"))
