"""The API reference reads well: every public function (``import astrocpg as ac``) has numpydoc
Parameters and Returns sections naming each of its parameters; no signature the reference
prints carries a default whose repr is longer than a line (a 32,000-character ``ModelSet``
once); and each summary autosummary takes (the first sentence) is a whole sentence, not cut
inside parentheses (``(Fig.``)."""

from __future__ import annotations

import importlib
import inspect
import re
from pathlib import Path

import pytest

import astrocpg as ac

ROOT = Path(__file__).resolve().parents[1]
FUNCTIONS = [n for n in ac.__all__ if inspect.isfunction(getattr(ac, n))]


def _section(doc: str, title: str) -> str | None:
    m = re.search(rf"^{title}\n-{{{len(title)}}}\n(.*?)(?=^\w[\w ]*\n-+\n|\Z)", doc, re.M | re.S)
    return m.group(1) if m else None


def test_the_public_functions_are_found() -> None:
    assert {"run", "unit", "train", "resume", "study", "evaluate", "load", "export",
            "describe", "report", "docs"} <= set(FUNCTIONS)


@pytest.mark.parametrize("name", FUNCTIONS)
def test_each_public_function_has_parameters_and_returns(name: str) -> None:
    func = getattr(ac, name)
    doc = inspect.getdoc(func) or ""
    params = _section(doc, "Parameters")
    returns = _section(doc, "Returns")
    assert params is not None and returns is not None and returns.strip(), \
        f"ac.{name}: no numpydoc Parameters / Returns section"
    documented = {p.strip() for line in params.splitlines() if line and not line[0].isspace()
                  for p in line.split(" : ")[0].split(",")}
    missing = [p for p in inspect.signature(func).parameters if p not in documented]
    assert not missing, f"ac.{name}: parameters not in its Parameters section: {missing}"


def _documented_callables() -> list[tuple[str, object]]:
    """Every function and method the API reference (docs/api/*.md) prints a signature of."""
    out: list[tuple[str, object]] = [(f"astrocpg.{n}", getattr(ac, n)) for n in FUNCTIONS]
    for page in sorted((ROOT / "docs" / "api").glob("*.md")):
        text = page.read_text(encoding="utf-8")
        for m in re.finditer(r"^\.\. auto(function|class|module):: (\S+)\n((?:   :\w+:.*\n)*)",
                             text, re.M):
            kind, target, options = m.groups()
            members = re.search(r":members:(.*)", options)
            module_name, _, attr = target.rpartition(".")
            if kind == "module":
                obj = importlib.import_module(target)
            else:
                try:
                    obj = getattr(importlib.import_module(module_name), attr)
                except (ImportError, AttributeError):
                    obj = getattr(ac, attr)
            if kind == "function":
                out.append((target, obj))
                continue
            names = [x.strip() for x in members.group(1).split(",") if x.strip()] if members \
                else []
            if kind == "class":
                out.append((target, obj))  # its __init__'s signature
            for n in names:
                out.append((f"{target}.{n}", getattr(obj, n)))
            if kind == "module" and members and not names:  # every public function
                out += [(f"{target}.{n}", f) for n, f in vars(obj).items()
                        if inspect.isfunction(f) and f.__module__ == obj.__name__
                        and not n.startswith("_")]
    return out


def test_no_signature_prints_a_giant_default() -> None:
    found = _documented_callables()
    assert len(found) > 30
    long = []
    for name, obj in found:
        try:
            sig = inspect.signature(obj)
        except (TypeError, ValueError):
            continue
        for p in sig.parameters.values():
            if p.default is not inspect.Parameter.empty and len(repr(p.default)) > 80:
                long.append(f"{name}({p.name}=...): a default of {len(repr(p.default))} "
                            f"characters")
    assert not long, "\n".join(long)


def _summary(doc: str) -> str:
    from docutils.frontend import get_default_settings
    from docutils.parsers.rst import Parser
    from docutils.utils import new_document
    from sphinx.ext.autosummary import extract_summary

    settings = get_default_settings(Parser)
    settings.report_level = 5
    document = new_document("api", settings)
    try:
        return extract_summary(doc.splitlines(), document.settings)
    except AttributeError:  # an older Sphinx takes the document
        return extract_summary(doc.splitlines(), document)


@pytest.mark.parametrize("name", FUNCTIONS + ["Result", "Trace"])
def test_each_summary_is_a_whole_sentence(name: str) -> None:
    summary = _summary(inspect.getdoc(getattr(ac, name)) or "")
    assert summary.count("(") == summary.count(")") and summary.endswith("."), \
        f"ac.{name}: the API index shows {summary!r}"
