"""The manual builds: ``sphinx-build -W -n`` (every warning an error, every cross-reference
checked) over ``docs/``, executing the tutorial and the examples (the ``site`` fixture of
``conftest.py``, built once per test session and shared with ``test_docs_browser.py``). The built site's relative
links and images all resolve, it has the API reference, each executed example has its
figures, and the model page has every parameter of the code. The frame-extraction command of
``docs/seeing/README.md`` runs as written."""

from __future__ import annotations

import re
import shlex
import subprocess
import sys
from html.parser import HTMLParser
from pathlib import Path
from urllib.parse import unquote, urlsplit

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
EXAMPLES = ["tutorial", "examples/fig3c", "examples/model_file", "examples/nwb_export",
            "examples/sweep", "examples/frames"]
API_OBJECTS = [
    # the functions at the names users call them by (import astrocpg as ac; ac.run)
    "astrocpg.unit", "astrocpg.run", "astrocpg.train", "astrocpg.resume", "astrocpg.load",
    "astrocpg.describe", "astrocpg.export", "astrocpg.plot", "astrocpg.video", "astrocpg.gait",
    "astrocpg.evaluate", "astrocpg.power", "astrocpg.study", "astrocpg.study_status",
    "astrocpg.report",
    "astrocpg.studies.outputs.result.Result",
    "astrocpg.studies.outputs.result.Result.spike_times", "astrocpg.studies.outputs.result.Result.trace",
    "astrocpg.studies.outputs.result.Trace", "astrocpg.errors.InputError",
    "astrocpg.models.ModelSet",
]


class _Links(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.links: list[str] = []
        self.ids: set[str] = set()

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if a.get("id"):
            self.ids.add(a["id"])
        for key in ("href", "src"):
            if a.get(key) and not (tag == "link" and key == "href" and "stylesheet" not in
                                   (a.get("rel") or "")):
                self.links.append(a[key])


def _parse(path: Path) -> _Links:
    parser = _Links()
    parser.feed(path.read_text(encoding="utf-8"))
    return parser


def test_every_relative_link_and_image_of_the_site_resolves(site: Path) -> None:
    pages = sorted(site.rglob("*.html"))
    parsed = {p: _parse(p) for p in pages}
    broken = []
    for page, links in parsed.items():
        for link in links.links:
            parts = urlsplit(link)
            if parts.scheme or link.startswith(("//", "mailto:", "javascript:", "data:")):
                continue
            target = page if not parts.path else (page.parent / unquote(parts.path)).resolve()
            if target.is_dir():
                target = target / "index.html"
            if not target.exists():
                broken.append(f"{page.relative_to(site)}: {link}")
            elif parts.fragment and target.suffix == ".html":
                ids = parsed[target].ids if target in parsed else _parse(target).ids
                if unquote(parts.fragment) not in ids:
                    broken.append(f"{page.relative_to(site)}: {link} (no such anchor)")
    assert not broken, "\n".join(broken)


def test_the_site_has_the_api_reference(site: Path) -> None:
    ids: set[str] = set()
    for page in (site / "api").glob("*.html"):
        ids |= _parse(page).ids
    missing = [name for name in API_OBJECTS if name not in ids]
    assert not missing, missing
    assert (site / "py-modindex.html").is_file()


@pytest.mark.parametrize("page", EXAMPLES)
def test_each_executed_example_shows_its_figures(site: Path, page: str) -> None:
    html = (site / f"{page}.html").read_text(encoding="utf-8")
    # what an executed cell drew: the images in its output, up to the next cell
    outputs = [re.split(r'<div class="cell[ _]', chunk, maxsplit=1)[0]
               for chunk in html.split('<div class="cell_output')[1:]]
    images = [src for out in outputs for src in re.findall(r'<img[^>]+src="([^"]+)"', out)]
    assert images, f"{page}: no figure among the executed cells' outputs"
    for src in images:
        assert (site / page).parent.joinpath(src).resolve().is_file(), src
    assert "Traceback" not in html and 'class="output traceback' not in html


def test_the_model_page_lists_every_parameter_of_the_code(site: Path) -> None:
    from astrocpg.models import DEFAULT_MODELS
    html = (site / "model.html").read_text(encoding="utf-8")
    names = [p for _, model in DEFAULT_MODELS.items() for p in model.parameters]
    missing = [n for n in names if f'<span class="pre">{n}</span>' not in html]
    assert not missing, missing
    for number in range(1, 24):   # every equation of the paper, by its number
        assert f"\\tag{{{number}}}" in html, number


def test_the_seeing_frames_command_runs_as_written(tmp_path: Path) -> None:
    """docs/seeing/README.md's command, on an MP4 of 120 frames written as ``astrocpg video``
    writes one (imageio-ffmpeg); ``list(reader)`` there once raised MemoryError."""
    import imageio.v2 as iio
    import numpy as np
    text = (DOCS / "seeing" / "README.md").read_text(encoding="utf-8")
    command = re.search(r'^(python -c ".*?")', text, re.S | re.M)
    assert command, "no python -c command in docs/seeing/README.md"
    video = tmp_path / "out" / "see" / "video_trial00.mp4"
    video.parent.mkdir(parents=True)
    with iio.get_writer(video, fps=30, macro_block_size=1) as writer:
        for k in range(120):
            writer.append_data(np.full((48, 64, 3), 2 * k, np.uint8))
    argv = shlex.split(command.group(1))
    argv[0] = sys.executable
    proc = subprocess.run(argv, cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    for second in (1, 2, 3):
        assert (tmp_path / f"video_frame_{second}s.png").is_file(), second


class _Images(HTMLParser):
    def __init__(self) -> None:
        super().__init__()
        self.images: list[dict[str, str | None]] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "img":
            self.images.append(dict(attrs))


def test_every_image_of_the_site_says_what_it_shows(site: Path) -> None:
    """An alt text for every figure, and not its file name: docutils writes the image's path
    as its alt text when a page gives none (an executed cell's figure gets a hash name)."""
    bad = []
    for page in sorted(site.rglob("*.html")):
        parser = _Images()
        parser.feed(page.read_text(encoding="utf-8"))
        for img in parser.images:
            if "toggler" in (img.get("class") or ""):   # the module index's +/- switches
                continue
            alt = (img.get("alt") or "").strip()
            src = img.get("src") or ""
            if (len(alt) < 12 or re.search(r"\.(png|jpe?g|svg|gif)$", alt, re.I)
                    or re.fullmatch(r"[\w./-]*[0-9a-f]{16,}[\w./-]*", alt)
                    or (src and (alt == src or alt.endswith(Path(src).name)))):
                bad.append(f"{page.relative_to(site)}: {src} alt={alt!r}")
    assert not bad, "\n".join(bad)


def test_the_citing_page_gives_citation_cff_as_bibtex(site: Path) -> None:
    """docs/citing.md makes its BibTeX from CITATION.cff at build time: this version, the
    paper's DOI."""
    import html as html_lib

    import astrocpg
    text = html_lib.unescape(re.sub(r"<[^>]+>", "", (site / "citing.html").read_text(
        encoding="utf-8")))
    assert "@software{astrocpg_" in text and f"{{{astrocpg.RELEASE}}}" in text
    assert "{{The astrocpg authors}}" in text and "{https://arxiv.org/abs/2312.15805}" in text
    assert "{10.48550/arXiv.2312.15805}" in text and "{Han, Zhuangyu and Sengupta, Abhronil}" in text


class _Assets(HTMLParser):
    """What a page loads by itself: scripts, style sheets, images, frames."""

    def __init__(self) -> None:
        super().__init__()
        self.assets: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        a = dict(attrs)
        if tag in ("script", "img", "iframe", "source") and a.get("src"):
            self.assets.append(a["src"] or "")
        elif tag == "link" and "stylesheet" in (a.get("rel") or "") and a.get("href"):
            self.assets.append(a["href"] or "")


def test_the_site_loads_nothing_from_another_host(site: Path) -> None:
    """The manual reads the same without internet: every script (MathJax included), style
    sheet and image it loads comes with it."""
    remote = []
    for page in sorted(site.rglob("*.html")):
        parser = _Assets()
        parser.feed(page.read_text(encoding="utf-8"))
        remote += [f"{page.relative_to(site)}: {src}" for src in parser.assets
                   if urlsplit(src).scheme in ("http", "https") or src.startswith("//")]
    assert not remote, "\n".join(remote[:20])
