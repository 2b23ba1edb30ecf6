"""The session loop ends a session in the very step its trial reaches L_max or its
L_non_alive-th non-upright step, whatever the other trials do (the loop looks for session ends
only when one can be due), and again after a restore sets the counters."""

from __future__ import annotations

import numpy as np

from brian2 import second

from astrocpg.coupling.assembly import build_closed_loop
from astrocpg.coupling.training import Training
from astrocpg.models import DEFAULT_MODELS


def _session_loop(sessions: int = 50):
    models = DEFAULT_MODELS.with_values({"L_max": 0.05 * second,
                                         "L_non_alive": 0.02 * second})
    loop = build_closed_loop(models, n_trials=3, seed=0, codegen="numpy")
    ended: list[tuple[int, int]] = []
    training = Training(loop.cpg, loop.bridge, models, n_sessions=sessions,
                        on_session=lambda tr, b: ended.append((b, loop.bridge.step_count)))
    return loop.bridge, training, ended


def _steps(bridge, training, alive_of_step, n: int) -> None:
    """``n`` session-loop steps as the bridge runs them (the physics left out): each step
    counted first, then the trials' upright state set, then the session loop."""
    for _ in range(n):
        bridge.step_count += 1
        bridge.alive[:] = alive_of_step(bridge.step_count)
        training.step()


def _rule(alive_of_step, n: int, trials: int, max_steps: int, limit: int):
    """The rule written plainly: (trial, step) of every session end."""
    steps, down, out = [0] * trials, [0] * trials, []
    for s in range(1, n + 1):
        alive = alive_of_step(s)
        for b in range(trials):
            steps[b] += 1
            down[b] += not alive[b]
            if steps[b] >= max_steps or down[b] >= limit:
                out.append((b, s))
                steps[b] = down[b] = 0
    return out


def test_sessions_end_at_the_step_a_limit_is_reached():
    bridge, training, ended = _session_loop()
    assert (training.max_steps, training.non_alive_limit) == (50, 20)

    # trial 0 stands: L_max ends its sessions. Trial 1 lies from step 31 on, so L_non_alive
    # ends its later sessions; trial 2 is down two steps of three, L_non_alive ends each.
    def alive(s: int) -> np.ndarray:
        return np.array([True, s <= 30, s % 3 == 0])

    _steps(bridge, training, alive, 150)
    expected = _rule(alive, 150, 3, 50, 20)
    assert ended == expected
    assert (0, 50) in ended and (0, 100) in ended and (1, 70) in ended  # both limits seen
    assert sum(b == 2 for b, _ in ended) > 3


def test_a_restore_of_the_counters_is_looked_at_the_next_step():
    bridge, training, ended = _session_loop()
    _steps(bridge, training, lambda s: np.ones(3, dtype=bool), 10)  # nothing due before 50
    training.step_in_session[1] = training.max_steps - 1  # as a checkpoint's restore sets it
    training.counters_set()
    _steps(bridge, training, lambda s: np.ones(3, dtype=bool), 1)
    assert ended == [(1, 11)]
