"""Training: the learning rule's structure, exact resume after SIGKILL, and bad input."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from astrocpg.studies.cli import main

SHORT = ["--set", "L_max=0.4*second", "--set", "L_non_alive=0.2*second", "--no-progress"]


def _train(out: Path, *args: str) -> int:
    return main(["train", "--out", str(out), *SHORT, *args])


def _weights(out: Path) -> np.ndarray:
    with np.load(out / "weights.npz") as z:
        return z["final_weights_mV"]


@pytest.mark.slow
def test_adenosine_alone_only_depresses(tmp_path):
    """With the reward term off (eta = 0) only adenosine acts: every learned weight is <= 0, and
    some are < 0 (the astrocytes release adenosine within a few sessions)."""
    assert _train(tmp_path / "a", "--sessions", "6", "--trials", "1", "--seed", "2",
                  "--set", "eta=0*mV", "--set", "eta_ADO=1e-3*mV") == 0
    w = _weights(tmp_path / "a")
    assert np.all(w <= 0) and np.any(w < 0)


@pytest.mark.slow
def test_no_astrocytes_and_no_reward_learns_nothing(tmp_path):
    assert _train(tmp_path / "b", "--sessions", "3", "--seed", "2", "--no-astrocytes",
                  "--set", "eta=0*mV", "--set", "eta_ADO=1e-3*mV") == 0
    assert np.all(_weights(tmp_path / "b") == 0)
    manifest = json.loads((tmp_path / "b" / "manifest.json").read_text())
    value = manifest["models"]["interlimb_synapse"]["parameters"]["astrocyte_regulation"]["value"]
    assert float(value) == 0.0


@pytest.mark.slow
def test_sessions_csv_rows(tmp_path):
    assert _train(tmp_path / "c", "--sessions", "3", "--trials", "2", "--seed", "1") == 0
    lines = (tmp_path / "c" / "sessions.csv").read_text().splitlines()
    header = lines[0].split(",")
    assert header[:4] == ["trial", "session", "length_s", "final_x_m"]
    assert len(lines) == 1 + 3 * 2
    rows = [dict(zip(header, line.split(","))) for line in lines[1:]]
    assert all(0 < float(r["length_s"]) <= 0.4 + 1e-9 for r in rows)
    assert sorted((int(r["trial"]), int(r["session"])) for r in rows) == \
        [(b, s) for b in range(2) for s in (1, 2, 3)]
    with np.load(tmp_path / "c" / "weights.npz") as z:
        assert z["weights_mV"].shape == (2, 3, 8, 8)


def _cli(*args: str, **kw) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "astrocpg.studies.cli", *args],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, **kw)


AUTHORS_DELAYS = Path(__file__).resolve().parents[1] / "models" / "variants" \
    / "interlimb_authors_delays.toml"


@pytest.mark.slow
@pytest.mark.parametrize("delays", [[], ["--model", f"interlimb_synapse={AUTHORS_DELAYS}"]],
                         ids=["built-in delays", "authors' delays (limbs in stages)"])
def test_resume_after_sigkill_is_exact(tmp_path, delays):
    # with recorded sessions: their state is part of the checkpoint too
    args = ["train", "--sessions", "20", "--trials", "2", "--seed", "4", "--record-every", "3",
            "--record-stride", "2", *SHORT, *delays]
    whole = tmp_path / "whole"
    p = _cli(*args, "--out", str(whole))
    assert p.wait(timeout=600) == 0, p.stderr.read()

    killed = tmp_path / "killed"
    p = _cli(*args, "--out", str(killed))
    ckpt = killed / "checkpoint.npz"
    deadline = time.time() + 300
    while not ckpt.exists() and time.time() < deadline:
        time.sleep(0.05)
    time.sleep(0.4)  # somewhere inside a later session
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    assert ckpt.exists()
    done_before = (killed / "sessions.csv").read_text().count("\n") - 1
    assert done_before < 40, "the kill came too late to test anything"
    r = _cli("train", "--resume", str(killed), "--no-progress")
    assert r.wait(timeout=600) == 0, r.stderr.read()
    assert (killed / "sessions.csv").read_text() == (whole / "sessions.csv").read_text()
    with np.load(whole / "weights.npz") as a, np.load(killed / "weights.npz") as b:
        assert np.array_equal(a["weights_mV"], b["weights_mV"], equal_nan=True)
        assert np.array_equal(a["final_weights_mV"], b["final_weights_mV"])
    recorded = sorted(p.relative_to(whole) for p in (whole / "recordings").rglob("*.npz"))
    # sessions 1, 4, 7, ..., 19 and the last (20) of each trial; spikes, traces, robot each
    assert len(recorded) == 2 * 8 * 3
    assert recorded == sorted(p.relative_to(killed) for p in (killed / "recordings").rglob("*.npz"))
    for rel in recorded:
        with np.load(whole / rel) as a, np.load(killed / rel) as b:
            assert a.files == b.files
            for k in a.files:
                assert np.array_equal(a[k], b[k]), (rel, k)


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    out = tmp_path_factory.mktemp("done") / "run"
    assert main(["train", "--out", str(out), *SHORT, "--sessions", "2", "--seed", "3"]) == 0
    return out


def _snapshot(folder: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in folder.iterdir()}


def _fails(capsys, argv, *words) -> str:
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1, err
    for w in words:
        assert w in err, (w, err)
    return err


def test_bad_set_name_and_unit(capsys, tmp_path):
    _fails(capsys, ["train", "--out", str(tmp_path / "x"), "--set", "eta_ADOO=1e-5*mV"],
           "eta_ADOO")
    _fails(capsys, ["train", "--out", str(tmp_path / "x"), "--set", "eta_ADO=2.3e-5*second"],
           "eta_ADO", "units")
    assert not (tmp_path / "x").exists()


def test_corrupt_and_foreign_checkpoints(capsys, tmp_path, finished):
    for name, mutate in (("corrupt", lambda b: b[:-10] + b"0123456789"),
                         ("foreign", lambda b: b"not a checkpoint" + b)):
        folder = tmp_path / name
        shutil.copytree(finished, folder)
        ck = folder / "checkpoint.npz"
        ck.write_bytes(mutate(ck.read_bytes()))
        before = _snapshot(folder)
        _fails(capsys, ["train", "--resume", str(folder)], "checkpoint" if name == "foreign"
               else "corrupt")
        assert _snapshot(folder) == before, "nothing may be overwritten"


def test_resume_with_other_parameters(capsys, tmp_path, finished):
    folder = tmp_path / "other"
    shutil.copytree(finished, folder)
    before = _snapshot(folder)
    _fails(capsys, ["train", "--resume", str(folder), "--seed", "9"], "seed")
    _fails(capsys, ["train", "--resume", str(folder), "--set", "eta=1e-9*mV"], "--set eta",
           "not 0.001*nvolt")
    # trained under numpy: refused under Cython, before anything is built or compiled
    _fails(capsys, ["train", "--resume", str(folder), "--codegen", "cython"], "--codegen",
           "started with Brian2's numpy target")
    assert os.environ.get("ASTROCPG_CODEGEN") is None, "--codegen leaked out of the command"
    assert _snapshot(folder) == before


def test_out_that_holds_a_run_is_not_overwritten(capsys, finished):
    before = _snapshot(finished)
    _fails(capsys, ["train", "--out", str(finished), "--sessions", "2"], "--resume")
    assert _snapshot(finished) == before


def test_checkpoints_are_spaced_by_their_cost_and_the_files_stay_the_same(tmp_path, monkeypatch):
    """Writes are spaced (CHECKPOINT_SPACING x the last write's duration): with slow writes
    (0.1 s each) a training writes at its first session end and its last and little between,
    where unspaced it writes at every step with a session end; the files are the same."""
    import astrocpg.studies.commands.trainer as trainer_module

    original = trainer_module.Trainer.write_checkpoint
    writes: list[list[int]] = []

    def slow_write(self):
        time.sleep(0.1)
        writes.append(self.training.sessions_done.tolist())
        original(self)

    monkeypatch.setattr(trainer_module.Trainer, "write_checkpoint", slow_write)
    # one process: the checkpoints counted are written here
    args = ("--sessions", "6", "--trials", "2", "--seed", "3", "--workers", "1")
    assert _train(tmp_path / "spaced", *args) == 0
    spaced = list(writes)
    writes.clear()
    monkeypatch.setattr(trainer_module, "CHECKPOINT_SPACING", 0.0)
    assert _train(tmp_path / "every", *args) == 0
    every = list(writes)
    assert every[0] != [0, 0] and every[-1] == [6, 6]
    assert len(every) >= 6  # a step with a session end per session of a trial, at least
    assert spaced[0] == every[0] and spaced[-1] == [6, 6]
    assert len(spaced) <= len(every) // 2, (spaced, every)
    for name in ("sessions.csv", "weights.npz"):
        assert (tmp_path / "spaced" / name).read_bytes() == \
            (tmp_path / "every" / name).read_bytes(), name
