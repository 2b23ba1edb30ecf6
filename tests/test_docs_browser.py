"""The built manual as a reader sees it: the model page opened from disk (file://) in a real
headless browser with networking off. Its equations are drawn (MathJax is served from the
manual itself, not from a CDN) and its parameter tables fit the text column.

Needs Chromium (Debian: ``apt-get install chromium``; ``ASTROCPG_BROWSER`` names another
Chromium-based browser); skipped without one. Uses the manual that ``conftest.py``'s ``site``
fixture builds once per test session, shared with tests/test_docs.py."""

from __future__ import annotations

import html
import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import pytest

# a few seconds each, on top of the manual's build that tests/test_docs.py shares
pytestmark = pytest.mark.slow

# every name a Chromium is installed under (Debian: chromium; Ubuntu's snap: chromium-browser)
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
WIDTH, HEIGHT = 1280, 1000   # a desktop window: sidebar, article and table of contents shown


def _browser() -> str:
    named = os.environ.get("ASTROCPG_BROWSER")
    found = [shutil.which(b) for b in ((named,) if named else BROWSERS)]
    found = [b for b in found if b]
    if not found:
        pytest.skip(f"no headless browser: install Chromium (Debian: apt-get install chromium) "
                    f"or set ASTROCPG_BROWSER; looked for {named or ', '.join(BROWSERS)}")
    return found[0]


def _dom(url: str, profile: Path) -> str:
    """The page's DOM after its scripts ran (10 s of virtual time: MathJax typesets in it),
    with every host name unresolvable: nothing can come from the network."""
    argv = [_browser(), "--headless", "--no-sandbox", "--disable-gpu",
            "--host-resolver-rules=MAP * ~NOTFOUND", "--disable-background-networking",
            "--no-first-run", "--disable-extensions", f"--user-data-dir={profile}",
            f"--window-size={WIDTH},{HEIGHT}", "--virtual-time-budget=10000", "--dump-dom", url]
    proc = subprocess.run(argv, capture_output=True, text=True, timeout=180)
    assert proc.returncode == 0 and "<html" in proc.stdout, proc.stderr[-3000:]
    return proc.stdout


def _text(dom: str) -> str:
    """What the page shows as text: the DOM without scripts, styles and tags."""
    dom = re.sub(r"<(script|style)\b.*?</\1>", " ", dom, flags=re.S | re.I)
    return html.unescape(re.sub(r"<[^>]+>", " ", dom))


def test_the_model_pages_equations_render_offline_from_disk(site: Path, tmp_path: Path) -> None:
    page = site / "model.html"
    built = page.read_text(encoding="utf-8")
    # MathJax comes with the manual, not from another host
    scripts = re.findall(r'<script[^>]+src="([^"]*mathjax[^"]*)"', built, re.I)
    assert scripts and all("://" not in s for s in scripts), scripts
    assert (site / scripts[0].split("?")[0]).is_file(), scripts[0]
    displayed = built.count('<div class="math notranslate')   # display equations as built
    inline = built.count('<span class="math notranslate')
    assert displayed > 0 and inline > 0, (displayed, inline)

    dom = _dom(page.as_uri(), tmp_path / "profile")
    drawn = re.findall(r"<mjx-container\b[^>]*>", dom)
    assert len(drawn) >= displayed + inline, (len(drawn), displayed, inline)
    assert len([c for c in drawn if 'display="true"' in c]) >= displayed
    # a formula MathJax could not read is drawn as an error box
    errors = re.findall(r'data-mjx-error="([^"]*)"|<mjx-merror\b[^>]*>', dom)
    assert not errors, errors[:5]
    text = _text(dom)
    raw = [m for m in ("\\(", "\\[", "$$", "\\begin{", "\\frac", "\\tag{") if m in text]
    assert not raw, f"raw LaTeX left on the page: {raw}"


def test_the_model_pages_parameter_tables_fit_the_text_column(site: Path,
                                                              tmp_path: Path) -> None:
    """The page as built, with a probe appended that measures each parameter table against
    the column it sits in once MathJax has drawn the symbols (a <base> makes the page's own
    relative links resolve from its copy in tmp_path)."""
    page = (site / "model.html").read_text(encoding="utf-8")
    assert page.count('class="astrocpg-parameters') >= 5
    probe = """<script>
window.addEventListener("load", function () {
  function measure() {
    var rows = [];
    document.querySelectorAll(".astrocpg-parameters table").forEach(function (t) {
      var box = t.parentElement;  // the theme's table wrapper, as wide as the text column
      rows.push({table: Math.ceil(t.getBoundingClientRect().width), column: box.clientWidth,
                 scrolls: box.scrollWidth > box.clientWidth + 1});
    });
    document.body.setAttribute("data-probe", JSON.stringify(rows));
  }
  (window.MathJax && MathJax.startup ? MathJax.startup.promise : Promise.resolve()).then(measure);
});
</script>"""
    copy = tmp_path / "model_probe.html"
    copy.write_text(page.replace("<head>", f'<head><base href="{site.as_uri()}/">', 1)
                    .replace("</body>", probe + "</body>", 1), encoding="utf-8")
    dom = _dom(copy.as_uri(), tmp_path / "profile")
    found = re.search(r'<body[^>]*data-probe="([^"]*)"', dom)
    assert found, "the probe did not run"
    tables = json.loads(html.unescape(found.group(1)))
    assert len(tables) >= 5, tables
    wide = [t for t in tables if t["scrolls"] or t["table"] > t["column"] + 1]
    assert not wide, f"tables wider than the text column ({WIDTH} px window): {wide}"
