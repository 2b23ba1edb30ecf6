"""One door into the models: no module outside ``models/`` reads a model parameter by its name
string except through the doors listed here, and every name read or set through a door is in
its model's declared interface (``astrocpg.models.INTERFACES``), the list a model file is
checked against at load.

The doors (and why each is allowed):

- ``models.value("NAME")``: the read. It returns a float in SI units and refuses, at run time
  too, a name its model's interface does not list (required or optional parameters).
- ``models.with_values({"NAME": ...})`` and ``models.with_zeros("NAME", ...)``: the writes the
  framework makes by name (the astrocytes' ablation, the frozen weights of ``power``); a
  literal name there must be in the interface as well.
- ``models.parameter(name)`` with a name that is not a literal: names a user gives (``--set``,
  a worlds file's ``scale``), checked by the model set itself.
- Whole tables, never indexed by a literal: ``.parameters.items()``, ``.rows()``,
  ``.namespace()`` (a Brian2 group's namespace), ``name in .parameters``.

Everything else is a finding: ``X.parameters[...]`` (or a name bound to ``X.parameters`` and
then indexed), ``X.parameter("NAME")``, and any string constant spelling a model parameter's
name that is not at a door, unless :data:`NOT_PARAMETER_READS` says why it is not a read.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from astrocpg.models import DEFAULT_MODELS, INTERFACES

ROOT = Path(__file__).resolve().parents[1]

#: Top-level folders of the repository that are not package code outside ``models/``.
SKIPPED = {"models", "tests", "docs", "build", "dist", ".git"}

#: (module, name) -> why a string constant that spells a parameter's name is not a read of it.
NOT_PARAMETER_READS: dict[tuple[str, str], str] = {
    ("network/layout.py", "pool_size"): "a key of the layout's JSON (Layout.to_json/from_json)",
    ("studies/outputs/export.py", "pool_size"): "a key of the manifest's layout JSON",
    ("studies/outputs/result.py", "pool_size"):
        "an old manifest's recorded parameter table (JSON text, not a model set)",
    ("studies/parameter_studies/study_file.py", "astrocyte_regulation"):
        "names, in a conflict message, the parameter 'astrocytes = false' sets",
    ("studies/commands/resume.py", "payload"):
        "a key of a checkpoint split into batches (each batch's saved state), not the world's",
    ("studies/commands/train_batched.py", "payload"):
        "a key of a checkpoint split into batches (each batch's saved state), not the world's",
}

PARAMETER_NAMES = {p: owner for owner, m in DEFAULT_MODELS.items() for p in m.parameters}


def _modules(root: Path):
    for path in sorted(root.rglob("*.py")):
        rel = path.relative_to(root)
        if rel.parts[0] in SKIPPED or any(p.startswith(".") for p in rel.parts):
            continue
        yield rel.as_posix(), ast.parse(path.read_text(encoding="utf-8"), filename=str(path))


def _is_parameters(node: ast.AST, bound: set[str]) -> bool:
    return ((isinstance(node, ast.Attribute) and node.attr == "parameters")
            or (isinstance(node, ast.Name) and node.id in bound))


def _door_names(tree: ast.AST) -> dict[int, str]:
    """id() of each string constant that stands at a door -> the door's name."""
    doors: dict[int, str] = {}
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)):
            continue
        method = node.func.attr
        if method == "value" and node.args:
            doors[id(node.args[0])] = "value"
        elif method == "with_zeros":
            for arg in node.args:
                doors[id(arg)] = "with_zeros"
        elif method == "with_values" and node.args and isinstance(node.args[0], ast.Dict):
            for key in node.args[0].keys:
                if key is not None:
                    doors[id(key)] = "with_values"
    return doors


def findings(root: Path = ROOT) -> list[str]:
    """Every read of a model parameter by its name outside the doors, one line each."""
    out: list[str] = []
    for rel, tree in _modules(root):
        bound = {t.id for node in ast.walk(tree) if isinstance(node, ast.Assign)
                 and _is_parameters(node.value, set())
                 for t in node.targets if isinstance(t, ast.Name)}
        doors = _door_names(tree)
        for node in ast.walk(tree):
            where = f"{rel}:{getattr(node, 'lineno', '?')}"
            if isinstance(node, ast.Subscript) and _is_parameters(node.value, bound):
                out.append(f"{where}: indexes a parameter table ({ast.unparse(node)})")
            elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                  and node.func.attr in ("parameter", "get") and node.args
                  and isinstance(node.args[0], ast.Constant)
                  and (node.func.attr == "parameter"
                       or _is_parameters(node.func.value, bound))):
                out.append(f"{where}: looks a parameter up by name ({ast.unparse(node)})")
            elif (isinstance(node, ast.Constant) and isinstance(node.value, str)
                  and node.value in PARAMETER_NAMES):
                name, owner = node.value, PARAMETER_NAMES[node.value]
                door = doors.get(id(node))
                if door is None:
                    if (rel, name) not in NOT_PARAMETER_READS:
                        out.append(f"{where}: names parameter {name!r} outside a door")
                elif name not in (INTERFACES[owner].readable() if owner in INTERFACES else ()):
                    out.append(f"{where}: {door}({name!r}) but {name} is not in the {owner} "
                               f"model's interface")
    return out


def test_no_module_outside_models_reads_a_parameter_by_name():
    assert findings() == []


def test_every_exception_is_still_needed():
    """An entry of the lists above that nothing matches any more is dropped, not kept."""
    constants = {(rel, node.value) for rel, tree in _modules(ROOT) for node in ast.walk(tree)
                 if isinstance(node, ast.Constant) and isinstance(node.value, str)}
    assert [k for k in NOT_PARAMETER_READS if k not in constants] == []


def test_the_scan_finds_each_kind_of_read(tmp_path):
    """The scan is not blind: each way of reading by name in a module is a finding."""
    (tmp_path / "coupling").mkdir()
    (tmp_path / "coupling" / "reads.py").write_text(
        'a = models.progress.parameters["L_max"].value\n'
        'p = models.pool.parameters\n'
        'b = p["pool_size"]\n'
        'c = models.parameter("tau_h")\n'
        'NAME = "tau_motor"\n'
        'd = models.value("tau_motor")\n'  # a door, but tau_motor is in no interface
        'e = models.value("L_max")\n',  # the door: no finding
        encoding="utf-8")
    lines = findings(tmp_path)
    text = "\n".join(lines)
    assert "reads.py:1: indexes a parameter table" in text
    assert "reads.py:3: indexes a parameter table" in text
    assert "reads.py:4: looks a parameter up by name" in text
    assert "reads.py:5: names parameter 'tau_motor' outside a door" in text
    assert "reads.py:6: value('tau_motor') but tau_motor is not in the motor_neuron" in text
    assert not any("reads.py:7" in line for line in lines)


def test_the_door_refuses_a_name_outside_the_interface():
    from astrocpg.errors import InputError
    assert DEFAULT_MODELS.value("L_max") == 10.0
    assert DEFAULT_MODELS.value("I_thigh") == pytest.approx(0.7)
    with pytest.raises(InputError, match="not in the motor_neuron model's interface"):
        DEFAULT_MODELS.value("tau_motor")


def test_every_interface_name_is_declared_by_the_default_models():
    """The built-in models honour their own interfaces (the check a model file meets)."""
    from astrocpg.models.files import check_interface
    for name, model in DEFAULT_MODELS.items():
        check_interface(model, INTERFACES.get(name), culprit=name)
