"""Training sessions, run inside the 1 ms loop (docs/model.md, "Sessions"; paper "Training
Session and Training Progress").

Each trial of a batch has its own sessions: a session ends at L_max or once the robot has spent
L_non_alive (not necessarily consecutive) non-upright; then that trial alone is reset (neurons,
traces, torque traces, STDP signals, hip integrator, physics; astrocytes and weights persist),
and its Progress and t_learning_start are set from the mean length of its last sessions.
Per step, this writes the trial's reward, its sliding mean and the learning flag where the
inter-limb synapses read them. At each session's start it remembers what the session starts
from besides the seed and the reset values (:class:`SessionStart`: the step, Progress,
t_learning_start, the astrocytes' state and the inter-limb weights), so that any session can
be replayed alone (:meth:`Training.begin_at`). Constants come from ``models`` (reward, progress, learning_start,
alive).

Divergence: the session loop is the bridge's ``training`` hook (order ``ORDER_TRAINING``, after
the step's divergence checks) and checks the CPG at every session end. When a trial diverges
(:class:`~astrocpg.errors.Diverged` from the bridge), its session in progress ends as a row with
``diverged`` = 1 (normal rows: 0) and the error goes on up: the run stops, the rows so far stay
in :attr:`Training.memory`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np
from brian2 import NetworkOperation, SpikeMonitor

from ..errors import Diverged, InputError
from ..models import ModelSet
from ..models.units import whole_steps
from ..network import CPG, POOLS
from . import session
from .bridge import ORDER_TRAINING, Bridge

SESSION_COLUMNS = (
    "trial", "session", "length_s", "final_x_m", "mean_reward", "mean_forward_speed_m_per_s",
    "spikes_thigh_motor", "spikes_calf_motor", "spikes_interneuron", "adenosine_releases",
    "progress", "t_learning_start_s", "diverged",
)


@dataclass
class SessionMemory:
    """What a trial carries from session to session (all of it goes into checkpoints)."""

    lengths: list[list[float]]
    weights: list[list[np.ndarray]]  # per trial, the 8x8 table (volt) after each session
    rows: list[dict[str, Any]] = field(default_factory=list)
    #: per trial, what each session started from (:class:`SessionStart`), the session in
    #: progress included: enough to replay any session alone
    starts: list[list["SessionStart"]] = field(default_factory=list)


@dataclass
class SessionStart:
    """What one session of one trial starts from, besides the seed and the reset values: the
    network step of its first step (the noise streams' step), its Progress and
    t_learning_start, and the state a reset leaves (astrocytes, inter-limb weights:
    :func:`~astrocpg.coupling.session.persistent_state`)."""

    step: int
    progress: float
    t_learning_start: float
    state: dict[str, np.ndarray]


def session_steps(models: ModelSet, dt: float) -> tuple[int, int, int, int]:
    """The session loop's counts from the models: (steps of the longest session ``L_max``,
    non-upright steps that end one ``L_non_alive``, sessions remembered ``session_memory``,
    steps of the reward's window ``reward_window``). Durations run as whole steps, so one
    that is not a whole number of ``dt`` steps is refused (it would be rounded while the
    manifest records it as set; :func:`astrocpg.models.units.whole_steps`)."""
    max_steps = whole_steps(models.value("L_max"), dt, culprit="progress.L_max")
    non_alive = whole_steps(models.value("L_non_alive"), dt, culprit="progress.L_non_alive")
    memory = models.value("session_memory")
    if not (memory >= 1 and float(memory).is_integer()):  # int(2.5) would keep 2
        raise InputError(f"must be a whole number of sessions, at least 1, got {memory:g}",
                         culprit="progress.session_memory")
    window = whole_steps(models.value("reward_window"), dt,
                         culprit="reward.reward_window")
    return max_steps, non_alive, int(memory), window


@dataclass
class _StepBuffers:
    """Scratch arrays of :meth:`Training.step`, per trial (``counts``: per trial and pool)."""

    row_start: np.ndarray  # b * window: where trial b's slots of the reward ring start
    slot: np.ndarray
    old: np.ndarray
    mean: np.ndarray
    time: np.ndarray
    flag: np.ndarray
    open: np.ndarray
    counts: np.ndarray

    @classmethod
    def allocate(cls, n_trials: int, window: int, pools: int) -> "_StepBuffers":
        return cls(row_start=np.arange(n_trials, dtype=np.int64) * window,
                   slot=np.zeros(n_trials, dtype=np.int64), old=np.zeros(n_trials),
                   mean=np.zeros(n_trials), time=np.zeros(n_trials),
                   flag=np.zeros(n_trials, dtype=bool), open=np.zeros(n_trials, dtype=bool),
                   counts=np.zeros((n_trials, pools), dtype=np.int64))


class Training:
    """The session loop of ``n_sessions`` sessions per trial, hooked into a :class:`Bridge`."""

    def __init__(self, cpg: CPG, bridge: Bridge, models: ModelSet, *, n_sessions: int,
                 on_session: Callable[["Training", int], None] | None = None) -> None:
        self.cpg, self.bridge, self.models = cpg, bridge, models
        self.n_sessions = int(n_sessions)
        self.on_session = on_session
        B = self.n_trials = cpg.n_trials
        dt = self.dt = bridge.dt
        (self.max_steps, self.non_alive_limit, self.memory_size,
         self.window) = session_steps(models, dt)
        self._progress_fn = models.progress.compile()
        self._learning_start_fn = models.learning_start.compile()

        n_pools = len(POOLS)
        # (trial, pool) tables of the pool group (live arrays with one stage of limbs)
        self._tables = [cpg.table("pool", v) for v in ("reward", "reward_mean", "learning")]
        self._reward, self._reward_mean, self._learning = (t.values for t in self._tables)
        self._progress_table = cpg.table("pool", "progress")
        self._progress_arr = self._progress_table.values
        self._n_table = cpg.table("pool", "n")
        L = cpg.layout
        kinds = np.arange(L.pools_per_trial) % n_pools
        self._thigh_pools = np.flatnonzero(kinds < 2)
        self._calf_pools = np.flatnonzero(kinds >= 2)

        # spike counts of interneurons and adenosine releases (counts only, no spike times)
        self.interneuron_count = SpikeMonitor(cpg.interneuron, record=False,
                                              name="count_interneuron")
        self.astrocyte_count = SpikeMonitor(cpg.astrocyte, record=False, name="count_astrocyte")
        cpg.net.add(self.interneuron_count, self.astrocyte_count)

        self.step_in_session = np.zeros(B, dtype=np.int64)
        self.non_alive = np.zeros(B, dtype=np.int64)
        self.ring = np.zeros((B, self.window))
        self.ring_sum = np.zeros(B)
        self.reward_sum = np.zeros(B)
        self.speed_sum = np.zeros(B)
        self.pool_counts = np.zeros((B, L.pools_per_trial), dtype=np.int64)
        self.count_base_in = np.zeros(B, dtype=np.int64)
        self.count_base_ado = np.zeros(B, dtype=np.int64)
        self.sessions_done = np.zeros(B, dtype=np.int64)
        self.done = np.zeros(B, dtype=bool)
        self.progress = np.zeros(B)
        self.t_learning_start = np.zeros(B)
        self.memory = SessionMemory(lengths=[[] for _ in range(B)],
                                    weights=[[] for _ in range(B)],
                                    starts=[[] for _ in range(B)])
        self._arange = np.arange(B)
        # the step's scratch arrays (allocated once) and the ring as one flat view
        self._buf = _StepBuffers.allocate(B, self.window, L.pools_per_trial)
        self._ring_flat = self.ring.reshape(-1)
        self._tables_live = all(t.live for t in self._tables)
        # the bridge's step_count from which step() looks for session ends again (0: at once;
        # a restore calls counters_set)
        self._check_at = 0
        self._start_x = bridge.layout.reset_qpos[bridge.layout.free_qpos_adr]
        self._forward = bridge.forward_velocity
        self._counted_step = -1  # the bridge's step_count when step() last ran
        for b in range(B):
            self._plan_session(b)
            self._remember_start(b)  # session 1 starts from the network as built
        # sessions that begin at the next step: their start is taken at the end of this one,
        # after the weight update (order 10) and before a checkpoint (order 20)
        self._starting = np.zeros(B, dtype=bool)
        self._any_starting = False
        cpg.net.add(NetworkOperation(self._take_starts, clock=cpg.clock, when="end", order=15,
                                     name="session_starts"))
        bridge.add_hook("after_physics", "training", self.step, order=ORDER_TRAINING)
        bridge.add_hook("diverged", "training_diverged", self._diverged, order=ORDER_TRAINING)

    # ---- per step (after the physics step and the reward)
    def step(self) -> None:
        """One step of every trial's session: counters, the reward's sliding window, the
        learning signals written where the inter-limb synapses read them, the session's sums;
        sessions that end now end (:meth:`_finish`). Hot loop: the same arithmetic as the
        plain expressions (``ring_sum / window``, ``step_in_session * dt >= t_learning_start``),
        written into buffers allocated once (:meth:`_buffers`); the state arrays are read
        afresh each step (a restore writes into them, never replaces them)."""
        br = self.bridge
        r = br.reward
        buf = self._buf
        self._counted_step = br.step_count
        steps = self.step_in_session
        steps += 1
        np.logical_not(br.alive, out=buf.flag)
        self.non_alive += buf.flag
        # the ring of the last `window` rewards, trial b's slot at b * window + step % window
        at = buf.slot
        np.remainder(steps, self.window, out=at)
        at += buf.row_start
        np.take(self._ring_flat, at, out=buf.old)
        self._ring_flat[at] = r
        np.subtract(r, buf.old, out=buf.old)
        self.ring_sum += buf.old
        self._reward[:] = r[:, None]
        np.divide(self.ring_sum, self.window, out=buf.mean)
        self._reward_mean[:] = buf.mean[:, None]
        np.multiply(steps, self.dt, out=buf.time)
        np.greater_equal(buf.time, self.t_learning_start, out=buf.flag)
        np.logical_not(self.done, out=buf.open)
        buf.flag &= buf.open
        self._learning[:] = buf.flag[:, None]
        if not self._tables_live:
            for table in self._tables:
                table.write()
        self.reward_sum += r
        self.speed_sum += self._forward
        np.copyto(buf.counts, self._n_table.read(), casting="unsafe")  # as astype(int64)
        self.pool_counts += buf.counts
        # no session can end before step _check_at: step_in_session grows by one a step and
        # non_alive by at most one, so a trial ends no sooner than the smaller of its two
        # distances to their limits (resets only lengthen them)
        if br.step_count < self._check_at:
            return
        left = min(int((self.max_steps - steps).min()),
                   int((self.non_alive_limit - self.non_alive).min()))
        if left > 0:
            self._check_at = br.step_count + left
            return
        ended = (steps >= self.max_steps) | (self.non_alive >= self.non_alive_limit)
        for b in np.flatnonzero(ended & ~self.done):
            self._finish(int(b))
        if self.done.all():
            self.cpg.net.stop()

    def counters_set(self) -> None:
        """The session counters (``step_in_session``, ``non_alive``) or the bridge's
        ``step_count`` were written from outside (a restore): look for session ends at the
        next step."""
        self._check_at = 0

    # ---- session boundaries
    def _plan_session(self, b: int) -> None:
        """Progress and t_learning_start of trial b's next session (missing sessions count 0)."""
        last = self.memory.lengths[b][-self.memory_size:]
        mean_length = sum(last) / self.memory_size
        self.progress[b] = 0.0 if self.done[b] else float(self._progress_fn(mean_length=mean_length))
        self.t_learning_start[b] = float(self._learning_start_fn(mean_length=mean_length))
        self._progress_table.read()  # the other trials' values as Brian2 holds them (restored)
        self._progress_arr[b, :] = self.progress[b]
        self._progress_table.write()

    def _remember_start(self, b: int) -> None:
        self.memory.starts[b].append(SessionStart(
            step=int(self.bridge.step_count), progress=float(self.progress[b]),
            t_learning_start=float(self.t_learning_start[b]),
            state=session.persistent_state(self.cpg, b)))

    def _take_starts(self) -> None:
        if not self._any_starting:
            return
        for b in np.flatnonzero(self._starting):
            self._remember_start(int(b))
        self._starting[:] = False
        self._any_starting = False

    def begin_at(self, b: int, start: SessionStart) -> None:
        """Start trial ``b``'s first session from ``start`` (a session recorded by another
        training), before the run: its Progress, t_learning_start, the state a reset leaves
        and the noise of its steps. The network's clock starts at 0, so the noise is shifted
        by ``start.step`` and the spike times by as many seconds."""
        self.progress[b] = start.progress
        self.t_learning_start[b] = start.t_learning_start
        self._progress_table.read()
        self._progress_arr[b, :] = start.progress
        self._progress_table.write()
        session.set_persistent_state(self.cpg, b, start.state, shift_s=start.step * self.dt)
        self.cpg.start_noise_at(start.step)
        self.memory.starts[b] = [start]

    def reopen(self) -> list[int]:
        """After a restore of a training of fewer sessions per trial than :attr:`n_sessions`
        (an extended training): each trial marked done with fewer sessions goes on as if it had
        never been done, its next session planned and its start remembered as the end of a
        session does for a trial not done. Exact only for a trial that finished its last session
        in the very step the state was taken (``step_in_session`` 0, as every trial of a
        finished training's last step is). Returns the trials reopened.

        A trial that finished earlier has run on since, idle (learning off, Progress 0), so its
        state is not what a longer training would have: refused (ValueError naming each such
        trial and its idle steps), nothing changed."""
        short = [int(b) for b in np.flatnonzero(self.done) if self.sessions_done[b] < self.n_sessions]
        idle = [(b, int(self.step_in_session[b])) for b in short if self.step_in_session[b] != 0]
        if idle:
            raise ValueError(", ".join(f"trial {b} ran {n} steps idle" for b, n in idle))
        for b in short:
            self.done[b] = False
            self._plan_session(b)
            self._remember_start(b)
        return short

    def _finish(self, b: int) -> None:
        # a session's end is a cheap moment to look at the whole CPG state
        self.bridge.check_cpg()
        row = self._row(b)
        self._close(b, row)
        if self.sessions_done[b] >= self.n_sessions:
            self.done[b] = True
        # next session: reset everything but astrocytes and weights
        session.reset_trial(self.cpg, b)
        self.bridge.reset_trial(b)
        self.step_in_session[b] = 0
        self.non_alive[b] = 0
        self.ring[b] = 0.0
        self.ring_sum[b] = 0.0
        self.reward_sum[b] = 0.0
        self.speed_sum[b] = 0.0
        self.pool_counts[b] = 0
        self._plan_session(b)
        if not self.done[b]:
            self._starting[b] = self._any_starting = True
        if self.on_session is not None:
            self.on_session(self, b)

    def _diverged(self, error: Diverged) -> None:
        """The bridge's ``diverged`` hook: trial ``error.trial``'s session in progress ends as a
        row marked diverged, its length up to the end of the step that diverged, its means over
        the steps before it (nothing is reset: the run stops). A trial that has done all its
        sessions gets no row."""
        b = error.trial
        if b is None or self.done[b]:
            return
        # found by the bridge before this step reached the session loop, or at a session end
        uncounted = int(self._counted_step != self.bridge.step_count)
        self._close(b, self._row(b, diverged=True, extra_steps=uncounted))

    def _close(self, b: int, row: dict[str, Any]) -> None:
        self.memory.rows.append(row)
        self.memory.lengths[b].append(row["length_s"])
        self.memory.weights[b].append(self.cpg.interlimb_weights()[b].copy())
        self.sessions_done[b] += 1

    def _row(self, b: int, diverged: bool = False, extra_steps: int = 0) -> dict[str, Any]:
        """Trial b's session in progress as a row of SESSION_COLUMNS (and the spike-count bases
        moved on to its end). ``extra_steps``: steps counted in the length only."""
        counted = int(self.step_in_session[b])
        length = (counted + extra_steps) * self.dt
        steps = max(counted, 1)
        br = self.bridge
        in_counts = self.interneuron_count.variables["count"].get_value()
        ado_counts = self.astrocyte_count.variables["count"].get_value()
        L = self.cpg.layout
        n_in = int(in_counts[b * L.interneurons_per_trial:(b + 1) * L.interneurons_per_trial].sum())
        n_ado = int(ado_counts[b * L.thigh_pools_per_trial:(b + 1) * L.thigh_pools_per_trial].sum())
        row = {
            "trial": b, "session": int(self.sessions_done[b]) + 1, "length_s": length,
            "final_x_m": float(br.torso_position[b, 0] - self._start_x),
            "mean_reward": self.reward_sum[b] / steps,
            "mean_forward_speed_m_per_s": self.speed_sum[b] / steps,
            "spikes_thigh_motor": int(self.pool_counts[b, self._thigh_pools].sum()),
            "spikes_calf_motor": int(self.pool_counts[b, self._calf_pools].sum()),
            "spikes_interneuron": n_in - int(self.count_base_in[b]),
            "adenosine_releases": n_ado - int(self.count_base_ado[b]),
            "progress": float(self.progress[b]),
            "t_learning_start_s": float(self.t_learning_start[b]),
            "diverged": int(diverged),
        }
        self.count_base_in[b], self.count_base_ado[b] = n_in, n_ado
        return row

    @property
    def total_done(self) -> int:
        return int(self.sessions_done.sum())
