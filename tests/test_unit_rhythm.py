"""One locomotion unit is faithful to SPEC section 3 (3 seeds x 30 s, open loop):
thigh flexor and extensor in anti-phase, calf flexor with thigh flexor, cycle period within 15%
of 0.53 s, rate per motor neuron within 15% of 27 Hz (thigh) and 25 Hz (calf)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from astrocpg.studies.analysis.rhythm import burst_phase, cycle_period, detect_bursts, rate_per_neuron
from astrocpg.studies.cli import main

SECONDS = 30.0
SEEDS = (1, 2, 3)
TRANSIENT = 1.0


def _circular_distance(a: float, b: float) -> float:
    d = abs(a - b) % 1.0
    return min(d, 1.0 - d)


@pytest.fixture(scope="module")
def unit_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("unit")
    # three units in one batch: trial b has the connectivity of seed 1 + b
    assert main(["unit", "--no-progress", "--seconds", str(SECONDS), "--seed", str(SEEDS[0]),
                 "--trials", str(len(SEEDS)), "--trace-dt", "10", "--out", str(out)]) == 0
    return out


@pytest.mark.slow
@pytest.mark.parametrize("trial", range(len(SEEDS)))
def test_unit_reproduces_spec_rhythm(unit_run, trial):
    spikes = np.load(unit_run / "spikes.npz")
    t, i = spikes["motor_times"], spikes["motor_indices"]
    keep = t >= TRANSIENT
    t, i = t[keep], i[keep]
    base = trial * 80
    pools = {name: np.arange(base + k * 20, base + (k + 1) * 20) for k, name in enumerate(
        ("thigh_flexor", "thigh_extensor", "calf_flexor", "calf_extensor"))}
    bursts = {name: detect_bursts(t, i, ids, SECONDS) for name, ids in pools.items()}
    period = cycle_period(bursts["thigh_flexor"])
    ext = burst_phase(bursts["thigh_flexor"], bursts["thigh_extensor"])
    calf_f = burst_phase(bursts["thigh_flexor"], bursts["calf_flexor"])
    calf_e = burst_phase(bursts["thigh_flexor"], bursts["calf_extensor"])
    rates = {n: rate_per_neuron(t, i, ids, TRANSIENT, SECONDS) for n, ids in pools.items()}
    print(f"seed {SEEDS[trial]}: period {period:.3f} s, phases ext {ext:.2f} calf_f {calf_f:.2f} "
          f"calf_e {calf_e:.2f}, rates " + ", ".join(f"{k} {v:.1f}" for k, v in rates.items()))
    assert abs(period - 0.53) <= 0.15 * 0.53
    assert _circular_distance(ext, 0.5) <= 0.1  # anti-phase
    assert _circular_distance(calf_f, 0.0) <= 0.1  # calf flexor with thigh flexor
    assert _circular_distance(calf_e, 0.5) <= 0.15  # calf extensor with thigh extensor
    for name in ("thigh_flexor", "thigh_extensor"):
        assert abs(rates[name] - 27.0) <= 0.15 * 27.0, name
    for name in ("calf_flexor", "calf_extensor"):
        assert abs(rates[name] - 25.0) <= 0.15 * 25.0, name


@pytest.mark.slow
def test_unit_outputs(unit_run):
    manifest = json.loads((unit_run / "manifest.json").read_text())
    assert manifest["seed"] == 1 and manifest["settings"]["trials"] == 3
    assert (unit_run / "unit.png").stat().st_size > 10_000
    traces = np.load(unit_run / "traces.npz")
    assert traces["motor_Ca"].shape[1] == 3 * 80
    assert np.all(np.diff(traces["motor_Ca_t"]) > 0)
