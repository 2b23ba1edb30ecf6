"""Bounded reading: no file a user hands astrocpg makes it use more memory or time than its
declared content needs. A FIFO (or another file that is not a regular one) given or placed as
any input is refused without a blocking read; JSON and TOML nested very deep are refused
before a parser recurses. Each refusal is one line on stderr, exit 2, naming the file.

On a FIFO, the old code blocked in ``open()`` forever: each FIFO here has a watchdog that,
after a few seconds, opens it for writing and closes it (an end-of-file), so that a reader
that did wait fails its assertion instead of hanging the suite.
"""

from __future__ import annotations

import json
import os
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from astrocpg.errors import InputError
from astrocpg.studies.cli import main
from astrocpg.studies.outputs import checkpoint as ck

DEEP = 100_000
REGULAR = "is not a regular file (a FIFO)"
NESTED = "nested too deeply"


# ---------------------------------------------------------------- helpers
@pytest.fixture
def fifo():
    """``fifo(path)`` makes a FIFO at ``path``; a watchdog unblocks a reader that waits on it
    (after 5 s: writes nothing and closes), until the test ends."""
    stop = threading.Event()
    made: list[Path] = []

    def watchdog(path: Path) -> None:
        if stop.wait(5):
            return
        while not stop.is_set():
            try:
                fd = os.open(path, os.O_WRONLY | os.O_NONBLOCK)
            except OSError:  # no reader yet (ENXIO), or gone
                time.sleep(0.05)
                continue
            os.close(fd)
            time.sleep(0.05)

    def make(path: Path) -> Path:
        path.parent.mkdir(parents=True, exist_ok=True)
        os.mkfifo(path)
        made.append(path)
        threading.Thread(target=watchdog, args=(path,), daemon=True).start()
        return path

    yield make
    stop.set()


def cli(argv: list[str], capsys) -> tuple[int, str]:
    """Exit code and the one line on stderr (asserted to be one line when it fails)."""
    try:
        code = main([str(a) for a in argv])
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else 1
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    if code != 0:
        assert len(lines) == 1 and lines[0].startswith("astrocpg:"), err
        assert "internal error" not in lines[0], lines[0]
    return code, lines[-1] if lines else ""


def deep_json(kind: str = "list") -> str:
    return "[" * DEEP + "]" * DEEP if kind == "list" else '{"a":' * DEEP + "1" + "}" * DEEP


def deep_toml(key: str = "x") -> str:
    return f"{key} = " + "[" * DEEP + "]" * DEEP + "\n"


def checkpoint_with(path: Path, *, meta: str | None = None, state: str | None = None) -> Path:
    """A checkpoint archive whose meta or state entry is the JSON text given."""
    good_meta = json.dumps({"format": ck.FORMAT, "version": ck.VERSION, "settings": {}})
    arrays = {"meta": np.frombuffer((meta or good_meta).encode(), dtype=np.uint8),
              "state": np.frombuffer((state or "{}").encode(), dtype=np.uint8)}
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        np.savez(f, **arrays)
    return path


# ---------------------------------------------------------------- deep JSON
@pytest.mark.parametrize("entry", ["state", "meta"])
@pytest.mark.parametrize("kind", ["list", "object"])
def test_checkpoint_json_nested_deep_is_refused_naming_the_file(tmp_path, entry, kind):
    path = checkpoint_with(tmp_path / ck.CHECKPOINT, **{entry: deep_json(kind)})
    with pytest.raises(InputError, match=NESTED) as e:
        ck.read_checkpoint(path)
    assert str(path) in e.value.line


def test_train_resume_refuses_a_deep_checkpoint(tmp_path, capsys):
    checkpoint_with(tmp_path / "t" / ck.CHECKPOINT, state=deep_json())
    code, line = cli(["train", "--resume", tmp_path / "t", "--no-progress"], capsys)
    assert code == 2 and NESTED in line and ck.CHECKPOINT in line, line


@pytest.mark.parametrize("command", ["plot", "export"])
def test_a_deep_manifest_is_refused(tmp_path, capsys, command):
    folder = tmp_path / "run"
    folder.mkdir()
    (folder / "manifest.json").write_text(deep_json("object"))
    code, line = cli([command, folder, "--out", tmp_path / "o"], capsys)
    assert code == 2 and NESTED in line and "manifest.json" in line, line


def test_load_refuses_a_deep_manifest(tmp_path):
    import astrocpg as ac

    (tmp_path / "manifest.json").write_text(deep_json())
    with pytest.raises(InputError, match=NESTED):
        ac.load(tmp_path)


def test_report_refuses_a_deep_study_index(tmp_path, capsys):
    folder = tmp_path / "study"
    folder.mkdir()
    (folder / "study.json").write_text(deep_json("object"))
    code, line = cli(["report", folder, "--out", tmp_path / "r"], capsys)
    assert code == 2 and NESTED in line and "study.json" in line, line


def test_weights_json_nested_deep_is_refused(tmp_path, capsys):
    (tmp_path / "w.json").write_text(deep_json())
    code, line = cli(["run", "--weights", tmp_path / "w.json", "--seconds", "0.01",
                      "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2 and NESTED in line and "--weights" in line, line


# ---------------------------------------------------------------- deep TOML
@pytest.mark.parametrize("text", [deep_toml(), "x = " + "{a=" * DEEP + "1" + "}" * DEEP,
                                  "[" + "a." * 5000 + "a]\nx = 1\n",
                                  "a" + ".a" * 5000 + " = 1\n"],
                         ids=["arrays", "inline-tables", "table-header", "dotted-key"])
def test_a_deep_model_file_is_refused(tmp_path, capsys, text):
    (tmp_path / "m.toml").write_text(text)
    code, line = cli(["run", "--model", f"astrocyte={tmp_path / 'm.toml'}", "--seconds",
                      "0.01", "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2 and NESTED in line and "--model astrocyte" in line, line


def test_a_deep_model_text_is_refused_by_the_api():
    from astrocpg.models.files import model_from_toml

    with pytest.raises(InputError, match=NESTED):
        model_from_toml(deep_toml(), culprit="models astrocyte")


def test_a_deep_study_file_is_refused(tmp_path, capsys):
    (tmp_path / "s.toml").write_text('[study]\nname = "t"\n' + deep_toml("sessions"))
    code, line = cli(["study", tmp_path / "s.toml", "--out", tmp_path / "o"], capsys)
    assert code == 2 and NESTED in line and "s.toml" in line, line


def test_a_deep_worlds_file_is_refused(tmp_path):
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.studies.commands.evaluate import read_worlds

    (tmp_path / "w.toml").write_text("[worlds]\n" + deep_toml("ground"))
    with pytest.raises(InputError, match=NESTED) as e:
        read_worlds(str(tmp_path / "w.toml"), DEFAULT_MODELS)
    assert "worlds" in [f.name for f in e.value.fields]  # the setting, whatever the door


def test_ordinary_documents_still_read():
    from astrocpg.support.reading import MAX_DEPTH, loads_json, loads_toml

    assert loads_json("[" * MAX_DEPTH + "]" * MAX_DEPTH, "x") is not None
    assert loads_json('{"a": "[[[[{{{{", "b": [1, [2, [3]]]}', "x")["a"] == "[[[[{{{{"
    doc = loads_toml('a = "[[[[x.y.z"  # [[[ a.b.c\n[t.u]\nv = 1.5\nw = [[1, 2], [3]]\n', "x")
    assert doc == {"a": "[[[[x.y.z", "t": {"u": {"v": 1.5, "w": [[1, 2], [3]]}}}
    with pytest.raises(InputError, match=NESTED):
        loads_json("[" * (MAX_DEPTH + 1) + "]" * (MAX_DEPTH + 1), "x")


# ---------------------------------------------------------------- not a regular file
def test_a_fifo_checkpoint_is_refused_unread(tmp_path, fifo):
    path = fifo(tmp_path / ck.CHECKPOINT)
    with pytest.raises(InputError, match="not a regular file") as e:
        ck.read_checkpoint(path)
    assert str(path) in e.value.line


def test_train_resume_refuses_a_fifo_checkpoint(tmp_path, capsys, fifo):
    fifo(tmp_path / "t" / ck.CHECKPOINT)
    code, line = cli(["train", "--resume", tmp_path / "t", "--no-progress"], capsys)
    assert code == 2 and REGULAR in line and ck.CHECKPOINT in line, line


@pytest.mark.parametrize("name", ["w.csv", "w.npz", "w.json", "w.npy", "w.txt"])
def test_run_refuses_fifo_weights(tmp_path, capsys, fifo, name):
    fifo(tmp_path / name)
    code, line = cli(["run", "--weights", tmp_path / name, "--seconds", "0.01",
                      "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2 and REGULAR in line and "--weights" in line, line
    assert not (tmp_path / "o").exists()


def test_run_refuses_a_training_folder_whose_weights_are_a_fifo(tmp_path, capsys, fifo):
    fifo(tmp_path / "t" / "weights.npz")
    code, line = cli(["run", "--weights", tmp_path / "t", "--seconds", "0.01",
                      "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2 and REGULAR in line and "weights.npz" in line, line


def test_api_run_refuses_fifo_weights(tmp_path, fifo):
    import astrocpg as ac

    fifo(tmp_path / "w.csv")
    with pytest.raises(InputError, match="not a regular file"):
        ac.run(seconds=0.01, weights=tmp_path / "w.csv", progress=False)


@pytest.mark.parametrize("option", ["--model astrocyte", "--equations motor_neuron",
                                    "--robot"])
def test_run_refuses_a_fifo_model_equation_or_robot_file(tmp_path, capsys, fifo, option):
    path = fifo(tmp_path / ("robot.xml" if option == "--robot" else "m.toml"))
    flag, _, slot = option.partition(" ")
    value = f"{slot}={path}" if slot else str(path)
    code, line = cli(["run", flag, value, "--seconds", "0.01", "--out", tmp_path / "o",
                      "--no-progress"], capsys)
    assert code == 2 and REGULAR in line and option in line, line


def test_study_refuses_a_fifo_study_file(tmp_path, capsys, fifo):
    fifo(tmp_path / "s.toml")
    code, line = cli(["study", tmp_path / "s.toml", "--out", tmp_path / "o"], capsys)
    assert code == 2 and REGULAR in line and "s.toml" in line, line


def test_api_study_refuses_a_fifo_study_file(tmp_path, fifo):
    import astrocpg as ac

    fifo(tmp_path / "s.toml")
    with pytest.raises(InputError, match="not a regular file"):
        ac.study(tmp_path / "s.toml", out=tmp_path / "o")


def test_a_fifo_worlds_file_is_refused(tmp_path, fifo):
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.studies.commands.evaluate import read_worlds

    fifo(tmp_path / "w.toml")
    with pytest.raises(InputError, match="not a regular file") as e:
        read_worlds(str(tmp_path / "w.toml"), DEFAULT_MODELS)
    assert "worlds" in [f.name for f in e.value.fields]  # the setting, whatever the door


@pytest.mark.parametrize("command", ["plot", "export"])
def test_a_fifo_manifest_is_refused(tmp_path, capsys, fifo, command):
    fifo(tmp_path / "run" / "manifest.json")
    code, line = cli([command, tmp_path / "run", "--out", tmp_path / "o"], capsys)
    assert code == 2 and REGULAR in line and "manifest.json" in line, line


def test_report_refuses_a_fifo_study_index(tmp_path, capsys, fifo):
    fifo(tmp_path / "study" / "study.json")
    code, line = cli(["report", tmp_path / "study", "--out", tmp_path / "r"], capsys)
    assert code == 2 and REGULAR in line and "study.json" in line, line


def test_a_fifo_among_a_folders_files_is_refused_not_hashed(tmp_path, fifo):
    """An inventory that lists a FIFO (0 bytes, as a FIFO's size reads) is checked by hash:
    refused, not waited on."""
    from astrocpg.studies.outputs.folder import file_sha256, verify

    folder = tmp_path / "run"
    fifo(folder / "spikes.npz")
    (folder / "manifest.json").write_text(json.dumps(
        {"astrocpg_command": "run", "inventory": {
            "spikes.npz": {"bytes": 0, "sha256": "0" * 64, "mtime_ns": 0}}}))
    with pytest.raises(InputError, match="not a regular file"):
        verify(folder)
    with pytest.raises(InputError, match="not a regular file"):
        file_sha256(folder / "spikes.npz")


def test_a_device_is_refused_too():
    from astrocpg.support.reading import read_bytes

    with pytest.raises(InputError, match=r"not a regular file \(a character device\)"):
        read_bytes("/dev/zero")  # would otherwise be read without end


# ---------------------------------------------------------------- sizes and headers
GIB = 1 << 30


def sparse(path: Path, size: int = GIB) -> Path:
    """A file of ``size`` bytes that takes no disk and no time to make."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "wb") as f:
        f.truncate(size)
    return path


def npy_claiming(shape: tuple[int, ...], data: bytes = b"\0" * 64) -> bytes:
    """A .npy whose header claims ``shape`` (float64) over a few bytes of data."""
    import io

    b = io.BytesIO()
    np.lib.format.write_array_header_1_0(b, {"descr": "<f8", "fortran_order": False,
                                             "shape": shape})
    return b.getvalue() + data


def npz_claiming(path: Path, name: str, shape: tuple[int, ...]) -> Path:
    import zipfile

    with zipfile.ZipFile(path, "w") as z:
        z.writestr(name + ".npy", npy_claiming(shape))
    return path


@pytest.mark.parametrize("name", ["w.csv", "w.json", "w.npy", "w.npz", "w.txt"])
def test_a_huge_weights_file_is_refused_by_its_size_unread(tmp_path, capsys, name):
    path = sparse(tmp_path / name)
    t0 = time.perf_counter()
    code, line = cli(["run", "--seconds", "0.3", "--weights", path, "--out", tmp_path / "o"],
                     capsys)
    assert code == 2 and str(path) in line and "1,073,741,824 bytes" in line, line
    assert "64 MiB" in line and "unread" in line, line
    assert time.perf_counter() - t0 < 10  # was: read whole (23 s, 7.5 GB for 1 GB)
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("kind", ["npy", "npz"])
def test_an_array_header_claiming_a_huge_shape_is_refused_before_numpy_allocates(
        tmp_path, capsys, kind):
    if kind == "npy":
        path = tmp_path / "w.npy"
        path.write_bytes(npy_claiming((1 << 30, 8, 8)))
    else:
        path = npz_claiming(tmp_path / "w.npz", "weights_mV", (1 << 30, 8, 8))
    code, line = cli(["run", "--seconds", "0.3", "--weights", path, "--out", tmp_path / "o"],
                     capsys)
    assert code == 2 and str(path) in line and "(1073741824, 8, 8)" in line, line


def test_a_training_whose_weights_header_claims_a_huge_shape_is_refused(tmp_path, capsys):
    folder = tmp_path / "t"
    assert main(["train", "--sessions", "1", "--set", "L_max=0.2*second", "--no-progress",
                 "--out", str(folder)]) == 0
    capsys.readouterr()
    npz_claiming(folder / "weights.npz", "final_weights_mV", (1 << 40, 8, 8))
    code, line = cli(["run", "--seconds", "0.3", "--weights", folder, "--out",
                      tmp_path / "o"], capsys)
    assert code == 2 and "weights.npz" in line and "(1099511627776, 8, 8)" in line, line


def test_a_checkpoint_entry_claiming_a_huge_shape_is_refused(tmp_path, capsys):
    """Before: NumPy allocated what the entry's header claimed ("out of memory")."""
    import zipfile

    path = checkpoint_with(tmp_path / "t" / ck.CHECKPOINT, state='{"x": {"$array": "a0"}}')
    with zipfile.ZipFile(path, "a") as z:
        z.writestr("a0.npy", npy_claiming((1 << 40,)))
    with pytest.raises(InputError, match=r"shape \(1099511627776,\)") as e:
        ck.read_checkpoint(path)
    assert str(path) in e.value.line
    code, line = cli(["train", "--resume", tmp_path / "t", "--no-progress"], capsys)
    assert code == 2 and ck.CHECKPOINT in line and "1099511627776" in line, line


@pytest.mark.parametrize("option", ["study", "--model", "--equations", "--population"])
def test_a_huge_text_file_is_refused_by_its_size_unread(tmp_path, capsys, option):
    path = sparse(tmp_path / ("x.toml" if option != "--equations" else "x.txt"))
    argv = {"study": ["study", path, "--out", tmp_path / "s"],
            "--model": ["run", "--seconds", "0.3", "--model", f"motor_neuron={path}", "--out",
                        tmp_path / "o"],
            "--equations": ["run", "--seconds", "0.3", "--equations",
                            f"motor_neuron={path}", "--out", tmp_path / "o"],
            "--population": ["run", "--seconds", "0.3", "--population", path, "--out",
                             tmp_path / "o"]}[option]
    code, line = cli(argv, capsys)
    assert code == 2 and str(path) in line and "16 MiB" in line, line


def test_a_plan_source_is_inflated_only_up_to_its_bound(tmp_path, capsys, monkeypatch):
    """A small .gz that inflates to more than the bound is refused while it inflates, naming
    the file and the bound (before: 3 GB inflated, "out of memory" naming no file)."""
    import gzip

    from astrocpg.studies.parameter_studies import measured

    monkeypatch.setattr(measured, "MAX_PLAN_BYTES", 1 << 20)
    path = tmp_path / "results.csv.gz"
    with gzip.open(path, "wb") as f:
        f.write(b"run_id,seed,length_s\n" + b"r,1,1.0\n" * (1 << 18))  # 2 MiB inflated
    assert path.stat().st_size < 100_000
    code, line = cli(["study", "quick", "--plan-from", path, "--out", tmp_path / "s"], capsys)
    assert code == 2 and str(path) in line and "1 MiB" in line and "inflated" in line, line
    assert not (tmp_path / "s").exists()
