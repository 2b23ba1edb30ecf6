"""Functions stay short enough to read as named steps: none in the package over 150 lines,
none in the command line (studies/cli/) over 120, none in the commands (studies/commands/: a
command's checks, its simulation and its writing as steps of their own) over 80."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SKIP = ("tests", "docs", "benchmarks", "_build_backend", ".venv", "build")
PACKAGE_LIMIT = 150
CLI_LIMIT = 120
COMMANDS_LIMIT = 80


def _package_files() -> list[Path]:
    return [p for p in sorted(ROOT.rglob("*.py"))
            if not set(p.relative_to(ROOT).parts[:-1]) & set(SKIP)
            and not any(part.startswith(".") for part in p.relative_to(ROOT).parts)]


def _functions(path: Path):
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
            yield node.name, node.lineno, node.end_lineno - first + 1


def _too_long(limit_of) -> list[str]:
    found = []
    for path in _package_files():
        rel = path.relative_to(ROOT)
        limit = limit_of(rel)
        for name, line, length in _functions(path):
            if length > limit:
                found.append(f"{rel.as_posix()}:{line} {name} ({length} lines > {limit})")
    return found


def test_no_function_in_the_package_is_over_150_lines():
    assert _package_files(), "no package files found"
    assert not _too_long(lambda rel: PACKAGE_LIMIT)


def test_no_function_in_the_command_line_is_over_120_lines():
    cli = [p for p in _package_files() if p.relative_to(ROOT).parts[:2] == ("studies", "cli")]
    assert len(cli) >= 4, cli  # the package: grammar, handlers, process plumbing
    assert not _too_long(lambda rel: CLI_LIMIT if rel.parts[:2] == ("studies", "cli")
                         else PACKAGE_LIMIT)


def test_no_function_in_the_commands_is_over_80_lines():
    commands = [p for p in _package_files()
                if p.relative_to(ROOT).parts[:2] == ("studies", "commands")]
    assert len(commands) >= 10, commands
    assert not _too_long(lambda rel: COMMANDS_LIMIT if rel.parts[:2] == ("studies", "commands")
                         else PACKAGE_LIMIT)


def test_the_walk_measures_what_it_should(tmp_path):
    """A function of 151 lines is found (the check can fail)."""
    f = tmp_path / "long.py"
    f.write_text("def f():\n" + "    x = 1\n" * 150)
    assert [length for _, _, length in _functions(f)] == [151]
