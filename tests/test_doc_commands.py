"""Every command and Python snippet of the manual runs as written, in the order a reader meets it.

The pages: README.md, then the manual in its table of contents' order (docs/index.md's
toctrees; a page's ``{include}`` is read where it stands, so docs/beyond/README.md comes with
docs/beyond.md). From each page: every line of a fenced ``bash``/``console``/``shell`` block
(continuations and heredocs joined, ``&&`` chains split) that starts with ``astrocpg`` or
``python``, and every fenced ``python`` block (plain snippets: the ``{code-cell}`` blocks are
executed by myst-nb when the manual is built, tests/test_docs.py).

The fast test checks each command without running it: the subcommand exists and
``astrocpg.studies.cli.build_parser()`` accepts every option; every file it reads (model,
equation, study, worlds, robot files, scripts, committed tables) exists in the repository or is
resolved by ``astrocpg.support.shipped`` by name, or was written by an earlier command of the manual;
every folder it reads was written by an earlier command; a ``python -m`` module is importable;
a snippet compiles and the ``astrocpg`` names it imports exist. The analyse.py commands of
docs/beyond/README.md run for real on the committed tables (seconds).

The slow test runs them all, in page order, in a temporary copy of the working tree that is
also the package imported (so the shipped studies and worlds are the copy's), with this
shortening rule (the manual states it too, docs/reproducibility.md, "How this manual is checked"):

- ``--seconds`` at most 4 (a run of 30 s or 10 s runs 4 s; ``unit``, ``run``, ``gait``,
  ``evaluate``, ``response``, and ``plot`` of a training get ``--seconds 4`` where their default
  is longer); ``response --warmup`` at most 4;
- a training: ``--sessions`` at most 2 and its sessions end at 1 s (``--set L_max=1*second``);
  an extension (``--resume DIR --sessions N``) one session more, 3;
  ``--session N`` (a replay) is the shortened training's last, 2, as is ``sessionNNNN`` in a
  recorded session's folder name; ``power --sessions`` at most 2, ``evaluate --repeats`` 1;
- a study (by name or path): its file in the copy keeps 2 sessions, one seed, the first two
  values of each sweep axis, ``L_max = 1*second`` in ``[base]``, and an ``[evaluate]`` of 1 s
  and 1 repeat; the robustness worlds keep their first two worlds;
- ``--codegen cython`` is dropped: the first build compiles for minutes, and both targets draw
  the same spikes (docs/reproducibility.md);
- in a Python snippet, ``seconds=`` at most 4 and ``sessions=`` at most 2;
- a command met a second time word for word (the same command on several pages) runs once;
- programs other than ``astrocpg`` and ``python`` (``pip``) are not run, except a
  ``cat > FILE <<'EOF'`` that writes a file a later command reads.

Commands that cannot run here are in EXCEPTIONS, each with its reason; they are still checked
statically. Nothing else is skipped.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
SHELL_LANGS = {"bash", "console", "shell", "sh"}

# the studies page's SLURM recipe: tests/test_slurm.py runs these two commands (the script,
# then the study on the scheduler it starts) on a SLURM cluster it starts on this machine
SLURM_CLUSTER = "python docs/cluster/slurm_cluster.py"
SLURM_STUDY = ("astrocpg study studies/parameter_studies/ablation.toml --out /scratch/$USER/ablation "
               "--scheduler tcp://NODE:PORT")
SLURM_RUN_BY = "run by tests/test_slurm.py on a one-machine SLURM cluster"

# command text (as joined from the page) -> why the slow test does not run it
EXCEPTIONS = {
    "python3 -m venv .venv": "makes a virtual environment and installs from the package index "
                             "(network); the tests run in such an installation",
    "python -m pytest": "the whole test suite, which this test is part of",
    "python -m sphinx -W -n -b html docs docs/_build/html":
        "builds the manual (minutes); tests/test_docs.py runs it",
    "python -m build": "builds the wheel and sdist; tests/test_wheel.py does",
    # run by tests/test_slurm.py on a SLURM cluster of this machine, with its values
    SLURM_STUDY: f"{SLURM_RUN_BY}: with the address its slurm_cluster.py prints",
    SLURM_CLUSTER: f"{SLURM_RUN_BY}, with its partition, 2 jobs, 2GB and 00:30:00",
    # a page's training is shortened here (sessions of 1 s, not 10 s), so the rows it gives
    # differ from the committed study's by construction: every such comparison is skipped
    "python docs/ablation/compare_seed.py ":
        "compares a training of full-length sessions with the committed rows of its study: "
        "shortened, the training's rows differ by construction",
    "python docs/ablation/compare_rows.py out/":
        "compares an evaluation or training of full-length runs with the committed rows: "
        "shortened, its rows differ by construction",
}


# --- reading the pages --------------------------------------------------------------------------

def _toctree_pages(index: Path) -> list[Path]:
    pages, inside = [], False
    for line in index.read_text(encoding="utf-8").splitlines():
        if line.startswith("```{toctree}"):
            inside = True
        elif inside and line.startswith("```"):
            inside = False
        elif inside and line.strip() and not line.lstrip().startswith(":"):
            md = DOCS / f"{line.strip()}.md"
            if md.exists():
                pages.append(md)
    return pages


def pages() -> list[Path]:
    """README.md, docs/index.md, then the toctrees' pages in order."""
    return [ROOT / "README.md", DOCS / "index.md"] + _toctree_pages(DOCS / "index.md")


@dataclass
class Block:
    page: Path
    line: int
    lang: str
    text: str


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of a page, an ``{include}``d file's blocks where it stands."""
    out: list[Block] = []
    lines = page.read_text(encoding="utf-8").splitlines()
    k = 0
    while k < len(lines):
        m = re.match(r"^(`{3,}|~{3,})\s*(\S*)", lines[k])
        if not m:
            k += 1
            continue
        fence, lang, start = m.group(1), m.group(2), k
        k += 1
        body = []
        while k < len(lines) and not lines[k].startswith(fence):
            body.append(lines[k])
            k += 1
        k += 1
        if lang == "{include}":
            included = (page.parent / lines[start].split(None, 1)[1].strip()).resolve()
            if included.suffix == ".md" and included.is_relative_to(DOCS):
                out.extend(blocks(included))
            continue
        out.append(Block(page, start + 1, lang, "\n".join(body)))
    return out


@dataclass
class Command:
    """One command of a page: ``text`` as a reader would type it (continuations joined)."""
    page: Path
    line: int
    text: str
    heredoc: str = ""           # the body of a ``<<'TAG'`` heredoc, if any
    snippet: bool = False       # a ```python block

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT)}:{self.line}"

    @property
    def words(self) -> list[str]:
        return shlex.split(self.text.split("<<")[0], comments=True)

    @property
    def program(self) -> str:
        words = [w for w in self.words if not re.match(r"^[A-Z_]+=", w)]
        return words[0] if words else ""


def _block_commands(block: Block) -> list[Command]:
    out: list[Command] = []
    lines = block.text.splitlines()
    k = 0
    while k < len(lines):
        line, first = lines[k], k
        k += 1
        if block.lang == "console":
            if not line.startswith("$ "):
                continue
            line = line[2:]
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        while line.rstrip().endswith("\\") and k < len(lines):
            line = line.rstrip()[:-1].rstrip() + " " + lines[k].strip()
            k += 1
        while k < len(lines):
            try:
                shlex.split(line, comments=True)
                break
            except ValueError:  # a quote continues on the next line
                line = line + "\n" + lines[k]
                k += 1
        heredoc = ""
        m = re.search(r"<<-?\s*'?(\w+)'?", line)
        if m:
            body = []
            while k < len(lines) and lines[k].strip() != m.group(1):
                body.append(lines[k])
                k += 1
            k += 1
            heredoc = "\n".join(body)
        # the text a reader types: a trailing comment dropped (a heredoc keeps its first line)
        text = line if "\n" in line else _strip_comment(line)
        out.append(Command(block.page, block.line + first + 1, text, heredoc))
    return out


def _strip_comment(line: str) -> str:
    """The line without a trailing ``# comment`` (a ``#`` outside quotes after a space)."""
    quote = None
    for i, ch in enumerate(line):
        if quote:
            if ch == quote:
                quote = None
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip()
    return line.rstrip()


def commands() -> list[Command]:
    """Every command and snippet of the manual, in the order a reader meets them."""
    out: list[Command] = []
    for page in pages():
        for block in blocks(page):
            if block.lang in SHELL_LANGS:
                out.extend(_block_commands(block))
            elif block.lang == "python":
                out.append(Command(block.page, block.line, block.text, snippet=True))
    return out


def segments(cmd: Command) -> list[list[str]]:
    """The ``&&``/``;``-separated parts of a command, as words, env assignments dropped."""
    parts, current = [], []
    for w in cmd.words:
        if w in ("&&", ";", "||"):
            parts.append(current)
            current = []
        else:
            current.append(w)
    parts.append(current)
    out = []
    for p in parts:
        while p and re.match(r"^[A-Z_]+=", p[0]):
            p = p[1:]
        if p:
            out.append(p)
    return out


#: commands that, met in page order after the shortened commands before them, are refused as
#: they would be for a reader who typed the page in order, and why (exit code, reason)
EXPECTED_REFUSALS = {
    "astrocpg train --resume out/astro": (
        (2,), "continues a stopped training; the training above it has finished, so astrocpg "
              "says so and changes nothing"),
    "MUJOCO_GL=osmesa astrocpg video out/run": (
        (0, 1), "renders only where OSMesa is installed; elsewhere the page's point: one line "
                "naming MUJOCO_GL and what to install (exit 1)"),
}


def _exception(cmd: Command) -> str | None:
    for key, why in EXCEPTIONS.items():
        if cmd.text.startswith(key) or (cmd.snippet and key in cmd.text.splitlines()[0]):
            return why
    return None


# --- what a command reads and writes -----------------------------------------------------------

def _parse(argv: list[str]):
    from astrocpg.studies.cli import build_parser
    return build_parser().parse_args(argv)


def _value(path: str) -> str:
    return path.split("=", 1)[1] if "=" in path else path


def reads_writes(argv: list[str]) -> tuple[list[tuple[str, str]], list[str]]:
    """(kind, path) read and paths written by ``astrocpg ARGV``; kind: file kinds of
    astrocpg.support.shipped (model, study, worlds), 'file' or 'folder'."""
    a = _parse(argv)
    reads: list[tuple[str, str]] = []
    writes: list[str] = []
    for f in getattr(a, "model_files", []) or []:
        reads.append(("model", _value(f)))
    for f in getattr(a, "equations", []) or []:
        reads.append(("file", _value(f)))
    c = a.command
    if c in ("unit", "run", "train"):
        writes.append(a.out or (a.resume if c == "train" else None) or "")
        if c == "train" and a.resume:
            reads.append(("folder", a.resume))
    if c == "run":
        if a.weights:
            reads.append(("folder" if not Path(a.weights).suffix else "file", a.weights))
        if a.robot:
            reads.append(("file", a.robot))
    if c in ("gait", "plot", "video", "evaluate", "report", "power", "export"):
        reads.append(("folder", a.dir))
        if getattr(a, "out", None):
            writes.append(a.out)
    if c == "evaluate" and a.worlds != "robustness":
        reads.append(("worlds", a.worlds))
    if c == "study" and a.status:  # reads a study folder, writes nothing
        reads.append(("folder", a.status))
    elif c == "study":
        reads.append(("study", a.file))
        from astrocpg.support.shipped import resolve
        study = resolve(a.file, "study")
        name = tomllib.loads(study.read_text())["study"]["name"] if study.exists() else ""
        writes.append(a.out or f"out/{name}")
    if c == "robot":
        writes.append(a.path)
    return reads, [w for w in writes if w]


NOT_PATHS = ("--unit",)
"""Options of the pages' scripts whose values are not paths (``analyse.py response --unit
mV/s``)."""


def _python_paths(argv: list[str]) -> tuple[list[str], list[str]]:
    """Paths a ``python SCRIPT ...`` command reads and writes (``--out X`` writes X)."""
    reads, writes = [], []
    k = 1
    while k < len(argv):
        w = argv[k]
        if w == "--out" and k + 1 < len(argv):
            writes.append(argv[k + 1])
            k += 2
            continue
        if w in NOT_PATHS and k + 1 < len(argv):  # a value with a slash that is no path
            k += 2
            continue
        # VALUE=EVALUATION.csv:RUN@TABLES (analyse.py response --point): two paths
        for part in w.split("@") if not w.startswith("-") else [w]:
            if re.match(r"^[\w.]+=", part) and "/" in part.split("=", 1)[1]:
                part = part.split("=", 1)[1]
            path = part.rsplit(":", 1)[0] if re.search(r":[\w.=-]+$", part) else part
            if "/" in path and not path.startswith("-"):
                reads.append(path)
        k += 1
    return reads, writes


def _redirect(cmd: Command) -> str | None:
    """The file a ``> FILE`` redirection writes."""
    m = re.search(r"(?<![<>])>\s*(\S+)", cmd.text.split("<<")[0])
    return m.group(1) if m and "\n" not in cmd.text else None


def _without_redirect(argv: list[str], redirect: str | None) -> list[str]:
    if redirect is None:
        return argv
    return [w for w in argv if w not in (">", redirect, ">" + redirect)]


def _under(path: str, made: set[str]) -> bool:
    p = Path(path)
    return any(p == Path(m) or Path(m) in p.parents for m in made)


def static_problems(cmds: list[Command]) -> list[str]:
    """Every problem of every command, walking the pages in order (so a folder or file a
    command reads must exist in the repository or have been written before)."""
    from astrocpg.support.shipped import resolve

    problems: list[str] = []
    made: set[str] = set()
    made_files: set[str] = set()
    writer: dict[str, str] = {}  # folder -> the command that wrote it (or its study's name)
    for cmd in cmds:
        def bad(msg: str) -> None:
            problems.append(f"{cmd.where}: {cmd.text.splitlines()[0]!r}: {msg}")

        if cmd.snippet:
            try:
                tree = ast.parse(cmd.text)
            except SyntaxError as e:
                bad(f"does not compile: {e}")
                continue
            for node in ast.walk(tree):
                if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("astrocpg"):
                    mod = importlib.import_module(node.module)
                    for alias in node.names:
                        if not hasattr(mod, alias.name):
                            try:
                                importlib.import_module(f"{node.module}.{alias.name}")
                            except ImportError:
                                bad(f"{node.module} has no {alias.name}")
            for m in re.finditer(r"(?:open\(|path = )\"([^\"]+)\"", cmd.text):
                if not (ROOT / m.group(1)).exists() and m.group(1) not in made_files:
                    bad(f"reads {m.group(1)}, which nothing wrote")
            for m in re.finditer(r"out=\"([^\"]+)\"", cmd.text):
                made.add(m.group(1))
            continue
        redirect = _redirect(cmd)
        if redirect:
            made_files.add(redirect)
        if cmd.heredoc:
            if cmd.program == "python":
                try:
                    compile(cmd.heredoc, cmd.where, "exec")
                except SyntaxError as e:
                    bad(f"heredoc does not compile: {e}")
                made_files.update(re.findall(r"open\(\"([^\"]+)\", \"w\"\)", cmd.heredoc))
            m = re.match(r"cat\s*>\s*(\S+)", cmd.text)
            if m:
                made_files.add(m.group(1))
        for argv in segments(cmd):
            argv = _without_redirect(argv, redirect)
            if argv[0] == "astrocpg":
                try:
                    reads, writes = reads_writes(argv[1:])
                except SystemExit as e:
                    bad(f"refused by astrocpg's parser (exit {e.code})")
                    continue
                c = argv[1]
                for out in writes:  # a second command into a written folder is refused
                    key = f"study {argv[2]}" if c == "study" else " ".join(argv)
                    if c in ("unit", "run", "train", "study", "robot") and "--resume" not in argv \
                            and writer.setdefault(out, key) != key and "--overwrite" not in argv:
                        bad(f"writes {out}, which {writer[out]!r} wrote before: refused")
                for kind, path in reads:
                    if kind in ("model", "study", "worlds"):
                        ok = resolve(path, kind).exists() or path in made_files
                    elif kind == "file":
                        ok = (ROOT / path).exists() or path in made_files
                    else:
                        ok = (ROOT / path).exists() or _under(path, made)
                    if not ok:
                        bad(f"reads {path} ({kind}), which is neither in the repository, "
                            f"a shipped name, nor written by an earlier command")
                made.update(writes)
                made_files.update(writes)
            elif argv[0] in ("python", "python3"):
                if argv[1] == "-m":
                    if importlib.util.find_spec(argv[2]) is None:
                        bad(f"no module {argv[2]}")
                elif argv[1] == "-c":
                    try:
                        compile(argv[2], cmd.where, "exec")
                    except SyntaxError as e:
                        bad(f"-c does not compile: {e}")
                    made_files.update(re.findall(r"'([^'{}\s]+\.\w+)'", argv[2]))
                elif argv[1] != "-":
                    if not (ROOT / argv[1]).is_file():
                        bad(f"no script {argv[1]}")
                    reads, writes = _python_paths(argv[1:])
                    for path in reads:
                        if not ((ROOT / path).exists() or _under(path, made)
                                or path in made_files):
                            bad(f"reads {path}, which is neither in the repository nor "
                                f"written by an earlier command")
                    made_files.update(writes)
    return problems


# --- the fast test ------------------------------------------------------------------------------

def test_pages_hold_the_commands():
    """The extraction finds the manual's commands (a regression in it would pass vacuously)."""
    cmds = commands()
    texts = [c.text for c in cmds]
    assert len(cmds) > 60
    assert any(t.startswith("astrocpg study compare_astrocytes") for t in texts)
    assert any(t.startswith("python docs/beyond/analyse.py worlds") for t in texts)
    assert any(c.snippet and "populations.population_from_toml" in c.text for c in cmds)
    covered = {c.page for c in cmds} | {p for p in pages()}
    for page in [ROOT / "README.md", *DOCS.glob("*.md"), *DOCS.glob("examples/*.md")]:
        if page.name != "changelog.md":
            assert page in covered, f"{page.relative_to(ROOT)} is in no toctree"


def test_every_command_is_valid():
    """Subcommands, options, files, shipped names and folders of every command, in page order."""
    problems = static_problems(commands())
    assert not problems, "\n".join(problems)


def test_static_check_catches_a_renamed_path(tmp_path):
    """The check itself: a command reading a file that is not there, or an unknown option, or a
    folder no earlier command wrote, is reported."""
    page = ROOT / "README.md"
    for text in ("astrocpg run --model alive=models/variants/no_such_file.toml --out out/x",
                 "astrocpg run --no-such-option --out out/x",
                 "astrocpg plot out/never_written",
                 "astrocpg study no_such_study",
                 "python docs/beyond/no_such_script.py"):
        assert static_problems([Command(page, 1, text)]), text


def test_analyse_commands_run_on_the_committed_tables(tmp_path):
    """docs/beyond/README.md's analyse.py commands that read committed tables only, run for
    real (each in a few seconds), with their outputs redirected to a temporary folder."""
    ran = 0
    for cmd in commands():
        if cmd.snippet or "docs/beyond/analyse.py" not in cmd.text or "out/" in cmd.text:
            continue
        redirect = _redirect(cmd)
        argv = _without_redirect(segments(cmd)[0], redirect)
        if "--out" in argv:
            argv[argv.index("--out") + 1] = str(tmp_path / Path(argv[argv.index("--out") + 1]).name)
        done = subprocess.run([sys.executable, *argv[1:]], cwd=ROOT, capture_output=True,
                              text=True, env={**os.environ, "MPLBACKEND": "Agg"}, timeout=300)
        assert done.returncode == 0, f"{cmd.where}: {cmd.text}\n{done.stderr[-2000:]}"
        if redirect:
            assert done.stdout == (ROOT / redirect).read_text(encoding="utf-8"), \
                f"{cmd.where}: {redirect} is not what the command writes"
        ran += 1
    assert ran >= 6


STATISTICS = ("docs/ablation/retest.py", "docs/ablation/compare_tables.py")


def test_statistics_commands_rewrite_the_committed_tables(tmp_path):
    """The retest.py and compare_tables.py commands of the manual and of docs/ablation's run
    pages that read committed rows and tables only: each runs, and its output is the committed
    file it redirects to (a table left stale by a change of the script or of its data fails)."""
    cmds = [c for c in commands() if not c.snippet]
    for page in sorted(DOCS.glob("ablation/*/README.md")):
        for block in blocks(page):
            if block.lang in SHELL_LANGS:
                cmds.extend(_block_commands(block))
    ran = set()
    for cmd in cmds:
        if not any(s in cmd.text for s in STATISTICS) or "out/" in cmd.text or cmd.text in ran:
            continue
        redirect = _redirect(cmd)
        assert redirect, f"{cmd.where}: {cmd.text} writes no committed file"
        argv = _without_redirect(segments(cmd)[0], redirect)
        done = subprocess.run([sys.executable, *argv[1:]], cwd=ROOT, capture_output=True,
                              text=True, env={**os.environ, "MPLBACKEND": "Agg"}, timeout=300)
        assert done.returncode == 0, f"{cmd.where}: {cmd.text}\n{done.stderr[-2000:]}"
        assert done.stdout == (ROOT / redirect).read_text(encoding="utf-8"), \
            f"{cmd.where}: {redirect} is not what the command writes"
        ran.add(cmd.text)
    # the rough and load-afferent retests, the streams' and the three runs' comparisons
    assert len(ran) >= 6, sorted(ran)


# --- the slow test: everything, in order, shortened ---------------------------------------------

MAX_SECONDS = 4.0
MAX_SESSIONS = 2
SESSION_LENGTH = "1*second"
LONG_DEFAULT = {"unit", "run", "gait", "evaluate", "response"}  # a default of more than 4 s


def _is_training(folder: Path) -> bool:
    """Whether ``folder`` holds a training (plot simulates its tables for ``--seconds``)."""
    try:
        manifest = json.loads((folder / "manifest.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(manifest, dict) and manifest.get("astrocpg_command") in ("train",
                                                                             "study-run")


def _toml(table: dict, prefix: str = "") -> str:
    """A TOML text for the simple tables of a study or worlds file."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, (int, float)):
            return repr(v)
        if isinstance(v, str):
            return json_str(v)
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, dict):
            return "{ " + ", ".join(f"{json_str(k)} = {value(x)}" for k, x in v.items()) + " }"
        raise TypeError(v)

    def json_str(s):
        import json
        return json.dumps(s)

    lines = [f"{json_str(k)} = {value(v)}" for k, v in table.items() if not isinstance(v, dict)]
    if prefix:
        lines.insert(0, "[" + prefix + "]")
    out = "\n".join(lines) + "\n"
    for k, v in table.items():
        if isinstance(v, dict):
            out += "\n" + _toml(v, f"{prefix}.{json_str(k)}" if prefix else json_str(k))
    return out


def shorten_study(path: Path) -> None:
    """The study file at ``path`` (in the copy) with the shortening rule applied, in place."""
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    s = data["study"]
    s["sessions"] = min(int(s.get("sessions", MAX_SESSIONS)), MAX_SESSIONS)
    seeds = s.get("seeds")
    first = seeds[0] if isinstance(seeds, list) else (seeds or {}).get("first", 1)
    s["seeds"] = {"first": first, "count": 1}
    if "batch" in s and s["batch"] != "auto":
        s["batch"] = 1
    data.setdefault("base", {})["L_max"] = SESSION_LENGTH
    for axis, values in (data.get("sweep", {}).get("axes") or {}).items():
        data["sweep"]["axes"][axis] = values[:2]
    if "evaluate" in data:
        data["evaluate"]["seconds"] = 1.0
        data["evaluate"]["repeats"] = 1
    path.write_text(_toml(data), encoding="utf-8")


def shorten_worlds(path: Path) -> None:
    data = tomllib.loads(path.read_text(encoding="utf-8"))
    data["worlds"] = dict(list(data["worlds"].items())[:2])
    path.write_text(_toml(data), encoding="utf-8")


def _set(argv: list[str], option: str, value: str, add: bool = True) -> list[str]:
    if option in argv:
        argv[argv.index(option) + 1] = value
    elif add:
        argv += [option, value]
    return argv


def shorten(argv: list[str], copy: Path, shortened: set[Path]) -> list[str]:
    """``astrocpg ARGV`` with the shortening rule applied (see the module docstring)."""
    argv = list(argv)
    while "--codegen" in argv:
        k = argv.index("--codegen")
        del argv[k:k + 2]
    argv = [re.sub(r"session\d{4}", f"session{MAX_SESSIONS:04d}", w) for w in argv]
    c = argv[0]
    if "--seconds" in argv:
        k = argv.index("--seconds") + 1
        argv[k] = f"{min(float(argv[k]), MAX_SECONDS):g}"
    elif c in LONG_DEFAULT and not (c == "run" and "--session" in argv):
        argv += ["--seconds", f"{MAX_SECONDS:g}"]
    elif c == "plot" and _is_training(copy / argv[1]):  # it simulates a training's tables
        argv += ["--seconds", f"{MAX_SECONDS:g}"]
    # a committed folder's tables (evaluate docs/.../tables --session 200) were not shortened:
    # its session stays; a training made by an earlier, shortened command has fewer sessions
    committed = c == "evaluate" and (ROOT / argv[1]).exists()
    if "--session" in argv and not committed:
        k = argv.index("--session") + 1
        argv[k] = str(min(int(argv[k]), MAX_SESSIONS))
    if c == "train" and "--resume" not in argv:
        argv = _set(argv, "--sessions", str(min(int(argv[argv.index("--sessions") + 1]),
                                                MAX_SESSIONS)) if "--sessions" in argv
                    else str(MAX_SESSIONS))
        argv += ["--set", f"L_max={SESSION_LENGTH}"]
    elif c == "train" and "--sessions" in argv:  # --resume --sessions N extends: one more
        argv = _set(argv, "--sessions", str(MAX_SESSIONS + 1))
    if c == "power":
        argv = _set(argv, "--sessions", str(MAX_SESSIONS))
    if c == "response":  # its warm-up (default 200 s) is simulated time too
        warmup = float(argv[argv.index("--warmup") + 1]) if "--warmup" in argv else 200.0
        argv = _set(argv, "--warmup", f"{min(warmup, MAX_SECONDS):g}")
    if c == "evaluate":
        argv = _set(argv, "--repeats", "1")
    if c == "study" and "--status" not in argv:
        from astrocpg.support.shipped import resolve
        original = resolve(argv[1], "study")
        target = (copy / original.resolve().relative_to(ROOT)) if original.resolve() \
            .is_relative_to(ROOT) else copy / argv[1]
        if target not in shortened:
            shorten_study(target)
            shortened.add(target)
    return argv


def _join(argv: list[str]) -> str:
    """``shlex.join``, leaving a leading ``~/`` unquoted so that bash expands it (a page's
    ``--out ~/studies/x``)."""
    return " ".join("~/" + shlex.quote(w[2:]) if w.startswith("~/") and len(w) > 2
                    else shlex.quote(w) for w in argv)


def _snippet(text: str) -> str:
    text = re.sub(r"seconds=(\d+(?:\.\d+)?)",
                  lambda m: f"seconds={min(float(m.group(1)), MAX_SECONDS):g}", text)
    return re.sub(r"sessions=(\d+)", lambda m: f"sessions={min(int(m.group(1)), MAX_SESSIONS)}",
                  text)


def _copy_tree(dest: Path) -> Path:
    """The working tree (what git tracks, and untracked files it does not ignore) under
    ``dest/astrocpg``: the package the commands import, and their working folder."""
    copy = dest / "astrocpg"
    listed = subprocess.run(["git", "ls-files", "-co", "--exclude-standard", "-z"], cwd=ROOT,
                            capture_output=True, text=True)
    if listed.returncode == 0 and listed.stdout:
        for name in filter(None, listed.stdout.split("\0")):
            src = ROOT / name
            if src.is_file():
                (copy / name).parent.mkdir(parents=True, exist_ok=True)
                shutil.copy2(src, copy / name)
    else:  # no git: everything but outputs and caches
        shutil.copytree(ROOT, copy, ignore=shutil.ignore_patterns(
            "out", "_build", "__pycache__", ".venv", ".git", "*.egg-info"))
    return copy


@pytest.mark.slow
def test_commands_run_in_order(tmp_path):
    """Every command and snippet, in page order, in a copy of the working tree, shortened."""
    copy = _copy_tree(tmp_path)
    shorten_worlds(copy / "studies" / "commands" / "robustness.toml")
    # a page's ~/studies/... lands in a home of the test's own (never the user's studies), with
    # the user's caches (compiled code) linked in so nothing is compiled again
    home = tmp_path / "home"
    home.mkdir()
    for cache in (".cache", ".cython"):
        if (Path.home() / cache).is_dir():
            (home / cache).symlink_to(Path.home() / cache)
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "MPLBACKEND": "Agg",
           "ASTROCPG_CODEGEN": "numpy", "HOME": str(home)}
    env.setdefault("MUJOCO_GL", "egl")
    env.pop("ASTROCPG_EXPERIMENTER", None)
    prelude = (f'astrocpg() {{ {shlex.quote(sys.executable)} -m astrocpg "$@"; }}\n'
               f'python() {{ {shlex.quote(sys.executable)} "$@"; }}\n'
               f'python3() {{ {shlex.quote(sys.executable)} "$@"; }}\n')
    done: set[str] = set()
    shortened: set[Path] = set()
    failures, ran, log = [], 0, []
    for cmd in commands():
        if _exception(cmd):
            if cmd.text.startswith("python3 -m venv"):  # its astrocpg part runs
                parts = [shlex.join(shorten(p[1:], copy, shortened)) for p in segments(cmd)
                         if p[0] == "astrocpg"]
                script = "".join(f"astrocpg {p}\n" for p in parts)
            else:
                continue
        elif not cmd.snippet and cmd.program not in ("astrocpg", "python", "python3") \
                and not (cmd.heredoc and cmd.program == "cat"):
            continue  # pip and other programs are not run (the module docstring)
        elif cmd.snippet:
            (copy / "_snippet.py").write_text(_snippet(cmd.text), encoding="utf-8")
            script = "python _snippet.py\n"
        elif cmd.heredoc or "\n" in cmd.text:
            script = cmd.text + ("\n" + cmd.heredoc + "\n" + re.search(
                r"<<-?\s*'?(\w+)'?", cmd.text).group(1) if cmd.heredoc else "") + "\n"
        else:
            parts = []
            redirect = _redirect(cmd)
            for argv in segments(cmd):
                argv = _without_redirect(argv, redirect)
                if argv[0] == "astrocpg":
                    argv = ["astrocpg", *shorten(argv[1:], copy, shortened)]
                parts.append(_join(argv))
            script = " && ".join(parts) + (f" > {shlex.quote(redirect)}" if redirect else "")
            prefix = re.match(r"^((?:[A-Z_]+=\S+\s+)*)", cmd.text).group(1)
            script = prefix + script + "\n"
        if script in done:
            continue
        done.add(script)
        run = subprocess.run(["bash", "-c", prelude + script], cwd=copy, env=env,
                             capture_output=True, text=True, timeout=1800)
        ran += 1
        log.append(f"{cmd.where}: {script.strip()} -> {run.returncode}")
        expected = EXPECTED_REFUSALS.get(cmd.text.split("#")[0].strip(), ((0,), ""))[0]
        if run.returncode not in expected:
            failures.append(f"{cmd.where}: {script.strip()}\n  exit {run.returncode}: "
                            f"{(run.stderr or run.stdout).strip()[-1500:]}")
    (tmp_path / "log.txt").write_text("\n".join(log))
    assert ran > 60
    assert not failures, "\n".join(failures)
