"""Shipped model files, studies and worlds are reached by name from any folder (an installed
wheel has no checkout beside it), and ``python -m astrocpg`` is the command line."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from astrocpg.models.compose import read_model_files
from astrocpg.support.shipped import resolve, shipped
from astrocpg.studies.parameter_studies.study import load_study


@pytest.fixture
def elsewhere(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    monkeypatch.chdir(tmp_path)  # no models/ or studies/ beside the working folder
    return tmp_path


def test_a_variant_by_name_and_by_repository_path(elsewhere: Path) -> None:
    by_name = read_model_files(["alive=alive_height"])
    by_path = read_model_files(["alive=models/variants/alive_height.toml"])
    assert by_name == by_path
    assert "alive" in by_name and by_name["alive"].strip()


def test_a_study_by_name(elsewhere: Path) -> None:
    study = load_study("compare_astrocytes")
    assert Path(study.path).name == "compare_astrocytes.toml"


def test_a_path_that_exists_wins_over_a_shipped_name(elsewhere: Path) -> None:
    mine = elsewhere / "alive_height.toml"
    mine.write_text("# mine\n")
    assert resolve("alive_height.toml", "model") == Path("alive_height.toml")
    assert resolve("no_such_file", "model") == Path("no_such_file")


def test_the_kinds_are_told_apart() -> None:
    assert "compare_astrocytes" in shipped("study")
    assert "alive_height" in shipped("model")
    assert "compare_astrocytes" not in shipped("model")


def test_python_dash_m_astrocpg(elsewhere: Path) -> None:
    import astrocpg
    done = subprocess.run([sys.executable, "-m", "astrocpg", "--version"], capture_output=True,
                          text=True, env={**os.environ}, cwd=elsewhere, timeout=120)
    assert done.returncode == 0, done.stderr
    assert astrocpg.__version__ in done.stdout


def test_astrocpg_docs_finds_the_manual_and_the_recipes_files(capsys, tmp_path, monkeypatch
                                                              ) -> None:
    """``astrocpg docs`` (``ac.docs``) says where the manual is; ``--path`` its folder, where
    the files its recipes read are; a path the manual spells reads the shipped file from any
    folder, and a missing input is the environment's (exit 1)."""
    import astrocpg as ac
    from astrocpg.support.shipped import DOCS, resolve_data
    from astrocpg.studies.cli import main

    monkeypatch.setenv("ASTROCPG_CACHE", str(tmp_path / "cache"))
    page = ac.docs()
    assert page.is_file() and page.name in ("index.md", "index.html")
    assert main(["docs", "--path"]) == 0
    folder = Path(capsys.readouterr().out.strip())
    assert folder == DOCS and (folder / "examples" / "interlimb_table.csv").is_file()
    monkeypatch.chdir(tmp_path)
    assert resolve_data("docs/examples/interlimb_table.csv") == \
        str(DOCS / "examples" / "interlimb_table.csv")
    assert resolve_data("docs/no_such.csv") == "docs/no_such.csv"
    assert resolve_data("../docs/examples/interlimb_table.csv").startswith("..")
    assert main(["gait", "docs/no_such_training"]) == 1
    assert "docs/no_such_training: no such file or folder" in capsys.readouterr().err
