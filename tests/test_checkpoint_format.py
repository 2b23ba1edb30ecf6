"""A checkpoint is data, never code, and a resume honours or refuses every
option given again, never ignores one (class 8).

* the codec (:mod:`astrocpg.studies.outputs.checkpoint`) stores every kind of value a training's
  state is made of (Brian2's stored state with its random state, tuples, dicts with any keys,
  NumPy scalars, object arrays, bytes) as arrays and JSON and reads it back exactly, and
  refuses to store anything else (no pickle fall-back);
* a malicious file planted as a training's or a study run's checkpoint (one that runs a shell
  command if it is unpickled: in astrocpg's old pickled format with a valid sha256, as a bare
  pickle under the new name, as an .npz with a pickled object array, with a ``$np`` entry that
  names the object dtype, or with a Python expression as a value) runs nothing: the command
  exits 2 with one line naming the checkpoint and leaves the folder as it was;
* a damaged (truncated, a byte flipped) or tampered (a whole archive of another shape) checkpoint
  is refused the same way;
* resume compares values, not spellings, and names each option that differs.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from astrocpg.studies.cli import main
from astrocpg.studies.outputs import checkpoint as ck
from tiny_study import tiny_study

SHORT = ["--set", "L_max=0.2*second", "--set", "L_non_alive=0.1*second"]
OLD_MAGIC = b"ASTROCPG-CHECKPOINT-1\n"  # astrocpg's pickled checkpoint.pkl, before format 2


class _Shell:
    """Unpickling this runs ``touch <marker>``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {shlex.quote(str(self.marker))}",))


def evil_pickle(marker: Path) -> bytes:
    return pickle.dumps({"fingerprint": "x", "settings": _Shell(marker)})


def old_format_file(marker: Path) -> bytes:
    """What astrocpg before format 2 read: MAGIC + sha256(body) + body (the hash unkeyed)."""
    body = evil_pickle(marker)
    return OLD_MAGIC + hashlib.sha256(body).hexdigest().encode() + b"\n" + body


def npz_with_pickled_array(marker: Path, like: Path) -> bytes:
    """A real checkpoint's entries plus one object array (np.save pickles it into the .npy)."""
    import io
    with np.load(like) as z:
        arrays = {k: z[k] for k in z.files}
    obj = np.empty(1, dtype=object)
    obj[0] = _Shell(marker)
    arrays["a0"] = obj
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def npz_with_object_dtype_entry(marker: Path, like: Path) -> bytes:
    """A whole archive whose state tree asks for a NumPy scalar of the object dtype with a
    Python expression as its value (an eval or a pickle would run it)."""
    import io
    with np.load(like) as z:
        arrays = {k: z[k] for k in z.files}
    state = json.loads(arrays["state"].tobytes())
    state["bridge"]["step_count"] = {"$np": "O", "v": f"__import__('os').system('touch {marker}')"}
    arrays["state"] = np.frombuffer(json.dumps(state).encode(), dtype=np.uint8)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    return buf.getvalue()


def tree(folder: Path) -> dict[str, str]:
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def one_line(capsys) -> str:
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("astrocpg:"), err
    assert "Traceback" not in err
    return lines[0]


# ---------------------------------------------------------------- the codec
def test_every_kind_of_state_round_trips_exactly(tmp_path):
    rng = np.random.RandomState(7)
    rng.rand(3)
    obj = np.empty(3, dtype=object)
    obj[:] = [np.arange(3), (1, "x"), None]
    state = {
        "none": None, "flags": [True, False], "int": 12, "huge": 2**70, "neg": -3,
        "float": 0.1 + 0.2, "nan": float("nan"), "inf": float("inf"), "minf": -float("inf"),
        "text": "caf\xe9 \u2013 \U0001F40E", "tuple": (1, (2.5, "a")), "list": [[], [1]],
        "int_keys": {0: "a", 7: (1,)}, "$dollar": {"$array": "not a tag"},
        "np": [np.float64(0.1), np.float32(1.5), np.int64(-4), np.uint32(2**32 - 1),
               np.bool_(True), np.int8(-1), np.float64("nan")],
        "small": np.arange(5, dtype=np.int32), "big": rng.rand(200, 3),
        "f32": np.linspace(0, 1, 100, dtype=np.float32), "empty": np.zeros((0, 8, 8)),
        "bools": np.array([[True, False]] * 50), "strings": np.array(["motor", "astro"]),
        "objects": obj, "bytes": b"\x00\x01\xff", "random": rng.get_state(),
        "zero_d": np.array(3.25), "complex": np.complex128(1 + 2j),
    }
    path = tmp_path / "c.npz"
    ck.write_checkpoint(path, {"fingerprint": "f"}, state)
    meta, back = ck.read_checkpoint(path)
    assert meta["fingerprint"] == "f" and meta["version"] == ck.VERSION

    def same(a, b, where="state"):
        assert type(a) is type(b), (where, type(a), type(b))
        if isinstance(a, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape, where
            if a.dtype.hasobject:
                for i, (x, y) in enumerate(zip(a.ravel(), b.ravel())):
                    same(x, y, f"{where}[{i}]")
            else:
                assert np.array_equal(a, b, equal_nan=a.dtype.kind in "fc"), where
        elif isinstance(a, np.generic):
            assert a.dtype == b.dtype and (a == b or (a != a and b != b)), where
        elif isinstance(a, dict):
            assert list(a) == list(b), where
            for k in a:
                same(a[k], b[k], f"{where}[{k!r}]")
        elif isinstance(a, (list, tuple)):
            assert len(a) == len(b), where
            for i, (x, y) in enumerate(zip(a, b)):
                same(x, y, f"{where}[{i}]")
        elif isinstance(a, float) and a != a:
            assert b != b, where
        else:
            assert a == b, where

    same(state, back)
    # what numpy's legacy generator does next is the same
    restored = np.random.RandomState()
    restored.set_state(back["random"])
    assert np.array_equal(restored.rand(5), rng.rand(5))
    # a file of plain arrays: numpy reads every entry with allow_pickle=False
    with np.load(path, allow_pickle=False) as z:
        assert all(z[k].dtype != object for k in z.files)


@pytest.mark.parametrize("value", [object(), {1, 2}, lambda: 0, Path("/x"),
                                   np.array([object()], dtype=object)])
def test_the_codec_refuses_what_is_not_data(tmp_path, value):
    with pytest.raises(TypeError):
        ck.write_checkpoint(tmp_path / "c.npz", {}, {"x": value})
    assert not (tmp_path / "c.npz").exists()


def test_a_brian2_quantity_is_not_silently_stripped_of_its_unit(tmp_path):
    from brian2 import ms
    with pytest.raises(TypeError):
        ck.write_checkpoint(tmp_path / "c.npz", {}, {"x": [1, 2] * ms})


def test_no_code_executing_load_in_the_package():
    """No pickle, no allow_pickle=True, no eval/exec of file contents anywhere in the package
    (tests aside: they build the malicious files)."""
    root = Path(ck.__file__).resolve().parents[2]
    offenders = []
    for p in root.rglob("*.py"):
        rel = p.relative_to(root).as_posix()
        # tests build the malicious files; hidden folders (a venv made in the checkout, as CI
        # makes .venv) and docs/_build hold other packages' code
        if rel.startswith(("tests/", "docs/_build/", "build/")) or any(
                part.startswith(".") for part in Path(rel).parts):
            continue
        text = p.read_text(encoding="utf-8")
        for word in ("import pickle", "pickle.load", "allow_pickle=True", "cPickle", "dill.",
                     "joblib.load", "marshal.load", "shelve.", "torch.load", "yaml.load",
                     "eval(", "exec("):
            if word in text:
                offenders.append((rel, word))
        if "np.load(" in text and "allow_pickle=True" not in text:
            # numpy's default refuses pickles too; the package says so where it reads folders
            if not rel.startswith("benchmarks/"):
                loads = text.count("np.load(")
                safe = text.count("allow_pickle=False")
                if safe < loads:
                    offenders.append((rel, f"np.load without allow_pickle=False ({loads - safe})"))
    assert not offenders, offenders


def test_the_payload_is_live(tmp_path):
    """The malicious bytes the tests plant do run code when unpickled (else they prove nothing)."""
    marker = tmp_path / "ran"
    subprocess.run([sys.executable, "-c", "import pickle,sys; pickle.loads(sys.stdin.buffer.read())"],
                   input=evil_pickle(marker), check=False, capture_output=True, timeout=60)
    assert marker.exists()


# ---------------------------------------------------------------- a training folder
@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("ckpt") / "train"
    assert main(["train", "--sessions", "2", "--seed", "3", *SHORT, "--out", str(out),
                 "--no-progress"]) == 0
    assert (out / ck.CHECKPOINT).exists() and not (out / ck.LEGACY_CHECKPOINT).exists()
    return out


def _plant(folder: Path, how: str, marker: Path) -> Path:
    """Plant a malicious checkpoint in ``folder``; returns the path the message must name."""
    new, old = folder / ck.CHECKPOINT, folder / ck.LEGACY_CHECKPOINT
    if how == "old-format":  # an old version's folder: only checkpoint.pkl
        new.unlink()
        old.write_bytes(old_format_file(marker))
        return old
    if how == "old-format-beside-new":
        old.write_bytes(old_format_file(marker))
        return old
    if how == "pickle-named-npz":
        new.write_bytes(evil_pickle(marker))
        return new
    if how == "old-format-named-npz":
        new.write_bytes(old_format_file(marker))
        return new
    if how == "npz-pickled-array":
        new.write_bytes(npz_with_pickled_array(marker, new))
        return new
    if how == "npz-object-dtype":
        new.write_bytes(npz_with_object_dtype_entry(marker, new))
        return new
    raise AssertionError(how)


PLANTS = ["old-format", "old-format-beside-new", "pickle-named-npz", "old-format-named-npz",
          "npz-pickled-array", "npz-object-dtype"]


@pytest.mark.parametrize("how", PLANTS)
def test_a_malicious_training_checkpoint_runs_nothing(tmp_path, trained, capsys, how):
    folder = tmp_path / "r"
    shutil.copytree(trained, folder)
    marker = tmp_path / "marker"
    named = _plant(folder, how, marker)
    before = tree(folder)
    code = main(["train", "--resume", str(folder), "--no-progress"])
    line = one_line(capsys)
    assert not marker.exists(), "the checkpoint ran code"
    assert code == 2, line
    assert str(named) in line, line
    if how.startswith("old-format") and named.name == ck.LEGACY_CHECKPOINT:
        assert "old format" in line and "never loaded" in line, line
    assert tree(folder) == before, "the folder changed"


def test_train_out_on_an_old_format_folder_is_refused_or_replaced(tmp_path, trained, capsys):
    folder = tmp_path / "r"
    shutil.copytree(trained, folder)
    marker = tmp_path / "marker"
    _plant(folder, "old-format", marker)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest.pop("inventory")  # as an old astrocpg wrote it (no inventory): the files it
    manifest["files"][ck.LEGACY_CHECKPOINT] = "the old checkpoint"  # names are its own
    (folder / "manifest.json").write_text(json.dumps(manifest))
    before = tree(folder)
    assert main(["train", "--sessions", "1", *SHORT, "--out", str(folder), "--no-progress"]) == 2
    line = one_line(capsys)
    assert str(folder / ck.LEGACY_CHECKPOINT) in line and "old format" in line, line
    assert tree(folder) == before
    assert main(["train", "--sessions", "1", *SHORT, "--out", str(folder), "--overwrite",
                 "--no-progress"]) == 0
    assert not (folder / ck.LEGACY_CHECKPOINT).exists() and (folder / ck.CHECKPOINT).exists()
    assert not marker.exists()


def _rewrite(path: Path, edit) -> None:
    """Read a checkpoint, let ``edit(meta, state)`` change it, write it back whole (a valid
    archive: only its content is off)."""
    meta, state = ck.read_checkpoint(path)
    for k in ("format", "version"):
        meta.pop(k)
    edit(meta, state)
    ck.write_checkpoint(path, meta, state)


def _unfinished(meta, state) -> None:
    state["training"]["sessions_done"] = np.array([1])


def _short_mujoco(meta, state) -> None:
    _unfinished(meta, state)
    state["mujoco"][0] = state["mujoco"][0][:5]


def _missing_object(meta, state) -> None:
    _unfinished(meta, state)
    del state["brian"]["motor"]


def _wrong_memory(meta, state) -> None:
    _unfinished(meta, state)
    state["memory"]["lengths"] = []


def _other_version(meta, state) -> None:
    pass  # written with a version bumped below


DAMAGE = {
    "truncated": (lambda p: p.write_bytes(p.read_bytes()[: p.stat().st_size // 2]), "corrupt"),
    "byte-flipped": (lambda p: p.write_bytes(_flip(p.read_bytes())), "corrupt"),
    "empty": (lambda p: p.write_bytes(b""), "not an astrocpg checkpoint"),
    "a-folder": (lambda p: (p.unlink(), p.mkdir()), "folder"),
    "foreign-npz": (lambda p: np.savez(open(p, "wb"), x=np.arange(3)), "not an astrocpg"),
    "mujoco-state-short": (lambda p: _rewrite(p, _short_mujoco), "does not fit"),
    "brian-object-missing": (lambda p: _rewrite(p, _missing_object), "does not fit"),
    "memory-of-other-shape": (lambda p: _rewrite(p, _wrong_memory), "does not fit"),
    "unknown-tag": (lambda p: _retag(p), "corrupt"),
    "other-version": (lambda p: _bump_version(p), "format version"),
    "settings-changed": (lambda p: _rewrite(p, lambda m, s: m["settings"].update(seed=9)),
                         "not consistent"),
}


def _relist(folder: Path) -> None:
    """The manifest's inventory lists the checkpoint as it now is (size, sha256, mtime)."""
    manifest = json.loads((folder / "manifest.json").read_text())
    path = folder / ck.CHECKPOINT
    manifest["inventory"][ck.CHECKPOINT] = {
        "bytes": path.stat().st_size, "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
        "mtime_ns": path.stat().st_mtime_ns}
    (folder / "manifest.json").write_text(json.dumps(manifest))


@pytest.mark.parametrize("how", ["mujoco-state-short", "brian-object-missing"])
def test_a_checkpoint_rewritten_whole_but_not_the_one_its_training_listed_is_refused(
        tmp_path, trained, capsys, how):
    """A checkpoint that is a whole archive of this format, rewritten after its training
    stopped: its manifest lists another sha256, so it is not that training's state."""
    folder = tmp_path / "r"
    shutil.copytree(trained, folder)
    DAMAGE[how][0](folder / ck.CHECKPOINT)
    before = tree(folder)
    code = main(["train", "--resume", str(folder), "--no-progress"])
    line = one_line(capsys)
    assert code == 2, line
    assert ck.CHECKPOINT in line and "has changed since" in line, line
    assert tree(folder) == before


def _flip(raw: bytes) -> bytes:
    b = bytearray(raw)
    b[len(b) // 3] ^= 0xFF  # inside an array's data: the archive's CRC-32 fails
    return bytes(b)


def _retag(p: Path) -> None:
    import io
    with np.load(p) as z:
        arrays = {k: z[k] for k in z.files}
    state = json.loads(arrays["state"].tobytes())
    state["bridge"]["step_count"] = {"$call": ["os.system", "true"]}
    arrays["state"] = np.frombuffer(json.dumps(state).encode(), dtype=np.uint8)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    p.write_bytes(buf.getvalue())


def _bump_version(p: Path) -> None:
    import io
    with np.load(p) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(arrays["meta"].tobytes())
    meta["version"] = 99
    arrays["meta"] = np.frombuffer(json.dumps(meta).encode(), dtype=np.uint8)
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    p.write_bytes(buf.getvalue())


@pytest.mark.parametrize("how", sorted(DAMAGE))
def test_a_damaged_or_tampered_checkpoint_is_refused_in_one_line(tmp_path, trained, capsys, how):
    folder = tmp_path / "r"
    shutil.copytree(trained, folder)
    damage, words = DAMAGE[how]
    damage(folder / ck.CHECKPOINT)
    if words == "does not fit":  # a tamper that listed its checkpoint in the manifest too:
        _relist(folder)          # the checks of the state's content are all that is left
    before = tree(folder)
    code = main(["train", "--resume", str(folder), "--no-progress"])
    line = one_line(capsys)
    assert code == 2, line
    assert ck.CHECKPOINT in line and words in line, line
    assert tree(folder) == before


# ---------------------------------------------------------------- a study's run folder
STUDY = tiny_study("evil", sessions=2)


@pytest.fixture(scope="module")
def study(tmp_path_factory) -> tuple[Path, Path]:
    base = tmp_path_factory.mktemp("study")
    file = base / "evil.toml"
    file.write_text(STUDY)
    out = base / "S"
    assert main(["study", str(file), "--out", str(out), "--workers", "1", "--no-progress"]) == 0
    return file, out


def _pending_copy(tmp_path: Path, out: Path) -> tuple[Path, Path]:
    """A copy of the study whose one run is not finished (a rerun resumes it)."""
    copy = tmp_path / "S"
    shutil.copytree(out, copy)
    (run,) = [p for p in (copy / "runs").iterdir() if p.is_dir()]
    status = json.loads((run / "status.json").read_text())
    status["state"] = "stopped"
    (run / "status.json").write_text(json.dumps(status))
    return copy, run


@pytest.mark.parametrize("how", PLANTS)
def test_a_malicious_checkpoint_in_a_study_run_runs_nothing(tmp_path, study, capsys, how):
    file, out = study
    copy, run = _pending_copy(tmp_path, out)
    marker = tmp_path / "marker"
    named = _plant(run, how, marker)
    before = tree(copy)
    code = main(["study", str(file), "--out", str(copy), "--workers", "1", "--no-progress"])
    line = one_line(capsys)
    assert not marker.exists(), "the checkpoint ran code"
    assert code == 2, line
    assert str(named) in line, line
    assert tree(copy) == before, "the study folder changed"


@pytest.mark.parametrize("how", ["old-format", "pickle-named-npz", "npz-pickled-array"])
def test_a_worker_reading_a_malicious_checkpoint_runs_nothing(tmp_path, study, how):
    """A file planted after the study's own check (on a shared file system, while it runs):
    the worker reads it as data, and the run fails with the reason."""
    from astrocpg.studies.parameter_studies.execute import execute_run
    from astrocpg.studies.parameter_studies.study import load_study

    file, out = study
    _, run = _pending_copy(tmp_path, out)
    marker = tmp_path / "marker"
    named = _plant(run, how, marker)
    (spec,) = load_study(file).runs
    status = execute_run(spec, str(run))
    assert not marker.exists(), "the checkpoint ran code"
    assert status["state"] == "failed", status
    assert status["error"].startswith(("InputError", "CheckpointCorrupt")), status["error"]
    assert named.name in status["error"], status["error"]


def test_the_study_refuses_a_checkpoint_of_other_settings(tmp_path, study, trained, capsys):
    file, out = study
    copy, run = _pending_copy(tmp_path, out)
    shutil.copy(trained / ck.CHECKPOINT, run / ck.CHECKPOINT)  # a whole one, of another run
    before = tree(copy)
    assert main(["study", str(file), "--out", str(copy), "--workers", "1", "--no-progress"]) == 2
    line = one_line(capsys)
    assert str(run / ck.CHECKPOINT) in line and "other settings" in line, line
    assert tree(copy) == before


# ---------------------------------------------------------------- resume options (class 8)
@pytest.fixture(scope="module")
def recorded(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("rec") / "train"
    assert main(["train", "--sessions", "1", "--seed", "3", *SHORT, "--record-every", "1",
                 "--record-stride", "10", "--spikes", "motor", "--traces", "motor_Ca",
                 "--out", str(out), "--no-progress"]) == 0
    return out


@pytest.mark.parametrize("argv, culprit, values", [
    (["--record-stride", "5"], "--record-stride", ("10", "5")),
    (["--record-every", "2"], "--record-every", ("1", "2")),
    (["--spikes", "motor,interneuron"], "--spikes", ("motor", "motor,interneuron")),
    (["--traces", "astrocyte_Ca"], "--traces", ("motor_Ca", "astrocyte_Ca")),
    (["--set", "L_max=0.3*second"], "--set L_max", ("200", "300")),
    # more sessions extend a training (test_train_extend.py); none is no number of sessions
    (["--sessions", "0"], "--sessions", ("0",)),
    (["--trials", "2"], "--trials", ("1", "2")),
    (["--seed", "4"], "--seed", ("3", "4")),
    (["--no-astrocytes"], "--no-astrocytes", ("on", "off")),
    (["--overwrite"], "--overwrite", ()),
], ids=lambda x: x if isinstance(x, str) else None)
def test_an_option_that_differs_on_resume_is_refused_naming_it(recorded, capsys, argv, culprit,
                                                               values):
    before = tree(recorded)
    code = main(["train", "--resume", str(recorded), *argv, "--no-progress"])
    line = one_line(capsys)
    assert code == 2, line
    assert f"astrocpg: {culprit}:" in line or f"astrocpg: error: {culprit}:" in line, line
    for v in values:
        assert v in line, (v, line)
    assert tree(recorded) == before


@pytest.mark.parametrize("argv", [
    ["--record-stride", "10"], ["--record-every", "1"], ["--spikes", "motor"],
    ["--traces", "motor_Ca"], ["--set", "L_max=200*ms"], ["--set", "L_max=0.2*second"],
    ["--set", "L_non_alive=100*msecond"], ["--sessions", "1"], ["--seed", "3"],
])
def test_an_option_given_with_the_recorded_value_is_accepted(recorded, capsys, argv):
    """The same value, spelled as given or otherwise: the options pass and the resume reaches
    its next check (the training is already finished)."""
    code = main(["train", "--resume", str(recorded), *argv, "--no-progress"])
    line = one_line(capsys)
    assert code == 2 and "already finished" in line, line


def test_recording_options_on_a_run_that_records_nothing(trained, capsys):
    for option, value in (("--record-stride", "5"), ("--spikes", "motor"),
                          ("--traces", "motor_Ca"), ("--record-every", "3")):
        assert main(["train", "--resume", str(trained), option, value, "--no-progress"]) == 2
        line = one_line(capsys)
        assert f"{option}:" in line and "records no sessions" in line, line


def test_record_stride_without_record_every_is_refused(tmp_path, capsys):
    assert main(["train", "--record-stride", "5", *SHORT, "--out", str(tmp_path / "o"),
                 "--no-progress"]) == 2
    assert "--record-stride" in one_line(capsys)
    assert not (tmp_path / "o").exists()


MODELS = Path(__file__).resolve().parents[1] / "models" / "variants"
AUTHORS_DELAYS = MODELS / "interlimb_authors_delays.toml"


@pytest.fixture(scope="module")
def with_model_file(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("model") / "train"
    assert main(["train", "--sessions", "1", "--seed", "3", *SHORT, "--model",
                 f"interlimb_synapse={AUTHORS_DELAYS}", "--out", str(out), "--no-progress"]) == 0
    return out


def test_a_changed_model_file_is_named_as_such(tmp_path, with_model_file, trained, capsys):
    from astrocpg.models import DEFAULT_MODELS
    from astrocpg.models.files import model_to_toml

    builtin = tmp_path / "builtin.toml"
    builtin.write_text(model_to_toml(DEFAULT_MODELS.interlimb_synapse))
    # the run used the authors' delays: a file of the built-in model is another model
    assert main(["train", "--resume", str(with_model_file), "--model",
                 f"interlimb_synapse={builtin}", "--no-progress"]) == 2
    line = one_line(capsys)
    assert "--model interlimb_synapse:" in line and "another interlimb_synapse model file" in line
    assert "other model settings" not in line
    # the run used the built-in model: a model file of other delays is refused as such
    assert main(["train", "--resume", str(trained), "--model",
                 f"interlimb_synapse={AUTHORS_DELAYS}", "--no-progress"]) == 2
    line = one_line(capsys)
    assert "--model interlimb_synapse:" in line and "built-in" in line, line
    # the same model, spelled otherwise (a comment added): accepted, so the next check speaks
    same = tmp_path / "same.toml"
    same.write_text("# my copy\n" + AUTHORS_DELAYS.read_text())
    assert main(["train", "--resume", str(with_model_file), "--model",
                 f"interlimb_synapse={same}", "--no-progress"]) == 2
    assert "already finished" in one_line(capsys)
    # a file of the built-in model for a run that used it: the same model
    assert main(["train", "--resume", str(trained), "--model",
                 f"interlimb_synapse={builtin}", "--no-progress"]) == 2
    assert "already finished" in one_line(capsys)


def test_changed_equations_are_named(tmp_path, trained, capsys):
    from astrocpg.models.motor_neuron import EQUATIONS
    eq = tmp_path / "eq.txt"
    eq.write_text(EQUATIONS.replace("/tau_motor", "/(2*tau_motor)"))
    assert main(["train", "--resume", str(trained), "--equations", f"motor_neuron={eq}",
                 "--no-progress"]) == 2
    line = one_line(capsys)
    assert "--equations motor_neuron:" in line and "built-in" in line, line
    eq.write_text(EQUATIONS)  # the equations it was trained with: accepted
    assert main(["train", "--resume", str(trained), "--equations", f"motor_neuron={eq}",
                 "--no-progress"]) == 2
    assert "already finished" in one_line(capsys)


def test_two_identical_trainings_write_the_same_bytes(tmp_path):
    """The same training twice (in this process and another, seconds apart): every file the
    same bytes -- the checkpoint's objects in one order, each .npz member with one timestamp --
    but the manifests, which say when and how long (their inventories' hashes agree)."""
    from astrocpg.studies.cli import main

    argv = ["train", "--sessions", "2", "--set", "L_max=0.3*second", "--record-every", "1",
            "--no-progress"]
    # a network built before in this process: Brian2 then names the clocks otherwise
    assert main(["run", "--seconds", "0.1", "--no-progress", "--out", str(tmp_path / "r")]) == 0
    assert main([*argv, "--out", str(tmp_path / "a")]) == 0
    done = subprocess.run([sys.executable, "-m", "astrocpg", *argv, "--out",
                           str(tmp_path / "b")], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr

    def files(root):
        return {p.relative_to(root).as_posix(): p.read_bytes() for p in sorted(root.rglob("*"))
                if p.is_file() and p.name != "manifest.json"}
    a, b = files(tmp_path / "a"), files(tmp_path / "b")
    assert "checkpoint.npz" in a and any(k.startswith("recordings/") for k in a)
    assert set(a) == set(b)
    assert [k for k in a if a[k] != b[k]] == []
    sha = [{k: v["sha256"] for k, v in json.loads((tmp_path / d / "manifest.json").read_text())
            ["inventory"].items() if not k.endswith("manifest.json")} for d in "ab"]
    assert sha[0] == sha[1]


def test_a_checkpoint_holds_no_address_of_brian2s_random_buffers(tmp_path, monkeypatch):
    """Brian2's random state holds the addresses of its Cython draw buffers: where a buffer lies
    in this process's memory (it differs after a Cython network drew ``randn()``). A
    checkpoint stores 0 there, and a resume keeps this process's addresses instead of writing
    an address from the file into Brian2's device (in another process it would point into
    memory never allocated there). Fails when the checkpoint stores Brian2's state as it is."""
    from brian2.devices.device import get_device

    from astrocpg.studies.commands import train_state

    device = get_device()
    # the addresses a Cython network that drew leaves behind (new arrays: compiled code that
    # holds the old ones is untouched)
    for name, fake in (("rand_buffer", 0x5A5A5A50), ("randn_buffer", 0x6B6B6B60)):
        monkeypatch.setattr(device, name, np.array([fake], dtype=np.intp))
    argv = ["train", "--sessions", "1", *SHORT, "--workers", "1", "--no-progress"]
    assert main([*argv, "--out", str(tmp_path / "a")]) == 0
    state = train_state.read_checkpoint(tmp_path / "a" / "checkpoint.npz")["brian"]
    random = state["_random_generator_state"]
    assert set(train_state.RANDOM_ADDRESSES) <= set(random)
    assert all(int(np.asarray(random[k]).ravel()[0]) == 0 for k in train_state.RANDOM_ADDRESSES)
    # restored: the device keeps its own addresses (not the file's 0)
    local = train_state.local_random_state(state)["_random_generator_state"]
    assert int(local["rand_buffer"][0]) == 0x5A5A5A50
    assert int(local["randn_buffer"][0]) == 0x6B6B6B60
    assert main(["train", "--resume", str(tmp_path / "a"), "--sessions", "2",
                 "--no-progress"]) == 0
    assert int(device.randn_buffer[0]) == 0x6B6B6B60
