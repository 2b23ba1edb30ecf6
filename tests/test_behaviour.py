"""Behaviour unchanged: a short unit, run and 3-session training give, bit for bit, the arrays
stored in tests/data/behaviour.json (``python benchmarks/behaviour.py --write`` stores them
anew after a deliberate change of the model or its noise)."""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def _behaviour():
    spec = importlib.util.spec_from_file_location("behaviour", ROOT / "benchmarks" / "behaviour.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_unit_run_and_train_give_the_stored_arrays_bit_for_bit():
    b = _behaviour()
    stored = json.loads(b.STORED.read_text())
    if stored["versions"]["numpy"] != np.__version__:
        pytest.skip(f"fingerprints stored with numpy {stored['versions']['numpy']}")
    key = b.section()  # the set of the code generation target in force (numpy by default)
    if key not in stored:
        pytest.skip(f"no fingerprints stored for {key}")
    now = b.fingerprints()
    for command, prints in stored[key].items():
        assert now[command] == prints, command
