"""What a batch of trials costs on this machine: the wall time per simulated second of the closed
loop for a network of ``n`` trials, measured once and stored, for a study's ``batch = "auto"``.

Batching trades two costs: every run pays a fixed cost per step (Brian2's ~20 code objects and
the bridge, whatever the number of trials) and a cost per trial (the neurons, MuJoCo's step).
Large batches spend less CPU per trial; small ones give a study more runs to spread over its
workers. The cost of a run is modelled as ``fixed + per_trial * n`` seconds per simulated
second, fitted to the closed loop measured at a few batch sizes under the current Brian2 target.

The measurement takes under a minute (3.5 simulated seconds at each of four batch sizes; longer
on a busy machine) and is stored in
``trial_cost.json`` in astrocpg's cache folder (``$ASTROCPG_CACHE``, default
``~/.cache/astrocpg``), keyed by machine, code-generation target and package versions, so it is
paid once per machine. CPU time, not wall time, is measured, so a busy machine gives the same
shape of costs (the choice depends only on the ratio ``fixed / per_trial``).
"""

from __future__ import annotations

import json
import math
import os
import platform
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from datetime import datetime, timezone
from importlib import metadata
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ...errors import InputError
from ..runtime.caches import cache_dir

COST_FILE = "trial_cost.json"
SIZES = (1, 4, 10, 20)  # batch sizes measured: the fit is a straight line through them
SECONDS = 3.0  # simulated seconds per size, after WARM_UP
# the first half second after a build is dearer than what follows (the robots land on the floor,
# many contacts at once), which inflates a run's fixed part when little is timed after it
# (benchmarks/trial_cost_timing.py measures both timings side by side; docs/performance.md)
WARM_UP = 0.5


@dataclass(frozen=True, kw_only=True)
class TrialCost:
    """Seconds (one core) per simulated second of a run of ``n`` trials: ``fixed +
    per_trial * n``.

    fixed: the part every run pays whatever its size (s per simulated s); per_trial: the part
    each trial adds; measured: ``{n: seconds per simulated second}`` as measured; codegen: the
    Brian2 target measured; key: machine, target and versions it holds for; when: UTC time of
    the measurement.
    """

    fixed: float
    per_trial: float
    measured: dict[int, float]
    codegen: str
    key: str
    when: str

    def run_seconds(self, n_trials: int, simulated_s: float) -> float:
        """CPU seconds of a run of ``n_trials`` for ``simulated_s`` simulated seconds."""
        return simulated_s * (self.fixed + self.per_trial * n_trials)

    @staticmethod
    def fit(measured: dict[int, float], *, codegen: str, key: str) -> "TrialCost":
        """The straight line through ``{n: s per simulated s}`` (least squares), its fixed
        part at least 0 and its per-trial part positive."""
        n = np.array(sorted(measured), dtype=float)
        y = np.array([measured[int(k)] for k in n])
        if len(n) < 2:
            raise ValueError("at least two batch sizes are needed to fit a cost")
        per_trial, fixed = np.polyfit(n, y, 1)
        per_trial = max(float(per_trial), 1e-9)
        fixed = max(float(fixed), 0.0)
        return TrialCost(fixed=fixed, per_trial=per_trial,
                         measured={int(k): float(v) for k, v in measured.items()},
                         codegen=codegen, key=key,
                         when=datetime.now(timezone.utc).isoformat(timespec="seconds"))


def machine_key(codegen: str) -> str:
    """What a measured cost holds for: the machine, the Brian2 target and the versions of
    the packages that run the loop."""
    versions = []
    for package in ("astrocpg", "brian2", "mujoco", "numpy"):
        try:
            versions.append(f"{package}={metadata.version(package)}")
        except metadata.PackageNotFoundError:
            versions.append(f"{package}=none")
    # the way it is measured too: a cost measured otherwise (an older warm-up) is measured again
    return " ".join([f"host={platform.node()}", f"cpus={os.cpu_count()}",
                     f"timed={WARM_UP:g}+{SECONDS:g}s",
                     f"machine={platform.machine()}",
                     f"python={platform.python_version()}", f"codegen={codegen}", *versions])


def _positive(value: Any, *, zero: bool = False) -> bool:
    """A finite number above 0 (or at least 0 with ``zero``), not a bool."""
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value) and (value >= 0 if zero else value > 0))


def _entry_problem(entry: Any) -> str | None:
    """Why a stored cost cannot be used (a hand-edited or corrupt cache: NaN, 0, negative,
    infinite or missing values would project a study at "0 s" or fail), or None."""
    if not isinstance(entry, dict):
        return "its entry for this machine is not a table"
    fields = {"fixed", "per_trial", "measured", "codegen", "key", "when"}
    if set(entry) != fields:
        return f"its entry for this machine needs exactly {', '.join(sorted(fields))}"
    if not _positive(entry["fixed"], zero=True):
        return f"fixed = {entry['fixed']!r} is not a finite number >= 0"
    if not _positive(entry["per_trial"]):
        return f"per_trial = {entry['per_trial']!r} is not a finite number > 0"
    measured = entry["measured"]
    if not isinstance(measured, dict) or len(measured) < 2:
        return "measured must map two or more batch sizes to their costs"
    for k, v in measured.items():
        if not (isinstance(k, str) and k.isdigit() and int(k) >= 1) or not _positive(v):
            return f"measured {k!r}: {v!r} is not a batch size with a finite cost > 0"
    if not all(isinstance(entry[k], str) for k in ("codegen", "key", "when")):
        return "codegen, key and when must be text"
    return None


def stored_trial_cost(codegen: str, *, note: Callable[[str], None] | None = None
                      ) -> TrialCost | None:
    """The cost measured earlier on this machine for ``codegen``, or None: none stored, or
    the stored one unusable (not finite, zero or negative, malformed), which ``note`` is told
    in one line naming the file (it is then measured again and stored over)."""
    path = cache_dir() / COST_FILE
    try:
        table = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError) as e:
        if note is not None:
            note(f"ignoring {path} ({type(e).__name__}: not readable JSON); measuring again")
        return None
    if not isinstance(table, dict):
        if note is not None:
            note(f"ignoring {path} (not a JSON object); measuring again")
        return None
    entry = table.get(machine_key(codegen))
    if entry is None:
        return None
    problem = _entry_problem(entry)
    if problem is not None:
        if note is not None:
            note(f"ignoring the cost stored in {path} ({problem}); measuring again")
        return None
    entry = dict(entry, measured={int(k): float(v) for k, v in entry["measured"].items()})
    return TrialCost(**entry)


def store_trial_cost(cost: TrialCost) -> Path | None:
    """Add ``cost`` to the stored table (atomically); None when the cache cannot be written
    (the cost is then measured again next time: never an error)."""
    path = cache_dir() / COST_FILE
    try:
        try:
            table = json.loads(path.read_text(encoding="utf-8"))
            if not isinstance(table, dict):
                table = {}
        except (OSError, ValueError):
            table = {}
        table[cost.key] = asdict(cost)
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".trial_cost-")
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            json.dump(table, f, indent=1)
        os.replace(tmp, path)
        return path
    except OSError:
        return None


def measure_trial_cost(codegen: str | None = None, *, sizes: tuple[int, ...] = SIZES,
                       seconds: float = SECONDS, warm_up: float = WARM_UP,
                       progress: bool = True) -> TrialCost:
    """Run the closed loop (default models, fixed weights) for ``warm_up`` untimed, then
    ``seconds`` timed, at each batch size in ``sizes`` and fit :class:`TrialCost` to the CPU
    time per simulated second."""
    from ...network import RUN_LOCK
    from ...network.codegen import codegen_target

    target = codegen_target(codegen)
    with RUN_LOCK:  # one Brian2 build-and-run at a time per process (network/runlock.py)
        return _measure(target, sizes, seconds, warm_up, progress)


def _measure(target: str, sizes: tuple[int, ...], seconds: float, warm_up: float,
             progress: bool) -> TrialCost:
    from ...coupling.assembly import build_closed_loop
    from ...models import DEFAULT_MODELS

    if len(set(sizes)) < 2 or min(sizes) < 1 or not seconds > 0 or not warm_up > 0:
        raise InputError("needs two or more batch sizes >= 1, seconds > 0 and warm_up > 0",
                         culprit="trial cost measurement")
    measured: dict[int, float] = {}
    for n in sorted(set(sizes)):
        if progress:
            sys.stderr.write(f"\rmeasuring the cost of a batch of {n} trial(s) "
                             f"(once per machine; sizes {', '.join(map(str, sizes))})")
            sys.stderr.flush()
        loop = build_closed_loop(DEFAULT_MODELS, n_trials=n, seed=1, codegen=target)
        loop.run(warm_up)  # code generation, the first steps and the landing
        c0 = time.process_time()
        loop.run(seconds)
        measured[n] = (time.process_time() - c0) / seconds
        del loop
    if progress:
        sys.stderr.write("\n")
    return TrialCost.fit(measured, codegen=target, key=machine_key(target))


def _note(text: str) -> None:
    sys.stderr.write(f"astrocpg: note: {text}\n")


def trial_cost(codegen: str | None = None, *, progress: bool = True) -> TrialCost:
    """The stored cost for this machine and target, measured (and stored) if there is none."""
    from ...network.codegen import codegen_target

    target = codegen_target(codegen)
    cost = stored_trial_cost(target, note=_note)
    if cost is None:
        cost = measure_trial_cost(target, progress=progress)
        store_trial_cost(cost)
    return cost
