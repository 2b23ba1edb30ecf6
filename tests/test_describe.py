"""astrocpg describe: equations rendered by sympy with the paper's symbols, parameter tables."""

from __future__ import annotations

from pathlib import Path

from astrocpg.models import DEFAULT_MODELS
from astrocpg.studies.cli import main
from astrocpg.studies.figures.describe import describe


def test_every_model_is_described_with_its_parameters() -> None:
    text = describe()
    for name, model in DEFAULT_MODELS.items():
        assert f"## {name}" in text
        for pname in model.parameters:
            assert f"| `{pname}` |" in text


def test_equations_use_the_papers_symbols() -> None:
    text = describe("astrocyte")
    # dIP3/dt = (IP3* - IP3)/tau_IP3 + r_IP3 * AG, with the table's symbols
    assert r"\frac{dIP_{3}}{dt}" in text and r"\tau_{IP_3}" in text and "IP_3^*" in text
    latex = describe("motor_neuron", "latex")
    assert r"\begin{align*}" in latex and r"\tau_{\mathrm{motor}}" in latex
    assert "_placeholder" not in describe("motor_neuron")


def test_describe_shows_an_edited_model(tmp_path: Path, capsys) -> None:
    from astrocpg.models.interneuron import EQUATIONS
    f = tmp_path / "in.txt"
    f.write_text(EQUATIONS.replace("dv/dt = ", "dv/dt = 0.5*"))
    assert main(["describe", "interneuron", "--equations", f"interneuron={f}"]) == 0
    assert "dv/dt = 0.5*" in capsys.readouterr().out
    assert main(["describe", "no_such_model"]) == 2
    assert main(["describe", "astrocyte", "--format", "html"]) == 2


def test_describe_a_parameter_by_its_name(capsys) -> None:
    """``astrocpg describe tau_motor``: the model that declares it, its value with units and
    every statement that uses it; a misspelt name: one line with the closest name."""
    assert main(["describe", "tau_motor"]) == 0
    text = capsys.readouterr().out
    assert text.startswith("## tau_motor: a parameter of motor_neuron")
    assert "| 9. ms |" in text and r"\tau_{\mathrm{motor}}" in text
    assert "- motor_neuron (equation):" in text and "/tau_motor" in text
    assert "## motor_neuron" not in text  # the parameter, not the whole model
    # the API, with an override: the value described is the one given
    import astrocpg
    assert "| 12. ms |" in astrocpg.describe("tau_motor", overrides=["tau_motor=12*ms"])
    latex = describe("tau_motor", "latex")
    assert r"\subsection*{tau\_motor: a parameter of motor\_neuron}" in latex
    assert r"\begin{align*}" in latex
    assert main(["describe", "tau_motr"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "did you mean tau_motor?" in err, err
