"""What the manual's pages name is what the tool writes or accepts.

- Figure tables (a table whose first column is headed ``figure`` and lists code names) list
  exactly the figures one kind of ``astrocpg plot`` writes: those drawn from a run's recording
  (:func:`~astrocpg.studies.figures.traces.trace_figures`, the registry ``plot`` of a run,
  unit or recorded session calls) or those ``plot`` of a training writes. A "(N figures)" next
  to a ``plot`` of a run is that count.
- File names in prose and tables (``name.npz``, ``.csv``, ``.json``, ``.png``, ...) are written
  by the package (a name in its source), are in the repository, or are named by one of the
  manual's commands; a table of a run's files lists exactly the files ``astrocpg run`` writes.
- Study files: every TOML study in the pages (a fenced ``toml`` block, or a heredoc of a shell
  block, with a ``[study]`` table) uses only keys the parser accepts, and loads when it names
  no file beside it; the study-file reference lists every key the parser accepts, and only
  those.
- Quoted error lines (``astrocpg: error: ...``, ``astrocpg: environment: ...``,
  ``astrocpg: diverged: ...``) are messages the code raises, with the kind its exception
  prints.
"""

from __future__ import annotations

import ast
import re
import tomllib
from functools import lru_cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [p for p in sorted(DOCS.rglob("*.md")) + [ROOT / "README.md"]
         if "_build" not in p.parts and "changelog" not in p.name.lower()]
FENCE = re.compile(r"^(`{3,}|~{3,})([^\n]*)\n(.*?)^\1[ \t]*$", re.S | re.M)
EXT = r"(?:npz|csv|csv\.gz|json|png|mp4|nwb|pdf|svg|txt)"
FILE_NAME = re.compile(rf"[A-Za-z0-9_.<>-]+\.{EXT}")
TRAINED = DOCS / "benchmarks" / "trained_astrocytes"


def _text(page: Path) -> str:
    return page.read_text(encoding="utf-8")


def _prose(text: str) -> str:
    """The page without its fenced blocks."""
    return FENCE.sub("", text)


def _tables(text: str) -> list[list[list[str]]]:
    """The Markdown tables of a page's prose, each a list of rows of cells (the header first,
    the rule left out)."""
    tables, rows = [], []
    for line in _prose(text).splitlines() + [""]:
        if line.startswith("|"):
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if not all(re.fullmatch(r":?-+:?", c) for c in cells):
                rows.append(cells)
        elif rows:
            tables.append(rows)
            rows = []
    return tables


def _code_names(cell: str) -> list[str]:
    return re.findall(r"`([^`]+)`", cell)


def _matches(listed: str, name: str) -> bool:
    """``astrocyte_<leg>_<pool>`` (a placeholder in angle brackets) matches
    ``astrocyte_FR_thigh_flexor``."""
    pattern = "".join(r"[A-Za-z0-9_]+" if part.startswith("<") else re.escape(part)
                      for part in re.split(r"(<[^>]+>)", listed))
    return re.fullmatch(pattern, name) is not None


# --- what the tool writes --------------------------------------------------------------------

@pytest.fixture(scope="module")
def written(tmp_path_factory) -> dict[str, set[str]]:
    """The figures and files the tool writes: a 0.05 s run with its default recording (its
    folder's files and the figures of its recording) and ``plot`` of a committed training
    (0.2 s with its trained tables)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import astrocpg as ac
    from astrocpg.studies.figures.traces import trace_figures

    tmp = tmp_path_factory.mktemp("written")
    result = ac.run(seconds=0.05, seed=1, out=tmp / "run", progress=False)
    figures = trace_figures(result)
    for fig in figures.values():
        plt.close(fig)
    training = ac.plot(TRAINED, seconds=0.2, out=tmp / "training", progress=False)
    plt.close("all")
    return {"run figures": set(figures),
            "training figures": {p.stem for p in training if p.parent == tmp / "training"},
            "run files": {p.name for p in (tmp / "run").iterdir()}}


def test_every_figure_table_lists_the_figures_plot_writes(written) -> None:
    kinds = {k: v for k, v in written.items() if k.endswith("figures")}
    assert all(kinds.values()), kinds
    found = 0
    for page in PAGES:
        for table in _tables(_text(page)):
            if table[0][0].lower() != "figure":
                continue
            listed = [n for row in table[1:] for n in _code_names(row[0])]
            if not listed:  # a table of published figures, in words
                continue
            found += 1
            fits = [kind for kind, names in kinds.items()
                    if all(any(_matches(x, n) for n in names) for x in listed)
                    and all(any(_matches(x, n) for x in listed) for n in names)]
            assert fits, (f"{page.relative_to(ROOT)}: the figure table {listed} is not the "
                          f"figures of one kind of plot: "
                          + "; ".join(f"{k}: {sorted(v)}" for k, v in kinds.items()))
    assert found >= 2, "no figure tables found"


def test_a_count_of_figures_is_the_count_plot_writes(written) -> None:
    for page in PAGES:
        for m in re.finditer(r"astrocpg plot out/\S+[^\n]*?\((\d+) figures\)", _text(page)):
            assert int(m.group(1)) == len(written["run figures"]), (
                f"{page.relative_to(ROOT)}: {m.group(0)!r}, but plot of a run writes "
                f"{len(written['run figures'])}")


def test_a_table_of_a_runs_files_lists_the_files_a_run_writes(written) -> None:
    run_files = written["run files"]
    assert {"manifest.json", "spikes.npz", "traces.npz", "robot.npz"} <= run_files
    page = DOCS / "first-run.md"
    tables = [t for t in _tables(_text(page)) if t[0][0].lower() == "file"]
    assert tables, "first-run.md has no table of a run's files"
    listed = {n for row in tables[0][1:] for n in _code_names(row[0])}
    assert listed == run_files, (listed, run_files)


@lru_cache(maxsize=1)
def _package_file_names() -> tuple[frozenset[str], tuple[str, ...]]:
    """File names in the package's source: string constants, and f-strings as patterns."""
    names: set[str] = set()
    patterns: list[str] = []
    for f in ROOT.rglob("*.py"):
        rel = f.relative_to(ROOT).parts
        if rel[0] in ("tests", "docs", "benchmarks", "build") or any(
                p.startswith(".") or p == "_build" for p in rel):
            continue
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                names.update(FILE_NAME.findall(node.value))
                names.add(node.value)
            elif isinstance(node, ast.JoinedStr):
                pattern = "".join(re.escape(v.value) if isinstance(v, ast.Constant)
                                  else r"[^/\s]+" for v in node.values)
                if re.search(EXT + "$", pattern.replace("\\", "")):
                    patterns.append(pattern)
    return frozenset(names), tuple(patterns)


def test_every_file_name_a_page_gives_is_written_or_exists() -> None:
    names, patterns = _package_file_names()
    in_repo = {p.name for p in ROOT.rglob("*") if not any(
        x.startswith(".") or x == "_build" for x in p.relative_to(ROOT).parts)}
    typed = set()  # what the manual's commands and snippets name (a user's own files)
    for page in PAGES:
        for m in FENCE.finditer(_text(page)):
            typed.update(Path(w).name for w in re.findall(r"[A-Za-z0-9_./<>{}-]+", m.group(3)))
    unknown = []
    for page in PAGES:
        for span in re.findall(r"`([^`\n]+)`", _prose(_text(page))):
            if not re.fullmatch(FILE_NAME, span) or "<" in span:
                continue
            if span in names or span in in_repo or span in typed:
                continue
            if any(re.fullmatch(p, span) for p in patterns):
                continue
            unknown.append(f"{page.relative_to(ROOT)}: {span}")
    assert not unknown, ("file names neither written by astrocpg, in the repository nor named "
                         f"by a command of the manual: {unknown}")


# --- study files -----------------------------------------------------------------------------

@lru_cache(maxsize=1)
def _accepted() -> dict[str, set[str]]:
    """Every key the study-file parser accepts, per table, read from the parser: its key sets,
    and where it keeps a set inside a function, the list its refusal names."""
    from astrocpg.errors import InputError
    from astrocpg.studies.parameter_studies import study_file as sf

    def listed(text: str, what: str) -> set[str]:
        try:
            sf.parse_study(text, Path("probe.toml"), None)
        except InputError as e:
            m = re.search(rf"\({what}: ([^)]*)\)", str(e))
            assert m, str(e)
            return {x.strip() for x in m.group(1).split(",")}
        raise AssertionError(f"the parser accepted {text!r}")

    head = "[study]\nsessions = 1\n"
    return {"sections": listed("[nonsense]\n", "sections"),
            "study": set(sf._STUDY_KEYS),
            "record": listed(head + "record = { every = 1, nonsense = 1 }\n", "keys"),
            "seeds": {"first", "count"},
            "sweep": listed(head + "[sweep]\nnonsense = 1\n", "keys"),
            "condition": set(sf._CONDITION_KEYS),
            "evaluate": set(sf._EVALUATE_KEYS)}


def _study_texts() -> list[tuple[str, str]]:
    """(where, TOML) of every study file in the pages: fenced toml blocks and heredocs."""
    out = []
    for page in PAGES:
        text = _text(page)
        for m in FENCE.finditer(text):
            where = f"{page.relative_to(ROOT)}:{text[:m.start()].count(chr(10)) + 1}"
            lang, body = m.group(2).strip(), m.group(3)
            bodies = [body] if lang == "toml" else re.findall(
                r"<<-?\s*'?(\w+)'?[^\n]*\n(.*?)\n\1\b", body, re.S)
            for b in bodies:
                b = b if isinstance(b, str) else b[1]
                if re.search(r"^\[study\]", b, re.M):
                    out.append((where, b))
    return out


def _keys_of(doc: dict) -> list[tuple[str, str]]:
    """(table, key) of every key of a study file's tables the parser checks."""
    out = [("sections", k) for k in doc]
    head = doc.get("study", {})
    out += [("study", k) for k in head]
    if isinstance(head.get("record"), dict):
        out += [("record", k) for k in head["record"]]
    if isinstance(head.get("seeds"), dict):
        out += [("seeds", k) for k in head["seeds"]]
    out += [("sweep", k) for k in doc.get("sweep", {})]
    for cond in doc.get("conditions", {}).values():
        out += [("condition", k) for k in cond]
    out += [("evaluate", k) for k in doc.get("evaluate", {})]
    return out


def test_every_study_file_of_the_manual_uses_keys_the_parser_accepts(tmp_path) -> None:
    from astrocpg.studies.parameter_studies.study import load_study

    accepted = _accepted()
    studies = _study_texts()
    assert any("study-files.md" in w for w, _ in studies), "no study in the study-file page"
    for where, text in studies:
        doc = tomllib.loads(text)
        bad = [f"[{table}] {key}" for table, key in _keys_of(doc) if key not in accepted[table]]
        assert not bad, f"{where}: keys the study parser refuses: {bad}"
        names_files = bool(doc.get("models")) or "populations" in doc.get("study", {}) or any(
            isinstance(v, list) and any(str(x).endswith(".toml") for x in v)
            for v in doc.get("sweep", {}).get("axes", {}).values()) or (
            doc.get("evaluate", {}).get("worlds", "robustness") != "robustness")
        if not names_files:  # it loads as the manual writes it
            path = tmp_path / "study.toml"
            path.write_text(text, encoding="utf-8")
            load_study(path)


def test_the_study_file_reference_lists_every_key_and_only_those() -> None:
    accepted = _accepted()
    text = _text(DOCS / "study-files.md")
    sections = {m.group(1) for m in re.finditer(r"^### `\[(\w+)(?:\.NAME)?\]`", text, re.M)}
    assert sections == accepted["sections"], (sections, accepted["sections"])
    keyed = {"study": "`[study]`", "record": "`record = {", "sweep": "`[sweep]`",
             "condition": "`[conditions.NAME]`", "evaluate": "`[evaluate]`"}
    for table, marker in keyed.items():
        start = text.index(marker)
        rows = next(t for t in _tables(text[start:]) if t[0][0] == "key")
        listed = {_code_names(row[0])[0] for row in rows[1:]}
        assert listed == accepted[table], (table, listed, accepted[table])


# --- quoted error lines ----------------------------------------------------------------------

@lru_cache(maxsize=1)
def _raised() -> dict[str, list[str]]:
    """The message patterns the package raises, by the kind its exception prints: the first
    argument of every ``InputError(...)``, ``EnvironmentFault(...)``, ``Diverged(...)`` call
    (an f-string's fields and other expressions match any text)."""
    from astrocpg import errors

    kinds = {"InputError": "error", "CheckpointCorrupt": "error",
             "EnvironmentFault": "environment", "Diverged": "diverged"}
    assert errors.InputError.exit_code == 2 and errors.EnvironmentFault.exit_code == 1

    def pattern(node) -> str:
        if isinstance(node, ast.Constant) and isinstance(node.value, str):
            return re.escape(node.value)
        if isinstance(node, ast.JoinedStr):
            return "".join(pattern(v) if isinstance(v, ast.Constant) else ".+?"
                           for v in node.values)
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Add):
            return pattern(node.left) + pattern(node.right)
        return ".+?"

    out: dict[str, list[str]] = {k: [] for k in set(kinds.values())}
    for f in ROOT.rglob("*.py"):
        rel = f.relative_to(ROOT).parts
        if rel[0] in ("tests", "docs", "benchmarks") or any(p.startswith(".") for p in rel):
            continue
        for node in ast.walk(ast.parse(f.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Call) and node.args:
                name = getattr(node.func, "id", getattr(node.func, "attr", ""))
                if name in kinds:
                    p = pattern(node.args[0])
                    # a message passed on (``InputError(f"{e}")``) says nothing of its words
                    if len(re.sub(r"\\(.)", r"\1", p.replace(".+?", ""))) >= 10:
                        out[kinds[name]].append(p)
    return out


def test_every_quoted_error_line_is_one_the_code_prints() -> None:
    raised = _raised()
    quoted = []
    for page in PAGES:
        text = _text(page)
        # a line of a fenced block, or an inline code span (which may wrap across lines)
        candidates = [line for m in FENCE.finditer(text) for line in m.group(3).splitlines()]
        candidates += [" ".join(s.split()) for s in re.findall(r"`([^`]+)`", _prose(text))]
        for c in candidates:
            m = re.search(r"astrocpg: (error|environment|diverged): (.+)", c)
            if m and "<" not in m.group(2):  # "<culprit>": the form of a line, not a line
                quoted.append((page, m.group(1), m.group(2).strip()))
    assert quoted, "no quoted error lines"
    wrong = []
    for page, kind, line in quoted:
        # the line is "<culprit>: <message>" or the message alone
        tails = [line] + [line[m.end():] for m in re.finditer(r": ", line)]
        if not any(re.fullmatch(p, tail, re.S) for tail in tails for p in raised[kind]):
            other = [k for k in raised if k != kind
                     and any(re.fullmatch(p, t, re.S) for t in tails for p in raised[k])]
            wrong.append(f"{page.relative_to(ROOT)}: 'astrocpg: {kind}: {line}'"
                         + (f" is printed as 'astrocpg: {other[0]}: ...'" if other else
                            " is no message the code raises"))
    assert not wrong, wrong


# --- the README on a code host ---------------------------------------------------------------

ROLE = re.compile(r"\{[a-z:]+\}`")
DIRECTIVE = re.compile(r"^(`{3,}|~{3,})\{(?!code-cell\})[^}]+\}", re.M)


def _first_screen(text: str) -> str:
    """A page's first 40 lines (front matter left out), to the end of their paragraph."""
    text = re.sub(r"\A---\n.*?\n---\n", "", text, flags=re.S)
    lines = text.split("\n")
    n = 40
    while n < len(lines) and lines[n].strip():
        n += 1
    return "\n".join(lines[:n])


def test_the_readmes_links_resolve_and_open_on_plain_markdown() -> None:
    """A code host renders Markdown, not MyST: every page README.md links to exists, and a
    Markdown page it links opens with a first screen free of MyST roles (``{term}`...```) and
    directives (an executed code cell still reads as code)."""
    readme = _text(ROOT / "README.md")
    links = [m for m in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", readme)
             if not re.match(r"[a-z]+:", m)]
    assert links
    missing = [link for link in links if not (ROOT / link).exists()]
    assert not missing, missing
    myst = []
    for link in links:
        if link.endswith(".md"):
            first = _first_screen(_text(ROOT / link))
            found = ROLE.findall(first) + DIRECTIVE.findall(first)
            if found:
                myst.append(f"{link}: {found}")
    assert not myst, ("pages linked from README.md whose first screen a code host shows as "
                      f"MyST markup: {myst}")


# --- the authors' code ----------------------------------------------------------------------

AUTHORS_CODE = re.compile(r"github\.com/NeuroCompLab-psu/Astrocyte_Regulated_Gait_Search/"
                          r"(?:tree|blob)/[0-9a-f]{40}")


def test_every_page_that_leans_on_the_authors_code_cites_it_at_a_commit() -> None:
    """A page that cites what the authors' code does links their repository at the commit the
    claim was read from (the manual's pages; docs/benchmarks/ holds benchmark output)."""
    uncited = []
    for page in PAGES:
        if "benchmarks" in page.relative_to(DOCS if page.is_relative_to(DOCS) else ROOT).parts:
            continue
        text = _text(page)
        if re.search(r"authors' (code|model|scheme|table|delays|order|formulation|preset|"
                     r"counter|command line|choices)", text) and not AUTHORS_CODE.search(text):
            uncited.append(str(page.relative_to(ROOT)))
    assert not uncited, ("pages citing the authors' code without its repository and commit: "
                         f"{uncited}")


# --- model files -----------------------------------------------------------------------------

def test_every_population_table_of_the_manual_is_the_recipes_file() -> None:
    """A ``[population]`` table shown in the pages uses only the keys the population reader
    accepts, each with the value of the recipe's file (tests/data/renshaw_population.toml,
    which tests/test_new_population.py runs)."""
    from astrocpg.network.populations import _ROW_KEYS

    recipe = tomllib.loads((ROOT / "tests" / "data" / "renshaw_population.toml")
                           .read_text(encoding="utf-8"))["population"]
    shown = 0
    for page in PAGES:
        for m in FENCE.finditer(_text(page)):
            if m.group(2).strip() != "toml" or not re.search(r"^\[population\]", m.group(3),
                                                             re.M):
                continue
            shown += 1
            table = tomllib.loads(m.group(3))["population"]
            assert set(table) <= _ROW_KEYS, (page, sorted(set(table) - _ROW_KEYS))
            differ = {k: v for k, v in table.items() if recipe.get(k) != v}
            assert not differ, (f"{page.relative_to(ROOT)}: the [population] table differs from "
                                f"the recipe's file: {differ}")
    assert shown, "no [population] table in the pages"
