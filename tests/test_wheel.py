"""The release: ``python -m build`` gives an sdist and a wheel without leaving files in the
source tree; the wheel holds the package data (the manual's pages and the files its recipes
read among them) and its version and commit, and installed into a fresh virtual environment it
runs, from another folder, ``astrocpg --version`` (the version and the commit), ``astrocpg docs``
(the manual is found) and the manual's recipes that read shipped files.

To keep the test off the network for the dependencies, the fresh environment sees this
environment's site-packages through a ``.pth`` line (a plain path: the ``.pth`` files there,
among them an editable install of this checkout, are not processed) and the wheel is installed
with ``--no-deps``; the test checks that ``astrocpg`` is imported from the fresh environment.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import sysconfig
import venv
import tarfile
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

# what the wheel must carry besides the modules: the model variants, the built-in studies and
# worlds, and the code that builds the robot model
PACKAGE_DATA = [
    "astrocpg/models/variants/gchi_astrocyte.toml",
    "astrocpg/models/variants/li_rinzel_astrocyte.toml",
    "astrocpg/models/variants/interlimb_authors_delays.toml",
    "astrocpg/models/variants/compare_astrocytes.toml",
    "astrocpg/studies/parameter_studies/quick.toml",
    "astrocpg/studies/parameter_studies/ablation.toml",
    "astrocpg/studies/commands/robustness.toml",
    "astrocpg/coupling/robot.py",
]


def recipe_inputs() -> list[str]:
    """Every file under docs/ that an ``astrocpg`` command of the manual reads (a folder: every
    file in it), as the doc-command test extracts the commands: what the wheel must ship."""
    sys.path.insert(0, str(ROOT / "tests"))
    try:
        import test_doc_commands as d
    finally:
        sys.path.remove(str(ROOT / "tests"))
    out: set[str] = set()
    for cmd in d.commands():
        if cmd.snippet:
            continue
        for argv in d.segments(cmd):
            if argv[0] != "astrocpg":
                continue
            try:
                reads, _ = d.reads_writes(argv[1:])
                plan = getattr(d._parse(argv[1:]), "plan_from", None)
            except SystemExit:
                continue  # the doc-command test names it
            paths = [p for _, p in reads] + ([plan] if plan else [])
            out.update(_files(paths))
    # commands shown with their output (```text blocks) or in a sentence: a docs/ path after
    # "astrocpg COMMAND" on the same line
    for page in d.pages():
        for line in page.read_text(encoding="utf-8").splitlines():
            for m in re.finditer(r"astrocpg [a-z]+ [^`]*?(docs/[\w./-]+)", line):
                out.update(_files([m.group(1).rstrip(".")]))
    return sorted(out)


def _files(paths: list[str]) -> set[str]:
    """The repository files of ``paths`` under docs/ (a folder: every file in it)."""
    out = set()
    for path in paths:
        if not path.startswith("docs/") or not (ROOT / path).exists():
            continue
        target = ROOT / path
        files = [target] if target.is_file() else [
            f for f in target.rglob("*") if f.is_file() and "__pycache__" not in f.parts]
        out.update(f.relative_to(ROOT).as_posix() for f in files)
    return out


def test_the_recipes_read_files_the_wheel_can_ship() -> None:
    """The extraction finds the recipes' shipped inputs (a regression would pass vacuously)."""
    found = recipe_inputs()
    assert "docs/examples/interlimb_table.csv" in found
    assert "docs/benchmarks/trained_astrocytes/weights.npz" in found
    assert any(p.startswith("docs/ablation/faster_loop/tables/") for p in found)


def _clean_env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME")}
    env.update(MPLBACKEND="Agg", **extra)
    return env


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> Path:
    pytest.importorskip("build")
    out = tmp_path_factory.mktemp("dist")
    before = {p.name for p in ROOT.iterdir()}
    proc = subprocess.run([sys.executable, "-m", "build", "--outdir", str(out), str(ROOT)],
                          cwd=out, env=_clean_env(), capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    assert "deprecat" not in (proc.stdout + proc.stderr).lower(), proc.stderr[-3000:]
    left = {p.name for p in ROOT.iterdir()} - before
    assert not left, f"the build left {sorted(left)} in the source tree"
    return out


def test_build_gives_an_sdist_and_a_wheel_with_the_package_data(dist: Path) -> None:
    sdists, wheels = list(dist.glob("astrocpg-*.tar.gz")), list(dist.glob("astrocpg-*.whl"))
    assert len(sdists) == 1 and len(wheels) == 1, sorted(p.name for p in dist.iterdir())
    names = set(zipfile.ZipFile(wheels[0]).namelist())
    missing = [p for p in PACKAGE_DATA if p not in names]
    assert not missing, missing
    metadata = zipfile.ZipFile(wheels[0]).read(
        next(n for n in names if n.endswith(".dist-info/METADATA"))).decode()
    import astrocpg
    info = astrocpg.build_info()
    assert f"Version: {info['version']}" in metadata
    assert "License-Expression: MIT" in metadata
    assert "Author: " in metadata and "Project-URL: Homepage, https://" in metadata
    assert any(n.endswith(".dist-info/licenses/LICENSE") for n in names)
    # the version and commit the wheel was built from, for an install without git
    built = zipfile.ZipFile(wheels[0]).read("astrocpg/_version.py").decode()
    assert f"version = {info['version']!r}" in built and f"commit = {info['commit']!r}" in built
    if info["source"] == "git":  # a development build names its commit
        assert info["commit"] and (info["version"] == astrocpg.RELEASE
                                   or f"+g{info['commit'][:9]}" in info["version"])
    # the manual's pages ship (astrocpg docs), the tests and the benchmarks do not
    assert not any(n.startswith(("tests/", "docs/", "astrocpg/tests/", "astrocpg/benchmarks/"))
                   for n in names)
    assert "astrocpg/docs/index.md" in names and "astrocpg/docs/training.md" in names
    missing = [p for p in recipe_inputs() if f"astrocpg/{p}" not in names]
    assert not missing, f"files the manual's recipes read, not in the wheel: {missing}"
    assert "astrocpg/support/shipped.py" in names and "astrocpg/__main__.py" in names
    sdist = set(tarfile.open(sdists[0]).getnames())
    for shown in ("CHANGELOG.md", "CITATION.cff", "docs/index.md", "benchmarks/all.py"):
        assert any(n.endswith("/" + shown) for n in sdist), shown


def test_the_wheel_runs_from_a_fresh_environment(dist: Path, tmp_path: Path) -> None:
    env_dir = tmp_path / "venv"
    venv.create(env_dir, with_pip=False)
    python = env_dir / ("Scripts" if os.name == "nt" else "bin") / "python"
    purelib = subprocess.run([str(python), "-c", "import sysconfig; "
                              "print(sysconfig.get_paths()['purelib'])"],
                             capture_output=True, text=True, check=True).stdout.strip()
    # this environment's dependencies (and pip), as a plain path: no .pth file there runs
    (Path(purelib) / "astrocpg_test_base.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    wheel = next(dist.glob("astrocpg-*.whl"))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = _clean_env()
    proc = subprocess.run([str(python), "-m", "pip", "install", "-q", "--no-deps",
                           "--ignore-installed", "--no-compile", str(wheel)],
                          cwd=elsewhere, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]

    where = subprocess.run([str(python), "-c", "import astrocpg; print(astrocpg.__file__)"],
                           cwd=elsewhere, env=env, capture_output=True, text=True, check=True)
    assert Path(where.stdout.strip()).resolve().is_relative_to(env_dir.resolve()), where.stdout

    script = env_dir / ("Scripts" if os.name == "nt" else "bin") / "astrocpg"
    import astrocpg
    info = astrocpg.build_info()
    version = subprocess.run([str(script), "--version"], cwd=elsewhere, env=env,
                             capture_output=True, text=True, timeout=120)
    assert version.returncode == 0, version.stderr
    # the version and commit the wheel was built from, known without git
    assert version.stdout.startswith(f"astrocpg {info['version']} ("), version.stdout
    if info["commit"]:
        assert f"commit {info['commit'][:12]}" in version.stdout, version.stdout
    else:
        assert "commit unknown" in version.stdout

    # the manual comes with the package, found from any folder
    docs = subprocess.run([str(script), "docs"], cwd=elsewhere, env=env, capture_output=True,
                          text=True, timeout=120)
    assert docs.returncode == 0, docs.stderr
    page = Path(docs.stdout.splitlines()[0].split(": ", 1)[1])
    assert page.is_file() and page.resolve().is_relative_to(env_dir.resolve()), docs.stdout
    folder = subprocess.run([str(script), "docs", "--path"], cwd=elsewhere, env=env,
                            capture_output=True, text=True, timeout=120).stdout.strip()
    assert (Path(folder) / "examples" / "interlimb_table.csv").is_file()

    # the manual's recipes that read shipped files, as the manual spells them (training.md)
    mine = subprocess.run([str(script), "run", "--weights", "docs/examples/interlimb_table.csv",
                           "--seconds", "0.2", "--no-progress", "--out", "out/mine"],
                          cwd=elsewhere, env=env, capture_output=True, text=True, timeout=600)
    assert mine.returncode == 0, mine.stderr[-3000:]
    # the manifest names the version and the commit the wheel was built from, without git
    import json
    manifest = json.loads((elsewhere / "out" / "mine" / "manifest.json").read_text())
    assert manifest["package_versions"]["astrocpg"] == info["version"]
    assert manifest["git"]["commit"] == info["commit"]
    assert manifest["git"]["source"] == "build"  # recorded by the build, read without git
    gait = subprocess.run([str(script), "gait", "docs/benchmarks/trained_astrocytes",
                           "--seconds", "0.2", "--repeats", "1", "--no-progress"],
                          cwd=elsewhere, env=env, capture_output=True, text=True, timeout=600)
    assert gait.returncode == 0, gait.stderr[-3000:]

    # a shipped variant by name: no models/ folder beside the working folder
    run = subprocess.run([str(script), "run", "--seconds", "0.2", "--no-progress", "--out",
                          "out/r", "--model", "alive=alive_height"], cwd=elsewhere, env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    assert (elsewhere / "out" / "r" / "manifest.json").is_file()

    robot = subprocess.run([str(script), "robot", "export", "a1.xml"], cwd=elsewhere, env=env,
                           capture_output=True, text=True, timeout=300)
    assert robot.returncode == 0, robot.stderr[-3000:]
    assert "<mujoco" in (elsewhere / "a1.xml").read_text()

    study = subprocess.run([str(python), "-c",
                            "from astrocpg.studies.parameter_studies.study import load_study; "
                            "from importlib.resources import files; "
                            "p = files('astrocpg.studies.parameter_studies') / 'quick.toml'; "
                            "print(len(load_study(str(p)).runs))"],
                           cwd=elsewhere, env=env, capture_output=True, text=True, timeout=300)
    assert study.returncode == 0 and int(study.stdout.strip()) > 0, study.stderr[-3000:]
    by_name = subprocess.run([str(python), "-c",
                              "from astrocpg.studies.parameter_studies.study import load_study; "
                              "print(len(load_study('compare_astrocytes').runs))"],
                             cwd=elsewhere, env=env, capture_output=True, text=True, timeout=300)
    assert by_name.returncode == 0 and int(by_name.stdout.strip()) > 0, by_name.stderr[-3000:]


def test_pip_wheel_leaves_nothing_in_the_source_tree(tmp_path: Path) -> None:
    """``pip wheel .`` builds in the tree itself (no sdist first); setuptools alone would leave
    ``build/`` and ``astrocpg.egg-info`` there."""
    before = {p.name for p in ROOT.iterdir()}
    proc = subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w",
                           str(tmp_path), str(ROOT)], cwd=tmp_path, env=_clean_env(),
                          capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert list(tmp_path.glob("astrocpg-*.whl"))
    left = {p.name for p in ROOT.iterdir()} - before
    assert not left, f"pip wheel left {sorted(left)} in the source tree"


def test_every_package_folder_is_listed_for_the_wheel():
    """A folder of the package with an __init__.py (a new sub-package such as the command
    line's) is in pyproject's ``packages``, so the wheel holds it."""
    import tomllib

    listed = set(tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"]
                 ["packages"])
    skip = {"tests", "docs", "benchmarks", "_build_backend", ".venv", "build"}
    found = {"astrocpg"}
    for init in ROOT.rglob("__init__.py"):
        rel = init.parent.relative_to(ROOT)
        if rel.parts and (rel.parts[0] in skip or rel.parts[0].startswith(".")):
            continue
        if rel.parts:
            found.add("astrocpg." + ".".join(rel.parts))
    assert found <= listed, f"not in pyproject's packages: {sorted(found - listed)}"
