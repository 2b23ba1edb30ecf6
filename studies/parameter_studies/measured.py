"""How long each seed trained in an earlier study: what ``astrocpg study --plan-from DIR`` costs
a study's runs with, in place of the bound ``sessions x L_max``.

A run's trials step together until its last trial has done its sessions, so a run lasts as
long as its busiest seed's training, and a training's length is the sum of its sessions'
lengths. Those depend on the condition: in the paper's ablation the robots with astrocytes learn
to walk and their sessions run to L_max (about 3,600 s per seed for 400 sessions), those without
fall sooner (about 2,600 s). Before a study has run nothing says which condition will train
longer; a finished study of the same conditions does. A seed's trajectory does not depend on
the batch it runs in, so on the same settings the lengths read here are the ones the new study
will train.
"""

from __future__ import annotations

import csv
import gzip
import io
from pathlib import Path

from ...errors import InputError
from .study_file import run_group

#: the results table of a study folder (``results.csv``; also read gzip-compressed)
TABLES = ("results.csv", "results.csv.gz")


def results_table(path: Path, culprit: str) -> Path:
    """The results table ``path`` names: the file itself, or a study folder's."""
    if path.is_dir():
        for name in TABLES:
            if (path / name).is_file():
                return path / name
        raise InputError(f"holds no results table ({' or '.join(TABLES)}): give a finished "
                         f"study's folder", culprit=culprit)
    if path.is_file():
        return path
    raise InputError("no such study folder or results table", culprit=culprit)


def measured_lengths(path: str | Path, *, culprit: str = "--plan-from"
                     ) -> dict[str, dict[int, tuple[float, int]]]:
    """``{group: {seed: (simulated seconds trained, sessions)}}`` from the results table of the
    study folder ``path`` (or the table itself): per condition and sweep point
    (:func:`~astrocpg.studies.parameter_studies.study_file.run_group`), each seed's summed
    session lengths and its number of sessions. A table that is not a study's results (a
    column missing, a value that is not a number) is refused naming the file and the row."""
    table = results_table(Path(path), culprit)
    where = f"{culprit} {table}"
    try:
        raw = table.read_bytes()
        text = (gzip.decompress(raw) if table.name.endswith(".gz") else raw).decode("utf-8")
    except (OSError, EOFError, gzip.BadGzipFile) as e:
        raise InputError(f"cannot read the table ({e})", culprit=where) from None
    except UnicodeDecodeError:
        raise InputError("not a UTF-8 text table", culprit=where) from None
    reader = csv.DictReader(io.StringIO(text))
    needed = {"run_id", "seed", "length_s"}
    missing = needed - set(reader.fieldnames or ())
    if missing:
        raise InputError(f"is not a study's results table (no column "
                         f"{', '.join(sorted(missing))})", culprit=where)
    lengths: dict[str, dict[int, tuple[float, int]]] = {}
    for line, row in enumerate(reader, start=2):
        try:
            seed, length = int(row["seed"]), float(row["length_s"])
        except (TypeError, ValueError):
            raise InputError(f"line {line}: seed {row['seed']!r} or length_s "
                             f"{row['length_s']!r} is not a number", culprit=where) from None
        if not (length >= 0.0 and length != float("inf")):
            raise InputError(f"line {line}: length_s {row['length_s']!r} is not a finite "
                             f"length", culprit=where)
        seeds = lengths.setdefault(run_group(row["run_id"]), {})
        total, n = seeds.get(seed, (0.0, 0))
        seeds[seed] = (total + length, n + 1)
    if not lengths:
        raise InputError("holds no sessions", culprit=where)
    return lengths


def planned_lengths(measured: dict[int, tuple[float, int]] | None, seeds: list[int],
                    n_sessions: int, bound_s: float) -> dict[int, float]:
    """Each seed's projected training length for ``n_sessions`` sessions of at most
    ``bound_s / n_sessions`` s: its measured mean session length times ``n_sessions`` (the
    measured total when the sessions are as many), at most ``bound_s``; a seed not measured gets
    ``bound_s``."""
    measured = measured or {}
    out = {}
    for s in seeds:
        total, n = measured.get(s, (0.0, 0))
        out[s] = min(bound_s, total / n * n_sessions) if n else bound_s
    return out
