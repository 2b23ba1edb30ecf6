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
