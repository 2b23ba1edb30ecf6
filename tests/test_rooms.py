"""Rooms that hold one thing: one saver writes every figure, and the split modules keep their
old import paths (``sweeps/study.py``, ``models/values.py``, ``coupling/bridge.py``)."""

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


def test_the_old_import_paths_still_hold():
    from astrocpg.coupling import bridge, robot_recording, robots
    from astrocpg.models import expressions, units, values
    from astrocpg.studies.sweeps import execute, layout, study, study_file, tables

    assert study.RunSpec is study_file.RunSpec and study.Study is study_file.Study
    assert study.execute_run is execute.execute_run and study.read_status is execute.read_status
    assert study.write_results is tables.write_results and study.utilisation is tables.utilisation
    assert study.timeline is tables.timeline and study.write_timeline is tables.write_timeline
    assert (study.RUNS, study.STATUS, study.GAITS, study.RESULTS) == \
        (layout.RUNS, layout.STATUS, layout.GAITS, layout.RESULTS)
    assert values.parse_value is units.parse_value and values.whole_steps is units.whole_steps
    assert values.compile_expression is expressions.compile_expression
    assert values.FUNCTIONS is expressions.FUNCTIONS and values.UNITS is units.UNITS
    assert bridge.Recording is robot_recording.Recording
    assert bridge.INSTABILITY_WARNINGS is robots.INSTABILITY_WARNINGS
