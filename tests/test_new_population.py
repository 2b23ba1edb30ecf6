"""A population added by one model file (tests/data/renshaw.toml) and one row of the population
table (astrocpg.network.populations) is built, scanned, recorded, loaded, exported to NWB and
plotted, with no other change to the package (docs/model-files.md, "A new population")."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from astrocpg.errors import InputError
from astrocpg.models.files import model_from_toml
from astrocpg.network import build_cpg, populations
from astrocpg.network.build import Wiring
from astrocpg.network.layout import POOLS

MODEL_FILE = Path(__file__).parent / "data" / "renshaw.toml"


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


@pytest.fixture
def renshaw():
    with populations.registered(renshaw_row()) as rows:
        yield rows[0]
    assert "renshaw" not in populations.names()  # the row is gone after the block


def test_built_and_scanned(renshaw):
    cpg = build_cpg(n_trials=2, seed=3)
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
    from astrocpg.studies.experiments.settings import model_set

    authors = Path(__file__).parents[1] / "models" / "variants" / "interlimb_authors_delays.toml"
    models = model_set(models={"interlimb_synapse": authors.read_text()})
    cpg = build_cpg(models, n_trials=1, seed=0)
    assert len(cpg.motor_groups) > 1
    total = sum(len(s) for s in cpg.synapse_kinds["motor_to_renshaw"])
    assert total == 4 * len(POOLS) * cpg.layout.pool_size


def test_recorded_exported_plotted(renshaw, tmp_path):
    pynwb = pytest.importorskip("pynwb")
    import astrocpg as ac

    folder = tmp_path / "unit"
    result = ac.unit(seconds=1.0, seed=1, out=folder, progress=False)
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

    # a process that has not registered the row reads the folder's built-in populations
    populations.unregister("renshaw")
    plain = ac.load(folder)
    assert "renshaw" not in plain.spikes and "motor" in plain.spikes
    with pynwb.NWBHDF5IO(str(ac.export(folder, "nwb", out=tmp_path / "plain.nwb")), "r") as io:
        nwb = io.read()
        assert "renshaw_v_trial0" not in nwb.acquisition
        assert "motor_Ca_trial0_FR" in nwb.acquisition
    ac.export(folder, "npz", out=tmp_path / "plain.npz")
    assert ac.plot(folder, out=tmp_path / "plain_figures", progress=False)


def test_register_refuses_a_taken_name():
    row = renshaw_row()
    for name in ("interneuron", "interlimb"):
        with pytest.raises(InputError, match="already in the population table"):
            populations.register(populations.Population(name=name, model=row.model,
                                                        cells_per_leg=row.cells_per_leg,
                                                        wire=wire_renshaw))
    with pytest.raises(InputError, match="wiring step"):
        populations.register(populations.Population(name="x", model=row.model,
                                                    cells_per_leg=row.cells_per_leg))
    assert populations.names() == tuple(p.name for p in populations.BUILT_IN)


def test_built_in_rows_are_the_former_lists():
    """The views read from the table are the lists the modules held before it."""
    from astrocpg.network.divergence import MODEL_OF
    from astrocpg.network.layout import Layout
    from astrocpg.network.recordable import POPULATIONS, TRACE_SOURCES, TRACES

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
