"""Test oracle: one locomotion unit advanced exactly as SPEC section 1 describes the authors'
code, in plain numpy (independent of Brian2 and of ``astrocpg.models``). Open loop: torso speed
0, no limit-position inhibition. Constants are the paper's (Table I) and SPEC's wiring table.

Readings of SPEC's wording: the refractory counter is set to the refractory period in steps at
a spike and checked before it counts down (so a neuron is silent for 5 steps after its spike
step); decay applies to every neuron; input to a refractory neuron is dropped.
"""

from __future__ import annotations

import numpy as np

DT = 1e-3
POOL = 20
# (source pool, target pool) of the six interneurons; pools: thigh F, thigh E, calf F, calf E
INTERNEURONS = ((0, 1), (1, 0), (2, 3), (3, 2), (1, 2), (0, 3))


def simulate_unit(seconds: float, seed: int, *, refractory_motor: int = 5,
                  refractory_interneuron: int = 3) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    n = 4 * POOL
    decay, decay_ca = np.exp(-DT / 9e-3), np.exp(-DT / 0.25)
    w = np.zeros((n, n))  # w[pre, post], mV
    for p in range(4):
        pos = rng.uniform(size=(POOL, 3))
        dist = np.sqrt(((pos[:, None] - pos[None]) ** 2).sum(-1))
        block = 4.0 * np.exp(-0.3 * dist)
        np.fill_diagonal(block, 0.0)
        w[p * POOL:(p + 1) * POOL, p * POOL:(p + 1) * POOL] = block
    v, ca, counter = np.zeros(n), np.zeros(n), np.zeros(n, int)
    vi, counter_i = np.zeros(6), np.zeros(6, int)
    syn, syn_i = np.zeros(n), np.zeros(6)
    times, idx, times_i, idx_i = [], [], [], []
    for step in range(int(round(seconds / DT))):
        active, active_i = counter == 0, counter_i == 0
        counter, counter_i = np.maximum(counter - 1, 0), np.maximum(counter_i - 1, 0)
        background = 1380.0 * DT * (1 + 0.5 * rng.uniform(-1, 1, n))  # mV
        v = (v + np.where(active, syn + background, 0.0)) * decay
        vi = (vi + np.where(active_i, syn_i, 0.0)) * decay
        spike = active & (rng.random(n) < 1 / (1 + np.exp(-np.clip((v - 10) / 0.1, -50, 50))))
        spike_i = active_i & (rng.random(6) < 1 / (1 + np.exp(-np.clip((vi - 10) / 0.1, -50, 50))))
        v[spike], vi[spike_i] = 0.0, 0.0
        counter[spike], counter_i[spike_i] = refractory_motor, refractory_interneuron
        ca[spike] += 1.0
        ca *= decay_ca
        v -= DT * 8000.0 / (1 + np.exp(-10 * (ca - 10)))
        # what arrives at the next step
        syn = w.T @ spike
        syn_i = np.zeros(6)
        for k, (src, tgt) in enumerate(INTERNEURONS):
            syn_i[k] = 2.0 * spike[src * POOL:(src + 1) * POOL].sum()
            if spike_i[k]:
                syn[tgt * POOL:(tgt + 1) * POOL] -= 50.0
        s = np.flatnonzero(spike)
        times.append(np.full(len(s), step * DT)); idx.append(s)
        s = np.flatnonzero(spike_i)
        times_i.append(np.full(len(s), step * DT)); idx_i.append(s)
    return {"motor_times": np.concatenate(times), "motor_indices": np.concatenate(idx),
            "interneuron_times": np.concatenate(times_i),
            "interneuron_indices": np.concatenate(idx_i)}
