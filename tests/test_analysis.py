"""The burst detector on known spike trains, and the authors' discretisation against SPEC 3 and
against the Brian2 unit."""

from __future__ import annotations

import numpy as np
import pytest

from astrocpg.studies.analysis.rhythm import (burst_phase, cycle_period, detect_bursts, rate_per_neuron,
                                       rhythm_summary)

POOLS = ("thigh_flexor", "thigh_extensor", "calf_flexor", "calf_extensor")


def _synthetic(period=0.5, burst=0.22, volley=0.018, offset=0.0, t_stop=10.0, ids=range(20),
               noise=0, seed=0):
    rng = np.random.default_rng(seed)
    t, i = [], []
    start = offset
    while start < t_stop:
        for k in np.arange(start, min(start + burst, t_stop), volley):
            for n in ids:
                if rng.random() < 0.95:
                    t.append(k); i.append(n)
        start += period
    for _ in range(noise):  # isolated spikes between bursts
        t.append(rng.uniform(0, t_stop)); i.append(rng.choice(list(ids)))
    order = np.argsort(t)
    return np.array(t)[order], np.array(i)[order]


def test_detects_period_phase_and_rate():
    ta, ia = _synthetic(offset=0.1, noise=20)
    tb, ib = _synthetic(offset=0.35, ids=range(20, 40), noise=20, seed=1)
    t, i = np.concatenate([ta, tb]), np.concatenate([ia, ib])
    a = detect_bursts(t, i, np.arange(20), 10.0)
    b = detect_bursts(t, i, np.arange(20, 40), 10.0)
    assert cycle_period(a) == pytest.approx(0.5, abs=0.005)
    assert burst_phase(a, b) == pytest.approx(0.5, abs=0.02)
    assert np.all(a[:, 1] - a[:, 0] == pytest.approx(0.216, abs=0.02))
    # bursts touching the edges of the recording are dropped
    assert a[0, 0] > 0 and a[-1, 1] < 10.0
    expected = 0.95 * 13 / 0.5  # 13 volleys per burst at 95% participation
    assert rate_per_neuron(t, i, np.arange(20), 1.0, 9.0) == pytest.approx(expected, rel=0.08)


def test_phase_is_circular():
    ta, ia = _synthetic(offset=0.1)
    tb, ib = _synthetic(offset=0.1 + 0.49, ids=range(20, 40))  # 0.98 of a cycle later
    t, i = np.concatenate([ta, tb]), np.concatenate([ia, ib])
    ph = burst_phase(detect_bursts(t, i, np.arange(20), 10.0),
                     detect_bursts(t, i, np.arange(20, 40), 10.0))
    assert min(ph, 1 - ph) < 0.03


def test_silent_pool_has_no_bursts():
    assert len(detect_bursts(np.array([1.0]), np.array([3]), np.arange(20), 5.0)) == 0
    assert np.isnan(cycle_period(np.zeros((0, 2))))


@pytest.mark.slow
def test_authors_discretisation_matches_spec_and_brian2_unit():
    """The oracle reproduces SPEC section 3, and the Brian2 unit agrees with it within 5%."""
    from authors_discretisation import simulate_unit as oracle
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.studies.commands.simulate import simulate_unit

    seconds = 30.0
    pools = {name: np.arange(k * 20, (k + 1) * 20) for k, name in enumerate(POOLS)}
    ref = []
    for seed in (1, 2, 3):
        s = oracle(seconds, seed)
        r = rhythm_summary(s["motor_times"], s["motor_indices"], pools, seconds)
        r["interneurons_total"] = np.sum(s["interneuron_times"] >= 1.0) / (seconds - 1.0)
        ref.append(r)
        print("oracle", seed, r["period"], r["rates"], r["interneurons_total"])
        assert r["period"] == pytest.approx(0.53, rel=0.05)
        assert r["rates"]["thigh_flexor"] == pytest.approx(27, rel=0.06)
        assert r["rates"]["calf_flexor"] == pytest.approx(25, rel=0.06)
        assert r["interneurons_total"] == pytest.approx(160, rel=0.1)
    result = simulate_unit(DEFAULT_MODELS, seconds=seconds, seed=1, n_trials=3,
                           record_traces=False, progress=False)
    t, i = result.spikes["motor"]
    ours = [rhythm_summary(t, i, {n: ids + 80 * b for n, ids in pools.items()}, seconds)
            for b in range(3)]
    for key in ("period",):
        a = np.mean([r[key] for r in ref]); b = np.mean([r[key] for r in ours])
        assert b == pytest.approx(a, rel=0.05), key
    for pool in POOLS:
        a = np.mean([r["rates"][pool] for r in ref]); b = np.mean([r["rates"][pool] for r in ours])
        assert b == pytest.approx(a, rel=0.05), pool
