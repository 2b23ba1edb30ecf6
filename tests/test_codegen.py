"""Brian2's code-generation target: numpy by default, Cython on request (--codegen or
$ASTROCPG_CODEGEN), recorded in every output, checked, and giving the same numbers."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest

from astrocpg.errors import EnvironmentFault, InputError
from astrocpg.network import build_cpg, codegen_target
from astrocpg.studies.cli import main


def _cython_or_skip() -> None:
    from brian2.codegen.runtime.cython_rt import CythonCodeObject

    if not CythonCodeObject.is_available():
        pytest.skip("no C compiler that Brian2's Cython target can use on this machine")


def _one_line_error(capsys, argv, code) -> str:
    assert main(argv) == code
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


def test_default_is_numpy_and_recorded(tmp_path, monkeypatch):
    monkeypatch.delenv("ASTROCPG_CODEGEN", raising=False)
    assert codegen_target() == "numpy"
    out = tmp_path / "u"
    assert main(["unit", "--seconds", "0.02", "--no-progress", "--out", str(out)]) == 0
    assert json.loads((out / "manifest.json").read_text())["codegen"] == "numpy"


def test_unknown_target_names_the_option_or_the_variable(capsys, tmp_path, monkeypatch):
    err = _one_line_error(capsys, ["unit", "--seconds", "0.02", "--codegen", "fortran",
                                   "--out", str(tmp_path / "a")], 2)
    assert err.startswith("astrocpg: error: --codegen:") and "numpy, cython" in err, err
    monkeypatch.setenv("ASTROCPG_CODEGEN", "fortran")
    err = _one_line_error(capsys, ["unit", "--seconds", "0.02", "--out", str(tmp_path / "b")], 2)
    assert "ASTROCPG_CODEGEN" in err and "fortran" in err, err
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()
    with pytest.raises(InputError, match="fortran"):
        build_cpg(codegen="fortran")


def test_cython_without_a_compiler_is_an_environment_fault_not_numpy(capsys, tmp_path,
                                                                       monkeypatch):
    from brian2.codegen.runtime.cython_rt import CythonCodeObject

    monkeypatch.setattr(CythonCodeObject, "is_available", classmethod(lambda cls: False))
    with pytest.raises(EnvironmentFault, match="C compiler"):
        build_cpg(codegen="cython")
    err = _one_line_error(capsys, ["unit", "--seconds", "0.02", "--codegen", "cython",
                                   "--out", str(tmp_path / "c")], 1)
    assert "Cython" in err, err
    assert os.environ.get("ASTROCPG_CODEGEN") is None


def test_each_network_keeps_its_target(monkeypatch):
    import brian2

    monkeypatch.delenv("ASTROCPG_CODEGEN", raising=False)
    cpg = build_cpg()
    assert cpg.codegen == "numpy"
    assert cpg.motor.codeobj_class is brian2.NumpyCodeObject


@pytest.mark.slow
def test_cython_gives_the_numbers_of_numpy(tmp_path):
    """Compiles the unit's code objects on a cold cache (minutes), then the same spikes and
    traces as numpy, and the target recorded."""
    _cython_or_skip()
    outs = {}
    for target in ("numpy", "cython"):
        outs[target] = tmp_path / target
        assert main(["unit", "--seconds", "0.5", "--no-progress", "--codegen", target,
                     "--out", str(outs[target])]) == 0
        assert json.loads((outs[target] / "manifest.json").read_text())["codegen"] == target
    for name in ("spikes.npz", "traces.npz"):
        with np.load(outs["numpy"] / name) as a, np.load(outs["cython"] / name) as b:
            assert a.files == b.files
            for k in a.files:
                if a[k].dtype.kind == "f":
                    np.testing.assert_allclose(b[k], a[k], rtol=1e-9, atol=1e-12, err_msg=k)
                else:
                    assert np.array_equal(a[k], b[k]), k
    with np.load(outs["numpy"] / "spikes.npz") as a:
        assert len(a["motor_times"]) > 100  # the comparison compared something


@pytest.mark.slow
def test_a_study_hands_the_target_to_its_workers(tmp_path):
    _cython_or_skip()
    spec = tmp_path / "cy.toml"
    spec.write_text('[study]\nname = "cy"\nsessions = 1\nseeds = { first = 1, count = 2 }\n'
                    'batch = 1\n[base]\nL_max = "0.3*second"\nL_non_alive = "0.15*second"\n'
                    '[conditions.astro]\nastrocytes = true\n')
    out = tmp_path / "out"
    assert main(["study", str(spec), "--out", str(out), "--workers", "2", "--no-progress",
                 "--codegen", "cython"]) == 0
    assert json.loads((out / "manifest.json").read_text())["codegen"] == "cython"
    runs = sorted((out / "runs").iterdir())
    assert len(runs) == 2
    for run in runs:
        assert json.loads((run / "manifest.json").read_text())["codegen"] == "cython", run
    assert os.environ.get("ASTROCPG_CODEGEN") is None
