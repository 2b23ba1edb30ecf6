"""The session loop of training on its own (coupling/training.py): session boundaries at L_max
and after L_non_alive steps down, per-trial resets, Progress and t_learning_start planned from
the last sessions' lengths, and the network stopped when every trial is done."""

from __future__ import annotations

import numpy as np
import pytest
from brian2 import second

from astrocpg.coupling.assembly import build_closed_loop
from astrocpg.coupling.training import SESSION_COLUMNS, Training
from astrocpg.models import DEFAULT_MODELS
from astrocpg.network import network_time

L_MAX, L_DOWN, SESSIONS = 0.06, 0.02, 3


@pytest.fixture(scope="module")
def trained():
    models = DEFAULT_MODELS.with_values({"L_max": L_MAX * second, "L_non_alive": L_DOWN * second})
    loop = build_closed_loop(models, n_trials=2, seed=4)
    calls: list[tuple[int, int]] = []
    training = Training(loop.cpg, loop.bridge, models, n_sessions=SESSIONS,
                        on_session=lambda tr, b: calls.append((b, int(tr.sessions_done[b]))))
    planned = [(float(training.progress[b]), float(training.t_learning_start[b]))
               for b in range(2)]
    # trial 1 starts upside down: its first session ends after L_non_alive steps down
    d = loop.bridge.data[1]
    d.qpos[loop.robot_layout.free_qpos_adr + 3:loop.robot_layout.free_qpos_adr + 7] = \
        [0.0, 1.0, 0.0, 0.0]
    loop.bridge.qpos[1] = d.qpos
    loop.cpg.net.run((SESSIONS * L_MAX + 1.0) * second, namespace={})
    return loop, training, calls, planned, models


def test_sessions_end_at_L_max_or_after_L_non_alive_down(trained):
    loop, training, calls, _, _ = trained
    rows = training.memory.rows
    assert len(rows) == 2 * SESSIONS and set(rows[0]) == set(SESSION_COLUMNS)
    by_trial = {b: [r for r in rows if r["trial"] == b] for b in (0, 1)}
    assert [r["session"] for r in by_trial[0]] == [1, 2, 3] == [r["session"] for r in by_trial[1]]
    assert all(r["length_s"] == pytest.approx(L_MAX) for r in by_trial[0])
    first = by_trial[1][0]["length_s"]
    assert first <= L_DOWN + 0.002 and first < L_MAX  # down from its first step
    # after the reset trial 1 is upright again: its later sessions run to L_max
    assert all(r["length_s"] == pytest.approx(L_MAX) for r in by_trial[1][1:])
    assert all(r["diverged"] == 0 for r in rows)
    assert calls == [(r["trial"], r["session"]) for r in rows]


def test_progress_planned_from_the_last_sessions(trained):
    loop, training, _, planned, models = trained
    memory = int(np.asarray(models.progress.parameters["session_memory"].value))
    progress = models.progress.compile()
    start = models.learning_start.compile()
    # before any session, missing sessions count as length 0
    assert planned[0] == (pytest.approx(float(progress(mean_length=0.0))),
                          pytest.approx(float(start(mean_length=0.0))))
    for b in (0, 1):
        mine = [r for r in training.memory.rows if r["trial"] == b]
        for k, row in enumerate(mine):
            lengths = [r["length_s"] for r in mine[:k]][-memory:]
            mean = sum(lengths) / memory
            assert row["progress"] == pytest.approx(float(progress(mean_length=mean)))
            assert row["t_learning_start_s"] == pytest.approx(float(start(mean_length=mean)))


def test_every_trial_done_stops_the_network_and_weights_are_kept(trained):
    loop, training, _, _, _ = trained
    assert training.done.all() and list(training.sessions_done) == [SESSIONS, SESSIONS]
    # the network stopped at the last session's end, not after the upper bound
    assert network_time(loop.cpg.net) < SESSIONS * L_MAX + 0.01
    for b in (0, 1):
        assert len(training.memory.weights[b]) == SESSIONS
        assert training.memory.weights[b][-1].shape == (8, 8)
