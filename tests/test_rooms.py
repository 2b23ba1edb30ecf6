"""Rooms that hold one thing: one saver writes every figure, and each name lives in one module
(no re-exported former homes)."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
SAVER = ROOT / "studies" / "figures" / "save.py"


def _package_files():
    for path in sorted(ROOT.rglob("*.py")):
        rel = path.relative_to(ROOT)
        if rel.parts[0] in ("tests", "docs", "benchmarks", "_build_backend") or ".venv" in rel.parts:
            continue
        yield path


def test_only_the_saver_writes_figures():
    """Functions that draw return Figures; ``figures/save.py`` writes them, at one dpi."""
    offenders = []
    for path in _package_files():
        if path == SAVER:
            continue
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Attribute) and node.attr in ("savefig", "print_figure"):
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not offenders, offenders


def test_plot_functions_return_figures():
    from matplotlib.figure import Figure

    from astrocpg.studies.figures import plots

    fig = plots.plot_weights(np.zeros((8, 8)), trial=0)
    assert isinstance(fig, Figure)
    tree = ast.parse((ROOT / "studies" / "figures" / "plots.py").read_text())
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name.startswith("plot_"):
            assert ast.unparse(node.returns) == "Figure", node.name
            assert node.args.args[0].arg != "path", node.name


def test_the_old_names_are_gone():
    """The split modules' names live in one place each: no module re-exports another's, and
    the former names (models/values.py, network/recordable.py, NonFinite, first_nonfinite)
    are gone."""
    import importlib

    import pytest

    from astrocpg.coupling import bridge
    from astrocpg.network import CPG, divergence
    from astrocpg.studies.parameter_studies import study
    from astrocpg.studies.settings import populations as settings

    for module in ("astrocpg.models.values", "astrocpg.network.recordable",
                   "astrocpg.studies.commands.settings"):
        with pytest.raises(ModuleNotFoundError):
            importlib.import_module(module)
    for module, names in ((study, ("execute_run", "utilisation", "timeline", "RESULTS",
                                   "study_overrides", "MAX_SEEDS")),
                          (settings, ("model_set", "override_items", "read_model_files")),
                          (bridge, ("INSTABILITY_WARNINGS",)), (divergence, ("NonFinite",)),
                          (CPG, ("first_nonfinite",))):
        assert not [n for n in names if hasattr(module, n)], module


def test_one_engine_runs_many_cells():
    """A study's runs and an evaluation's cells go through the runtime's engine
    (``runtime/cells.py``): no other module hands tasks to a Dask cluster itself."""
    engine = ROOT / "studies" / "runtime" / "cells.py"
    callers = []
    for path in _package_files():
        for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "run_on_cluster":
                callers.append(path.relative_to(ROOT).as_posix())
    assert callers and set(callers) == {engine.relative_to(ROOT).as_posix()}, callers


def test_the_engine_runs_cells_here_in_order_and_skips_finished_ones():
    from astrocpg.studies.runtime.cells import pending, run_cells

    kept = {"b": [2]}
    done, todo = pending({"a": (1,), "b": (2,), "c": (3,)}, kept.get)
    assert done == {"b": [2]} and list(todo) == ["a", "c"]

    class Bar:
        closed = False

        def close(self):
            self.closed = True

    seen, bar = [], Bar()
    run_cells(lambda x: [x * 10], list(todo.items()),
              lambda name, outcome: seen.append((name, outcome.status, outcome.result())),
              bar=bar, here=True)
    assert seen == [("a", "finished", [10]), ("c", "finished", [30])] and bar.closed
