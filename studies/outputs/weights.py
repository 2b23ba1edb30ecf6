"""Reading inter-limb weight tables: a file (.npy, .npz, .json, text/CSV) or a training folder."""

from __future__ import annotations

import io
import zipfile
import zlib
from pathlib import Path

import numpy as np

from ...errors import InputError
from ...reading import check_regular, loads_json, read_bytes
from .folder import MANIFEST, verify

WEIGHTS = "weights.npz"


def load_weights(path: str | Path, trial: int | None = None, *,
                 culprit: str = "--weights") -> np.ndarray:
    """An 8x8 inter-limb table in mV from .npy, .npz ('weights_mV' or 'weights'), .json or
    text, or a training folder (its final tables: all trials, or ``trial``); returns volt.
    Every problem is an InputError naming ``culprit`` and the path as the user typed it."""
    p = Path(path)
    where = f"{culprit} {path}" if culprit else str(path)
    if p.is_dir():
        check_regular(p / WEIGHTS, where)  # a FIFO is refused, never waited on
        check_regular(p / MANIFEST, where)
        if not (p / WEIGHTS).is_file():
            raise InputError(f"folder holds no {WEIGHTS} (not a training run)", culprit=where)
        if (p / MANIFEST).is_file():  # a training's: the tables are what its manifest lists
            verify(p, culprit=where, strict=False, only=(WEIGHTS,))
        try:
            with np.load(p / WEIGHTS, allow_pickle=False) as z:
                w = np.asarray(z["final_weights_mV"], dtype=float)
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error):
            raise InputError(f"{WEIGHTS} is corrupt or truncated", culprit=where) from None
        if w.ndim != 3 or w.shape[-2:] != (8, 8):
            raise InputError(f"{WEIGHTS} holds tables of shape {w.shape}, not (trials, 8, 8)",
                             culprit=where)
        if trial is not None:
            if not 0 <= trial < len(w):
                raise InputError(f"{path} has {len(w)} trial(s)", culprit=f"--trial {trial}")
            w = w[trial]
    else:
        check_regular(p, where)  # a FIFO, device or socket: refused, never waited on
        if not p.is_file():
            raise InputError("no such file or folder", culprit=where)
        try:
            raw = read_bytes(p, where)  # what was checked is what is read
            if p.suffix == ".npy":
                w = np.load(io.BytesIO(raw), allow_pickle=False)
            elif p.suffix == ".npz":
                with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                    w = z["weights_mV"] if "weights_mV" in z else z["weights"]
            elif p.suffix == ".json":
                obj = loads_json(raw, where)
                w = obj["weights_mV"] if isinstance(obj, dict) else obj
            else:
                w = np.loadtxt(io.StringIO(raw.decode("utf-8")),
                               delimiter="," if p.suffix == ".csv" else None)
            w = np.asarray(w, dtype=float)
        except InputError:
            raise
        except Exception as e:  # numpy/json raise many types for a bad file: all are bad input
            raise InputError(f"cannot read an 8x8 table in mV ({type(e).__name__})",
                             culprit=where) from None
        if w.shape[-2:] != (8, 8) or w.ndim not in (2, 3):
            raise InputError(f"expected an 8x8 table, got shape {w.shape}", culprit=where)
    if not np.all(np.isfinite(w)):
        raise InputError("contains non-finite values", culprit=where)
    return w * 1e-3
