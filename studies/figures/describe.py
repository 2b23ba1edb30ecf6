"""``astrocpg describe [MODEL]``: each model's equations, rendered by sympy with the paper's
symbols, and its parameter table, as Markdown or LaTeX, to check a model against a paper.
``astrocpg describe senses`` lists the robot senses a neuron model may bind.

Equations come from the model's own Brian2 strings (so an edited model is described as it is);
a statement sympy cannot render (e.g. Brian2's ``timestep`` function) is shown as code.
"""

from __future__ import annotations

import re
from typing import Any

import sympy
from brian2 import Equations
from brian2.equations.equations import DIFFERENTIAL_EQUATION, SUBEXPRESSION
from brian2.parsing.sympytools import str_to_sympy

from ...errors import InputError, did_you_mean
from ...models import DEFAULT_MODELS, ModelSet

def _symbol_names(model: Any) -> dict[sympy.Symbol, str]:
    """Parameter names -> the paper's symbols (LaTeX) for sympy.latex."""
    out = {}
    for p in model.parameters.values():
        if p.symbol and p.symbol.strip():
            out[sympy.Symbol(p.name, real=True)] = p.symbol
            out[sympy.Symbol(p.name)] = p.symbol
    return out


def _latex(expr: str, names: dict[sympy.Symbol, str]) -> str | None:
    try:
        e = str_to_sympy(expr)
    except Exception:
        return None
    names = {s: names.get(s, names.get(sympy.Symbol(s.name), None)) for s in e.free_symbols}
    names = {s: v for s, v in names.items() if v}
    try:
        text = sympy.latex(e, symbol_names=names, mul_symbol="dot")
    except Exception:
        return None
    # Brian2 writes rand() as rand(_placeholder_arg) for sympy
    return text.replace(r"{\left(_placeholder_{arg} \right)}", "()")


def _name_latex(var: str, names: dict[sympy.Symbol, str]) -> str:
    return names.get(sympy.Symbol(var), sympy.latex(sympy.Symbol(var)))


def _unit(eq) -> str:
    dim = eq.dim
    if dim is None or dim.is_dimensionless:
        return "1"
    from brian2 import get_unit
    return str(get_unit(dim))


def model_lines(model: Any) -> list[dict[str, str]]:
    """The model's statements: kind, LaTeX (or None) and the Brian2 code."""
    names = _symbol_names(model)
    rows: list[dict[str, str]] = []
    text = getattr(model, "equations", None) or getattr(model, "model", None)
    if isinstance(text, str) and text.strip():
        for eq in Equations(text).ordered:
            lhs = _name_latex(eq.varname, names)
            flags = f" ({', '.join(sorted(eq.flags))})" if eq.flags else ""
            code = f"{eq.varname}{flags} : {_unit(eq)}"
            if eq.type == DIFFERENTIAL_EQUATION:
                rhs = _latex(str(eq.expr), names)
                latex = None if rhs is None else rf"\frac{{d{lhs}}}{{dt}} = {rhs}"
                code = f"d{eq.varname}/dt = {eq.expr} : {_unit(eq)}{flags}"
            elif eq.type == SUBEXPRESSION:
                rhs = _latex(str(eq.expr), names)
                latex = None if rhs is None else f"{lhs} = {rhs}"
                code = f"{eq.varname} = {eq.expr} : {_unit(eq)}{flags}"
            else:
                latex = None
            rows.append({"kind": "equation" if latex else "variable", "latex": latex,
                         "code": code})
    for var, binding in (getattr(model, "senses", None) or {}).items():
        only = f" (only {', '.join(binding.only)})" if binding.only else ""
        rows.append({"kind": "sense", "latex": None,
                     "code": f"{var} <- robot sense {binding.sense}{only}"})
    expression = getattr(model, "expression", None)
    if expression:
        rhs = _latex(expression, names)
        rows.append({"kind": "expression", "latex": None if rhs is None else f"{model.name} = "
                     f"{rhs}", "code": expression})
    for kind in ("threshold", "reset", "refractory", "on_pre", "on_step"):
        value = getattr(model, kind, None)
        if not value or not isinstance(value, str):
            continue
        for stmt in [s.strip() for s in re.split(r"[;\n]", value) if s.strip()]:
            latex = None
            m = re.match(r"^(\w+)\s*(\+=|-=|\*=|=)\s*(.+)$", stmt)
            if m and kind != "threshold":
                rhs = _latex(m.group(3), names)
                op = {"=": r"\leftarrow", "+=": r"\mathrel{+}=", "-=": r"\mathrel{-}=",
                      "*=": r"\mathrel{*}="}[m.group(2)]
                if rhs is not None:
                    latex = f"{_name_latex(m.group(1), names)} {op} {rhs}"
            elif kind == "threshold":
                latex = _latex(stmt, names)
            rows.append({"kind": kind, "latex": latex, "code": stmt})
    return rows


def _models(name: str | None, models: ModelSet) -> list[tuple[str, Any]]:
    items = list(models.items())
    if name is None:
        return items
    found = [(n, m) for n, m in items if n == name]
    if not found:
        names = [n for n, _ in items]
        parameters = sorted({p for _, m in items for p in m.parameters})
        raise InputError(f"'{name}' is neither a model nor a parameter"
                         f"{did_you_mean(name, names + ['senses'] + parameters)} "
                         f"(models: {', '.join(names)}; or 'senses'; or a parameter: "
                         f"'astrocpg models dump MODEL' lists a model's)", culprit="describe")
    return found


def _declaring(name: str, models: ModelSet) -> list[tuple[str, Any]]:
    """The models that declare parameter ``name`` (usually one)."""
    return [(n, m) for n, m in models.items() if name in m.parameters]


def describe_parameter(name: str, fmt: str = "markdown",
                       models: ModelSet = DEFAULT_MODELS) -> str:
    """One parameter: for each model that declares it, its value with units, symbol and
    meaning, and every statement of every model that uses it (equations, resets, on_pre...)."""
    parts = []
    users = [(n, row) for n, m in models.items() for row in model_lines(m)
             if re.search(rf"(?<![\w.]){re.escape(name)}(?!\w)", row["code"])]
    for model_name, model in _declaring(name, models):
        ((_, value, symbol, meaning),) = [r for r in model.parameters.rows() if r[0] == name]
        if fmt == "markdown":
            out = [f"## {name}: a parameter of {model_name}", "",
                   "| name | symbol | value | meaning |", "|---|---|---|---|",
                   f"| `{name}` | ${symbol}$ | {value} | {meaning} |", ""]
            if users:
                out.append("used in:")
                for user, row in users:
                    shown = f"$${row['latex']}$$  " if row["latex"] else ""
                    out.append(f"- {user} ({row['kind']}): {shown}`{row['code']}`")
            else:
                out.append(f"used in no statement of a model (read by the code that {model_name}"
                           f" configures: 'astrocpg describe {model_name}')")
        else:
            out = [rf"\subsection*{{{_tex_escape(name)}: a parameter of "
                   rf"{_tex_escape(model_name)}}}",
                   r"\begin{tabular}{llll}", r"name & symbol & value & meaning \\ \hline",
                   rf"\texttt{{{_tex_escape(name)}}} & ${symbol}$ & {_tex_escape(value)} & "
                   rf"{_tex_escape(meaning)} \\", r"\end{tabular}"]
            eqs = [(u, row) for u, row in users if row["latex"]]
            if eqs:
                out += [r"\begin{align*}", " \\\\\n".join(f"  &{row['latex']}"
                                                           for _, row in eqs), r"\end{align*}"]
            for user, row in users:
                if not row["latex"]:
                    out.append(rf"\noindent {_tex_escape(user)} ({row['kind']}): "
                               rf"\texttt{{{_tex_escape(row['code'])}}}\\")
        parts.append("\n".join(out))
    return "\n\n".join(parts) + "\n"


def describe(name: str | None = None, fmt: str = "markdown",
             models: ModelSet = DEFAULT_MODELS) -> str:
    """Markdown or LaTeX text describing one model or all of them."""
    if fmt not in ("markdown", "latex"):
        raise InputError(f"--format must be markdown or latex, got '{fmt}'")
    if name == "senses":  # not a model: what a neuron model may bind (models/senses.py)
        from ...models.senses import describe_senses
        text = describe_senses()
        if fmt == "markdown":
            return ("## Robot senses a neuron model may read (its [senses] table)\n\n```\n"
                    + text + "\n```\n")
        return "\\begin{verbatim}\n" + text + "\n\\end{verbatim}\n"
    if name is not None and name not in dict(models.items()) and _declaring(name, models):
        return describe_parameter(name, fmt, models)  # a parameter's name, not a model's
    parts = []
    for model_name, model in _models(name, models):
        desc = (model.description or "").strip()
        lines = model_lines(model)
        if fmt == "markdown":
            out = [f"## {model_name}", ""]
            if desc:
                out += [desc, ""]
            for row in lines:
                if row["latex"]:
                    out.append(f"- {row['kind']}: $${row['latex']}$$  `{row['code']}`")
                else:
                    out.append(f"- {row['kind']}: `{row['code']}`")
            out += ["", "| name | symbol | value | meaning |", "|---|---|---|---|"]
            for pname, value, symbol, meaning in model.parameters.rows():
                out.append(f"| `{pname}` | ${symbol}$ | {value} | {meaning} |")
            parts.append("\n".join(out))
        else:
            out = [rf"\subsection*{{{_tex_escape(model_name)}}}"]
            if desc:
                out.append(_tex_escape(desc))
            eqs = [row["latex"] for row in lines if row["latex"]]
            if eqs:
                out += [r"\begin{align*}", " \\\\\n".join(f"  &{e}" for e in eqs),
                        r"\end{align*}"]
            for row in lines:
                if not row["latex"]:
                    out.append(rf"\noindent {row['kind']}: \texttt{{{_tex_escape(row['code'])}}}"
                               r"\\")
            out += [r"\begin{tabular}{llll}", r"name & symbol & value & meaning \\ \hline"]
            for pname, value, symbol, meaning in model.parameters.rows():
                out.append(rf"\texttt{{{_tex_escape(pname)}}} & ${symbol}$ & "
                           rf"{_tex_escape(value)} & {_tex_escape(meaning)} \\")
            out.append(r"\end{tabular}")
            parts.append("\n".join(out))
    return "\n\n".join(parts) + "\n"


def _tex_escape(text: str) -> str:
    for a, b in (("\\", r"\textbackslash{}"), ("_", r"\_"), ("%", r"\%"), ("&", r"\&"),
                 ("#", r"\#"), ("$", r"\$"), ("{", r"\{"), ("}", r"\}")):
        text = text.replace(a, b)
    return text
