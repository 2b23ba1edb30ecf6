"""What a training's writes cost as its files grow: ``sessions.csv`` + ``weights.npz``
(``Trainer.write_outputs``) and ``checkpoint.npz`` (``Trainer.write_checkpoint``) for 20 trials
after 0, 50, 200 and 400 sessions each (the paper's ablation run), on this machine's disk.

    python benchmarks/checkpoint_cost.py [--trials 20] [--sessions 0 50 200 400]

The session memory is filled with synthetic rows and tables of the real sizes; the network is
the real one. With 20 trials a session ends about every L / 20 simulated seconds (L the mean
session length), so writing at every session end, as trainings did before the writes were
spaced (``CHECKPOINT_SPACING`` in ``studies/commands/trainer.py``), adds about
``write_s x 20 / L`` wall seconds per simulated second. Spaced, at most 1 / (1 + 49) = 2 % of the
wall time goes to writing.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from astrocpg.coupling.training import SESSION_COLUMNS  # noqa: E402
from astrocpg.models import DEFAULT_MODELS  # noqa: E402
from astrocpg.studies.commands.trainer import Trainer  # noqa: E402
from astrocpg.studies.settings import TrainSettings  # noqa: E402


def measure(trials: int = 20, sessions: tuple[int, ...] = (0, 50, 200, 400),
            repeats: int = 3) -> list[dict[str, float]]:
    """Per session count: ``outputs_s``, ``checkpoint_s`` (means of ``repeats`` writes) and
    ``checkpoint_bytes``."""
    rng = np.random.default_rng(0)
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        trainer = Trainer(DEFAULT_MODELS, TrainSettings(n_sessions=max(sessions), seed=1,
                                                        n_trials=trials, astrocytes=True),
                          folder, progress=False)
        mem = trainer.training.memory
        row = {k: 1.2345678 for k in SESSION_COLUMNS} | {"trial": 0, "session": 1, "diverged": 0}
        for n in sorted(sessions):
            while len(mem.weights[0]) < n:
                for b in range(trials):
                    mem.weights[b].append(rng.random((8, 8)) * 1e-3)
                    mem.lengths[b].append(9.0)
                    mem.rows.append(dict(row, trial=b))
            t0 = time.perf_counter()
            for _ in range(repeats):
                trainer.write_outputs()
            t1 = time.perf_counter()
            for _ in range(repeats):
                trainer.write_checkpoint()
            t2 = time.perf_counter()
            out.append({"sessions": n, "outputs_s": (t1 - t0) / repeats,
                        "checkpoint_s": (t2 - t1) / repeats,
                        "checkpoint_bytes": (folder / "checkpoint.npz").stat().st_size})
    return out


def lines(trials: int = 20, sessions: tuple[int, ...] = (0, 50, 200, 400),
          session_s: float = 9.64) -> list[str]:
    rows = measure(trials, sessions)
    per_sim_s = trials / session_s
    text = [f"{'sessions':>8} {'outputs ms':>10} {'checkpoint ms':>13} {'checkpoint MB':>13} "
            f"{'every session end: s per sim s':>31}"]
    for r in rows:
        write = r["outputs_s"] + r["checkpoint_s"]
        text.append(f"{r['sessions']:>8} {r['outputs_s'] * 1e3:>10.1f} "
                    f"{r['checkpoint_s'] * 1e3:>13.1f} {r['checkpoint_bytes'] / 1e6:>13.2f} "
                    f"{write * per_sim_s:>31.3f}")
    text.append(f"({trials} trials, sessions of {session_s:g} s: a session end every "
                f"{session_s / trials:.2f} simulated s; spaced writes: at most 2% of the wall "
                f"time)")
    return text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--sessions", type=int, nargs="+", default=[0, 50, 200, 400])
    ap.add_argument("--session-length", type=float, default=9.64,
                    help="mean session length, s (docs/results.md: the ablation, with astrocytes)")
    args = ap.parse_args()
    for line in lines(args.trials, tuple(args.sessions), args.session_length):
        print(line)


if __name__ == "__main__":
    main()
