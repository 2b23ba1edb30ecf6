"""The longest functions and modules of the package (lines, from the AST; tests, docs and
benchmarks left out), to see which rooms are overfull.

    python benchmarks/longest.py            # this checkout
    python benchmarks/longest.py DIR --top 10   # another tree, e.g. `git archive REV | tar -x -C DIR`
"""

from __future__ import annotations

import argparse
import ast
from pathlib import Path

SKIP = ("tests/", "docs/", "benchmarks/", "_build_backend/", "build/")


def measure(root: Path) -> tuple[list[tuple[int, str]], list[tuple[int, str]]]:
    """(functions, modules) as (lines, name), longest first."""
    funcs, mods = [], []
    for p in sorted(root.rglob("*.py")):
        rel = p.relative_to(root).as_posix()
        if rel.startswith(SKIP) or any(part.startswith(".") for part in Path(rel).parts):
            continue
        src = p.read_text(encoding="utf-8")
        mods.append((len(src.splitlines()), rel))
        for node in ast.walk(ast.parse(src)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                funcs.append((node.end_lineno - node.lineno + 1, f"{rel}:{node.name}"))
    return sorted(funcs, reverse=True), sorted(mods, reverse=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", nargs="?", default=str(Path(__file__).resolve().parents[1]),
                        help="the tree to measure (default: this checkout)")
    parser.add_argument("--top", type=int, default=8, help="how many of each (default 8)")
    args = parser.parse_args()
    funcs, mods = measure(Path(args.root))
    print("functions: " + ", ".join(f"{name} {n}" for n, name in funcs[:args.top]))
    print("modules:   " + ", ".join(f"{name} {n}" for n, name in mods[:args.top]))


if __name__ == "__main__":
    main()
