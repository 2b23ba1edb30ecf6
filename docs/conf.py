"""Sphinx configuration of the astrocpg manual.

Build (from the repository root, with ``pip install -e ".[docs]"``)::

    python -m sphinx -W -n --keep-going -b html docs docs/_build/html

Why Sphinx: the API reference is generated from the package's own docstrings (autodoc,
autosummary), the pages are Markdown (MyST), and the tutorial and the examples are notebooks
that myst-nb executes during the build, so every figure of an example is drawn by the code of
the tree being built. ``-W`` turns every warning into an error and ``-n`` makes every
cross-reference that does not resolve a warning, so a broken internal link, a stale API name or
an example that raises fails the build (``tests/test_docs.py`` runs it).
"""

from __future__ import annotations

import json
import re
import os
import sys
import tempfile
from pathlib import Path

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent

import astrocpg  # noqa: E402  (the package documented: must be this tree)

if Path(astrocpg.__file__).resolve().parent != ROOT.resolve():
    raise RuntimeError(
        f"the manual documents {ROOT}, but 'import astrocpg' finds {astrocpg.__file__}: "
        f"install this tree (pip install -e \".[docs]\") or put it on PYTHONPATH")

project = "astrocpg"
author = "The astrocpg authors"
copyright = "2026, The astrocpg authors"
release = version = astrocpg.__version__

extensions = [
    "myst_nb",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",   # MathJax 3 copied into _static/mathjax: equations need no network
    "sphinx_copybutton",
]

# MathJax is served from the built manual (_static/mathjax, copied there by
# sphinx-mathjax-offline), never from a CDN, so the equations render on a machine without
# internet and from file://. Its SVG output draws every glyph itself: no web font to load, which
# a browser may refuse from file://. The extension sets its own `mathjax_path` (CHTML) when it
# loads, after this file is read, so `setup` below sets ours.
MATHJAX_PATH = "mathjax/tex-svg.js"

# The result folders under docs/ (recorded studies, their reports) are data that the pages
# show and link to, not pages of their own.
exclude_patterns = ["_build", "ablation", "beyond", "variants", "seeing", "benchmarks",
                    "**/.ipynb_checkpoints",
                    "Thumbs.db", ".DS_Store"]

html_theme = "furo"
html_title = f"astrocpg {release}"
html_static_path = ["_static"]
html_css_files = ["astrocpg.css"]   # the model's wide parameter tables fit the text column
templates_path: list[str] = []

myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]

# --- the examples: executed at every build, in a temporary folder, by this interpreter -------
nb_execution_mode = "cache"
nb_execution_timeout = 600
nb_execution_raise_on_error = True   # an example that raises fails the build
nb_execution_in_temp = True          # whatever an example writes stays out of the tree
nb_execution_show_tb = True
nb_merge_streams = True
nb_render_markdown_format = "myst"   # Markdown outputs (the model's parameter tables) as MyST

# One kernel for every notebook: this very interpreter, with matplotlib's inline backend (so
# figures land on the page even when MPLBACKEND=Agg is set for the tests). The pages name no
# kernel, so Jupyter starts its default, "python3": this one, found first on JUPYTER_PATH
# whatever other "python3" kernels this machine has.
_KERNEL = "python3"
_kernels = Path(tempfile.mkdtemp(prefix="astrocpg-docs-jupyter-"))
(_kernels / "kernels" / _KERNEL).mkdir(parents=True)
(_kernels / "kernels" / _KERNEL / "kernel.json").write_text(json.dumps({
    "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
    "display_name": "astrocpg docs", "language": "python",
    "env": {"MPLBACKEND": "module://matplotlib_inline.backend_inline",
            # no ipywidgets here: tqdm's notebook bars fall back to text, which it says
            "PYTHONWARNINGS": "ignore:IProgress not found",
            # where the recorded results are, for the pages that read their manifests
            "ASTROCPG_DOCS": str(DOCS)}}))
os.environ["JUPYTER_PATH"] = os.pathsep.join(
    [str(_kernels)] + [p for p in os.environ.get("JUPYTER_PATH", "").split(os.pathsep) if p])

# --- the API reference -----------------------------------------------------------------------
autosummary_generate = False          # the pages hold the autodoc directives themselves
autodoc_typehints = "none"            # signatures stay readable; docstrings say the types
autodoc_member_order = "bysource"

nitpicky = True
# Names of other libraries (no intersphinx: the build must not need the network).
nitpick_ignore_regex = [
    (r"py:.*", r"(numpy|np|pandas|pd|brian2|mujoco|matplotlib|pathlib|typing|collections|os"
               r"|dask|distributed|pynwb|datetime)(\..*)?"),
    (r"py:.*", r"(Path|Any|Mapping|Sequence|Iterable|Callable|NoReturn|Figure|Quantity"
               r"|Network|DataFrame|MjModel|MjData|ndarray)"),
]


def _numpydoc(app, what, name, obj, options, lines):
    """A docstring with numpydoc's underlined sections (Parameters, Returns, Raises, Examples)
    as reST, by Sphinx's napoleon; only those (the others are plain text, read by
    :func:`_plain_docstring`), their types as text, not cross-references to builtins this
    offline build cannot resolve."""
    if not any(re.fullmatch(r"\s*-{3,}\s*", line) for line in lines):
        return
    from sphinx.ext.napoleon import Config
    from sphinx.ext.napoleon.docstring import NumpyDocstring

    config = Config(napoleon_use_param=False, napoleon_use_rtype=False,
                    napoleon_google_docstring=False)
    lines[:] = NumpyDocstring(lines, config, app, what, name, obj, options).lines()


def _plain_docstring(app, what, name, obj, options, lines):
    """The project's docstrings are plain text: ``name: what it is`` lines whose continuation
    is indented, and aligned ``name    what`` tables. reST reads an indented continuation as a
    block quote ("Unexpected indentation"), so join continuations to their line (literal
    blocks after ``::`` stay as they are), and keep a paragraph made only of such lines one
    line each (a line block)."""
    out: list[str] = []
    literal = None          # indentation of the paragraph that opened a literal block
    for line in lines:
        indent = len(line) - len(line.lstrip())
        if literal is not None and (not line.strip() or indent > literal):
            out.append(line)
            continue
        literal = None
        prev = out[-1] if out else ""
        prev_indent = len(prev) - len(prev.lstrip())
        if line.strip() and prev.strip() and indent > prev_indent and not prev.rstrip().endswith("::"):
            out[-1] = prev.rstrip() + " " + line.strip()
        else:
            out.append(line)
        if out[-1].rstrip().endswith("::"):
            literal = len(out[-1]) - len(out[-1].lstrip())
    key = re.compile(r"^\s*[\w][\w ,/()*.-]*?(: | {2,})\S")
    result: list[str] = []
    paragraph: list[str] = []
    for line in out + [""]:
        if line.strip():
            paragraph.append(line)
            continue
        if len(paragraph) >= 2 and all(key.match(x) for x in paragraph):
            result.extend("| " + x.strip() for x in paragraph)
        else:
            result.extend(paragraph)
        result.append(line)
        paragraph = []
    lines[:] = result[:-1]


nitpick_ignore = [("py:class", "Trainer"), ("py:class", "TrainingStopped"),
                  ("py:class", "Study"), ("py:class", "RunSpec")]


def setup(app):
    app.config.mathjax_path = MATHJAX_PATH
    app.connect("autodoc-process-docstring", _numpydoc)
    app.connect("autodoc-process-docstring", _plain_docstring)
