"""CITATION.cff gives a usable citation: the paper as the preferred citation (the model), the
software with its release, date and URL (the tool), and a BibTeX entry from ``cffconvert`` that
BibTeX reads with the right author (an organisation, not a person named "authors"), title and
version."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

import astrocpg

ROOT = Path(__file__).resolve().parents[1]


def _cff() -> dict:
    return yaml.safe_load((ROOT / "CITATION.cff").read_text())


def test_citation_names_the_release_and_prefers_the_paper() -> None:
    cff = _cff()
    assert cff["type"] == "software"
    assert str(cff["version"]) == astrocpg.RELEASE
    assert astrocpg.RELEASE in cff["title"]  # cffconvert's BibTeX has no version field
    assert re.fullmatch(r"\d{4}-\d{2}-\d{2}", str(cff["date-released"]))
    assert cff["url"].startswith("https://")
    (author,) = cff["authors"]
    assert "family-names" not in author and author["name"] == "{The astrocpg authors}"
    paper = cff["preferred-citation"]
    assert paper["type"] == "article" and int(paper["year"]) == 2023
    assert paper["doi"] == "10.48550/arXiv.2312.15805"
    assert [a["family-names"] for a in paper["authors"]] == ["Han", "Sengupta"]


def _bibtex_fields(text: str) -> tuple[str, dict[str, str]]:
    """The entry type and fields of one BibTeX entry, braces checked: a small reader for
    ``key = {value}`` fields (what cffconvert writes)."""
    depth = 0
    for ch in text:
        depth += {"{": 1, "}": -1}.get(ch, 0)
        assert depth >= 0, text
    assert depth == 0, text
    m = re.match(r"\s*@(\w+)\{([^,\s]+),\s*(.*)\}\s*$", text, re.S)
    assert m, text
    fields, body = {}, m.group(3)
    for fm in re.finditer(r"(\w+)\s*=\s*\{", body):
        start, depth = fm.end(), 1
        i = start
        while depth:
            depth += {"{": 1, "}": -1}.get(body[i], 0)
            i += 1
        fields[fm.group(1).lower()] = body[start:i - 1]
    return m.group(1).lower(), fields


def test_cffconvert_gives_bibtex_with_author_title_and_version(tmp_path: Path) -> None:
    exe = shutil.which("cffconvert") or (Path(sys.executable).parent / "cffconvert")
    if not Path(exe).exists():
        pytest.skip("cffconvert is not installed (pip install -e '.[test]')")
    shutil.copy(ROOT / "CITATION.cff", tmp_path / "CITATION.cff")
    valid = subprocess.run([str(exe), "--validate"], cwd=tmp_path, capture_output=True,
                           text=True, timeout=120)
    assert valid.returncode == 0, valid.stdout + valid.stderr
    done = subprocess.run([str(exe), "-f", "bibtex"], cwd=tmp_path, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    kind, fields = _bibtex_fields(done.stdout)
    assert kind == "misc"
    # one organisation: the whole name in its own braces
    assert fields["author"] == "{The astrocpg authors}", fields
    assert fields["title"].startswith("astrocpg") and astrocpg.RELEASE in fields["title"]
    assert fields["year"] == str(_cff()["date-released"])[:4]
    assert fields["url"] == _cff()["url"]
    try:
        import bibtexparser
        from bibtexparser.middlewares import SeparateCoAuthors, SplitNameParts
    except ImportError:
        return
    lib = bibtexparser.parse_string(done.stdout,
                                    append_middleware=[SeparateCoAuthors(), SplitNameParts()])
    assert not lib.failed_blocks and len(lib.entries) == 1
    (name,) = lib.entries[0].fields_dict["author"].value
    assert name.first == [] and name.last == ["{The astrocpg authors}"], name


def test_changelog_has_unreleased_and_a_dated_release() -> None:
    text = (ROOT / "CHANGELOG.md").read_text()
    assert "## [Unreleased]" in text
    assert re.search(rf"^## \[{re.escape(astrocpg.RELEASE)}\] - \d{{4}}-\d{{2}}-\d{{2}}$",
                     text, re.M)
