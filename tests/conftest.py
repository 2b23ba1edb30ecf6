"""Shared fixtures. ``../shared`` (beside the repository) holds the authors' A1 model, used by
tests only; set ASTROCPG_SHARED to point elsewhere."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")


def shared_dir() -> Path:
    env = os.environ.get("ASTROCPG_SHARED")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "shared"


@pytest.fixture(scope="session")
def reference_a1_path() -> Path:
    path = shared_dir() / "reference" / "a1" / "xml" / "a1_gait_search.xml"
    if not path.is_file():
        pytest.skip(f"reference A1 model not found at {path}")
    return path


def pytest_configure(config: pytest.Config) -> None:
    """``python -m pytest`` runs the fast tests (pyproject: ``-m 'not slow'``); with CI=true
    (as ``.ci/run`` runs it) the same command runs every test, the slow ones too."""
    if os.environ.get("CI", "").lower() in ("1", "true", "yes") \
            and config.option.markexpr == "not slow":
        config.option.markexpr = ""
