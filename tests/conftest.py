"""Shared fixtures. ``../shared`` (beside the repository) holds the authors' A1 model, used by
tests only; set ASTROCPG_SHARED to point elsewhere."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

# The interrupt tests press Ctrl-C on commands they start (SIGINT to the child or its group).
# A suite started in the background (`bash .ci/run &`, nohup from a script: a shell without
# job control starts such a job with SIGINT ignored) would pass that on: an ignored signal stays
# ignored across exec, Python then installs no KeyboardInterrupt, and every command would run
# through its Ctrl-C. A handler, unlike SIG_IGN, is reset to the default at exec, so each
# command starts as it does from a terminal.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def shared_dir() -> Path:
    env = os.environ.get("ASTROCPG_SHARED")
    return Path(env) if env else Path(__file__).resolve().parents[2] / "shared"


@pytest.fixture(scope="session")
def reference_a1_path() -> Path:
    path = shared_dir() / "reference" / "a1" / "xml" / "a1_gait_search.xml"
    if not path.is_file():
        pytest.skip(f"reference A1 model not found at {path}")
    return path


@pytest.fixture(scope="session")
def site(tmp_path_factory) -> Path:
    """The manual, built once per test session with ``sphinx -W -n`` (every warning an error,
    every cross-reference checked), executing the tutorial and the examples: its HTML folder.
    tests/test_docs.py checks its pages and links, tests/test_docs_browser.py shows them in a
    browser."""
    pytest.importorskip("sphinx")
    pytest.importorskip("myst_nb")
    root = Path(__file__).resolve().parents[1]
    out = tmp_path_factory.mktemp("docs")
    env = dict(os.environ, MPLBACKEND="Agg")
    proc = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-n", "--keep-going", "-q",
                           "-b", "html", str(root / "docs"), str(out / "html")],
                          cwd=root, env=env, capture_output=True, text=True, timeout=1800)
    assert proc.returncode == 0, (proc.stdout[-4000:] + proc.stderr[-8000:])
    return out / "html"


class _CheckoutIsAFolder:
    """The checkout's root is the package's source (``package-dir``), so it holds an
    ``__init__.py``, and pytest would collect it as a package named after the clone's folder:
    a clone in ``copy/`` shadows the standard library's ``copy`` and one in ``my-clone/`` has
    its ``__init__`` imported as a loose module. The tests import the installed ``astrocpg``
    instead, so the root is collected as a plain folder, whatever its name."""

    @pytest.hookimpl(tryfirst=True)
    def pytest_collect_directory(self, path: Path, parent: pytest.Collector):
        if path == Path(__file__).resolve().parents[1]:
            return pytest.Dir.from_parent(parent, path=path)
        return None


def pytest_configure(config: pytest.Config) -> None:
    """``python -m pytest`` runs the fast tests (pyproject: ``-m 'not slow'``); with CI=true
    (as ``.ci/run`` runs it) the same command runs every test, the slow ones too."""
    config.pluginmanager.register(_CheckoutIsAFolder(), "astrocpg-checkout-is-a-folder")
    if os.environ.get("CI", "").lower() in ("1", "true", "yes") \
            and config.option.markexpr == "not slow":
        config.option.markexpr = ""
