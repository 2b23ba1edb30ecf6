"""docs/tutorial.ipynb runs from top to bottom (nbclient, this interpreter as the kernel, in an
empty working folder), and is stored with the outputs of one such run, so that a code host
shows them: every code cell run once, in order, without an error, the file small and free of
the paths of the machine that ran it."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "docs" / "tutorial.ipynb"
KERNEL = "astrocpg-tutorial-test"


def test_tutorial_is_stored_with_its_outputs():
    """Run it with nbclient in an empty folder (as test_tutorial_executes does) and commit the
    result, without nbclient's per-cell timing metadata."""
    text = NOTEBOOK.read_text(encoding="utf-8")
    nb = json.loads(text)
    code = [c for c in nb["cells"] if c["cell_type"] == "code"]
    assert code, "no code cells"
    assert [c.get("execution_count") for c in code] == list(range(1, len(code) + 1)), \
        "every code cell run once, top to bottom, in one kernel"
    outputs = [o for c in code for o in c.get("outputs", [])]
    assert sum(bool(c.get("outputs")) for c in code) >= len(code) // 2, "outputs missing"
    assert not [o for o in outputs if o["output_type"] == "error"]
    assert not [o for o in outputs if o.get("name") == "stderr"], "a warning in the outputs"
    assert not [c for c in code if "execution" in c.get("metadata", {})], "timing metadata"
    assert len(text) < 200_000, f"{len(text)} characters: outputs too large to commit"
    for folder in ("/tmp/", "/home/", "/root/", "/work/", "/Users/"):
        assert folder not in text, f"a path of the machine that ran it ({folder})"


def _kernel_dir(root: Path) -> Path:
    """A kernelspec for this very interpreter in a private Jupyter data folder: found first on
    JUPYTER_PATH, whatever other 'python3' kernels a machine (or a fresh CI venv) has."""
    spec = root / "kernels" / KERNEL
    spec.mkdir(parents=True)
    (spec / "kernel.json").write_text(json.dumps({
        "argv": [sys.executable, "-m", "ipykernel_launcher", "-f", "{connection_file}"],
        "display_name": "astrocpg tests", "language": "python"}))
    return root


@pytest.mark.slow  # about 30 s of CPU (a minute on a busy 2-core machine)
def test_tutorial_executes(tmp_path, monkeypatch):
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    jupyter = _kernel_dir(tmp_path / "jupyter")
    monkeypatch.setenv("JUPYTER_PATH", os.pathsep.join(
        [str(jupyter)] + [p for p in os.environ.get("JUPYTER_PATH", "").split(os.pathsep) if p]))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    work = tmp_path / "work"
    work.mkdir()
    nb = nbformat.read(NOTEBOOK, as_version=4)
    client = nbclient.NotebookClient(nb, kernel_name=KERNEL, timeout=300,
                                     resources={"metadata": {"path": str(work)}})
    client.execute()
    errors = [o for c in nb.cells if c.cell_type == "code" for o in c.outputs
              if o.output_type == "error"]
    assert not errors
    assert (work / "tutorial_out" / "run" / "manifest.json").is_file()
    assert (work / "tutorial_out" / "run.nwb").is_file()
