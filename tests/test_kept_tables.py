"""A study's kept tables (``docs/ablation/final_tables.py``) read back by ``astrocpg evaluate``:
the committed tables of a study are evaluated as its runs are, at any kept session."""

from __future__ import annotations

import csv
import json
import shutil

import numpy as np
import pytest

from astrocpg.errors import InputError
from astrocpg.network import interlimb_labels
from astrocpg.studies.cli import main
from astrocpg.studies.outputs.kept_tables import (is_kept_tables, keep_tables,
                                                  kept_controllers, kept_weights)


def _study(root, sessions_done=(3, 3)):
    """A study folder with one run: per-session tables of two seeds, first seed 4."""
    run = root / "runs" / "astrocytes__drive=1.1__seeds4-5"
    run.mkdir(parents=True)
    per_session = np.arange(2 * 3 * 64, dtype=float).reshape(2, 3, 8, 8) * 1e-2  # mV
    final = per_session[np.arange(2), np.array(sessions_done) - 1]
    np.savez(run / "weights.npz", weights_mV=per_session, final_weights_mV=final,
             sessions_done=np.array(sessions_done), labels=np.array(interlimb_labels()))
    settings = {"run_id": run.name, "condition": "astrocytes", "point": {"drive": "1.1"},
                "seed": 4, "astrocytes": True, "overrides": [], "models": {}}
    (run / "manifest.json").write_text(json.dumps({"settings": settings, "seed": 4,
                                                   "package_versions": {"numpy": "x"}}))
    return per_session


def test_kept_tables_are_read_back_at_each_kept_session(tmp_path):
    per_session = _study(tmp_path / "study")
    kept = tmp_path / "tables"
    keep_tables(tmp_path / "study", kept, sessions=[1, 2, 9])  # 9: not reached, not kept
    assert is_kept_tables(kept) and not is_kept_tables(tmp_path / "study")
    [c] = kept_controllers(kept)
    assert (c["condition"], c["point"], c["first_seed"]) == ("astrocytes", "drive=1.1", 4)
    assert c["source"] == "astrocytes__drive=1.1__seeds4-5"
    np.testing.assert_allclose(kept_weights(c), per_session[:, -1] * 1e-3)
    np.testing.assert_allclose(kept_weights(c, 1), per_session[:, 0] * 1e-3)
    np.testing.assert_allclose(kept_weights(c, 3), per_session[:, 2] * 1e-3)  # = the final
    with pytest.raises(InputError, match="after sessions 1, 2, 3 only") as e:
        kept_weights(c, 9)
    assert e.value.culprit == "session=9"  # the setting, in the Python API's words
    meta = json.loads(c["kept"].read_text())
    assert meta["package_versions"] == {"numpy": "x"}
    assert meta["tables"]["arrays"]["weights_mV_after_2"] == [2, 8, 8]


def test_a_kept_table_changed_after_it_was_written_is_refused(tmp_path):
    _study(tmp_path / "study")
    kept = tmp_path / "tables"
    keep_tables(tmp_path / "study", kept)
    [c] = kept_controllers(kept)
    with np.load(c["folder"]) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["final_weights_mV"][0, 0, 0] += 1.0
    np.savez(c["folder"], **arrays)
    with pytest.raises(InputError, match="sha256 differs"):
        kept_weights(c)


def test_kept_tables_are_read_by_their_labels(tmp_path):
    per_session = _study(tmp_path / "study")
    kept = tmp_path / "tables"
    keep_tables(tmp_path / "study", kept)
    [c] = kept_controllers(kept)
    order = np.arange(8)[::-1]  # the same tables, rows and columns written in reverse order
    with np.load(c["folder"]) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["final_weights_mV"] = arrays["final_weights_mV"][:, order][:, :, order]
    arrays["labels"] = arrays["labels"][order]
    np.savez(c["folder"], **arrays)
    meta = json.loads(c["kept"].read_text())
    import hashlib
    meta["tables"]["sha256"] = hashlib.sha256(c["folder"].read_bytes()).hexdigest()
    c["kept"].write_text(json.dumps(meta))
    np.testing.assert_allclose(kept_weights(c), per_session[:, -1] * 1e-3)


def test_evaluate_reads_a_studys_kept_tables_as_it_reads_the_study(tmp_path):
    """The same rows from the training and from its kept tables (but the source's name)."""
    train = tmp_path / "study" / "runs" / "astrocytes__seeds5-6"
    assert main(["train", "--out", str(train), "--sessions", "2", "--trials", "2", "--seed", "5",
                 "--set", "L_max=0.2*second", "--no-progress"]) == 0
    kept = tmp_path / "tables"
    keep_tables(tmp_path / "study", kept, sessions=[1])
    worlds = tmp_path / "w.toml"
    worlds.write_text('[worlds.flat]\n')
    rows = {}
    for name, source, extra in (("train", train, ["--session", "1"]),
                                ("kept", kept, ["--session", "1"]),
                                ("final", kept, [])):
        assert main(["evaluate", str(source), "--worlds", str(worlds), "--seconds", "0.2",
                     "--repeats", "1", "--out", str(tmp_path / name), "--no-progress",
                     *extra]) == 0
        rows[name] = list(csv.DictReader(open(tmp_path / name / "evaluation.csv")))
    assert {r["source"] for r in rows["kept"]} == {"astrocytes__seeds5-6"}
    strip = [{k: v for k, v in r.items() if k not in ("source", "condition")}
             for r in rows["train"]]
    assert [{k: v for k, v in r.items() if k not in ("source", "condition")}
            for r in rows["kept"]] == strip
    manifest = json.loads((tmp_path / "kept" / "manifest.json").read_text())
    assert manifest["settings"]["tables"] == "after session 1"
    # a session the folder does not keep: refused before anything runs, naming what it keeps
    assert main(["evaluate", str(kept), "--worlds", str(worlds), "--session", "7",
                 "--out", str(tmp_path / "x"), "--no-progress"]) == 2
    assert not (tmp_path / "x").exists()
    shutil.rmtree(kept)
    kept.mkdir()
    assert main(["evaluate", str(kept), "--no-progress"]) == 2  # an empty folder: named
