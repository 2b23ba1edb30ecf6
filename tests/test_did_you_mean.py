"""Every name a user types gets a "did you mean": each refusal of an unknown name (an
``InputError`` whose message says "unknown ...") names the closest known names through the one
helper, :func:`astrocpg.errors.did_you_mean` (difflib), or through the unit parser's own
suggestions. Checked on the source, so a new refusal without it fails here; and on the command
line for the names the issue met."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from astrocpg.studies.cli import main

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ("models", "network", "coupling", "studies", "errors.py", "support")

#: refusals of an "unknown" thing that is no name a user typed, and why
NOT_A_TYPED_NAME = {
    # a checkpoint's own entries and dtypes: a corrupt file, not a name anyone typed
    ("studies/outputs/checkpoint.py", "unknown dtype"),
    ("studies/outputs/checkpoint.py", "unknown entry"),
}


def _refusals() -> list[tuple[str, int, str, bool]]:
    """(file, line, message start, suggests) of every ``InputError(...)`` built with a message
    that says "unknown"."""
    out = []
    files = [p for part in PACKAGE for p in
             ([ROOT / part] if part.endswith(".py") else sorted((ROOT / part).rglob("*.py")))]
    for path in files:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if not (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "InputError"
                    and node.args):
                continue
            text = "".join(v.value for v in ast.walk(node.args[0])
                           if isinstance(v, ast.Constant) and isinstance(v.value, str))
            if "unknown" not in text.lower():
                continue
            names = {getattr(n, "id", None) or getattr(n, "attr", None) for n in ast.walk(node)}
            suggests = bool(names & {"did_you_mean", "hint", "hints", "suggestion"})
            out.append((path.relative_to(ROOT).as_posix(), node.lineno, text[:40], suggests))
    return out


def test_the_source_scan_finds_the_refusals() -> None:
    found = _refusals()
    assert len(found) > 10 and any(s for *_, s in found)


def test_every_unknown_name_refusal_suggests_the_closest() -> None:
    bare = [f"{f}:{line}: {text!r}" for f, line, text, suggests in _refusals()
            if not suggests and not any(f == nf and text.lower().startswith(t)
                                        for nf, t in NOT_A_TYPED_NAME)]
    assert not bare, "refusals of an unknown name without did_you_mean:\n" + "\n".join(bare)


@pytest.mark.parametrize("argv, hint", [
    (["describe", "eta_AD"], "did you mean eta_ADO?"),
    (["describe", "astrocyte", "--format", "txt"], "did you mean text?"),
    (["models", "dump", "astrocite"], "did you mean astrocyte?"),
    (["describe", "astrocyte", "--model", "astrocyte=li_rinzel_astrocyt"],
     "did you mean li_rinzel_astrocyte?"),
    (["describe", "motor_neuron", "--set", "tau_motr=8*ms"], "did you mean tau_motor?"),
])
def test_a_misspelt_name_gets_the_closest(argv, hint, capsys) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and hint in err, err


def test_a_misspelt_study_and_key(tmp_path: Path, capsys) -> None:
    assert main(["study", "quik", "--out", str(tmp_path / "o")]) == 2
    assert "did you mean quick?" in capsys.readouterr().err
    f = tmp_path / "s.toml"
    f.write_text('[study]\nname = "x"\nsesions = 2\n')
    assert main(["study", str(f), "--out", str(tmp_path / "o")]) == 2
    assert "unknown key 'sesions' (did you mean sessions?)" in capsys.readouterr().err
    f.write_text('[study]\nname = "x"\n[sweeep]\n')
    assert main(["study", str(f), "--out", str(tmp_path / "o")]) == 2
    assert "did you mean sweep?" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()
