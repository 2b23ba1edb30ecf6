"""Reading inter-limb weight tables: a file (.npy, .npz, .json, text/CSV) or a training folder.

The table (docs/training.md, "Your own inter-limb table"): 8 x 8, in mV, row = the source
(presynaptic) thigh pool, column = the target (postsynaptic) one, both in the order of
:func:`~astrocpg.network.interlimb_labels` (FR, FL, RR, RL; flexor before extensor). A CSV may
carry that order as labels: a header row of the 8 target labels after a top-left cell that
says the direction (``source \\ target``, or ``target \\ source`` for a table whose rows are
targets), and each row's source label first; it is then read by its labels, in any order.
"""

from __future__ import annotations

import csv
import io
import os
import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import (EnvironmentFault, Field, InputError, advice, did_you_mean, setting,
                      shown_with)
from ...network import interlimb_labels
from ...support.reading import (MAX_TABLE_BYTES, check_npy, check_npz, check_regular, loads_json,
                        open_regular, read_bytes)
from .folder import MANIFEST, verify

WEIGHTS = "weights.npz"


def load_weights(path: str | Path, trial: int | None = None, *,
                 culprit: str | Field = setting("weights"),
                 session: int | None = None) -> np.ndarray:
    """An 8x8 inter-limb table in mV from .npy, .npz ('weights_mV' or 'weights'), .json or
    text, or a training folder (its final tables, or with ``session`` its tables after that
    session, which every trial must have done: all trials, or ``trial``); returns volt.
    Every problem is an InputError naming ``culprit`` and the path as the user typed it."""
    p = Path(path)
    where = shown_with(culprit, path) if culprit else str(path)
    if p.is_dir():
        check_regular(p / WEIGHTS, where)  # a FIFO is refused, never waited on
        check_regular(p / MANIFEST, where)
        if not (p / WEIGHTS).is_file():
            raise InputError(f"folder holds no {WEIGHTS} (not a training run)", culprit=where)
        try:  # each array's header against its bytes, before anything is hashed or made
            with open_regular(p / WEIGHTS, where) as f:
                check_npz(f, p / WEIGHTS, where)
        except OSError:
            raise InputError(f"{WEIGHTS} is corrupt or truncated", culprit=where) from None
        if (p / MANIFEST).is_file():  # a training's: the tables are what its manifest lists
            verify(p, culprit=where, strict=False, only=(WEIGHTS,))
        try:
            with np.load(p / WEIGHTS, allow_pickle=False) as z:
                if session is None:
                    w = np.asarray(z["final_weights_mV"], dtype=float)
                else:
                    w = _after_session(z, session, where)
        except InputError:  # a session the trials have not done: said as such
            raise
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error):
            raise InputError(f"{WEIGHTS} is corrupt or truncated", culprit=where) from None
        if w.ndim != 3 or w.shape[-2:] != (8, 8):
            raise InputError(f"{WEIGHTS} holds tables of shape {w.shape}, not (trials, 8, 8)",
                             culprit=where)
        if trial is not None:
            if not 0 <= trial < len(w):
                raise InputError(f"{path} has {len(w)} trial(s)", culprit=setting("trial", trial))
            w = w[trial]
    else:
        if session is not None:
            raise InputError("a table file has no sessions: give a training folder",
                             culprit=setting("session", session))
        check_regular(p, where)  # a FIFO, device or socket: refused, never waited on
        if not os.path.lexists(p):  # a missing input: the environment's (exit 1)
            raise EnvironmentFault("no such file or folder", culprit=where)
        if not p.is_file():
            raise InputError("is not a file", culprit=where)
        try:
            # what was checked is what is read: refused by its size (MAX_TABLE_BYTES) before
            # a byte is read, and an array file by its header before an array is made
            raw = read_bytes(p, where, limit=MAX_TABLE_BYTES)
            if p.suffix == ".npy":
                check_npy(io.BytesIO(raw), len(raw), path, where)
                w = np.load(io.BytesIO(raw), allow_pickle=False)
            elif p.suffix == ".npz":
                check_npz(io.BytesIO(raw), path, where, limit=MAX_TABLE_BYTES)
                with np.load(io.BytesIO(raw), allow_pickle=False) as z:
                    w = z["weights_mV"] if "weights_mV" in z else z["weights"]
                    labels = [str(x) for x in z["labels"]] if "labels" in z.files else None
                if labels is not None:  # one order for rows and columns: read by it
                    w = by_labels(np.asarray(w, dtype=float), labels, labels, where)
            elif p.suffix == ".json":
                obj = loads_json(raw, where)
                w = obj["weights_mV"] if isinstance(obj, dict) else obj
            elif p.suffix == ".csv":
                w = read_csv_table(raw.decode("utf-8"), where)
            else:
                w = np.loadtxt(io.StringIO(raw.decode("utf-8")))
            w = np.asarray(w, dtype=float)
        except InputError:
            raise
        except Exception as e:  # numpy/json raise many types for a bad file: all are bad input
            raise InputError(f"cannot read an 8x8 table in mV ({type(e).__name__})",
                             culprit=where) from None
        if w.shape[-2:] != (8, 8) or w.ndim not in (2, 3):
            raise InputError(f"expected an 8x8 table (rows: the 8 source pools, columns: the 8 "
                             f"target pools), got shape {w.shape}", culprit=where)
    if not np.all(np.isfinite(w)):
        raise InputError("contains non-finite values", culprit=where)
    return w * 1e-3


def _after_session(z: Any, session: int, where: str) -> np.ndarray:
    """Every trial's table after ``session`` (1-based) from a training's weights.npz, whose
    ``weights_mV`` holds the table after each session; refused unless every trial did it."""
    if isinstance(session, bool) or not isinstance(session, (int, np.integer)) or session < 1:
        raise InputError(f"must be a whole number of at least 1, got {session!r}",
                         culprit=setting("session"))
    done = np.asarray(z["sessions_done"])
    if int(done.min()) < session:
        raise InputError(f"{where}: not every trial has done {session} sessions (the fewest: "
                         f"{int(done.min())})", culprit=setting("session", session))
    return np.asarray(z["weights_mV"][:, session - 1], dtype=float)


#: The top-left cell of a labelled CSV: which pools its rows are (normalised: no spaces,
#: lower case).
DIRECTIONS = {"source\\target": False, "target\\source": True}


def _label(text: str) -> str:
    return " ".join(text.split())


def by_labels(w: np.ndarray, rows: list[str], columns: list[str], where: str) -> np.ndarray:
    """The (8, 8) table ``w`` (rows and columns labelled) in the canonical order."""
    order = interlimb_labels()
    index = {name: k for k, name in enumerate(order)}
    if w.shape[-2:] != (8, 8):
        raise InputError(f"expected an 8x8 table, got shape {w.shape}", culprit=where)
    for axis, labels in (("row", rows), ("column", columns)):
        labels = [_label(x) for x in labels]
        for x in labels:
            if x not in index:
                raise InputError(f"unknown {axis} label {x!r}{did_you_mean(x, order)} (the "
                                 f"pools: {', '.join(order)})", culprit=where)
        twice = next((x for x in labels if labels.count(x) > 1), None)
        if twice is not None:
            raise InputError(f"the {axis} label {twice!r} appears twice", culprit=where)
    r = [index[_label(x)] for x in rows]
    c = [index[_label(x)] for x in columns]
    out = np.empty_like(w)
    out[..., np.asarray(r)[:, None], np.asarray(c)[None, :]] = w  # row a is source r[a]
    return out


def read_csv_table(text: str, where: str) -> np.ndarray:
    """An 8x8 table in mV from CSV text: 8 rows of 8 numbers (rows: sources, in the canonical
    order), or the labelled form (module docstring), read by its labels. Lines starting with
    ``#`` and blank lines are skipped. A header whose top-left cell does not name the
    direction, or labels on one side only, are refused: a table is never read transposed
    without saying so."""
    lines = [x for x in text.splitlines() if x.strip() and not x.lstrip().startswith("#")]
    rows = [[c.strip() for c in r] for r in csv.reader(io.StringIO("\n".join(lines)))]
    if not rows:
        raise InputError("holds no table (expected 8 rows of 8 numbers in mV)", culprit=where)

    def numbers(cells: list[str], what: str) -> list[float]:
        try:
            return [float(c) for c in cells]
        except ValueError:
            bad = next(c for c in cells if not _is_number(c))
            raise InputError(f"{what}: {bad!r} is not a number (mV)", culprit=where) from None

    if all(_is_number(c) for c in rows[0]):  # no labels: the canonical order, rows = sources
        if len(rows) != 8 or any(len(r) != 8 for r in rows):
            shape = (len(rows), max(len(r) for r in rows))
            raise InputError(f"expected an 8x8 table (rows: the 8 source pools, columns: the 8 "
                             f"target pools), got {len(rows)} rows of "
                             f"{'/'.join(sorted({str(len(r)) for r in rows}))} values "
                             f"(shape {shape})", culprit=where)
        return np.array([numbers(r, f"row {k + 1}") for k, r in enumerate(rows)])
    corner, columns = rows[0][0], rows[0][1:]
    direction = corner.replace(" ", "").lower()
    if direction not in DIRECTIONS:
        raise InputError(f"a labelled table's top-left cell names its direction: "
                         f"'source \\ target' (rows are the source pools) or 'target \\ "
                         f"source', not {corner!r}", culprit=where)
    body = rows[1:]
    if len(columns) != 8 or len(body) != 8 or any(len(r) != 9 for r in body):
        raise InputError(f"a labelled table has a header of 8 pool labels and 8 rows of a label "
                         f"and 8 values; got {len(columns)} column labels and {len(body)} rows",
                         culprit=where)
    if any(_is_number(r[0]) for r in body):
        raise InputError("a labelled table labels every row too (its first cell)",
                         culprit=where)
    w = np.array([numbers(r[1:], f"row {r[0]!r}") for r in body])
    labels = [r[0] for r in body]
    if DIRECTIONS[direction]:  # rows are targets: read by the labels, as sources x targets
        return by_labels(w.T, columns, labels, where)
    return by_labels(w, labels, columns, where)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def check_table(table: Any, models: Any, where: str) -> None:
    """A table read from a user's file (volt; (8, 8) or (trials, 8, 8)) against the inter-limb
    synapse: a same-limb entry (no synapse there) must be 0 and every other within
    [w_min, w_max] of the run's model (read through ``models.value``); else an InputError
    naming the entry (source -> target, mV) and the bound."""
    w = np.asarray(table, dtype=float)
    labels = interlimb_labels()
    limb = np.repeat(np.arange(len(labels) // 2), 2)
    same = limb[:, None] == limb[None, :]
    flat = w.reshape(-1, 8, 8)
    trial = (lambda b: f" (table {b})") if len(flat) > 1 else (lambda b: "")
    for b, t in enumerate(flat):
        bad = np.argwhere(same & (t != 0))
        if len(bad):
            i, j = bad[0]
            raise InputError(f"{labels[i]} -> {labels[j]}{trial(b)} is {t[i, j] * 1e3:g} mV, "
                             f"but a limb's own 2x2 block has no synapse: it must be 0",
                             culprit=where)
    try:
        lo, hi = models.value("w_min"), models.value("w_max")
    except (AttributeError, KeyError, TypeError, InputError):
        return  # an inter-limb synapse model without those bounds: nothing to check against
    tol = 1e-9 * max(abs(lo), abs(hi))
    for b, t in enumerate(flat):
        for bound, name, out in ((hi, "above w_max", t > hi + tol),
                                 (lo, "below w_min", t < lo - tol)):
            bad = np.argwhere(out & ~same)
            if len(bad):
                i, j = bad[0]
                raise InputError(f"{labels[i]} -> {labels[j]}{trial(b)} is {t[i, j] * 1e3:g} "
                                 f"mV, {name} = {bound * 1e3:g} mV (the inter-limb synapse's "
                                 f"bound; the table is in mV)", culprit=where)


def tables_state(folder: str | Path) -> dict[str, Any]:
    """What a training folder's current tables are: ``{"final": bool, "running": bool,
    "sessions_done": [min, max], "sessions": planned, "label": str, "warning": str}``.

    The tables :func:`load_weights` reads from a folder are each trial's tables after its last
    finished session. They are the *final* tables only when the training is not running and
    every trial has done the sessions it was asked for; otherwise they are labelled by the
    sessions they are after, and ``warning`` says why (a training still running, or one stopped
    before its end), so that no output calls them final."""
    from .folder import holder_of

    p = Path(folder)
    planned = None
    try:
        manifest = loads_json(read_bytes(p / MANIFEST, str(p / MANIFEST)), str(p / MANIFEST))
        planned = int((manifest.get("settings") or {}).get("n_sessions"))
    except (InputError, OSError, ValueError, TypeError, AttributeError):
        planned = None
    try:
        with np.load(p / WEIGHTS, allow_pickle=False) as z:
            done = np.asarray(z["sessions_done"]) if "sessions_done" in z.files else None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error):
        done = None
    lo, hi = (int(done.min()), int(done.max())) if done is not None and done.size else (None, None)
    running = holder_of(p) is not None
    final = (not running and planned is not None and lo is not None and lo == hi == planned)
    after = ("after session ?" if lo is None else
             f"after session {lo}" if lo == hi else f"after sessions {lo}-{hi}")
    label = "final" if final else after
    warning = ""
    if running:
        warning = (f"{p} is still training: its tables are those {after}"
                   + (f" of {planned}" if planned else "") + ", not final")
    elif not final:
        warning = (f"{p} stopped before its end: its tables are those {after}"
                   + (f" of {planned}" if planned else "")
                   + f" (continue it with {advice('resume', p)})")
    return {"final": final, "running": running, "sessions_done": [lo, hi], "sessions": planned,
            "label": label, "warning": warning}
