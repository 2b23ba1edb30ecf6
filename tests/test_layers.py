"""The house rules, as tests: imports point down only (import-linter contracts in
pyproject.toml), nothing imports the command line, no private name crosses a module, no module
below the command line names one of its options."""

from __future__ import annotations

import argparse
import ast
import re
import shutil
import subprocess
import sys
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_DIRS = ("models", "network", "coupling", "studies", "support")


def _package_files() -> list[Path]:
    return [p for d in PACKAGE_DIRS for p in sorted((ROOT / d).rglob("*.py"))]


def test_import_linter_contracts_kept():
    exe = shutil.which("lint-imports") or str(Path(sys.executable).with_name("lint-imports"))
    if not Path(exe).exists():
        pytest.fail("lint-imports not installed: pip install -e '.[test]'")
    proc = subprocess.run([exe, "--config", str(ROOT / "pyproject.toml")], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-2000:]
    assert "broken" not in proc.stdout.lower().replace("0 broken", "")


def _imports(path: Path):
    tree = ast.parse(path.read_text(), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            yield node, node.module or "", [a.name for a in node.names]
        elif isinstance(node, ast.Import):
            yield node, "", [a.name for a in node.names]


def test_nothing_imports_the_command_line():
    offenders = []
    for path in _package_files():
        if (ROOT / "studies" / "cli") in path.parents:  # the command line's own modules
            continue
        for node, module, names in _imports(path):
            if module.endswith("cli") or "cli" in names or any(n.endswith(".cli") for n in names):
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not offenders, offenders


def test_no_private_name_imported_across_modules():
    offenders = []
    for path in _package_files():
        for node, module, names in _imports(path):
            if not isinstance(node, ast.ImportFrom) or node.level == 0:
                continue  # third-party internals (brian2's) are not ours to rename
            for name in names:
                if name.startswith("_") and not name.startswith("__"):
                    offenders.append(f"{path.relative_to(ROOT)}:{node.lineno} {name}")
    assert not offenders, offenders


def test_no_eval_or_exec_in_the_package():
    """Input is parsed, never evaluated (values, expressions, study files)."""
    offenders = []
    for path in _package_files():
        tree = ast.parse(path.read_text(), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                    and node.func.id in ("eval", "exec"):
                offenders.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not offenders, offenders


# ------------------------------------------------ option names belong to the command line
# A module below the command line names a setting by its field (``seconds``, ``overrides``,
# ``trace_dtype``), never by an option (``--seconds``, ``--set``): only ``studies/cli/`` knows
# how the command line spells a setting, so renaming an option touches that package alone.

def _option_strings() -> set[str]:
    """Every long option of every command of the command line (bar --help and --version)."""
    from astrocpg.studies.cli.grammar import build_parser

    found: set[str] = set()
    parsers = [build_parser()]
    while parsers:
        for action in parsers.pop()._actions:
            found.update(o for o in action.option_strings if o.startswith("--"))
            if isinstance(action, argparse._SubParsersAction):
                parsers.extend(action.choices.values())
    return found - {"--help", "--version"}


def _option_pattern(options) -> re.Pattern[str]:
    alternatives = "|".join(re.escape(o) for o in sorted(options, key=len, reverse=True))
    return re.compile(rf"(?<![\w-])({alternatives})(?![\w-])")


def _option_mentions(path: Path, pattern) -> list[tuple[int, str]]:
    """(line, option) of each option ``pattern`` finds in the strings, docstrings and comments
    of the Python file ``path``."""
    kinds = {tokenize.STRING, tokenize.COMMENT, getattr(tokenize, "FSTRING_MIDDLE", -1)}
    found = []
    with open(path, "rb") as f:
        for token in tokenize.tokenize(f.readline):
            if token.type not in kinds:
                continue
            for m in pattern.finditer(token.string):
                found.append((token.start[0] + token.string.count("\n", 0, m.start()),
                              m.group(1)))
    return found


def test_no_option_name_below_the_command_line():
    pattern = _option_pattern(_option_strings())
    cli = ROOT / "studies" / "cli"
    offenders = [f"{path.relative_to(ROOT)}:{line}:{option}"
                 for path in [*sorted(ROOT.glob("*.py")), *_package_files()]
                 if cli not in path.parents
                 for line, option in _option_mentions(path, pattern)]
    assert not offenders, f"{len(offenders)} option names below the command line:\n" \
        + "\n".join(offenders)


def test_option_scanner_finds_a_planted_mention(tmp_path):
    planted = tmp_path / "planted.py"
    planted.write_text('"""Set it with ``--seconds``."""\n'
                       'x = 1  # or --set, not --settings nor a--set\n'
                       'y = f"record again with --trace-dtype {x}"\n'
                       'z = "--out-of-scope"\n')
    pattern = _option_pattern({"--seconds", "--set", "--trace-dtype", "--out"})
    assert _option_mentions(planted, pattern) == [(1, "--seconds"), (2, "--set"),
                                                   (3, "--trace-dtype")]
