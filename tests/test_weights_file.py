"""A user's inter-limb table (``astrocpg run --weights FILE``): rows are the source pools,
columns the targets, in mV, in the order of ``interlimb_labels``; a labelled CSV is read by its
labels (never silently transposed); a wrong shape, a value outside [w_min, w_max] or a
same-limb weight is refused naming the entry and the bound."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from astrocpg.errors import InputError
from astrocpg.models import DEFAULT_MODELS
from astrocpg.network import interlimb_labels
from astrocpg.studies.cli import main
from astrocpg.studies.outputs.weights import check_table, load_weights

EXAMPLE = Path(__file__).resolve().parents[1] / "docs" / "examples" / "interlimb_table.csv"
LABELS = interlimb_labels()


def _table() -> np.ndarray:
    """An asymmetric table in mV within the bounds (a transposed reading would differ)."""
    rng = np.random.default_rng(3)
    w = np.round(rng.uniform(-0.05, 0.05, (8, 8)), 4)
    limb = np.repeat(np.arange(4), 2)
    w[limb[:, None] == limb[None, :]] = 0.0
    return w


def _labelled(w: np.ndarray, corner: str = "source \\ target", rows=None, cols=None) -> str:
    rows = list(range(8)) if rows is None else rows
    cols = list(range(8)) if cols is None else cols
    lines = [",".join([corner] + [LABELS[j] for j in cols])]
    lines += [",".join([LABELS[i]] + [repr(float(w[i, j])) for j in cols]) for i in rows]
    return "\n".join(lines) + "\n"


def test_the_documented_example_file_is_read(tmp_path, capsys):
    w = load_weights(EXAMPLE) * 1e3
    assert w.shape == (8, 8)
    fr_f, rl_f, fl_f = (LABELS.index(x) for x in ("FR thigh_flexor", "RL thigh_flexor",
                                                   "FL thigh_flexor"))
    assert w[fr_f, rl_f] == pytest.approx(0.04) and w[fr_f, fl_f] == pytest.approx(-0.02)
    check_table(w * 1e-3, DEFAULT_MODELS, "example")
    assert main(["run", "--seconds", "0.01", "--weights", str(EXAMPLE), "--out",
                 str(tmp_path / "r"), "--no-progress"]) == 0
    # the docs name the file and the pools in the code's order
    training = (EXAMPLE.parents[1] / "training.md").read_text()
    assert "examples/interlimb_table.csv" in training
    assert ", ".join(f"`{x}`" for x in LABELS) in training


def test_labels_in_any_order_and_either_direction(tmp_path):
    w = _table()
    plain = tmp_path / "plain.csv"
    plain.write_text("\n".join(",".join(repr(float(x)) for x in r) for r in w))
    assert np.allclose(load_weights(plain) * 1e3, w)
    shuffled = tmp_path / "shuffled.csv"
    shuffled.write_text(_labelled(w, rows=[3, 0, 7, 1, 6, 2, 5, 4], cols=[7, 6, 5, 4, 3, 2, 1, 0]))
    assert np.allclose(load_weights(shuffled) * 1e3, w)
    # rows are targets, and the corner says so: read by its labels, as sources x targets
    flipped = tmp_path / "flipped.csv"
    flipped.write_text(_labelled(w.T, corner="target \\ source"))
    assert np.allclose(load_weights(flipped) * 1e3, w)
    # a header that does not say the direction: refused, never guessed
    for corner in ("", "pools", "to \\ from"):
        bad = tmp_path / "bad.csv"
        bad.write_text(_labelled(w.T, corner=corner))
        with pytest.raises(InputError, match="source \\\\ target"):
            load_weights(bad)
    npz = tmp_path / "t.npz"
    order = [4, 5, 6, 7, 0, 1, 2, 3]
    np.savez(npz, weights_mV=w[np.ix_(order, order)], labels=np.array([LABELS[k] for k in order]))
    assert np.allclose(load_weights(npz) * 1e3, w)


@pytest.mark.parametrize("edit, words", [
    (lambda w: w[:7], "8x8"),
    (lambda w: np.hstack([w, w[:, :1]]), "8x8"),
    (lambda w: _set(w, 0, 2, 0.06), "FR thigh_flexor -> FL thigh_flexor is 0.06 mV, above "
                                    "w_max = 0.05 mV"),
    (lambda w: _set(w, 7, 4, -0.5), "RL thigh_extensor -> RR thigh_flexor is -0.5 mV, below "
                                    "w_min = -0.05 mV"),
    (lambda w: _set(w, 0, 1, 0.01), "FR thigh_flexor -> FR thigh_extensor is 0.01 mV, but a "
                                    "limb's own 2x2 block"),
])
@pytest.mark.parametrize("suffix", [".csv", ".npz"])
def test_bad_tables_are_refused_naming_the_entry(tmp_path, capsys, edit, words, suffix):
    w = edit(_table())
    path = tmp_path / f"w{suffix}"
    if suffix == ".csv":
        path.write_text("\n".join(",".join(repr(float(x)) for x in r) for r in w))
    else:
        np.savez(path, weights_mV=w)
    out = tmp_path / "o"
    assert main(["run", "--seconds", "0.01", "--weights", str(path), "--out", str(out),
                 "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and f"--weights {path}" in err and words in err, err
    assert not out.exists()


def test_the_bound_is_the_models(tmp_path):
    w = _set(_table(), 0, 2, 0.06)
    path = tmp_path / "w.csv"
    path.write_text(_labelled(w))
    with pytest.raises(InputError, match="above w_max = 0.05 mV"):
        check_table(load_weights(path), DEFAULT_MODELS, "w")
    from brian2 import mV
    check_table(load_weights(path), DEFAULT_MODELS.with_values({"w_max": 0.1 * mV}), "w")


def _set(w: np.ndarray, i: int, j: int, v: float) -> np.ndarray:
    w = w.copy()
    w[i, j] = v
    return w
