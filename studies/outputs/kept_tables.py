"""A study's trained inter-limb tables, kept beside its results and read back as controllers.

A study folder holds every session's table of every seed (``runs/<run_id>/weights.npz``, tens
of MB); what a page of results needs is each seed's table after a few sessions (a few kB). A
*kept-tables folder* holds, for each run of the study,

- ``<run_id>.npz``: ``final_weights_mV`` (seeds, 8, 8), each seed's table after its last
  session; ``seeds`` and ``sessions_done`` (seeds,); ``labels`` (8,), the rows' and columns'
  pools (``FR_flexor`` ...); and ``weights_mV_after_<S>`` (seeds, 8, 8) for each kept session
  ``S`` that every seed reached;
- ``<run_id>.json``: the run's settings (condition, swept point, models, overrides), first
  seed, package versions, code version and machine, copied from the run's manifest, and under
  ``"tables"`` the ``.npz``'s name, sha256 and arrays.

:func:`keep_tables` writes one from a study folder (``docs/ablation/final_tables.py``);
``astrocpg evaluate`` reads one like a study folder (:func:`kept_controllers`), so committed
tables can be evaluated again, at any kept session, without the training they came from.
"""

from __future__ import annotations

import hashlib
import io
import json
import zipfile
import zlib
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...errors import InputError, setting
from ...support.reading import MAX_TABLE_BYTES, check_npz, check_regular, read_bytes, read_json
from .folder import MANIFEST
from .weights import WEIGHTS, by_labels

KEPT = ("settings", "seed", "models", "package_versions", "codegen", "git", "machine", "created")
"""What a kept table's ``.json`` copies from its run's manifest."""
FINAL = "final_weights_mV"
AFTER = "weights_mV_after_{}"


def _run_tables(run: Path, sessions: Sequence[int]) -> dict[str, np.ndarray]:
    manifest = read_json(run / MANIFEST)
    with np.load(run / WEIGHTS, allow_pickle=False) as w:
        data = {k: w[k] for k in w.files}
    n = data[FINAL].shape[0]
    first = int(manifest.get("seed", manifest.get("settings", {}).get("seed", 1)))
    out = {FINAL: data[FINAL], "labels": data["labels"],
           "seeds": np.arange(first, first + n), "sessions_done": data["sessions_done"]}
    for s in sessions:
        if int(data["sessions_done"].min()) >= s:
            out[AFTER.format(s)] = data["weights_mV"][:, s - 1]
    return out


def keep_tables(study: str | Path, out: str | Path,
                sessions: Sequence[int] = ()) -> list[tuple[Path, dict[str, np.ndarray]]]:
    """Write the kept-tables folder ``out`` of the study folder ``study``: one ``.npz`` and
    one ``.json`` per run that has a ``weights.npz`` (finished or stopped), with each seed's
    final table and its tables after each of ``sessions`` that every seed reached. Returns
    [(npz path, arrays)]."""
    study, out = Path(study), Path(out)
    for s in sessions:  # "after session 0" would be the last session's tables, mislabelled
        if isinstance(s, bool) or not isinstance(s, (int, np.integer)) or s < 1:
            raise InputError(f"a session is counted from 1, got {s}", culprit=setting("sessions"))
    runs = sorted(p for p in (study / "runs").glob("*") if (p / WEIGHTS).is_file())
    if not runs:
        raise InputError(f"no run with a weights.npz under {study / 'runs'}", culprit=str(study))
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for run in runs:
        arrays = _run_tables(run, sessions)
        npz = out / f"{run.name}.npz"
        np.savez(npz, **arrays)
        manifest = read_json(run / MANIFEST)
        meta = {k: manifest[k] for k in KEPT if k in manifest}
        done = arrays["sessions_done"]
        planned = (manifest.get("settings") or {}).get("n_sessions")
        meta["tables"] = {"file": npz.name,
                          "sha256": hashlib.sha256(npz.read_bytes()).hexdigest(),
                          "arrays": {k: list(v.shape) for k, v in arrays.items()},
                          # final_weights_mV are final only where every seed did its sessions
                          "sessions_done": [int(done.min()), int(done.max())],
                          "final": planned is not None
                          and int(done.min()) == int(done.max()) == int(planned)}
        (out / f"{run.name}.json").write_text(json.dumps(meta, indent=1) + "\n",
                                              encoding="utf-8")
        written.append((npz, arrays))
    return written


def is_kept_tables(folder: Path) -> bool:
    """Whether ``folder`` is a kept-tables folder: a ``.json`` with a ``"tables"`` entry."""
    return folder.is_dir() and any(_meta(p) is not None for p in sorted(folder.glob("*.json")))


def _meta(path: Path) -> dict[str, Any] | None:
    try:
        meta = read_json(path)
    except (OSError, ValueError, InputError):
        return None
    if isinstance(meta, dict) and isinstance(meta.get("tables"), dict) \
            and isinstance(meta.get("settings"), dict):
        return meta
    return None


def kept_controllers(folder: Path) -> list[dict[str, Any]]:
    """The runs of a kept-tables folder as ``astrocpg evaluate`` takes a study's runs: each
    {folder (the ``.npz``), settings, condition, point, first_seed, kept (the ``.json``)}."""
    found = []
    for path in sorted(folder.glob("*.json")):
        meta = _meta(path)
        if meta is None:
            continue
        settings = meta["settings"]
        point = settings.get("point") or {}
        found.append({"folder": folder / str(meta["tables"].get("file", path.stem + ".npz")),
                      "settings": settings,
                      "condition": str(settings.get("condition", "")),
                      "point": ";".join(f"{k}={v}" for k, v in sorted(point.items())),
                      "first_seed": int(settings.get("seed", meta.get("seed", 1))),
                      "kept": path, "source": path.stem})
    if not found:
        raise InputError("holds no kept tables (<run>.json with a \"tables\" entry, beside its "
                         ".npz)", culprit=str(folder))
    return found


def kept_state(controller: dict[str, Any]) -> dict[str, Any]:
    """Whether a kept run's ``final_weights_mV`` are final: ``{"final", "label", "warning"}``
    as :func:`~astrocpg.studies.outputs.weights.tables_state` gives for a training. They are
    final only when every seed did the sessions its run planned (its settings' ``n_sessions``);
    a run kept after it stopped early holds each seed's last tables, labelled by the sessions
    they are after."""
    meta = _meta(Path(controller["kept"])) or {}
    done = (meta.get("tables") or {}).get("sessions_done")
    if done is None:  # kept before the .json said: read the .npz
        try:
            with np.load(Path(controller["folder"]), allow_pickle=False) as z:
                d = np.asarray(z["sessions_done"])
            done = [int(d.min()), int(d.max())]
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error):
            done = None
    try:
        planned = int((meta.get("settings") or {}).get("n_sessions"))
    except (TypeError, ValueError):
        planned = None
    lo, hi = (None, None) if not done else (int(done[0]), int(done[1]))
    final = planned is not None and lo is not None and lo == hi == planned
    after = ("after session ?" if lo is None else
             f"after session {lo}" if lo == hi else f"after sessions {lo}-{hi}")
    warning = "" if final else (
        f"{controller['kept']}: its run stopped before its end; its tables are those {after}"
        + (f" of {planned}" if planned else ""))
    return {"final": final, "label": "final" if final else after, "warning": warning}


def kept_weights(controller: dict[str, Any], session: int | None = None) -> np.ndarray:
    """The tables (volt, (seeds, 8, 8)) of one kept run: its final tables, or with ``session``
    those after that session (kept, or final where every seed did exactly that many).
    InputError if the ``.npz`` is not the one its ``.json`` names (sha256), or the session was
    not kept, naming the kept ones."""
    npz = Path(controller["folder"])
    where = str(npz)
    check_regular(npz, where)  # a FIFO is refused, never waited on
    if not npz.is_file():
        raise InputError(f"no such file (named by {controller['kept']})", culprit=where)
    raw = read_bytes(npz, where, limit=MAX_TABLE_BYTES)  # refused by its size, unread
    want = _meta(Path(controller["kept"]))["tables"].get("sha256")
    if want and hashlib.sha256(raw).hexdigest() != want:
        raise InputError(f"is not the file {Path(controller['kept']).name} names (its sha256 "
                         f"differs: changed since it was written)", culprit=where)
    check_npz(io.BytesIO(raw), npz, where, limit=MAX_TABLE_BYTES)  # headers before arrays
    try:
        with np.load(io.BytesIO(raw), allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error):
        raise InputError("is corrupt or truncated", culprit=where) from None
    done = np.asarray(arrays.get("sessions_done", []))
    if session is None:
        w = arrays[FINAL]
    elif AFTER.format(session) in arrays:
        w = arrays[AFTER.format(session)]
    elif done.size and int(done.min()) == int(done.max()) == session:
        w = arrays[FINAL]
    else:
        kept = sorted({int(k.rsplit("_", 1)[1]) for k in arrays if k.startswith("weights_mV_after_")}
                      | ({int(done.min())} if done.size and done.min() == done.max() else set()))
        raise InputError(f"{where} keeps the tables after sessions "
                         f"{', '.join(map(str, kept)) or 'none'} only",
                         culprit=setting("session", session))
    w = np.asarray(w, dtype=float)
    if w.ndim != 3 or w.shape[-2:] != (8, 8):
        raise InputError(f"holds tables of shape {w.shape}, not (seeds, 8, 8)", culprit=where)
    if not np.all(np.isfinite(w)):
        raise InputError("contains non-finite values", culprit=where)
    if "labels" in arrays:  # one order for rows and columns: read by it
        labels = [str(x) for x in arrays["labels"]]
        w = np.stack([by_labels(t, labels, labels, where) for t in w])
    return w * 1e-3
