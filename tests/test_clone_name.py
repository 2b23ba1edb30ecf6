"""The suite passes from a clone whatever its folder's name: the checkout's root is the
package's source (``package-dir``), so pytest would otherwise collect it as a package named
after the folder, and a clone in ``copy/`` shadowed the standard library's ``copy``: every Dask
worker then failed to start ("Nanny failed to start"). tests/conftest.py collects the root as
a plain folder; this runs a probe from clones named ``copy`` and ``my-clone``."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

PROBE = '''
import copy


def test_the_standard_library_copy_is_imported():
    assert hasattr(copy, "deepcopy"), copy.__file__


def test_a_dask_worker_process_starts():
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                      dashboard_address=":0") as cluster, Client(cluster) as client:
        assert client.submit(sum, [1, 2, 3]).result(timeout=60) == 6
'''


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("git") is None or not (ROOT / ".git").exists(),
                    reason="needs git and a git checkout to clone")
@pytest.mark.parametrize("name", ["copy", "my-clone"])
def test_the_suite_runs_from_a_clone_of_any_name(tmp_path, name):
    clone = tmp_path / name
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True, timeout=120)
    (clone / "tests" / "test_probe_clone_name.py").write_text(PROBE)
    run = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:randomly",
                          "-p", "no:cacheprovider", "tests/test_probe_clone_name.py"],
                         cwd=clone, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    assert "2 passed" in run.stdout


def test_no_test_puts_the_checkouts_parent_on_the_import_path():
    """A test that puts the folder above the checkout on PYTHONPATH or sys.path makes the clone's
    folder importable under its own name: a clone in copy/ then shadows the standard library's
    copy in that process (the installed astrocpg is what a test imports)."""
    import re

    above = re.compile(r"(PYTHONPATH|sys\.path).*(parents\[1\]|ROOT\.parent|\.parent\.parent)")
    found = [f"{p.name}:{k}" for p in sorted((ROOT / "tests").glob("*.py"))
             for k, line in enumerate(p.read_text().splitlines(), 1) if above.search(line)]
    assert found == []
