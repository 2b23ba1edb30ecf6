"""Model files (TOML): dump -> edit -> pass back with --model, new parameters and terms, the
interface, and one clear line for every bad file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from astrocpg.models import DEFAULT_MODELS
from astrocpg.models.files import model_from_toml, model_to_toml
from astrocpg.studies.cli import main


def _dump(capsys, name: str, *extra: str) -> str:
    assert main(["models", "dump", name, *extra]) == 0
    return capsys.readouterr().out


def _astrocyte_with_extra_term(text: str, term: str = "1/tau_extra",
                               declaration: str = '"2*second"') -> str:
    """The dumped astrocyte with a new parameter tau_extra and a term of dAG/dt using it."""
    old = "dAG/dt = -AG/tau_AG + r_AG*n_pool/dt : 1"
    assert old in text
    text = text.replace(old, f"dAG/dt = -AG/tau_AG + r_AG*n_pool/dt + {term} : 1")
    return text.replace("[parameters]\n", "[parameters]\n"
                        f'tau_extra = {{ value = {declaration}, symbol = "\\\\tau_x", '
                        f'meaning = "a new 2-AG source", positive = true }}\n')


def _fails_cleanly(capsys, argv: list[str], out: Path, *expected: str) -> str:
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1, err
    assert err.startswith("astrocpg: error:"), err
    for word in expected:
        assert word in err, (word, err)
    assert not out.exists(), "nothing may be written on bad input"
    return err


@pytest.mark.parametrize("name", [name for name, _ in DEFAULT_MODELS.items()])
def test_dump_then_load_gives_the_built_in_model(capsys, name):
    model = dict(DEFAULT_MODELS.items())[name]
    text = _dump(capsys, name)
    assert text == model_to_toml(model)
    assert model_from_toml(text, culprit="t", default=model) == model


def test_dump_applies_set(capsys):
    text = _dump(capsys, "astrocyte", "--set", "tau_AG=2*second")
    assert model_from_toml(text, culprit="t").parameters["tau_AG"].value == 2 * \
        DEFAULT_MODELS.astrocyte.parameters["tau_AG"].value


def test_models_list_shows_interfaces(capsys):
    assert main(["models", "list"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("astrocyte"))
    assert "n_pool" in line and "ADO" in line


def test_new_parameter_and_term_act_in_run(capsys, tmp_path):
    text = _astrocyte_with_extra_term(_dump(capsys, "astrocyte"))
    f = tmp_path / "astro.toml"
    f.write_text(text)
    common = ["run", "--seconds", "1", "--seed", "3", "--no-progress", "--spikes", "none",
              "--traces", "astrocyte_AG"]
    assert main([*common, "--out", str(tmp_path / "base")]) == 0
    assert main([*common, "--model", f"astrocyte={f}", "--out", str(tmp_path / "new")]) == 0
    # the new parameter is a parameter like any other: --set reaches it
    assert main([*common, "--model", f"astrocyte={f}", "--set", "tau_extra=1e6*second",
                 "--out", str(tmp_path / "off")]) == 0
    capsys.readouterr()
    from astrocpg.studies.outputs.result import load
    base, new, off = (load(tmp_path / n) for n in ("base", "new", "off"))
    ag = {k: np.asarray(r.traces["astrocyte_AG"][1], dtype=float) for k, r in
          (("base", base), ("new", new), ("off", off))}
    # 1/tau_extra = 0.5/s of extra 2-AG: visibly more 2-AG after 1 s
    assert ag["new"][-1].mean() > ag["base"][-1].mean() + 0.1
    assert np.allclose(ag["off"], ag["base"], atol=1e-3)
    # the manifest records the file's content and hash
    manifest = json.loads((tmp_path / "new" / "manifest.json").read_text())
    record = manifest["settings"]["models"]["astrocyte"]
    assert record["content"] == text and len(record["sha256"]) == 64
    assert "tau_extra" in manifest["models"]["astrocyte"]["parameters"]


def test_describe_renders_a_model_file(capsys, tmp_path):
    f = tmp_path / "astro.toml"
    f.write_text(_astrocyte_with_extra_term(_dump(capsys, "astrocyte")))
    assert main(["describe", "astrocyte", "--model", f"astrocyte={f}"]) == 0
    out = capsys.readouterr().out
    assert "tau_extra" in out and "a new 2-AG source" in out


# ---- bad files: one line, exit 2, nothing written

def _bad(capsys, tmp_path, content: bytes | str, *expected: str) -> None:
    f = tmp_path / "bad.toml"
    f.write_bytes(content if isinstance(content, bytes) else content.encode())
    _fails_cleanly(capsys, ["run", "--seconds", "1", "--no-progress", "--model",
                            f"astrocyte={f}", "--out", str(tmp_path / "o")],
                   tmp_path / "o", "astrocyte", *expected)


def test_missing_interface_variable(capsys, tmp_path):
    text = _dump(capsys, "astrocyte").replace(
        "dADO/dt = -ADO/tau_ADO : 1", "dADX/dt = -ADX/tau_ADO : 1").replace(
        'reset = "ADO += r_ADO"', 'reset = "ADX += r_ADO"').replace(
        'ADO = { value = "0.0" }', "")
    _bad(capsys, tmp_path, text, "lacks ADO", "interface")


def test_duplicate_parameter_in_the_file(capsys, tmp_path):
    text = _dump(capsys, "astrocyte").replace(
        "[parameters]\n", '[parameters]\ntau_IP3 = { value = "1*second" }\n')
    _bad(capsys, tmp_path, text, "tau_IP3")


def test_parameter_another_model_declares(capsys, tmp_path):
    text = _dump(capsys, "astrocyte").replace(
        "[parameters]\n", '[parameters]\ntau_motor = { value = "1*second" }\n')
    _bad(capsys, tmp_path, text, "tau_motor", "also declared by")


def test_unknown_unit(capsys, tmp_path):
    text = _astrocyte_with_extra_term(_dump(capsys, "astrocyte"), declaration='"2*secnod"')
    _bad(capsys, tmp_path, text, "tau_extra", "secnod")


def test_wrong_units_in_the_new_term(capsys, tmp_path):
    text = _astrocyte_with_extra_term(_dump(capsys, "astrocyte"), term="tau_extra")
    _bad(capsys, tmp_path, text, "unit")


def test_not_utf8(capsys, tmp_path):
    _bad(capsys, tmp_path, b'name = "astrocyte"\nequations = "\xff\xfe"\n', "UTF-8")


def test_not_toml(capsys, tmp_path):
    _bad(capsys, tmp_path, "equations = '''\n", "TOML")


# ---- studies: [models] and a sweep axis of model files

STUDY = """
[study]
name = "variants"
sessions = 1
seeds = [1]
[base]
L_max = "1*second"
tau_extra = "4*second"
[models]
astrocyte = "extra.toml"
[conditions.astrocytes]
astrocytes = true
"""


@pytest.mark.slow
def test_study_models_table_and_axis(capsys, tmp_path):
    from astrocpg.studies.parameter_studies.execute import execute_run
    from astrocpg.studies.parameter_studies.study import load_study

    dumped = _dump(capsys, "astrocyte")
    extra = _astrocyte_with_extra_term(dumped)
    (tmp_path / "extra.toml").write_text(extra)
    (tmp_path / "li_rinzel.toml").write_text(dumped)
    study = tmp_path / "s.toml"
    study.write_text(STUDY)
    spec, = load_study(study).runs
    assert spec.models["astrocyte"]["content"] == extra
    assert "tau_extra=4*second" in spec.overrides  # a parameter the file declares
    # a sweep axis named by a model lists model files: two astrocytes in one study
    study.write_text(STUDY.replace('tau_extra = "4*second"\n', "") +
                     '[sweep.axes]\nastrocyte = ["li_rinzel.toml", "extra.toml"]\n')
    runs = load_study(study).runs
    assert [r.point for r in runs] == [{"astrocyte": "li_rinzel.toml"},
                                       {"astrocyte": "extra.toml"}]
    assert [r.models["astrocyte"]["content"] for r in runs] == [dumped, extra]
    assert len({r.fingerprint() for r in runs}) == 2
    # one tiny run builds the file's model
    status = execute_run(runs[1], str(tmp_path / "run"))
    assert status["state"] == "finished", status.get("error")
    manifest = json.loads((tmp_path / "run" / "manifest.json").read_text())
    assert "tau_extra" in manifest["models"]["astrocyte"]["parameters"]
    assert manifest["settings"]["models"]["astrocyte"]["content"] == extra


def test_study_bad_model_file(capsys, tmp_path):
    from astrocpg.errors import InputError
    from astrocpg.studies.parameter_studies.study import load_study

    text = _dump(capsys, "astrocyte").replace("dAG/dt", "dAX/dt").replace(
        'AG = { value = "0.0" }', "")
    (tmp_path / "extra.toml").write_text(text)
    study = tmp_path / "s.toml"
    study.write_text(STUDY.replace('tau_extra = "4*second"\n', ""))
    with pytest.raises(InputError) as e:
        load_study(study)
    assert "[models] astrocyte" in e.value.line and "lacks AG" in e.value.line


@pytest.mark.slow
def test_train_records_the_file_and_power_and_resume_use_it(capsys, tmp_path):
    text = _astrocyte_with_extra_term(_dump(capsys, "astrocyte"))
    f = tmp_path / "astro.toml"
    f.write_text(text)
    out = tmp_path / "t"
    assert main(["train", "--sessions", "1", "--set", "L_max=1*second", "--model",
                 f"astrocyte={f}", "--no-progress", "--out", str(out)]) == 0
    settings = json.loads((out / "manifest.json").read_text())["settings"]
    assert settings["models"]["astrocyte"]["content"] == text
    capsys.readouterr()
    # resuming with another astrocyte is refused; power rebuilds the recorded model
    other = tmp_path / "other.toml"
    other.write_text(_dump(capsys, "astrocyte"))
    assert main(["train", "--resume", str(out), "--model",
                 f"astrocyte={other}"]) == 2
    assert "--model astrocyte: that run was trained with another astrocyte model file" in \
        capsys.readouterr().err
    assert main(["power", str(out), "--sessions", "1", "--no-progress"]) == 0


VARIANTS = Path(__file__).resolve().parents[1] / "models" / "variants"


def test_shipped_variants(capsys):
    """models/variants: the Li-Rinzel file is the built-in astrocyte; the G-ChI astrocyte has
    the same interface; the study compares them."""
    from astrocpg.models.compose import model_set
    from astrocpg.studies.parameter_studies.study import load_study

    li_rinzel = (VARIANTS / "li_rinzel_astrocyte.toml").read_text()
    assert li_rinzel == _dump(capsys, "astrocyte")
    gchi = model_set(models={"astrocyte": (VARIANTS / "gchi_astrocyte.toml").read_text()})
    assert "Gamma_A" in gchi.astrocyte.brian_equations().names
    assert "tau_IP3" not in gchi.astrocyte.parameters
    runs = load_study(VARIANTS / "compare_astrocytes.toml").runs
    assert {r.point["astrocyte"] for r in runs} == {"li_rinzel_astrocyte.toml",
                                                    "gchi_astrocyte.toml"}


BEYOND = Path(__file__).resolve().parents[1] / "docs" / "beyond"


def test_the_gait_map_study_sweeps_a_parameter_its_model_file_declares(tmp_path):
    """docs/beyond/gait_map_trained.toml: 5 x 5 points over the drive and torque_gain, a
    parameter of torque_gain.toml; at torque_gain = 1 that file runs exactly as the built-in
    torque trace."""
    from astrocpg.models.compose import model_set
    from astrocpg.studies.parameter_studies.study import load_study

    runs = load_study(BEYOND / "gait_map_trained.toml").runs
    assert len(runs) == 25 and {r.point["torque_gain"] for r in runs} == \
        {"0.6", "0.8", "1.0", "1.2", "1.4"}
    out = {}
    for name, models in (("built-in", []), ("file", ["--model",
                                                    f"torque={BEYOND / 'torque_gain.toml'}"])):
        assert main(["run", "--seconds", "0.3", "--no-progress", *models,
                     "--out", str(tmp_path / name)]) == 0
        with np.load(tmp_path / name / "robot.npz") as z:
            out[name] = {k: z[k] for k in z.files}
    assert out["built-in"].keys() == out["file"].keys()
    for k in out["file"]:
        assert np.array_equal(out["built-in"][k], out["file"][k]), k
    assert model_set(models={"torque": (BEYOND / "torque_gain.toml").read_text()}) \
        .torque.parameters["torque_gain"].value == 1.0
