"""``astrocpg describe`` of the built-in models comes from a cache without importing Brian2."""

from __future__ import annotations

import subprocess
import sys

CHECK = ("import sys, io, contextlib\n"
         "from astrocpg.studies.cli import main\n"
         "buf = io.StringIO()\n"
         "with contextlib.redirect_stdout(buf):\n"
         "    rc = main(['describe'] + sys.argv[1:])\n"
         "sys.stderr.write(f'{rc} {\"brian2\" in sys.modules}\\n')\n"
         "sys.stdout.write(buf.getvalue())\n")


def _describe(cache, *args):
    p = subprocess.run([sys.executable, "-c", CHECK, *args], capture_output=True, text=True,
                       env={"ASTROCPG_CACHE": str(cache), "PATH": "/usr/bin:/bin"}, timeout=120)
    rc, brian = p.stderr.strip().splitlines()[-1].split()
    return int(rc), brian == "True", p.stdout


def test_second_describe_reads_the_cache_without_brian2(tmp_path):
    rc, brian, first = _describe(tmp_path)
    assert rc == 0 and brian and "\nastrocyte\n=========\n" in first
    rc, brian, second = _describe(tmp_path)
    assert rc == 0 and not brian
    assert second == first
    rc, brian, one = _describe(tmp_path, "world")
    rc, brian, again = _describe(tmp_path, "world")
    assert not brian and again == one and one.startswith("world\n=====")


def test_overrides_bypass_the_cache(tmp_path):
    _describe(tmp_path)
    rc, brian, text = _describe(tmp_path, "astrocyte", "--set", "tau_AG=2*second")
    assert rc == 0 and brian and "2. s" in text
    rc, brian, text = _describe(tmp_path, "nope")
    assert rc == 2


def test_a_new_renderer_gives_fresh_texts(tmp_path, monkeypatch):
    """The cache is named by the renderer's source too: texts written by an older renderer
    (e.g. Markdown where plain text is now the default) are not read back."""
    from astrocpg.studies.runtime import describe_cache

    before = describe_cache.models_key()
    edited = tmp_path / "describe.py"
    edited.write_bytes(describe_cache._RENDERER.read_bytes() + b"\n# edited\n")
    monkeypatch.setattr(describe_cache, "_RENDERER", edited)
    assert describe_cache.models_key() != before
