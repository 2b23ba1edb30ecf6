"""Which runs of a study folder are the study: its index (``study.json``) keeps the run ids
and settings of every version of the study file run into the folder (``specs``; a later
version may add runs, never change one), and ``current``, the runs the study file now names.
What reads a study's runs (its report, its evaluation) reads those of ``current`` only: a study
file edited to fewer seeds leaves the earlier runs in ``runs/``, not in the study.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ...errors import InputError
from ...support.reading import read_json

INDEX = "study.json"


def current_specs(index: dict[str, Any]) -> dict[str, Any]:
    """The runs (run id -> spec) of a study's index that its study file now names. An index
    written before ``current`` was: all its specs."""
    specs = index.get("specs", {})
    if not isinstance(specs, dict):
        return {}
    current = index.get("current")
    if not isinstance(current, list):
        return dict(specs)
    # a run id is a folder name under runs/ (never a path out of it)
    return {run_id: specs[run_id] for run_id in current
            if isinstance(run_id, str) and run_id in specs
            and Path(run_id).name == run_id and run_id not in (".", "..")}


def read_current(folder: Path, culprit: str) -> dict[str, Any]:
    """:func:`current_specs` of the study in ``folder``; InputError naming ``culprit`` when
    its index is missing or unreadable."""
    try:
        index = read_json(Path(folder) / INDEX)
        if not isinstance(index, dict):
            raise ValueError
    except InputError:  # not a regular file, nested too deeply: refused, naming it
        raise
    except (OSError, ValueError):
        raise InputError(f"not a study folder (no readable {INDEX})", culprit=culprit) \
            from None
    return current_specs(index)
