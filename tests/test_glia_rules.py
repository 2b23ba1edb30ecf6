"""docs/beyond/glia_question/decide.py: the tests RULES.md fixes for the glia question, on
synthetic evaluations of the arms still to be trained (and the committed ones of the rest)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location(
    "decide", ROOT / "docs" / "beyond" / "glia_question" / "decide.py")
decide = importlib.util.module_from_spec(spec)
spec.loader.exec_module(decide)

TAGS = {"graded": "glia__astrocyte=graded-astrocyte_interlimb_synapse=interlimb-synapse",
        "activity": "glia__astrocyte=li-rinzel-astrocyte_interlimb_synapse="
                    "homeostatic-interlimb-synapse",
        "constant": "glia__astrocyte=li-rinzel-astrocyte_interlimb_synapse="
                    "constant-depression-interlimb-synapse"}


def test_exact_sign_flip_holm_and_the_smallest_p_of_12_seeds():
    assert decide.sign_flip_p(np.ones(12)) == pytest.approx(2 / 4096)
    assert decide.sign_flip_p(np.zeros(12)) == 1.0
    assert decide.sign_flip_p(np.array([1.0, -1.0] * 6)) == 1.0
    assert decide.holm([0.01, 0.04, 0.03]) == pytest.approx([0.03, 0.06, 0.06])
    assert decide.z(0.975) == pytest.approx(1.95996, abs=1e-4)
    assert decide.mdd(0.3, 12, 4) == pytest.approx((2.4977 + 0.8416) * 0.3 / 12 ** 0.5, rel=1e-3)


def test_arms_and_drives_are_read_from_the_run_ids():
    assert decide.arm_of(TAGS["graded"]) == "graded"
    assert decide.arm_of(TAGS["activity"] + "_I_background_0=1104-mV-second") == "activity"
    assert decide.arm_of("control__interlimb_synapse=constant-depression-interlimb-synapse"
                         "__seeds1-20") == "constant"
    assert decide.arm_of("astrocytes__seeds1-20") == "paper"
    assert decide.arm_of("no-astrocytes__seeds1-20") == "none"
    assert decide.drive_of("x_I_background_0=1656-mV-second__seeds1-12") == 1.2
    assert decide.drive_of("astrocytes__seeds1-20") == 1.0


def _evaluation(path: Path, trot: dict[str, float], seed: int = 1) -> Path:
    rng = np.random.default_rng(seed)
    rows = []
    for arm, tag in TAGS.items():
        for key in decide.DRIVES:
            if arm != "graded" and key == "1380":
                continue
            for s in range(1, 13):
                for repeat in range(5):
                    hit = rng.random() < trot[arm]
                    rows.append({"source": f"{tag}_I_background_0={key}-mV-second__seeds1-12",
                                 "seed": s, "world": "flat", "repeat": repeat,
                                 "gait": "trot" if hit else "none",
                                 "rhythm": "trot" if hit else "none"})
    pd.DataFrame(rows).to_csv(path, index=False)
    return path


def test_h1_verdicts(tmp_path, capsys):
    wide = _evaluation(tmp_path / "wide.csv", {"graded": 0.7, "activity": 0.0, "constant": 0.0})
    assert decide.main(["h1", "--glia-drive", str(wide)]) == 0
    out = capsys.readouterr().out
    assert "**Verdict (H1): supported.**" in out and "Holm over 4" in out
    none = _evaluation(tmp_path / "none.csv", {"graded": 0.0, "activity": 0.0, "constant": 0.0})
    decide.main(["h1", "--glia-drive", str(none)])
    assert "against (every primary difference within its margin)" in capsys.readouterr().out
    worse = _evaluation(tmp_path / "worse.csv", {"graded": 0.0, "activity": 0.0,
                                                 "constant": 0.8})
    decide.main(["h1", "--glia-drive", str(worse)])
    assert "against (a following depression does worse)" in capsys.readouterr().out


def test_h2_reads_the_lopsided_study(tmp_path, capsys):
    drive = _evaluation(tmp_path / "drive.csv", {"graded": 0.3, "activity": 0.3,
                                                 "constant": 0.3})
    rows = []
    for arm, tag in {**TAGS, "paper": "lopsided__astrocyte=li-rinzel-astrocyte_"
                                      "interlimb_synapse=interlimb-synapse"}.items():
        for s in range(1, 13):
            for repeat in range(5):
                hit = arm == "graded" or (arm == "activity" and s % 3 == 0 and repeat == 0)
                rows.append({"source": tag.replace("glia__", "lopsided__") + "__seeds1-12",
                             "seed": s, "world": "flat", "repeat": repeat,
                             "gait": "none", "rhythm": "trot" if hit else "none"})
    lop = tmp_path / "lop.csv"
    pd.DataFrame(rows).to_csv(lop, index=False)
    assert decide.main(["h2", "--glia-lopsided", str(lop), "--glia-drive", str(drive)]) == 0
    out = capsys.readouterr().out
    assert "| graded - constant | trot rhythm (thigh bursts) | 12 | 1.000 | 0.000 |" in out
    assert "**Verdict (H2): supported.**" in out


@pytest.mark.parametrize("hypothesis, written, args", [
    ("h1", "glia_drive/h1.md", ["--glia-drive", "glia_drive/evaluation.csv"]),
    ("h2", "glia_lopsided/h2.md", ["--glia-lopsided", "glia_lopsided/evaluation.csv",
                                   "--glia-drive", "glia_drive/evaluation.csv"]),
])
def test_the_committed_reading_is_what_the_rules_make_of_the_committed_evaluations(
        hypothesis, written, args, capsys):
    """h1.md and h2.md, which the pages quote, are decide.py's output on the committed
    evaluations, verdict included: a conclusion on the pages follows from its tables."""
    beyond = ROOT / "docs" / "beyond"
    assert decide.main([hypothesis, *[str(beyond / a) if a.endswith(".csv") else a
                                      for a in args]]) == 0
    assert capsys.readouterr().out.strip() == (beyond / written).read_text().strip()


def test_the_graded_astrocytes_realised_mean_is_read_from_its_rows(capsys):
    """realised_mean.md, which the pages quote, is realised_mean.py on the committed rows."""
    spec = importlib.util.spec_from_file_location(
        "realised_mean", ROOT / "docs" / "beyond" / "glia_question" / "realised_mean.py")
    realised = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(realised)
    drive = ROOT / "docs" / "beyond" / "glia_drive"
    assert realised.main([str(drive / "results_graded.csv.gz")]) == 0
    assert capsys.readouterr().out.strip() == (drive / "realised_mean.md").read_text().strip()
