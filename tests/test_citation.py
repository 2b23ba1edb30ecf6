"""CITATION.cff gives a usable citation: a release date, a preferred citation with year and
version, and the implemented paper with its year and arXiv DOI."""

from __future__ import annotations

import re
from pathlib import Path

import yaml

import astrocpg

ROOT = Path(__file__).resolve().parents[1]


def test_citation_names_the_release_and_the_paper() -> None:
    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    assert cff["version"] == astrocpg.__version__
    assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", str(cff["date-released"]))
    preferred = cff["preferred-citation"]
    assert preferred["version"] == astrocpg.__version__
    assert int(preferred["year"]) == int(str(cff["date-released"])[:4])
    paper = cff["references"][0]
    assert int(paper["year"]) == 2023
    assert paper["doi"] == "10.48550/arXiv.2312.15805"


def test_changelog_has_unreleased_and_a_dated_release() -> None:
    text = (ROOT / "CHANGELOG.md").read_text()
    assert "## [Unreleased]" in text
    assert re.search(rf"^## \[{re.escape(astrocpg.__version__)}\] - \d{{4}}-\d{{2}}-\d{{2}}$",
                     text, re.M)
