"""``astrocpg describe [MODEL]``: each model's equations and its parameter table, to check a
model against a paper: plain text for a terminal (the default), Markdown, or LaTeX (rendered by
sympy with the paper's symbols). ``astrocpg describe senses`` lists the robot senses a neuron
model may bind.

Equations come from the model's own Brian2 strings (so an edited model is described as it is),
in the order the model file states them and with its signs and terms in the order written (the
LaTeX is rendered from an unevaluated sympy tree); a statement sympy cannot render (e.g.
Brian2's ``timestep`` function) is shown as code.
"""

from __future__ import annotations

import re
from typing import Any

import sympy
from brian2 import Equations
from brian2.equations.equations import DIFFERENTIAL_EQUATION, SUBEXPRESSION
from brian2.parsing.rendering import SympyNodeRenderer

from ...errors import InputError, did_you_mean, setting
from ...models import DEFAULT_MODELS, ModelSet

#: what ``format`` may be: plain text for a terminal, Markdown, LaTeX
FORMATS = ("text", "markdown", "latex")

# a parameter table's "no symbol" (the symbol column of a switch or a seed)
_NO_SYMBOL = ("", "-")


def _has_symbol(symbol: str | None) -> bool:
    return bool(symbol) and symbol.strip() not in _NO_SYMBOL


def _plain_name(name: str) -> str:
    """A name without a symbol, in LaTeX: sympy's own for ``x``, ``n_pre``, ``IP3``; a name of
    several underscored parts keeps them (``I_{interlimb\\_post}``, not sympy's
    ``I_{interlimb post}``)."""
    head, _, rest = name.partition("_")
    if "_" not in rest:
        return sympy.latex(sympy.Symbol(name))
    rest = rest.replace("_", r"\_")
    return f"{sympy.latex(sympy.Symbol(head))}_{{{rest}}}"


def _symbol_names(model: Any) -> dict[str, str]:
    """Parameter names -> the paper's symbols (LaTeX) for sympy.latex."""
    return {p.name: p.symbol for p in model.parameters.values() if _has_symbol(p.symbol)}


def _sympy(expr: str) -> Any:
    """``expr`` as an unevaluated sympy tree: its terms in the order written."""
    with sympy.evaluate(False):
        return SympyNodeRenderer().render_expr(expr)


def _latex(expr: str, names: dict[str, str]) -> str | None:
    try:
        e = _sympy(expr)
    except Exception:
        return None
    symbols = {s: names.get(s.name) or _plain_name(s.name) for s in e.free_symbols
               if isinstance(s, sympy.Symbol)}
    try:
        text = sympy.latex(e, symbol_names=symbols, mul_symbol="dot", order="none")
    except Exception:
        return None
    # an unevaluated unary minus prints as (-1)·x
    text = re.sub(r"\\left\(-1\\right\) \\cdot ", "-", text)
    # Brian2 writes rand() as rand(_placeholder_arg) for sympy
    return text.replace(r"{\left(_placeholder_{arg} \right)}", "()")


def _name_latex(var: str, names: dict[str, str]) -> str:
    return names.get(var) or _plain_name(var)


def _unit(eq) -> str:
    dim = eq.dim
    if dim is None or dim.is_dimensionless:
        return "1"
    from brian2 import get_unit
    return str(get_unit(dim))


_GREEK = ("alpha beta gamma delta epsilon zeta eta theta iota kappa lambda mu nu xi pi rho "
          "sigma tau upsilon phi chi psi omega Gamma Delta Theta Lambda Xi Pi Sigma Phi Psi "
          "Omega").split()
_UNICODE = dict(zip(_GREEK, "αβγδεζηθικλμνξπρστυφχψωΓΔΘΛΞΠΣΦΨΩ"))
_UNICODE.update({"ell": "ℓ", "to": "→", "rightarrow": "→", "leftarrow": "←", "infty": "∞",
                 "cdot": "·"})


def plain_symbol(symbol: str) -> str:
    """A LaTeX symbol as plain Unicode text for a terminal (``\\tau_{\\mathrm{motor}}`` ->
    ``τ_motor``); a symbol with a command it does not know stays LaTeX."""
    text = re.sub(r"\\(mathrm|mathbf|mathit|text|operatorname)\s*\{", "{", symbol)
    text = text.replace(r"\_", "_").replace(r"\,", " ")
    text = re.sub(r"\\([A-Za-z]+)", lambda m: _UNICODE.get(m.group(1), m.group(0)), text)
    text = text.replace("{", "").replace("}", "")
    return symbol if "\\" in text else text


def _comments(text: str) -> dict[str, str]:
    """{variable: the comment of the line declaring it} of a Brian2 equation string."""
    out = {}
    for line in text.splitlines():
        m = re.match(r"^\s*(?:d(\w+)/dt|(\w+))\s*[=:][^#]*#\s*(.*?)\s*$", line)
        if m:
            out[m.group(1) or m.group(2)] = m.group(3)
    return out


def _code(expr: str) -> str:
    return " ".join(str(expr).split())


def _equation_rows(text: str, names: dict[str, str]) -> list[dict[str, Any]]:
    """The rows of a Brian2 equation string, in the order the text states them."""
    rows: list[dict[str, Any]] = []
    comments = _comments(text)
    eqs = Equations(text)
    for var in eqs.keys():  # the text's order (``.ordered`` sorts them by kind)
        eq = eqs[var]
        lhs = _name_latex(var, names)
        flags = f" ({', '.join(sorted(eq.flags))})" if eq.flags else ""
        note = comments.get(var, "")
        if eq.type == DIFFERENTIAL_EQUATION:
            rhs = _latex(str(eq.expr), names)
            latex = None if rhs is None else rf"\frac{{d{lhs}}}{{dt}} = {rhs}"
            plain = f"d{var}/dt = {_code(eq.expr)}"
        elif eq.type == SUBEXPRESSION:
            rhs = _latex(str(eq.expr), names)
            latex = None if rhs is None else f"{lhs} = {rhs}"
            plain = f"{var} = {_code(eq.expr)}"
        else:
            latex, plain = None, var
        code = f"{plain} : {_unit(eq)}{flags}"
        rows.append({"kind": "equation" if latex else "variable", "latex": latex,
                     "code": code, "text": plain, "note": note,
                     "unit": ", ".join([_unit(eq), *sorted(eq.flags)])})
    return rows


_ASSIGN = {"=": ("\\leftarrow", "←"), "+=": ("\\mathrel{+}=", "+="),
           "-=": ("\\mathrel{-}=", "-="), "*=": ("\\mathrel{*}=", "*=")}


def model_lines(model: Any) -> list[dict[str, str]]:
    """The model's statements, in its file's order: kind, LaTeX (or None), the Brian2 code,
    and (``text``, ``unit``, ``note``) the plain text of a terminal."""
    names = _symbol_names(model)
    rows: list[dict[str, Any]] = []
    text = getattr(model, "equations", None) or getattr(model, "model", None)
    if isinstance(text, str) and text.strip():
        rows += _equation_rows(text, names)
    for var, binding in (getattr(model, "senses", None) or {}).items():
        only = f" (only {', '.join(binding.only)})" if binding.only else ""
        code = f"{var} <- robot sense {binding.sense}{only}"
        rows.append({"kind": "sense", "latex": None, "code": code, "text": code})
    expression = getattr(model, "expression", None)
    if expression:
        rhs = _latex(expression, names)
        rows.append({"kind": "expression", "latex": None if rhs is None else f"{model.name} = "
                     f"{rhs}", "code": expression,
                     "text": f"{model.name} = {_code(expression)}"})
    for kind in ("threshold", "reset", "refractory", "on_pre", "on_step"):
        value = getattr(model, kind, None)
        if not value or not isinstance(value, str):
            continue
        for stmt in [s.strip() for s in re.split(r"[;\n]", value) if s.strip()]:
            latex, plain = None, _code(stmt)
            m = re.match(r"^(\w+)\s*(\+=|-=|\*=|=)\s*(.+)$", stmt)
            if m and kind != "threshold":
                rhs = _latex(m.group(3), names)
                op, arrow = _ASSIGN[m.group(2)]
                if rhs is not None:
                    latex = f"{_name_latex(m.group(1), names)} {op} {rhs}"
                plain = f"{m.group(1)} {arrow} {_code(m.group(3))}"
            elif kind == "threshold":
                latex = _latex(stmt, names)
            rows.append({"kind": kind, "latex": latex, "code": stmt, "text": plain})
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


def _table(rows: list[tuple[str, ...]], indent: str = "  ") -> list[str]:
    """Rows as plain-text columns, the first row the header."""
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]) - 1)]
    return [(indent + "  ".join(c.ljust(w) for c, w in zip(r, widths)) + "  " + r[-1]).rstrip()
            for r in rows]


def _parameter_rows(model: Any) -> list[tuple[str, str, str, str]]:
    return [("name", "symbol", "value", "meaning")] + [
        (name, plain_symbol(symbol) if _has_symbol(symbol) else "-", value, meaning)
        for name, value, symbol, meaning in model.parameters.rows()]


def _text_statements(lines: list[dict[str, Any]]) -> list[str]:
    """The plain-text statements of a model: each with its unit and the file's comment."""
    out = []
    for row in lines:
        text = row["text"]
        if row["kind"] not in ("equation", "variable", "expression", "sense"):
            text = f"{row['kind']}: {text}"
        extra = f"  [{row['unit']}]" if row.get("unit") else ""
        note = f"  # {row['note']}" if row.get("note") else ""
        out.append(f"  {text}{extra}{note}")
    return out


def _parameter_text(name: str, model_name: str, model: Any,
                    users: list[tuple[str, dict[str, Any]]]) -> list[str]:
    ((_, value, symbol, meaning),) = [r for r in model.parameters.rows() if r[0] == name]
    head = f"{name}: a parameter of {model_name}"
    out = [head, "=" * len(head), "",
           *_table(_parameter_rows(model)[:1] + [(name, plain_symbol(symbol)
                                                  if _has_symbol(symbol) else "-",
                                                  value, meaning)], indent=""), ""]
    if users:
        out.append("used in:")
        for user, row in users:
            out.append(f"  {user} ({row['kind']}): {row['text']}")
    else:
        out.append(f"used in no statement of a model (read by the code that {model_name} "
                   f"configures: 'astrocpg describe {model_name}')")
    return out


def describe_parameter(name: str, fmt: str = "text", models: ModelSet | None = None) -> str:
    """One parameter: for each model that declares it, its value with units, symbol and
    meaning, and every statement of every model that uses it (equations, resets, on_pre...)."""
    models = DEFAULT_MODELS if models is None else models
    parts = []
    users = [(n, row) for n, m in models.items() for row in model_lines(m)
             if re.search(rf"(?<![\w.]){re.escape(name)}(?!\w)", row["code"])]
    for model_name, model in _declaring(name, models):
        ((_, value, symbol, meaning),) = [r for r in model.parameters.rows() if r[0] == name]
        if fmt == "text":
            out = _parameter_text(name, model_name, model, users)
        elif fmt == "markdown":
            out = [f"## {name}: a parameter of {model_name}", "",
                   "| name | symbol | value | meaning |", "|---|---|---|---|",
                   f"| `{name}` | {_md_symbol(symbol)} | {value} | {meaning} |", ""]
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
                   rf"\texttt{{{_tex_escape(name)}}} & {_tex_symbol(symbol)} & "
                   rf"{_tex_escape(value)} & {_tex_escape(meaning)} \\", r"\end{tabular}"]
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


def _md_symbol(symbol: str) -> str:
    return f"${symbol}$" if _has_symbol(symbol) else "-"


def _tex_symbol(symbol: str) -> str:
    return f"${symbol}$" if _has_symbol(symbol) else "--"


def _describe_text(model_name: str, model: Any, desc: str, lines: list[dict[str, Any]]) -> str:
    out = [model_name, "=" * len(model_name), ""]
    if desc:
        out += [desc, ""]
    if lines:
        out += ["statements (in the model file's order; [unit, flags]):", *_text_statements(lines),
                ""]
    if len(model.parameters):
        out += ["parameters:", *_table(_parameter_rows(model))]
    return "\n".join(out).rstrip()


def _describe_markdown(model_name: str, model: Any, desc: str,
                       lines: list[dict[str, Any]]) -> str:
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
        out.append(f"| `{pname}` | {_md_symbol(symbol)} | {value} | {meaning} |")
    return "\n".join(out)


def _describe_latex(model_name: str, model: Any, desc: str, lines: list[dict[str, Any]]) -> str:
    out = [rf"\subsection*{{{_tex_escape(model_name)}}}"]
    if desc:
        out.append(_tex_escape(desc))
    eqs = [row["latex"] for row in lines if row["latex"]]
    if eqs:
        out += [r"\begin{align*}", " \\\\\n".join(f"  &{e}" for e in eqs), r"\end{align*}"]
    for row in lines:
        if not row["latex"]:
            out.append(rf"\noindent {row['kind']}: \texttt{{{_tex_escape(row['code'])}}}"
                       r"\\")
    out += [r"\begin{tabular}{llll}", r"name & symbol & value & meaning \\ \hline"]
    for pname, value, symbol, meaning in model.parameters.rows():
        out.append(rf"\texttt{{{_tex_escape(pname)}}} & {_tex_symbol(symbol)} & "
                   rf"{_tex_escape(value)} & {_tex_escape(meaning)} \\")
    out.append(r"\end{tabular}")
    return "\n".join(out)


def _senses(fmt: str) -> str:
    from ...models.senses import describe_senses
    text = describe_senses()
    if fmt == "text":
        return "Robot senses a neuron model may read (its [senses] table)\n\n" + text + "\n"
    if fmt == "markdown":
        return ("## Robot senses a neuron model may read (its [senses] table)\n\n```\n"
                + text + "\n```\n")
    return "\\begin{verbatim}\n" + text + "\n\\end{verbatim}\n"


def describe(name: str | None = None, fmt: str = "text", models: ModelSet | None = None) -> str:
    """Plain text, Markdown or LaTeX describing one model or all of them (``models``: None,
    the built-in ones)."""
    models = DEFAULT_MODELS if models is None else models
    if fmt not in FORMATS:
        raise InputError(f"must be {', '.join(FORMATS[:-1])} or {FORMATS[-1]}, got "
                         f"'{fmt}'{did_you_mean(fmt, FORMATS)}", culprit=setting("format"))
    if name == "senses":  # not a model: what a neuron model may bind (models/senses.py)
        return _senses(fmt)
    if name is not None and name not in dict(models.items()) and _declaring(name, models):
        return describe_parameter(name, fmt, models)  # a parameter's name, not a model's
    render = {"text": _describe_text, "markdown": _describe_markdown,
              "latex": _describe_latex}[fmt]
    parts = [render(model_name, model, (model.description or "").strip(), model_lines(model))
             for model_name, model in _models(name, models)]
    return "\n\n".join(parts) + "\n"


def _tex_escape(text: str) -> str:
    for a, b in (("\\", r"\textbackslash{}"), ("_", r"\_"), ("%", r"\%"), ("&", r"\&"),
                 ("#", r"\#"), ("$", r"\$"), ("{", r"\{"), ("}", r"\}")):
        text = text.replace(a, b)
    return text
